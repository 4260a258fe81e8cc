"""The stamp a report page of ``docs/`` starts with: the date and commit its numbers were made
at, and the command that regenerates it.

The stamp is the line under the page's title::

    Made 2026-11-26 at commit 055d792. Regenerate with `manta-drake study findings ...`.

A study writes its page through ``write_stamped``: if the page's text apart from the stamp's
date and commit is what the file already holds, the file is left as it is (regenerating
changes no byte); otherwise the stamp takes today's date and the checkout's commit
(``git rev-parse --short HEAD``, or ``unknown`` outside a git checkout) and the rest of the
stamp line (the commands) is kept as the page has it.
"""

from __future__ import annotations

import datetime
import pathlib
import re
import subprocess

from manta_drake.studies import REPO

STAMP = re.compile(r"^Made (?P<date>\S+) at commit (?P<commit>\S+?)\. (?P<rest>.*)$", re.MULTILINE)


def commit(repo: pathlib.Path = REPO) -> str:
    """The short hash of ``repo``'s HEAD if ``repo`` is the top of a git checkout, else
    ``"unknown"``."""
    try:
        top = subprocess.run(
            ["git", "-C", str(repo), "rev-parse", "--show-toplevel"],
            capture_output=True,
            text=True,
            timeout=10,
            check=True,
        )
        if pathlib.Path(top.stdout.strip()).resolve() != pathlib.Path(repo).resolve():
            return "unknown"
        out = subprocess.run(
            ["git", "-C", str(repo), "rev-parse", "--short", "HEAD"],
            capture_output=True,
            text=True,
            timeout=10,
            check=True,
        )
    except (OSError, subprocess.SubprocessError):
        return "unknown"
    return out.stdout.strip() or "unknown"


def stamp_line(regenerate: str, date: str = "unknown", made_at: str = "unknown") -> str:
    """The stamp: ``regenerate`` is the rest of the line after "Regenerate with "."""
    return f"Made {date} at commit {made_at}. Regenerate with {regenerate}"


def _unstamped(text: str) -> str:
    return STAMP.sub(lambda m: f"Made - at commit -. {m['rest']}", text, count=1)


def write_stamped(path: pathlib.Path, text: str) -> bool:
    """Writes ``text`` (a page whose stamp line may carry any date and commit) to ``path``
    with today's date and the checkout's commit in its stamp, unless the file already holds
    the same page apart from those two; returns whether the file was written."""
    path = pathlib.Path(path)
    if path.exists() and _unstamped(path.read_text()) == _unstamped(text):
        return False
    today = datetime.date.today().isoformat()
    made_at = commit()
    text = STAMP.sub(lambda m: f"Made {today} at commit {made_at}. {m['rest']}", text, count=1)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text)
    return True


def replace_marked_block(
    path: pathlib.Path,
    block: str,
    begin: str,
    end: str,
    new_page: tuple[str, str] | None = None,
    what: str = "the tables",
) -> None:
    """Replaces the block of ``path`` between the markers ``begin`` and ``end`` (which
    ``block`` carries itself), keeping the rest, through ``write_stamped``.

    Args:
        path: the page.
        block: the new block, markers included.
        begin, end: the markers.
        new_page: (title, command): a missing page is written as the title, its stamp (to
            be regenerated with ``command``) and the block; None: a missing page is refused.
        what: what the markers hold, for the error ("the tables").

    Raises:
        SystemExit: the page has no such block (or is missing and ``new_page`` is None).
    """
    path = pathlib.Path(path)
    if new_page is not None and not path.exists():
        title, command = new_page
        write_stamped(path, f"# {title}\n\n" + stamp_line(f"`{command}`.") + "\n\n" + block + "\n")
        return
    text = path.read_text() if path.exists() else ""
    if begin not in text or end not in text:
        if new_page is not None:
            raise SystemExit(
                f"error: {path} exists but has no {begin} ... {end} block; add "
                f"the two markers where {what} belong, or choose another "
                "--out folder"
            )
        raise SystemExit(
            f"error: {path} has no {begin} ... {end} block; add the two markers where {what} belong"
        )
    head, rest = text.split(begin, 1)
    write_stamped(path, head + block + rest.split(end, 1)[1])
