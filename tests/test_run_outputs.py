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

from manta_drake.interrupts import RunInterrupted
from manta_drake.scenario import load_scenario
from manta_drake.simulate import (
    OutputFolderError,
    check_output_folder,
    run,
    write_interrupted_start,
)

CLI = [sys.executable, "-m", "manta_drake.cli"]


def _default_signals() -> None:
    """In the child: SIGINT, SIGTERM and SIGHUP at their defaults, as a shell starts a
    command (a test run under nohup or a CI runner would otherwise hand down an ignored
    SIGHUP, which the command rightly keeps ignoring)."""
    for sig in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP):
        signal.signal(sig, signal.SIG_DFL)


def _stand(duration=0.2):
    return load_scenario("stand", overrides={"duration": duration, "visualization.meshcat": False})


def _file(tmp: pathlib.Path) -> pathlib.Path:
    (tmp / "f").write_text("x")
    return tmp / "f"


@pytest.mark.parametrize(
    "make, words",
    [
        (lambda tmp: "", "an empty path"),
        (lambda tmp: _file(tmp), "is a file"),
        (lambda tmp: _file(tmp) / "sub", "cannot be created"),
    ],
)
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


@pytest.mark.slow
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
    assert metrics["status"] == "interrupted"
    assert metrics["failure"] == {
        "stage": "load",
        "time_s": 0.0,
        "reason": "terminated (SIGTERM)",
        "signal": "SIGTERM",
    }
    assert not (out / "log.npz").exists()


def _wait_for_mark(out: pathlib.Path, stage: str, timeout: float) -> float:
    """Waits until ``out/metrics.json`` says ``running`` at ``stage``; the time it did."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        try:
            metrics = json.loads((out / "metrics.json").read_text())
        except (OSError, ValueError):
            metrics = {}
        if metrics.get("status") == "running" and metrics.get("stage") == stage:
            return time.monotonic()
        time.sleep(0.01)
    raise AssertionError(f"{out}: no 'running' mark of stage {stage} in {timeout} s")


def _old_ok_run(out: pathlib.Path) -> None:
    """A folder as an earlier, finished run left it: its scenario.yaml, log and ok story."""
    from manta_drake.simulate import SCENARIO_HEADER

    out.mkdir(parents=True)
    (out / "scenario.yaml").write_text(SCENARIO_HEADER + "duration: 0.3\n")
    (out / "log.npz").write_bytes(b"old")
    (out / "metrics.json").write_text(json.dumps({"scenario": "stand", "status": "ok"}))


@pytest.mark.slow
@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGHUP, signal.SIGINT])
@pytest.mark.parametrize("after", [0.2, 1.3])
def test_a_signal_while_the_run_imports_says_so_in_place_of_the_earlier_story(tmp_path, sig, after):
    """Signalled 0.2 s or 1.3 s after it started (still importing pydrake and loading the
    scenario), `manta-drake run` prints one line, exits with 128 + the signal and leaves a
    metrics.json that says it was interrupted by that signal, not the earlier run's ok,
    and none of the earlier run's files."""
    out = tmp_path / "out"
    _old_ok_run(out)
    started = time.monotonic()
    # 20 s of simulated standing: on a fast machine the run may be simulating at 1.3 s, but
    # never finished (a signal after its ok story would find nothing left to interrupt).
    process = subprocess.Popen(
        CLI + ["run", "stand", "--out", str(out), "--duration", "20", "--no-meshcat", "--quiet"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        preexec_fn=_default_signals,
    )
    # The mark comes within about 0.1 s of the start (later on a loaded machine: then the
    # signal follows it at once).
    marked = _wait_for_mark(out, "load", timeout=30)
    time.sleep(max(0.0, started + after - marked))
    process.send_signal(sig)
    _, err = process.communicate(timeout=60)
    reason = "interrupted (Ctrl-C)" if sig == signal.SIGINT else f"terminated ({sig.name})"
    assert process.returncode == 128 + sig, err
    word = "interrupted" if sig == signal.SIGINT else "terminated"
    assert err.strip().splitlines() == [f"manta-drake: {word} ({sig.name})"], err
    metrics = json.loads((out / "metrics.json").read_text())
    assert metrics["status"] == "interrupted", metrics
    assert metrics["failure"]["signal"] == sig.name and metrics["failure"]["reason"] == reason
    # Still loading, or (on a fast machine at 1.3 s) building or simulating.
    assert metrics["failure"]["stage"] in ("load", "build", "simulation")
    if metrics["failure"]["stage"] != "simulation":
        assert not (out / "log.npz").exists()
    else:
        assert (out / "log.npz").read_bytes() != b"old"


@pytest.mark.slow
@pytest.mark.parametrize(
    "sig, code, reason",
    [
        (signal.SIGTERM, 143, "terminated (SIGTERM)"),
        (signal.SIGHUP, 129, "terminated (SIGHUP)"),
        (signal.SIGINT, 130, "interrupted (Ctrl-C)"),
    ],
)
def test_a_signal_mid_run_writes_the_partial_log_and_why(tmp_path, sig, code, reason):
    out = tmp_path / "out"
    # A shell that starts jobs in the background (as a CI runner may) hands them SIGINT
    # ignored, and Python then keeps ignoring it: give the run the default disposition.
    process = subprocess.Popen(
        CLI + ["run", "two_behaviors", "--out", str(out), "--no-meshcat", "--quiet"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        preexec_fn=_default_signals,
    )
    # Wait until the simulation is under way: the 'running' metrics.json of stage 'build'
    # is written when the run has loaded its scenario, then the build takes about a second.
    _wait_for_mark(out, "build", timeout=60)
    time.sleep(2.0)
    process.send_signal(sig)
    _, err = process.communicate(timeout=60)
    assert process.returncode == code, err
    assert len(err.strip().splitlines()) == 1, err
    metrics = json.loads((out / "metrics.json").read_text())
    assert metrics["status"] == "interrupted" and metrics["failure"]["reason"] == reason
    assert metrics["failure"]["signal"] == sig.name
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


@pytest.mark.slow
def test_a_run_that_empties_the_battery_stops_and_says_so(tmp_path):
    """Started just above the cut-off, the trot drains the pack within a second: the run
    ends there (not at its duration), failed, with the battery's reason, and the log and
    the energy block end where it stopped."""
    from manta_drake.simulate import SimulationError

    s = load_scenario(
        "locomotion_trot",
        overrides={
            "duration": 3.0,
            "actuators.initial_soc": 0.2002,
            "visualization.meshcat": False,
        },
    )
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


def test_an_import_error_while_a_signal_is_pending_is_the_interruption(
    tmp_path, monkeypatch, capsys
):
    """pydrake's module initialisation turns the exception of a signal's handler into
    ImportError("initialization failed"): `manta-drake run` still says it was terminated,
    and so does the folder."""
    import os

    import manta_drake.cli as cli

    def import_broken_by_a_signal(*args):
        try:
            os.kill(os.getpid(), signal.SIGTERM)
            time.sleep(10)  # the handler raises here
        except KeyboardInterrupt:
            raise ImportError("initialization failed") from None
        raise AssertionError("the signal was not turned into an exception")

    out = tmp_path / "out"
    _old_ok_run(out)
    monkeypatch.setattr(cli, "_scenario", import_broken_by_a_signal)
    assert cli.main(["run", "stand", "--out", str(out)]) == 128 + signal.SIGTERM
    assert capsys.readouterr().err.strip().splitlines() == ["manta-drake: terminated (SIGTERM)"]
    metrics = json.loads((out / "metrics.json").read_text())
    assert metrics["status"] == "interrupted"
    assert metrics["failure"] == {
        "stage": "load",
        "time_s": 0.0,
        "reason": "terminated (SIGTERM)",
        "signal": "SIGTERM",
    }
    assert not (out / "log.npz").exists() and not (out / "scenario.yaml").exists()


def test_a_bad_input_leaves_the_folder_as_it_was(tmp_path, capsys):
    """The folder is marked running before the scenario is loaded; a scenario that fails its
    checks puts it back: the earlier run's files and story stay, a new folder is not left."""
    from manta_drake.cli import main

    out = tmp_path / "out"
    _old_ok_run(out)
    before = {p.name: p.read_bytes() for p in out.iterdir()}
    assert main(["run", "stand", "--out", str(out), "--set", "contact.friction=9"]) == 2
    assert "contact.friction: 9.0 is outside" in capsys.readouterr().err
    assert {p.name: p.read_bytes() for p in out.iterdir()} == before
    fresh = tmp_path / "new" / "deeper"
    assert main(["run", "stand", "--out", str(fresh), "--set", "contact.frction=1"]) == 2
    assert not (tmp_path / "new").exists()


def test_ignored_signals_stay_ignored():
    """Under `nohup` (SIGHUP ignored) a closed terminal must not stop the run; the others
    still raise."""
    import os

    from manta_drake.interrupts import interrupts_as_exceptions

    previous = signal.signal(signal.SIGHUP, signal.SIG_IGN)
    try:
        with interrupts_as_exceptions() as received:
            os.kill(os.getpid(), signal.SIGHUP)
            time.sleep(0.05)
            assert received == [] and signal.getsignal(signal.SIGHUP) is signal.SIG_IGN
            with pytest.raises(RunInterrupted, match="SIGTERM"):
                os.kill(os.getpid(), signal.SIGTERM)
                time.sleep(10)
            assert received == ["SIGTERM"]
        assert signal.getsignal(signal.SIGHUP) is signal.SIG_IGN
    finally:
        signal.signal(signal.SIGHUP, previous)


@pytest.mark.parametrize(
    "name, reason, status",
    [
        ("SIGINT", "interrupted (Ctrl-C)", 130),  # POSIX: SIGINT is 2, SIGHUP 1, SIGTERM 15
        ("SIGHUP", "terminated (SIGHUP)", 129),
        ("SIGTERM", "terminated (SIGTERM)", 143),
    ],
)
def test_an_interruption_names_its_signal_and_the_shells_exit_status(name, reason, status):
    from manta_drake.interrupts import interruption

    stop = RunInterrupted(name)
    assert (stop.reason, stop.exit_status) == (reason, status)
    assert interruption(KeyboardInterrupt()).signal_name == "SIGINT"  # a bare Ctrl-C
    assert interruption(ImportError("initialization failed"), [name]).signal_name == name
    assert interruption(ValueError("a bad input")) is None


def test_metrics_that_cannot_be_computed_leave_a_failed_story_not_running(tmp_path, monkeypatch):
    import manta_drake.simulate as simulate

    def broken(*args):
        raise ValueError("no samples")

    monkeypatch.setattr(simulate, "compute_metrics", broken)
    with pytest.raises(simulate.SimulationError, match="log or metrics failed: ValueError"):
        run(_stand(0.05), tmp_path / "out", progress=False, write_outputs=False)
    metrics = json.loads((tmp_path / "out" / "metrics.json").read_text())
    assert metrics["status"] == "failed"
    assert metrics["failure"] == {
        "stage": "metrics",
        "time_s": pytest.approx(0.05),
        "reason": "ValueError: no samples",
    }


def test_a_signal_between_the_build_and_the_run_is_told(tmp_path, monkeypatch):
    """A signal that comes after the build's story is settled and before the run's own
    signal handling takes over (here: as that handling is installed) still leaves a
    metrics.json that says the run was interrupted, at the build."""
    import contextlib

    from manta_drake import simulate
    from manta_drake.scenario import load_scenario

    @contextlib.contextmanager
    def signalled():
        raise RunInterrupted("SIGTERM")
        yield []  # pragma: no cover

    monkeypatch.setattr(simulate, "signals_flagged", signalled)
    scenario = load_scenario("stand", overrides={"duration": 0.01, "visualization.meshcat": False})
    with pytest.raises(RunInterrupted):
        simulate.run(scenario, tmp_path / "out", progress=False, write_outputs=False)
    metrics = json.loads((tmp_path / "out" / "metrics.json").read_text())
    assert metrics["status"] == "interrupted"
    assert metrics["failure"] == {
        "stage": "build",
        "time_s": 0.0,
        "reason": "terminated (SIGTERM)",
        "signal": "SIGTERM",
    }
