"""A commit message's subject is one line of at most 72 characters, the detail in the body
after a blank line (CONTRIBUTING.md, "Commits"). Run by pre-commit's commit-msg hook:

    pre-commit install --hook-type commit-msg

Usage: python scripts/check_commit_subject.py MESSAGE_FILE (exit status 1 with one line
saying what is wrong).
"""

import pathlib
import sys

MAX_SUBJECT = 72


def problem(message: str) -> str | None:
    """What is wrong with ``message`` (git's comment lines left out), or None."""
    lines = [line for line in message.splitlines() if not line.startswith("#")]
    while lines and not lines[0].strip():
        lines.pop(0)
    if not lines:
        return "the message is empty"
    subject = lines[0]
    if len(subject) > MAX_SUBJECT:
        return f"the subject is {len(subject)} characters, over {MAX_SUBJECT}: {subject[:40]}..."
    if len(lines) > 1 and lines[1].strip():
        return "the subject is followed by a second line; leave a blank line before the body"
    return None


def main(argv: list[str]) -> int:
    why = problem(pathlib.Path(argv[1]).read_text(encoding="utf-8"))
    if why:
        print(f"commit message: {why}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
