"""The package works when installed non-editable (as from a wheel): models and shipped
scenarios are package data, nothing is found through the repository's folders."""

import json
import os
import pathlib
import shutil
import subprocess
import sys

import pytest

ROOT = pathlib.Path(__file__).resolve().parent.parent


def _clean_copy(dest: pathlib.Path) -> pathlib.Path:
    """The repository's tracked files (as they are in the work tree) copied to ``dest``:
    no build/, no *.egg-info, no caches, so a stale build folder cannot leak into the wheel."""
    files = subprocess.run(["git", "ls-files", "-z"], cwd=ROOT, check=True,
                           capture_output=True).stdout.decode().split("\0")
    for name in filter(None, files):
        source = ROOT / name
        if source.is_file():
            target = dest / name
            target.parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(source, target)
    return dest


@pytest.mark.slow
def test_non_editable_install_lists_and_runs_a_shipped_scenario(tmp_path):
    site = tmp_path / "site"
    tree = _clean_copy(tmp_path / "tree")
    subprocess.run([sys.executable, "-m", "pip", "install", "--quiet", "--no-deps",
                    "--no-build-isolation", "--disable-pip-version-check", "--target", str(site),
                    str(tree)], check=True, capture_output=True, text=True, timeout=600)
    # Run from an empty folder with only the installed copy first on the path.
    work = tmp_path / "work"
    work.mkdir()
    env = dict(os.environ, PYTHONPATH=str(site))

    def manta(*args):
        return subprocess.run([str(site / "bin" / "manta-drake"), *args], cwd=work, env=env,
                              capture_output=True, text=True, timeout=600)

    where = subprocess.run([sys.executable, "-c", "import manta_drake; print(manta_drake.__file__)"],
                           cwd=work, env=env, capture_output=True, text=True)
    assert where.stdout.strip().startswith(str(site)), where.stdout + where.stderr
    listed = manta("list")
    assert listed.returncode == 0, listed.stderr
    assert "three_behaviors" in listed.stdout and str(site) in listed.stdout
    result = manta("run", "locomotion_swim", "--duration", "1", "--out", "out", "--no-meshcat",
                   "--quiet")
    assert result.returncode == 0, result.stderr
    metrics = json.loads((work / "out" / "metrics.json").read_text())
    assert metrics["status"] == "ok" and metrics["sim_time_s"] == pytest.approx(1.0)
    # models/ installs as manta_drake.models, with its data and the shipped scenarios.
    models = site / "manta_drake" / "models"
    for name in ("manta.sdf", "pool.sdf", "package.xml", "hydrodynamics.yaml",
                 "scenarios/three_behaviors.yaml"):
        assert (models / name).is_file(), name
    # Every package of the source tree is in the install (an explicit list can miss one).
    installed = {p.relative_to(site).parent for p in (site / "manta_drake").rglob("__init__.py")}
    source = {p.relative_to(ROOT).parent for p in (ROOT / "manta_drake").rglob("__init__.py")}
    assert source <= installed, sorted(map(str, source - installed))
