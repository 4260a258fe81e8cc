"""scripts/check_commit_subject.py: the commit-msg hook's rule (CONTRIBUTING.md)."""

import importlib.util
import pathlib
import subprocess
import sys

import pytest
import yaml

ROOT = pathlib.Path(__file__).resolve().parents[1]
SCRIPT = ROOT / "scripts" / "check_commit_subject.py"
spec = importlib.util.spec_from_file_location("check_commit_subject", SCRIPT)
assert spec is not None and spec.loader is not None
check = importlib.util.module_from_spec(spec)
spec.loader.exec_module(check)


@pytest.mark.parametrize(
    "message, why",
    [
        ("a" * 72 + "\n\nbody\n", None),
        ("# git's comment\n\nSubject\n# another\n\nBody line\n", None),
        ("Subject only\n", None),
        ("a" * 73 + "\n", "the subject is 73 characters, over 72: " + "a" * 40 + "..."),
        ("Subject\nbody without a blank line\n", "the subject is followed by a second line"),
        ("# only comments\n\n", "the message is empty"),
    ],
)
def test_the_rule(message, why):
    found = check.problem(message)
    assert (found is None) if why is None else found.startswith(why)


def test_the_hook_exits_1_with_one_line(tmp_path):
    message = tmp_path / "COMMIT_EDITMSG"
    message.write_text("x" * 80 + "\n")
    done = subprocess.run(
        [sys.executable, str(SCRIPT), str(message)], capture_output=True, text=True
    )
    assert done.returncode == 1
    assert done.stderr == f"commit message: the subject is 80 characters, over 72: {'x' * 40}...\n"
    message.write_text("Short\n\nBody\n")
    assert subprocess.run([sys.executable, str(SCRIPT), str(message)]).returncode == 0


def test_pre_commit_runs_it_at_the_commit_msg_stage():
    config = yaml.safe_load((ROOT / ".pre-commit-config.yaml").read_text())
    hooks = {h["id"]: h for repo in config["repos"] for h in repo["hooks"]}
    assert hooks["commit-subject"]["stages"] == ["commit-msg"]
    assert "scripts/check_commit_subject.py" in hooks["commit-subject"]["entry"]
    assert config["default_stages"] == ["pre-commit"]
