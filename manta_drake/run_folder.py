"""A run's output folder and the story its ``metrics.json`` tells, whatever ends the run.

This module is light (the standard library; ``config_io`` for the folder check; the bag's
file names from ``manta_drake.ros2``; the signal handling of ``manta_drake.interrupts``), so
``manta-drake run`` turns signals into exceptions, checks the folder and marks it
``running`` before the slow imports (pydrake) start: an interrupt at any moment after that
leaves a metrics.json that says why.

* ``check_output_folder``: a folder that cannot take a run's files is refused first.
* ``starting_run``: while the scenario is imported and loaded the folder's metrics.json says
  ``running``; an interrupt there leaves ``status: interrupted`` with the signal (and removes
  the earlier run's files), a bad input leaves the folder as it was.
* ``interrupted_failure``, ``write_interrupted_start``: the story of a run a signal stopped
  (``manta_drake.interrupts.RunInterrupted``).

``manta_drake.simulate.run`` writes the story of the run itself (``status`` ``ok``,
``failed`` or ``interrupted``) through the same functions.
"""

from __future__ import annotations

import contextlib
import json
import os
import pathlib
import time

from manta_drake.interrupts import RunInterrupted, interruption, signals_deferred
from manta_drake.ros2 import BAG_FILES

# The files a run writes (and the only ones it removes from an old output folder): the bag's
# (``manta-drake run --bag``) too, so a run without one leaves no earlier run's bag.
OUTPUT_FILES = (
    "scenario.yaml",
    "recording.html",
    "log.npz",
    "metrics.json",
    "joints.png",
    "states.png",
    "trajectory.png",
    *BAG_FILES,
)
SCENARIO_HEADER = (
    "# The resolved scenario of this run (every field, overrides applied); run it "
    "again\n# with: manta-drake run scenario.yaml --out DIR\n"
)


class SimulationError(RuntimeError):
    """The simulation failed; ``out_dir`` still holds the log up to the failure."""


class OutputFolderError(SimulationError):
    """The output folder cannot take a run's files; raised before anything is built."""


def check_output_folder(out_dir, inputs=(), create: bool = True) -> pathlib.Path:
    """Checks that a run can write its files into ``out_dir`` without losing anything, before
    anything expensive starts; creates the folder if ``create``.

    Refused: an empty path; a path that is a file, or under one; a folder that cannot be
    created or written; a folder holding one of ``inputs`` (a run never overwrites its own
    input) or a ``scenario.yaml`` that no run wrote (a user's own file).

    Raises:
        OutputFolderError: one line naming the folder and why.
    """
    # Imported here: the signals are turned into exceptions (interrupts_as_exceptions)
    # before anything but the standard library is imported.
    from manta_drake.config_io import check_writable_folder

    out_dir = check_writable_folder(out_dir, "--out", "out/run", OutputFolderError, create)
    ours = {(out_dir / name).resolve() for name in OUTPUT_FILES}
    for path in inputs:
        if path is not None and pathlib.Path(path).resolve() in ours:
            raise OutputFolderError(
                f"--out {out_dir}: the run would overwrite its own input {path}; choose "
                "another output folder"
            )
    existing = out_dir / "scenario.yaml"
    if existing.is_file():
        try:
            head = existing.read_text(encoding="utf-8", errors="replace")[: len(SCENARIO_HEADER)]
        except OSError:
            head = ""
        if head != SCENARIO_HEADER:
            raise OutputFolderError(
                f"--out {out_dir}: holds a scenario.yaml that no run wrote; a run would "
                "replace it: choose another output folder"
            )
    return out_dir


def write_atomic(path: pathlib.Path, text: str) -> None:
    """Writes ``text`` to ``path`` through a temporary file in the same folder and a rename,
    so a reader (or a kill) never sees half a file."""
    tmp = path.with_name(f".{path.name}.tmp")
    tmp.write_text(text)
    os.replace(tmp, path)


def write_metrics(out_dir: pathlib.Path, metrics: dict) -> None:
    """The folder's ``metrics.json`` (whole, by ``write_atomic``)."""
    write_atomic(out_dir / "metrics.json", json.dumps(metrics, indent=2) + "\n")


def remove_outputs(out_dir: pathlib.Path) -> None:
    """Removes the files an earlier run wrote in ``out_dir`` (``OUTPUT_FILES``), no others."""
    for name in OUTPUT_FILES:
        (out_dir / name).unlink(missing_ok=True)


def running_metrics(name: str, stage: str) -> dict:
    """The metrics.json of a run under way at ``stage`` (``load``: the scenario is being
    imported and loaded; ``build``: the run has replaced the folder's files): a run that
    ends replaces it, so a folder that keeps it holds a run still going or killed."""
    return {
        "scenario": name,
        "status": "running",
        "stage": stage,
        "started": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
        "note": "written when the run started; a run that ends replaces it, so this one is "
        "still running or was killed",
    }


def interrupted_failure(stage: str, time_s: float, stop: RunInterrupted) -> dict:
    """The failure block of a run a signal stopped at ``stage`` and sim time ``time_s``."""
    return {
        "stage": stage,
        "time_s": float(time_s),
        "reason": stop.reason,
        "signal": stop.signal_name,
    }


def write_interrupted_start(out_dir: pathlib.Path, name: str, error: BaseException) -> None:
    """A run interrupted while its scenario was imported or loaded (before ``run`` took the
    folder over): the folder's earlier outputs go and a metrics.json says the run never
    started and why (``status: interrupted``, the signal)."""
    stop = interruption(error) or RunInterrupted("SIGINT")
    remove_outputs(out_dir)
    write_metrics(
        out_dir,
        {
            "scenario": name,
            "status": "interrupted",
            "failure": interrupted_failure("load", 0.0, stop),
        },
    )


def _read(path: pathlib.Path) -> str | None:
    try:
        return path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError):
        return None


def _put_back(out_dir: pathlib.Path, previous: str | None, created: list) -> None:
    """The folder as it was before ``starting_run``: its earlier metrics.json (or none) and
    none of the folders it created."""
    metrics = out_dir / "metrics.json"
    if previous is None:
        metrics.unlink(missing_ok=True)
    else:
        write_atomic(metrics, previous)
    for folder in created:  # the deepest first; a folder something else wrote into stays
        with contextlib.suppress(OSError):
            folder.rmdir()


@contextlib.contextmanager
def starting_run(out, name: str, inputs=(), received=()):
    """Checks ``out`` (``check_output_folder``, the run's ``inputs``) and marks it as taken
    by a run that is starting: the folder is created and its metrics.json says ``running``
    (``stage: load``) at once; yields the folder. ``name`` names the scenario (the file's
    stem); ``received`` is the list of ``interrupts_as_exceptions``. A signal while the
    folder is checked and marked waits until it is marked.

    When the block raises and the folder still holds that mark (``simulate.run`` had not yet
    written its own story): an interruption (``interruption``: the signal's exception, or
    any exception while a signal was received) removes the earlier run's files and leaves
    ``status: interrupted`` with the signal, and is raised as ``RunInterrupted``; any other
    error (a bad input) puts the folder back as it was (its earlier metrics.json, or no
    folder if there was none).

    Raises:
        OutputFolderError: the folder cannot take the run (nothing was written).
    """
    mark = None
    try:
        with signals_deferred():
            out_dir = check_output_folder(out, inputs, create=False)
            created = [p for p in (out_dir, *out_dir.parents) if not p.exists()]
            metrics = out_dir / "metrics.json"
            previous = _read(metrics)
            out_dir.mkdir(parents=True, exist_ok=True)
            mark = json.dumps(running_metrics(name, "load"), indent=2) + "\n"
            write_atomic(metrics, mark)
        yield out_dir
    except BaseException as error:
        stop = interruption(error, received)
        if mark is None or _read(metrics) != mark:
            raise  # not marked, or the run wrote its own story
        if stop is None:
            try:
                with signals_deferred():
                    _put_back(out_dir, previous, created)
            except RunInterrupted as late:  # a signal while the folder was put back
                stop = late
            else:
                raise
        with signals_deferred():
            out_dir.mkdir(parents=True, exist_ok=True)
            write_interrupted_start(out_dir, name, stop)
        if stop is error:
            raise
        raise stop from error
