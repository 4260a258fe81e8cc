"""The package works when installed non-editable (as from a wheel): models and shipped
scenarios are package data, nothing is found through the repository's folders."""

import json
import os
import pathlib
import subprocess
import sys

import pytest

ROOT = pathlib.Path(__file__).resolve().parent.parent


@pytest.mark.slow
def test_non_editable_install_lists_and_runs_a_shipped_scenario(tmp_path):
    site = tmp_path / "site"
    subprocess.run([sys.executable, "-m", "pip", "install", "--quiet", "--no-deps",
                    "--no-build-isolation", "--disable-pip-version-check", "--target", str(site),
                    str(ROOT)], check=True, capture_output=True, text=True, timeout=600)
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
    assert (site / "manta_drake" / "model" / "models" / "manta.sdf").is_file()
