"""The ``manta-drake`` command line.

    manta-drake run SCENARIO.yaml --out DIR [--duration S] [--set KEY=VALUE ...] [--no-meshcat]
                    [--bag] [--topic-map FILE]
    manta-drake bag RUN_DIR [--topic-map FILE]       (manta_drake.ros2: a run as a ROS 2 bag)
    manta-drake list
    manta-drake station SCENARIO.yaml --lcm URL      (manta_drake.seam)
    manta-drake controller SCENARIO.yaml --lcm URL   (manta_drake.seam)
    manta-drake sweep SWEEP.yaml --out DIR           (manta_drake.sweep)
    manta-drake calibrate CALIBRATION.yaml --out DIR (manta_drake.calibrate)
    manta-drake optimize SPEC.yaml --out DIR         (manta_drake.optimize)

Each of the last five lives in its own package, which provides ``add_<command>_parser(sub)``
(adds its subparser) and ``<command>_main(args) -> int``; see ``EXTENSIONS``.

Errors are printed as one line (no traceback) and exit with status 2. Ctrl-C, SIGTERM and
SIGHUP are turned into exceptions before anything slow is imported: one line, exit status
128 + the signal (``manta_drake.interrupts``), and for ``run`` a metrics.json that says so
(``manta_drake.run_folder``).
"""

from __future__ import annotations

import argparse
import contextlib
import os
import pathlib
import shutil
import sys
import tempfile


def print_metrics(metrics: dict, out_dir) -> None:
    """A short table of a run's metrics and where its outputs are."""
    keys = [
        "scenario",
        "status",
        "sim_time_s",
        "wall_time_s",
        "real_time_factor",
        "mean_velocity_body",
        "yaw_rate_deg_s",
        "steady_window_s",
        "near_wall_at_s",
        "min_wall_clearance_m",
        "touched_wall",
        "distance_m",
        "max_joint_step_rad",
        "max_penetration_m",
        "final_max_joint_error_rad",
    ]
    energy_keys = [
        "mean_electrical_power_w",
        "hotel_power_w",
        "cot_electrical_dry_weight",
        "cot_net_of_hotel_dry_weight",
        "cot_mechanical_dry_weight",
        "operation_time_h",
        "battery_soc_end",
    ]
    print()
    for key in keys:
        if key in metrics:
            value = metrics[key]
            if isinstance(value, bool):
                value = "yes" if value else "no"
            elif isinstance(value, float):
                value = f"{value:.4g}"
            elif isinstance(value, list):
                value = "[" + ", ".join(f"{v:.4g}" for v in value) + "]"
            elif value is None:
                value = "-"
            print(f"  {key:<28} {value}")
    if metrics.get("note"):  # why a metric above is missing
        print(f"  {'':<28} ({metrics['note']})")
    energy = metrics.get("energy") or {}
    for key in energy_keys:
        if key in energy:
            value = energy[key]
            print(f"  {key:<28} {'-' if value is None else f'{value:.4g}'}")
    if energy.get("cost_of_transport_note"):
        print(f"  {'':<28} ({energy['cost_of_transport_note']})")
    failure = metrics.get("failure")
    if failure:
        print(
            f"  {'failure':<28} {failure.get('stage')} at {failure.get('time_s', 0):.3f} s: "
            f"{failure.get('reason')}"
        )
    for tr in metrics.get("transitions", []):
        from manta_drake.metrics import transition_span

        print(f"  transition {tr['from']:>8} -> {tr['to']:<8} {transition_span(tr)} s")
    out_dir = pathlib.Path(out_dir)
    print(f"\n  outputs in {out_dir}/")
    if (out_dir / "recording.html").exists():  # a run removes its old one before it writes
        print(f"  recording: open {(out_dir / 'recording.html').resolve()} in a browser")


@contextlib.contextmanager
def _stderr_held(received):
    """While inside, what is written to the standard error (by compiled code too) is held in
    a temporary file and written out on exit, unless the block was interrupted
    (``received`` is the list of ``interrupts_as_exceptions``): a library's report of the
    import a signal broke into (pydrake's "Could not initialize pydrake" and a traceback)
    would only bury the one line that says the run was interrupted."""
    from manta_drake.interrupts import (
        interruption,
        signals_deferred,
        signals_flagged,
        stop_if_signalled,
    )

    with signals_flagged() as pending:  # a signal now is raised once the restore is due
        sys.stderr.flush()
        try:
            saved = os.dup(2)
        except OSError:  # no standard error to hold
            saved = None
        if saved is not None:
            held = tempfile.TemporaryFile()  # noqa: SIM115 - closed in the finally below
            os.dup2(held.fileno(), 2)
    if saved is None:
        stop_if_signalled(pending)
        yield
        return
    interrupted = False
    try:
        stop_if_signalled(pending)
        yield
    except BaseException as e:
        interrupted = interruption(e, received) is not None
        raise
    finally:
        with signals_deferred():
            sys.stderr.flush()
            os.dup2(saved, 2)
            os.close(saved)
            if not (interrupted or received):
                held.seek(0)
                shutil.copyfileobj(held, sys.stderr.buffer)
                sys.stderr.flush()
            held.close()


# The options of `run` that set a scenario field, and the field.
_OPTION_FIELDS = {"--duration": "duration", "--no-meshcat": "visualization.meshcat"}


def _load_and_run(
    scenario_path,
    out,
    duration=None,
    no_meshcat=False,
    progress=True,
    settings=(),
    received=(),
    topic_map=None,
    live_address=None,
):
    """Loads a scenario (with the command line's overrides: ``--duration``, ``--set
    KEY=VALUE`` for any dotted scenario field, checked like the file) and runs it; with a
    ``topic_map`` (``ros2.topic_map.TopicMap``) the run writes its ROS 2 bag too.

    Before the slow imports the output folder is checked and marked ``running``
    (``run_folder.starting_run``): an interrupt from then on leaves a metrics.json that
    says so; ``received`` is the list of ``interrupts_as_exceptions`` (a signal's exception
    that an import turned into another error is still the interruption)."""
    from manta_drake.interrupts import stop_if_signalled
    from manta_drake.run_folder import starting_run

    given = pathlib.Path(scenario_path)  # a shipped scenario's name is never in the folder
    with starting_run(out, given.stem, [given] if given.is_file() else [], received) as out_dir:
        with _stderr_held(received):
            from manta_drake.scenario import find_scenario
            from manta_drake.simulate import run

        path = find_scenario(scenario_path)
        options = {}
        if duration is not None:
            options["duration"] = duration
        if no_meshcat:
            options["visualization.meshcat"] = False
        scenario = _scenario(path, settings, options)
        stop_if_signalled(received)
        live = _live_view(scenario, topic_map, live_address)
        try:
            return (
                run(scenario, out_dir, progress=progress, inputs=[path], bag=topic_map, live=live),
                scenario,
            )
        finally:
            if live is not None:
                live.close()


def _live_view(scenario, topic_map, address):
    """The live view of ``--foxglove HOST:PORT`` (None without it); says where it is."""
    if address is None:
        return None
    from manta_drake.ros2.live import LiveView, parse_address
    from manta_drake.ros2.topic_map import load_topic_map

    host, port = parse_address(address)
    live = LiveView(scenario, topic_map or load_topic_map(), host, port)
    print(
        f"live view: {live.url} (Foxglove: Open connection, Foxglove WebSocket; served "
        "while the run runs)",
        file=sys.stderr,
        flush=True,
    )
    return live


def _scenario(path, settings, options: dict):
    """The scenario file with the ``--set`` values and then the options' fields
    (``options``: dotted key -> value) layered on it. A ``--set`` value an option replaces
    is still checked (the file with every ``--set`` value must load), so a bad value never
    passes unseen."""
    from manta_drake.scenario import ScenarioError, load_scenario, parse_set, with_overrides

    overrides = parse_set(list(settings))
    replaced = {
        key: option
        for key in overrides
        for option, field in _OPTION_FIELDS.items()
        if field in options and (field == key or field.startswith(key + "."))
    }
    if not replaced:
        return load_scenario(path, overrides={**overrides, **options})
    try:
        scenario = load_scenario(path, overrides=overrides)
    except ScenarioError as e:
        # An error of the file or of another value is told as usual; else it is the
        # replaced value's.
        kept = {key: value for key, value in overrides.items() if key not in replaced}
        load_scenario(path, overrides={**kept, **options})
        key, option = next(iter(replaced.items()))
        raise ScenarioError(
            f"--set {key}: {str(e).removeprefix(f'{path}: ')} (checked "
            f"although {option} replaces it)"
        ) from None
    return with_overrides(scenario, options)


_SET_HELP = (
    "override a scenario field, e.g. --set contact.friction=0.6 or --set "
    "water.coefficient_scales.body.linear_damping=1.2 (repeatable; checked like the file)"
)


def _error(e: BaseException) -> int:
    """Prints an error as one line and returns the exit status 2 (the callers pass
    exceptions, never an interruption: they report those as one)."""
    message = " ".join(str(e).split())
    if isinstance(e, MemoryError):
        message = f"out of memory{': ' + message if message else ''} (a sweep or grid too large?)"
    elif not message:  # an exception without a message still says what it was
        message = type(e).__name__
    print(f"manta-drake: error: {message} (--debug shows the traceback)", file=sys.stderr)
    return 2


def run_experiment(doc: str, scenario_path, default_out: str, after_run=None) -> int:
    """The body of a diagram script: parse ``--scenario --out --duration --no-meshcat
    --debug``, run, call ``after_run(result, scenario)`` (it returns figure paths), print
    the metrics. Errors are one line with exit status 2, as in ``manta-drake run``."""
    parser = argparse.ArgumentParser(description=doc.splitlines()[0])
    parser.add_argument("--scenario", default=scenario_path)
    parser.add_argument("--out", default=default_out)
    parser.add_argument("--duration", type=float, help="override the scenario's duration [s]")
    parser.add_argument("--no-meshcat", action="store_true", help="no Meshcat recording")
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", help=_SET_HELP)
    parser.add_argument("--debug", action="store_true", help="show full tracebacks")
    args = parser.parse_args()
    from manta_drake.interrupts import interruption, interrupts_as_exceptions

    with interrupts_as_exceptions() as received:
        try:
            result, scenario = _load_and_run(
                args.scenario,
                args.out,
                args.duration,
                args.no_meshcat,
                settings=args.set,
                received=received,
            )
            figures = after_run(result, scenario) if after_run else []
        except (KeyboardInterrupt, Exception) as e:  # one clear line; --debug: the traceback
            if interruption(e, received):
                return _interrupted(interruption(e, received))
            if args.debug:
                raise
            return _error(e)
    print_metrics(result.metrics, result.out_dir)
    for path in figures or []:
        print(f"  figure: {path}")
    return 0


def _list() -> int:
    from manta_drake.config_io import load_yaml_mapping
    from manta_drake.scenario import shipped_scenarios

    for path in shipped_scenarios():
        data, _ = load_yaml_mapping(path, "scenario")
        print(f"{path.stem:<22} {data.get('description', '')}")
    print(
        "\n(run one with `manta-drake run NAME --out DIR`; the files are in "
        f"{shipped_scenarios()[0].parent})"
    )
    return 0


def _topic_map(args, wanted: bool = False):
    """The topic map of ``--topic-map FILE`` (else the shipped one) when a bag is ``wanted``,
    or ``--bag`` or ``--topic-map`` (which implies ``--bag``) asks for one, read and checked
    before anything else; None otherwise."""
    if not (wanted or getattr(args, "bag", False) or args.topic_map):
        return None
    from manta_drake.ros2.topic_map import load_topic_map

    return load_topic_map(args.topic_map)


def print_bag(summary) -> None:
    """One line per topic of a bag (``ros2.bag.BagSummary``) and where it is."""
    from manta_drake.ros2 import BAG_FILE, METADATA_FILE

    print(
        f"\n  ROS 2 bag: {summary.folder}/ ({BAG_FILE}, {summary.size_bytes / 1e3:.0f} kB, "
        f"and {METADATA_FILE}), {summary.start_ns / 1e9:g} to {summary.end_ns / 1e9:g} s"
    )
    for topic, (ros_type, count) in summary.topics.items():
        print(f"  {topic:<28} {ros_type:<34} {count} messages")


def _run(args, received=()) -> int:
    topic_map = _topic_map(args)
    if args.foxglove is not None:  # checked before anything is built
        from manta_drake.ros2 import require
        from manta_drake.ros2.live import parse_address

        parse_address(args.foxglove)
        require("foxglove")
    result, _ = _load_and_run(
        args.scenario,
        args.out,
        args.duration,
        args.no_meshcat,
        progress=not args.quiet,
        settings=args.set,
        received=received,
        topic_map=topic_map,
        live_address=args.foxglove,
    )
    print_metrics(result.metrics, result.out_dir)
    if result.bag is not None:
        print_bag(result.bag)
    return 0


def _bag(args) -> int:
    """``manta-drake bag RUN_DIR``: an existing run folder's log as a ROS 2 bag."""
    topic_map = _topic_map(args, wanted=True)
    from manta_drake.ros2.bag import bag_run_folder

    print_bag(bag_run_folder(args.run_dir, topic_map))
    return 0


# command -> (module with add_<command>_parser(subparsers) and <command>_main(args), the
# one-line help `manta-drake --help` shows). Only the command being run imports its module:
# `manta-drake run` does not load the seam, the sweep or the studies, and `--help` loads
# nothing heavy.
EXTENSIONS = {
    "station": ("manta_drake.seam", "run the simulated robot alone, over LCM or ROS 2"),
    "controller": ("manta_drake.seam", "run the controller alone, over LCM or ROS 2"),
    "sweep": (
        "manta_drake.sweep",
        "many runs on a Dask cluster: grids, rows, Monte Carlo (docs/sweeps.md)",
    ),
    "calibrate": (
        "manta_drake.calibrate",
        "fit hydrodynamic coefficients to measured runs on Dask (Sim2Real; docs/sweeps.md)",
    ),
    "optimize": (
        "manta_drake.optimize",
        "design a gait by CMA-ES on a Dask cluster (docs/optimize.md)",
    ),
    "study": ("manta_drake.studies", "run a study that regenerates a report of docs/"),
}


def _extension(command: str):
    import importlib

    name = EXTENSIONS[command][0]
    try:
        return importlib.import_module(name)
    except ModuleNotFoundError as e:
        if e.name != name:
            raise
        return None


def _command_in(argv) -> str | None:
    """The subcommand ``argv`` names (its first argument that is not an option)."""
    for arg in argv:
        if not arg.startswith("-"):
            return arg
    return None


def _parser(argv) -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="manta-drake", description="Manta-ray robot simulator")
    sub = parser.add_subparsers(dest="command", required=True)
    p_run = sub.add_parser("run", help="simulate a scenario YAML file")
    p_run.add_argument(
        "scenario", help="scenario YAML file, or a shipped scenario's name (see `manta-drake list`)"
    )
    p_run.add_argument("--out", required=True, help="output folder")
    p_run.add_argument("--duration", type=float, help="override the scenario's duration [s]")
    p_run.add_argument("--no-meshcat", action="store_true", help="no Meshcat recording")
    p_run.add_argument("--quiet", action="store_true", help="no progress bar")
    p_run.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", help=_SET_HELP)
    p_run.add_argument(
        "--foxglove",
        nargs="?",
        const="127.0.0.1:8765",
        metavar="HOST:PORT",
        help="serve the run's ROS 2 topics live to the Foxglove app while it "
        "runs (default 127.0.0.1:8765; port 0: any free port; docs/ros2.md)",
    )
    _add_bag_options(p_run, with_flag=True)
    p_bag = sub.add_parser("bag", help="write a run folder's log.npz as a ROS 2 bag (docs/ros2.md)")
    p_bag.add_argument("run_dir", help="a run's output folder (with log.npz and scenario.yaml)")
    _add_bag_options(p_bag, with_flag=False)
    parser.add_argument("--debug", action="store_true", help="show full tracebacks")
    sub.add_parser("list", help="list the shipped scenarios")
    chosen = _command_in(argv)
    for command, (_, help_text) in EXTENSIONS.items():
        module = _extension(command) if command == chosen else None
        if module is not None:
            getattr(module, f"add_{command}_parser")(sub)
        else:  # listed by --help; its options are read only when it is the command
            sub.add_parser(command, help=help_text, add_help=False)
    return parser


def _add_bag_options(parser, with_flag: bool) -> None:
    """``--bag`` (``with_flag``) and ``--topic-map FILE`` (which then implies it)."""
    if with_flag:
        parser.add_argument(
            "--bag",
            action="store_true",
            help="also write the run as a ROS 2 bag (run.mcap and metadata.yaml; docs/ros2.md)",
        )
    parser.add_argument(
        "--topic-map",
        metavar="FILE",
        help="the bag's topics, types, QoS and rates: your changes to the "
        "shipped models/ros2_topics.yaml" + (" (implies --bag)" if with_flag else ""),
    )


def _interrupted(stop) -> int:
    """One line for Ctrl-C (or SIGTERM/SIGHUP during a run, an ``interrupts.RunInterrupted``);
    the exit status 128 + signal."""
    name = stop.signal_name
    print(
        f"manta-drake: {'interrupted' if name == 'SIGINT' else 'terminated'} ({name})",
        file=sys.stderr,
    )
    return stop.exit_status


def main(argv=None) -> int:
    # First, before any slow import (a command's module, pydrake): Ctrl-C, SIGTERM and
    # SIGHUP from here on end the command with one line and, for `run`, the output
    # folder's story (interrupts.interrupts_as_exceptions).
    from manta_drake.interrupts import interruption, interrupts_as_exceptions

    argv = sys.argv[1:] if argv is None else list(argv)
    with interrupts_as_exceptions() as received:
        try:  # building the parser imports the command's module: a signal may come here too
            args = _parser(argv).parse_args(argv)
        except (KeyboardInterrupt, Exception) as e:
            if interruption(e, received):  # Ctrl-C, or the import a signal broke into
                return _interrupted(interruption(e, received))
            raise
        try:
            if args.command in EXTENSIONS:
                return getattr(_extension(args.command), f"{args.command}_main")(args)
            if args.command == "bag":
                return _bag(args)
            return _list() if args.command == "list" else _run(args, received)
        except (KeyboardInterrupt, Exception) as e:  # one clear line; --debug: the traceback
            if interruption(e, received):  # a signal, e.g. pydrake's ImportError for Ctrl-C
                return _interrupted(interruption(e, received))
            if args.debug:
                raise
            return _error(e)


if __name__ == "__main__":
    sys.exit(main())
