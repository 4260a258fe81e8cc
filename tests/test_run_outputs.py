"""A run's story is never wrong: the output folder is checked before anything is built, a
signal mid-run leaves the partial log and a metrics.json that says why, and no hidden
staging folder or earlier run's file is left beside the new one."""

import json
import pathlib
import signal
import subprocess
import sys
import time

import pytest

from manta_drake.scenario import load_scenario
from manta_drake.simulate import (
    OutputFolderError,
    RunInterrupted,
    check_output_folder,
    run,
    write_interrupted_start,
)

CLI = [sys.executable, "-m", "manta_drake.cli"]


def _stand(duration=0.2):
    return load_scenario("stand", overrides={"duration": duration,
                                             "visualization.meshcat": False})


def _file(tmp: pathlib.Path) -> pathlib.Path:
    (tmp / "f").write_text("x")
    return tmp / "f"


@pytest.mark.parametrize("make, words", [
    (lambda tmp: "", "an empty path"),
    (lambda tmp: _file(tmp), "is a file"),
    (lambda tmp: _file(tmp) / "sub", "cannot be created"),
])
def test_bad_output_folders_are_refused_before_the_build(tmp_path, make, words):
    with pytest.raises(OutputFolderError, match=words):
        run(_stand(), make(tmp_path), progress=False)


def test_a_users_scenario_file_and_the_runs_own_input_are_never_replaced(tmp_path):
    mine = tmp_path / "scenario.yaml"
    mine.write_text("duration: 1.0\n")
    with pytest.raises(OutputFolderError, match="holds a scenario.yaml that no run wrote"):
        check_output_folder(tmp_path)
    with pytest.raises(OutputFolderError, match="overwrite its own input"):
        check_output_folder(tmp_path, inputs=[mine])
    assert mine.read_text() == "duration: 1.0\n"
    # A run's own scenario.yaml may be replaced by the next run into the same folder.
    out = tmp_path / "out"
    run(_stand(), out, progress=False, write_outputs=False)
    assert check_output_folder(out) == out


def test_a_second_run_leaves_no_file_of_the_first_and_no_staging_folder(tmp_path):
    out = tmp_path / "out"
    run(_stand(), out, progress=False)
    (out / "recording.html").write_text("stale")  # as if the first run had recorded
    run(_stand(), out, progress=False, write_outputs=False)
    names = sorted(p.name for p in out.iterdir())
    assert names == ["log.npz", "metrics.json", "scenario.yaml"]
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")]


def test_an_interrupted_load_replaces_the_earlier_runs_story(tmp_path):
    out = tmp_path / "out"
    run(_stand(), out, progress=False, write_outputs=False)
    write_interrupted_start(out, "stand", RunInterrupted("SIGTERM"))
    metrics = json.loads((out / "metrics.json").read_text())
    assert metrics["status"] == "failed"
    assert metrics["failure"] == {"stage": "load", "time_s": 0.0,
                                  "reason": "terminated (SIGTERM)"}
    assert not (out / "log.npz").exists()


@pytest.mark.slow
@pytest.mark.parametrize("sig, code, reason", [
    (signal.SIGTERM, 143, "terminated (SIGTERM)"),
    (signal.SIGHUP, 129, "terminated (SIGHUP)"),
    (signal.SIGINT, 130, "interrupted (Ctrl-C)"),
])
def test_a_signal_mid_run_writes_the_partial_log_and_why(tmp_path, sig, code, reason):
    out = tmp_path / "out"
    # A shell that starts jobs in the background (as a CI runner may) hands them SIGINT
    # ignored, and Python then keeps ignoring it: give the run the default disposition.
    process = subprocess.Popen(CLI + ["run", "two_behaviors", "--out", str(out),
                                      "--no-meshcat", "--quiet"],
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                               preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    # Wait until the simulation is under way: the 'running' metrics.json is written when
    # the run starts, then the build takes about a second.
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline:
        if (out / "metrics.json").is_file() and \
                json.loads((out / "metrics.json").read_text())["status"] == "running":
            break
        time.sleep(0.05)
    time.sleep(2.0)
    process.send_signal(sig)
    _, err = process.communicate(timeout=60)
    assert process.returncode == code, err
    assert len(err.strip().splitlines()) == 1, err
    metrics = json.loads((out / "metrics.json").read_text())
    assert metrics["status"] == "failed" and metrics["failure"]["reason"] == reason
    # On a loaded machine the signal may still find the run building its diagram: the
    # story then says so; once simulating, the partial log ends where the run stopped.
    assert metrics["failure"]["stage"] in ("build", "simulation")
    if metrics["failure"]["stage"] == "simulation":
        import numpy as np

        assert 0.0 < metrics["failure"]["time_s"] < 70.0
        log = np.load(out / "log.npz")
        assert log["t"][-1] == pytest.approx(metrics["failure"]["time_s"], abs=0.01)
    else:
        assert not (out / "log.npz").exists()


def test_a_run_that_empties_the_battery_stops_and_says_so(tmp_path):
    """Started just above the cut-off, the trot drains the pack within a second: the run
    ends there (not at its duration), failed, with the battery's reason, and the log and
    the energy block end where it stopped."""
    from manta_drake.simulate import SimulationError

    s = load_scenario("locomotion_trot", overrides={
        "duration": 3.0, "actuators.initial_soc": 0.2002, "visualization.meshcat": False})
    with pytest.raises(SimulationError, match="battery empty"):
        run(s, tmp_path / "out", progress=False, write_outputs=False)
    metrics = json.loads((tmp_path / "out" / "metrics.json").read_text())
    assert metrics["status"] == "failed"
    stop = metrics["failure"]["time_s"]
    assert "battery empty" in metrics["failure"]["reason"] and 0.0 < stop < 3.0
    assert metrics["sim_time_s"] == pytest.approx(stop, abs=2e-3)
    assert metrics["energy"]["battery_soc_end"] <= 0.2 + 1e-9
    import numpy as np

    log = np.load(tmp_path / "out" / "log.npz")
    assert log["t"][-1] == pytest.approx(stop, abs=2e-3)
