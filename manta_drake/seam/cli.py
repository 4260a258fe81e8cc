"""``manta-drake station`` and ``manta-drake controller`` (``manta_drake.cli`` dispatches
here), over LCM (``--lcm URL``, the default) or ROS 2 (``--ros2``)."""

from __future__ import annotations

import math
import os
import pathlib

from manta_drake.config_io import check_in_range, check_writable_folder
from manta_drake.scenario import find_scenario, load_scenario
from manta_drake.seam.controller_process import run_controller
from manta_drake.seam.errors import SeamError
from manta_drake.seam.failsafe import DEFAULT_FAILSAFE_AFTER_S
from manta_drake.seam.link import (
    DEFAULT_STARTUP_TIMEOUT_S,
    DEFAULT_TIMEOUT_S,
    DEFAULT_URL,
    STALE_AFTER_S,
    check_url,
    open_lcm,
)
from manta_drake.seam.station_process import run_station
from manta_drake.simulate import OutputFolderError

# What a side writes into --out.
OUTPUT_FILES = tuple(
    f"{side}_{kind}" for side in ("station", "controller") for kind in ("log.npz", "metrics.json")
)


def _add_common(parser) -> None:
    parser.add_argument(
        "scenario",
        help="scenario YAML file, or a shipped scenario's name; "
        "the station and the controller must use the same",
    )
    parser.add_argument(
        "--lcm", metavar="URL", help=f"LCM URL (default {DEFAULT_URL}; both sides the same)"
    )
    parser.add_argument(
        "--ros2",
        action="store_true",
        help="carry the seam over ROS 2 (DDS) instead of LCM: standard "
        "messages on the topic map's topics, /clock (docs/ros2.md)",
    )
    parser.add_argument(
        "--domain",
        type=int,
        metavar="N",
        help="with --ros2: the ROS 2 domain id, 0-232 (default: "
        "ROS_DOMAIN_ID, else 0; both sides the same)",
    )
    parser.add_argument(
        "--topic-map",
        metavar="FILE",
        help="with --ros2: your changes to the shipped models/ros2_topics.yaml",
    )
    parser.add_argument(
        "--dds-config",
        metavar="FILE",
        help="with --ros2: a Cyclone DDS XML of your own instead of the shipped "
        "loopback-only one (to reach another machine)",
    )
    parser.add_argument(
        "--duration", type=float, metavar="S", help="override the scenario's duration [s]"
    )
    parser.add_argument(
        "--wall-clock",
        action="store_true",
        help="run on wall time with the latest messages (as on the robot) "
        "instead of lockstep; give it to both sides",
    )
    parser.add_argument(
        "--timeout",
        type=float,
        default=DEFAULT_TIMEOUT_S,
        metavar="S",
        help=f"give up when the other side is silent this long (default {DEFAULT_TIMEOUT_S:g} s)",
    )
    parser.add_argument(
        "--startup-timeout",
        type=float,
        default=DEFAULT_STARTUP_TIMEOUT_S,
        metavar="S",
        help=f"the same for its first message (default {DEFAULT_STARTUP_TIMEOUT_S:g} s)",
    )
    parser.add_argument(
        "--out", metavar="DIR", help="write <side>_log.npz and <side>_metrics.json here"
    )
    parser.add_argument("--quiet", action="store_true", help="no progress on stderr")


def add_station_parser(subparsers) -> None:
    """Adds ``manta-drake station``."""
    p = subparsers.add_parser(
        "station",
        help="run the simulated robot alone, over LCM or ROS 2",
        description="Runs the station (the simulated robot) of a "
        "scenario alone: publishes its sensors, reads the commands of "
        "`manta-drake controller` over LCM (docs/lcm.md) or ROS 2 "
        "(--ros2, docs/ros2.md).",
    )
    _add_common(p)


def add_controller_parser(subparsers) -> None:
    """Adds ``manta-drake controller``."""
    p = subparsers.add_parser(
        "controller",
        help="run the controller alone, over LCM or ROS 2",
        description="Runs the controller of a scenario alone against "
        "`manta-drake station` (or the robot) over LCM (docs/lcm.md) or "
        "ROS 2 (--ros2, docs/ros2.md).",
    )
    _add_common(p)
    p.add_argument(
        "--failsafe-after",
        type=float,
        default=DEFAULT_FAILSAFE_AFTER_S,
        metavar="S",
        help="on the wall clock: command the safe state (the start "
        "stance, the balloon full) once the station has been silent this long "
        f"(default {DEFAULT_FAILSAFE_AFTER_S:g} s; lockstep: after "
        f"{STALE_AFTER_S:g} s)",
    )


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
            raise OutputFolderError(
                f"--out {out_dir}: a side would overwrite its own input "
                f"{path}; choose another output folder"
            )
    return out_dir


def check_options(args) -> None:
    """The options, each checked in one line before anything is loaded or built.

    Raises:
        ScenarioError, SeamError, OutputFolderError: the first option that is refused.
    """
    for name in ("timeout", "startup_timeout", "failsafe_after"):
        if getattr(args, name, None) is not None:
            check_in_range(
                f"--{name.replace('_', '-')}",
                getattr(args, name),
                0.0,
                math.inf,
                "(0, inf) s",
                open_low=True,
                open_high=True,
            )
    if args.ros2:
        _check_ros2_options(args)
        return
    for option in ("domain", "topic_map", "dds_config"):
        if getattr(args, option) is not None:
            raise SeamError(
                f"--{option.replace('_', '-')} is an option of the seam over ROS 2: give --ros2 too"
            )
    args.lcm = args.lcm or DEFAULT_URL
    check_url(args.lcm)
    open_lcm(args.lcm, getattr(args, "command", None) or "seam")  # what only liblcm can tell


def _check_ros2_options(args) -> None:
    """``--ros2``'s options, each in one line (the domain from ROS_DOMAIN_ID when not
    given); sets ``args.domain``."""
    from manta_drake.ros2 import require
    from manta_drake.ros2.dds import check_domain, read_config
    from manta_drake.ros2.topic_map import load_topic_map

    if args.lcm is not None:
        raise SeamError("--lcm and --ros2: the seam runs over one transport; give one")
    require("cyclonedds")
    if args.domain is None:
        text = os.environ.get("ROS_DOMAIN_ID", "").strip() or "0"
        try:
            args.domain = int(text)
        except ValueError:
            raise SeamError(
                f"ROS_DOMAIN_ID={text!r}: a ROS 2 domain id is an integer in "
                "0-232 (or give --domain N)"
            ) from None
    check_domain(args.domain)
    if args.dds_config is not None:
        read_config(args.dds_config)
    load_topic_map(args.topic_map)


def _transport(args, scenario, who: str):
    """The LCM URL, or the ROS 2 transport of ``--ros2``."""
    if not args.ros2:
        return args.lcm
    from manta_drake.ros2.bag import bag_constants
    from manta_drake.ros2.topic_map import load_topic_map
    from manta_drake.seam.ros2_link import Ros2Transport

    topic_map = load_topic_map(args.topic_map)
    return Ros2Transport(
        who,
        args.domain,
        topic_map,
        bag_constants(scenario, topic_map, fin_links=False),
        args.dds_config,
    )


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


def _main(args, run, who: str, **options) -> int:
    scenario = _load(args)
    transport = _transport(args, scenario, who)
    try:
        result = run(
            scenario,
            transport,
            wall_clock=args.wall_clock,
            timeout=args.timeout,
            startup_timeout=args.startup_timeout,
            progress=not args.quiet,
            **options,
        )
    except SeamError as e:  # a side that ran and then failed still writes what it did
        if args.out and e.result is not None:
            e.result.write(args.out)
        raise
    if args.out:
        result.write(args.out)
    print(result.summary(), flush=True)
    return 0


def station_main(args) -> int:
    """``manta-drake station SCENARIO [--lcm URL | --ros2 [--domain N]]``."""
    return _main(args, run_station, "station")


def controller_main(args) -> int:
    """``manta-drake controller SCENARIO [--lcm URL | --ros2 [--domain N]]``."""
    return _main(args, run_controller, "controller", failsafe_after=args.failsafe_after)
