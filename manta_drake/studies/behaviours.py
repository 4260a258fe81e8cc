"""Behaviours and modalities as data: the paper's runs against the heading hold and the
flow-, depth- and energy-driven run (docs/behaviours.md).

Runs two_behaviors, three_behaviors, locomotion_swim, swim_heading_hold,
two_behaviors_heading_hold and four_behaviors (and swim_heading_hold with the opposite trim
sign; one Dask task each) into ``--runs DIR`` (default out/behaviours), reads every number
from their logs (transitions, walls, the free-water window, speeds, yaw rates, the trim, the
estimates) and writes the report into ``--out DIR`` (default: the checkout's docs/): the page
``DIR/behaviours.md`` (its prose is the template ``templates/behaviours.md.j2``) and the
figures ``DIR/figures/heading_hold.png`` and ``DIR/figures/four_behaviors.png``.

Usage: manta-drake study behaviours [--out docs] [--runs out/behaviours] [--reuse]
       [--workers N | --scheduler ADDRESS]
"""

from __future__ import annotations

import json
import pathlib
import shutil

import numpy as np

from manta_drake.cluster import (
    add_cluster_arguments,
    check_cluster_arguments,
    cluster_client,
)
from manta_drake.metrics import transition_span

SCENARIOS = (
    "two_behaviors",
    "three_behaviors",
    "locomotion_swim",
    "swim_heading_hold",
    "two_behaviors_heading_hold",
    "four_behaviors",
    "swim_heading_hold_reversed",
)
# Runs that are a shipped scenario with overrides: name -> (scenario, overrides).
VARIANTS = {"swim_heading_hold_reversed": ("swim_heading_hold", {"heading_hold.turn_sign": -1})}
# The heading hold's runs, whose mean trim the page gives.
HEADING_RUNS = ("locomotion_swim", "swim_heading_hold", "swim_heading_hold_reversed")
DEFAULT_RUNS = pathlib.Path("out/behaviours")


def run_one(name: str, out: str) -> dict:
    """Runs the shipped scenario ``name`` into ``out``; its metrics (the log stays there)."""
    from manta_drake.scenario import load_scenario
    from manta_drake.simulate import run

    base, overrides = VARIANTS.get(name, (name, {}))
    scenario = load_scenario(base, overrides={"visualization.meshcat": False, **overrides})
    return run(scenario, out, progress=False).metrics


def _runs(args) -> dict:
    out = pathlib.Path(args.runs)
    todo = [n for n in SCENARIOS if not (args.reuse and (out / n / "metrics.json").is_file())]
    with cluster_client(args) as client:
        if client is None:
            for name in todo:
                run_one(name, str(out / name))
        else:
            futures = [client.submit(run_one, n, str(out / n), pure=False) for n in todo]
            client.gather(futures)
    return {n: json.loads((out / n / "metrics.json").read_text()) for n in SCENARIOS}


# ---------------------------------------------------------------------------------------------
# The page's numbers, from the runs' metrics and logs


def run_facts(m: dict) -> dict:
    """What the page says of one run, from its metrics: its behaviour changes, walls,
    velocity, yaw rate and free-water window."""
    return {
        "transitions": [
            {"change": f"{t['from']} -> {t['to']}", "span": transition_span(t)}
            for t in m.get("transitions", [])
        ],
        "near": m.get("near_wall_at_s"),
        "closest": max(m["min_wall_clearance_m"], 0.0),
        "touched": bool(m["touched_wall"]),
        "uv": m.get("mean_velocity_body"),
        "yaw": m.get("yaw_rate_deg_s"),
        "window": m.get("steady_window_s"),
    }


def mean_trim(log, window) -> float | None:
    """The heading hold's mean trim over the window, or None for a run without the hold."""
    if "heading_trim" not in log.files:
        return None
    t = log["t_heading_trim"]
    sel = (t >= window[0]) & (t <= window[1])
    return float(log["heading_trim"][sel, 0].mean())


def current_schedule(spec) -> dict:
    """four_behaviors' current: its speed, the last time it is on and when it has stopped."""
    keys = spec.water.current_schedule
    on_until = max(k.time for k in keys if np.linalg.norm(k.velocity) > 0)
    return {
        "speed": max(np.linalg.norm(k.velocity) for k in keys),
        "on_until": on_until,
        "off_at": min(k.time for k in keys if k.time > on_until),
    }


def estimates_at(log, times) -> list[dict]:
    """four_behaviors' estimates and balloon command at each of ``times`` (the first sample
    at or after it)."""

    def at(key, t):
        return float(log[key][min(np.searchsorted(log[f"t_{key}"], t), len(log[key]) - 1), 0])

    return [
        {
            "t": t,
            "z_hat": at("z_hat", t),
            "flow_hat": at("flow_hat", t),
            "energy_hat": at("energy_hat", t),
            "balloon": at("balloon_command", t),
        }
        for t in times
    ]


def drift_reading(log, four: dict, start: float, end: float) -> dict:
    """four_behaviors from ``start`` (the balloon rule's) to ``end`` (the current's): the
    robot's drift speed along y [m/s], the filtered flow speed's range [m/s]; z_hat's lowest
    value over the first 5 s and when the walk gave way to the trot (None if never)."""
    t, speed = log["t_flow_speed_hat"], log["flow_speed_hat"][:, 0]
    inside = speed[(t >= start) & (t <= end)]
    y = log["body_xyz"][:, 1]
    drift = (np.interp(end, log["t"], y) - np.interp(start, log["t"], y)) / (end - start)
    tz, z = log["t_z_hat"], log["z_hat"][:, 0]
    back = (
        tr["start_s"] for tr in four["transitions"] if (tr["from"], tr["to"]) == ("walk", "trot")
    )
    return {
        "speed": drift,
        "start": start,
        "end": end,
        "flow_low": inside.min(),
        "flow_high": inside.max(),
        "z_low": z[tz <= 5.0].min(),
        "back": next(back, None),
    }


def four_spec(spec) -> dict:
    """The settings of the four_behaviors scenario the page quotes."""
    return {
        "rule_after": spec.balloon.rule.after,
        "soc0_pct": 100 * spec.actuators.initial_soc,
        "reserve_pct": (100 * spec.energy_estimator.soc_low, 100 * spec.energy_estimator.soc_high),
        "flow_band": (spec.flow_estimator.speed_low, spec.flow_estimator.speed_high),
        "flow_time_constant": spec.flow_estimator.time_constant,
    }


def page_context(metrics: dict, runs: pathlib.Path) -> dict:
    """The numbers of the page, from the runs' metrics and the logs in ``runs``."""
    from manta_drake.scenario import load_scenario

    facts = {name: run_facts(m) for name, m in metrics.items()}
    for name in HEADING_RUNS:
        facts[name]["trim"] = mean_trim(np.load(runs / name / "log.npz"), facts[name]["window"])
    swim = metrics["locomotion_swim"]
    facts["locomotion_swim"]["free_water_end"] = (
        swim["near_wall_at_s"] or swim["steady_window_s"][1]
    )
    four = metrics["four_behaviors"]
    facts["four_behaviors"]["behaviours"] = sorted(
        {b for t in four["transitions"] for b in (t["from"], t["to"])}
    )
    spec = load_scenario("four_behaviors")
    current = current_schedule(spec)
    log = np.load(runs / "four_behaviors" / "log.npz")
    on, off = current["on_until"], current["off_at"]
    times = (4.0, on, off + 4.0, off + 8.0, 30.0, 50.0, 65.0)  # s
    energy = four.get("energy", {})
    return {
        "runs": facts,
        "current": current,
        "spec": four_spec(spec),
        "estimates": estimates_at(log, times),
        "drift": drift_reading(log, four, spec.balloon.rule.after, current["on_until"]),
        "energy": {
            "power_w": energy.get("mean_electrical_power_w", float("nan")),
            "soc_end_pct": 100 * energy.get("battery_soc_end", float("nan")),
        },
    }


def stamp(out=None, runs=DEFAULT_RUNS) -> str:
    """The page's stamp: the command that makes it again (with ``--out`` and ``--runs`` as
    given), and the runs behind it."""
    from manta_drake.studies.stamp import stamp_line

    words = ["manta-drake study behaviours"]
    words += [] if out is None else [f"--out {out}"]
    words += [] if pathlib.Path(runs) == DEFAULT_RUNS else [f"--runs {runs}"]
    return stamp_line(
        f"`{' '.join(words)}` (the runs: `manta-drake run NAME` for each scenario below; "
        "`python diagrams/four_behaviors.py`)."
    )


def page(metrics: dict, runs: pathlib.Path, stamp_text: str | None = None) -> str:
    """The page for these runs (``stamp_text``: its stamp line, by default ``stamp()``)."""
    from manta_drake.studies.report import render

    context = page_context(metrics, pathlib.Path(runs))
    return render("behaviours.md.j2", stamp=stamp_text or stamp(), **context)


# ---------------------------------------------------------------------------------------------
# The figures


def _heading_figure(runs: pathlib.Path, path: pathlib.Path) -> None:
    """The swim's yaw with and without the heading hold, and the hold's trim."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=(10, 6))
    ax1, ax2 = fig.subplots(2, 1, sharex=True)
    for name, label in (
        ("locomotion_swim", "swim (printed Phi'_swim lag)"),
        ("swim_heading_hold", "the same swim, heading held by the IMU"),
    ):
        log = np.load(runs / name / "log.npz")
        ax1.plot(log["t"], np.degrees(np.unwrap(log["body_rpy"][:, 2])), label=label)
        if "heading_trim" in log.files:
            ax2.plot(
                log["t_heading_trim"],
                log["heading_trim"][:, 0],
                label="trim u (left x (1+u), right x (1-u))",
            )
    ax1.set_ylabel("yaw [deg]")
    ax1.legend(fontsize=8)
    ax2.set_ylabel("heading trim")
    ax2.set_xlabel("time [s]")
    ax2.legend(fontsize=8)
    for ax in (ax1, ax2):
        ax.grid(alpha=0.3)
    fig.suptitle("Heading hold: the swim's yaw with and without the IMU's trim")
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def _four_figure(runs: pathlib.Path, metrics: dict, path: pathlib.Path) -> None:
    """four_behaviors' run as the transition runs are drawn (cf. the paper's Fig. 11)."""
    from manta_drake import plots
    from manta_drake.scenario import load_scenario

    data = np.load(runs / "four_behaviors" / "log.npz")
    log = {k: data[k] for k in data.files}
    plots.fig_transition_run(
        log,
        metrics,
        path,
        "four_behaviors: flow, depth and the battery choose the behaviour (cf. paper Fig. 11)",
        leaves=load_scenario("four_behaviors").behaviour_tree().leaves,
    )


def write_figures(metrics: dict, runs: pathlib.Path, folder: pathlib.Path) -> pathlib.Path:
    """Both figures into ``folder``/figures (the file-only backend: no display needed)."""
    import matplotlib

    matplotlib.use("Agg")
    figures = folder / "figures"
    figures.mkdir(parents=True, exist_ok=True)
    _heading_figure(runs, figures / "heading_hold.png")
    _four_figure(runs, metrics["four_behaviors"], figures / "four_behaviors.png")
    return figures


# ---------------------------------------------------------------------------------------------
# The command line


def parser(prog=None):
    """The command line's options."""
    from manta_drake.studies.options import StudyParser

    parser = StudyParser(prog=prog, description=" ".join(__doc__.split("\n\n")[0].split()))
    parser.add_argument(
        "--out",
        type=pathlib.Path,
        metavar="DIR",
        help="where the report goes: DIR/behaviours.md and DIR/figures/ (default the "
        "checkout's docs/)",
    )
    parser.add_argument(
        "--runs",
        type=pathlib.Path,
        default=DEFAULT_RUNS,
        metavar="DIR",
        help=f"where the runs go, one folder each (default {DEFAULT_RUNS})",
    )
    parser.add_argument(
        "--reuse",
        action="store_true",
        help="reuse runs already in --runs (their metrics.json and log.npz)",
    )
    add_cluster_arguments(parser)
    return parser


def main(argv=None, prog=None) -> int:
    """The command line (``manta-drake study behaviours``); returns the exit status."""
    from manta_drake.config_io import check_writable_folder
    from manta_drake.studies.report import output_folder
    from manta_drake.studies.stamp import write_stamped

    args = parser(prog).parse_args(argv)
    check_cluster_arguments(args)  # every option before a cluster or a run starts
    check_writable_folder(args.runs, "--runs", example=str(DEFAULT_RUNS))
    folder = output_folder(args.out, prog or "manta-drake study behaviours")
    metrics = _runs(args)
    figures = write_figures(metrics, args.runs, folder)
    page_path = folder / "behaviours.md"
    written = write_stamped(page_path, page(metrics, args.runs, stamp(args.out, args.runs)))
    print(f"{page_path} {'written' if written else 'unchanged'}; figures in {figures}")
    for name in SCENARIOS:
        facts = run_facts(metrics[name])
        changes = "; ".join(f"{t['change']} {t['span']} s" for t in facts["transitions"])
        print(f"{name:28s} {changes or 'none'} | closest {facts['closest']:.2f} m")
    shutil.rmtree(args.runs / "dask-worker-space", ignore_errors=True)
    return 0
