"""``manta-drake station`` and ``manta-drake controller`` (``manta_drake.cli`` dispatches
here)."""

from __future__ import annotations

from manta_drake.scenario import load_scenario
from manta_drake.seam.controller_process import run_controller
from manta_drake.seam.errors import SeamError
from manta_drake.seam.link import DEFAULT_STARTUP_TIMEOUT_S, DEFAULT_TIMEOUT_S, DEFAULT_URL
from manta_drake.seam.station_process import run_station


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


def _load(args):
    if args.timeout <= 0 or args.startup_timeout <= 0:
        raise SeamError("--timeout and --startup-timeout must be > 0 s")
    return load_scenario(args.scenario, {"duration": args.duration} if args.duration else {})


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
