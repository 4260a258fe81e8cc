"""``manta-drake station`` and ``manta-drake controller`` (``manta_drake.cli`` dispatches
here)."""

from __future__ import annotations

import math
import pathlib

from manta_drake.config_io import check_in_range, check_writable_folder
from manta_drake.scenario import find_scenario, load_scenario
from manta_drake.seam.controller_process import run_controller
from manta_drake.seam.link import (
    DEFAULT_STARTUP_TIMEOUT_S,
    DEFAULT_TIMEOUT_S,
    DEFAULT_URL,
    check_url,
    open_lcm,
)
from manta_drake.seam.station_process import run_station
from manta_drake.simulate import OutputFolderError

# What a side writes into --out.
OUTPUT_FILES = tuple(f"{side}_{kind}" for side in ("station", "controller")
                     for kind in ("log.npz", "metrics.json"))


def _add_common(parser) -> None:
    parser.add_argument("scenario", help="scenario YAML file, or a shipped scenario's name; "
                        "the station and the controller must use the same")
    parser.add_argument("--lcm", default=DEFAULT_URL, metavar="URL",
                        help=f"LCM URL (default {DEFAULT_URL}; both sides the same)")
    parser.add_argument("--duration", type=float, metavar="S",
                        help="override the scenario's duration [s]")
    parser.add_argument("--wall-clock", action="store_true",
                        help="run on wall time with the latest messages (as on the robot) "
                        "instead of lockstep; give it to both sides")
    parser.add_argument("--timeout", type=float, default=DEFAULT_TIMEOUT_S, metavar="S",
                        help="give up when the other side is silent this long "
                        f"(default {DEFAULT_TIMEOUT_S:g} s)")
    parser.add_argument("--startup-timeout", type=float, default=DEFAULT_STARTUP_TIMEOUT_S,
                        metavar="S", help="the same for its first message "
                        f"(default {DEFAULT_STARTUP_TIMEOUT_S:g} s)")
    parser.add_argument("--out", metavar="DIR",
                        help="write <side>_log.npz and <side>_metrics.json here")
    parser.add_argument("--quiet", action="store_true", help="no progress on stderr")


def add_station_parser(subparsers) -> None:
    """Adds ``manta-drake station``."""
    p = subparsers.add_parser("station", help="run the simulated robot alone, over LCM",
                              description="Runs the station (the simulated robot) of a "
                              "scenario alone: publishes its sensors, reads the commands of "
                              "`manta-drake controller` over LCM (docs/lcm.md).")
    _add_common(p)


def add_controller_parser(subparsers) -> None:
    """Adds ``manta-drake controller``."""
    p = subparsers.add_parser("controller", help="run the controller alone, over LCM",
                              description="Runs the controller of a scenario alone against "
                              "`manta-drake station` (or the robot) over LCM (docs/lcm.md).")
    _add_common(p)


def check_out_folder(out_dir, inputs=(), create: bool = True) -> pathlib.Path:
    """Checks the ``--out`` folder before anything is built, as
    ``manta_drake.simulate.check_output_folder`` does for a run: an empty path, a file, a
    folder that cannot be created or written, or one where a side would overwrite its own
    input are refused; creates it if ``create`` (a refused scenario leaves no folder, so the
    first check does not). A user's ``scenario.yaml`` there is not refused: a side writes
    only ``<side>_log.npz`` and ``<side>_metrics.json``.

    Raises:
        OutputFolderError: one line naming the folder and why.
    """
    out_dir = check_writable_folder(out_dir, "--out", "out/split", OutputFolderError, create)
    ours = {(out_dir / name).resolve() for name in OUTPUT_FILES}
    for path in inputs:
        if pathlib.Path(path).resolve() in ours:
            raise OutputFolderError(f"--out {out_dir}: a side would overwrite its own input "
                                    f"{path}; choose another output folder")
    return out_dir


def check_options(args) -> None:
    """The options, each checked in one line before anything is loaded or built.

    Raises:
        ScenarioError, SeamError, OutputFolderError: the first option that is refused.
    """
    for name in ("timeout", "startup_timeout"):
        check_in_range(f"--{name.replace('_', '-')}", getattr(args, name), 0.0, math.inf,
                       "(0, inf) s", open_low=True, open_high=True)
    check_url(args.lcm)
    open_lcm(args.lcm, getattr(args, "command", None) or "seam")  # what only liblcm can tell


def _load(args):
    check_options(args)
    path = find_scenario(args.scenario)
    if args.out is not None:
        check_out_folder(args.out, inputs=[path], create=False)
    # --duration 0 is refused by the scenario's own check, with its range, as `run` does.
    scenario = load_scenario(path, {} if args.duration is None else {"duration": args.duration})
    if args.out is not None:
        check_out_folder(args.out, inputs=[path])
    return scenario


def _main(args, run) -> int:
    scenario = _load(args)
    result = run(scenario, args.lcm, wall_clock=args.wall_clock, timeout=args.timeout,
                 startup_timeout=args.startup_timeout, progress=not args.quiet)
    if args.out:
        result.write(args.out)
    print(result.summary(), flush=True)
    return 0


def station_main(args) -> int:
    """``manta-drake station SCENARIO --lcm URL``."""
    return _main(args, run_station)


def controller_main(args) -> int:
    """``manta-drake controller SCENARIO --lcm URL``."""
    return _main(args, run_controller)
