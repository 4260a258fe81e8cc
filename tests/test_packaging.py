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
    files = (
        subprocess.run(["git", "ls-files", "-z"], cwd=ROOT, check=True, capture_output=True)
        .stdout.decode()
        .split("\0")
    )
    for name in filter(None, files):
        source = ROOT / name
        if source.is_file():
            target = dest / name
            target.parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(source, target)
    return dest


@pytest.fixture(scope="module")
def installed(tmp_path_factory):
    """A non-editable install (as from a wheel) of a clean copy of the tree."""
    tmp = tmp_path_factory.mktemp("install")
    site = tmp / "site"
    tree = _clean_copy(tmp / "tree")
    subprocess.run(
        [
            sys.executable,
            "-m",
            "pip",
            "install",
            "--quiet",
            "--no-deps",
            "--no-build-isolation",
            "--disable-pip-version-check",
            "--target",
            str(site),
            str(tree),
        ],
        check=True,
        capture_output=True,
        text=True,
        timeout=600,
    )
    return site


@pytest.mark.slow
def test_non_editable_install_lists_and_runs_a_shipped_scenario(tmp_path, installed):
    site = installed
    # Run from an empty folder with only the installed copy first on the path.
    work = tmp_path / "work"
    work.mkdir()
    env = dict(os.environ, PYTHONPATH=str(site))

    def manta(*args):
        return subprocess.run(
            [str(site / "bin" / "manta-drake"), *args],
            cwd=work,
            env=env,
            capture_output=True,
            text=True,
            timeout=600,
        )

    where = subprocess.run(
        [sys.executable, "-c", "import manta_drake; print(manta_drake.__file__)"],
        cwd=work,
        env=env,
        capture_output=True,
        text=True,
    )
    assert where.stdout.strip().startswith(str(site)), where.stdout + where.stderr
    listed = manta("list")
    assert listed.returncode == 0, listed.stderr
    assert "three_behaviors" in listed.stdout and str(site) in listed.stdout
    result = manta(
        "run", "locomotion_swim", "--duration", "1", "--out", "out", "--no-meshcat", "--quiet"
    )
    assert result.returncode == 0, result.stderr
    metrics = json.loads((work / "out" / "metrics.json").read_text())
    assert metrics["status"] == "ok" and metrics["sim_time_s"] == pytest.approx(1.0)
    # models/ installs as manta_drake.models, with its data and the shipped scenarios.
    models = site / "manta_drake" / "models"
    for name in (
        "manta.sdf",
        "pool.sdf",
        "package.xml",
        "hydrodynamics.yaml",
        "scenarios/three_behaviors.yaml",
    ):
        assert (models / name).is_file(), name
    # Every package of the source tree is in the install (an explicit list can miss one).
    installed = {p.relative_to(site).parent for p in (site / "manta_drake").rglob("__init__.py")}
    source = {p.relative_to(ROOT).parent for p in (ROOT / "manta_drake").rglob("__init__.py")}
    assert source <= installed, sorted(map(str, source - installed))


# Root ignores permission bits; without these capabilities it obeys them like any user.
_AS_A_USER = [
    "setpriv",
    "--bounding-set=-dac_override,-dac_read_search,-fowner",
    "--inh-caps=-dac_override,-dac_read_search,-fowner",
]


@pytest.mark.slow
@pytest.mark.parametrize("writable_tmp", [True, False], ids=["tmp cache", "no cache"])
def test_read_only_install_without_a_writable_home_runs(tmp_path, installed, writable_tmp):
    """A read-only install, an unwritable home and no NUMBA_CACHE_DIR (a service account, a
    container, a remote Dask worker): the CLI still starts and runs a scenario with water
    and the CPG; the compiled kernels cache in a temporary folder, or compile without a
    cache when there is none."""
    if os.geteuid() == 0 and shutil.which("setpriv") is None:
        pytest.skip("needs setpriv to drop root's permission override")
    site = tmp_path / "site"
    shutil.copytree(installed, site)
    home, tmp, out = tmp_path / "home", tmp_path / "tmp", tmp_path / "out"
    for folder in (home, tmp, out):
        folder.mkdir()
    subprocess.run(["chmod", "-R", "a-w", str(site), str(home)], check=True)
    if not writable_tmp:
        tmp.chmod(0o555)
    env = {
        k: v
        for k, v in os.environ.items()
        if k not in ("NUMBA_CACHE_DIR", "XDG_CACHE_HOME", "PYTHONPYCACHEPREFIX")
    }
    env.update(PYTHONPATH=str(site), HOME=str(home), TMPDIR=str(tmp), MPLCONFIGDIR=str(out))
    prefix = _AS_A_USER if os.geteuid() == 0 else []
    try:
        probe = subprocess.run(prefix + ["touch", str(site / "probe")], capture_output=True)
        assert probe.returncode != 0, "the install is writable: the test would prove nothing"

        def manta(*args):
            return subprocess.run(
                prefix + [sys.executable, "-m", "manta_drake.cli", *args],
                cwd=out,
                env=env,
                capture_output=True,
                text=True,
                timeout=600,
            )

        helped = manta("--help")
        assert helped.returncode == 0, helped.stderr
        ran = manta(
            "run",
            "locomotion_trot",
            "--duration",
            "0.1",
            "--out",
            str(out / "run"),
            "--no-meshcat",
            "--quiet",
        )
        assert ran.returncode == 0, ran.stderr
        assert json.loads((out / "run" / "metrics.json").read_text())["status"] == "ok"
        cached = list(tmp.glob("manta_drake-numba-*/**/*.nbi"))
        assert bool(cached) == writable_tmp, cached
    finally:
        subprocess.run(["chmod", "-R", "u+w", str(site), str(home), str(tmp)], check=False)
