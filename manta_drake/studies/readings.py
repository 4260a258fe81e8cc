"""The printed gait matrices under different readings of their signs and row order.

Eqs. (6)-(8) cannot all be read with one sign convention (docs/design.md, section 6 (c)).
This study runs every locomotion scenario (12 s, mean over 6-12 s, free water) with its
gait and stance taken from one reading at a time, so the choice in ``gaits.py`` rests on
numbers. A reading is data (``READINGS``: a gait name to its ``GaitParams``, built from the
package's library, which is read and never changed); each run names the reading's gait in
a gait file of its own folder (``explicit_gait``):

* ``printed``: every matrix exactly as printed, rows fl, fr, rl, rr (``swim_printed`` for
  the swim);
* ``shipped``: what ``gaits.GAITS`` holds (the swim's right-fin pitch mirrored, the legged
  gaits as printed);
* ``mirror_left``: every gait made mirror-symmetric, each right fin's R and X rows the
  mirror (``MIRROR_SIGNS``) of its left partner's as printed;
* ``mirror_right``: the same from the printed right rows;
* ``left_first``: the rows read as fl, rl, fr, rr (left side first) and the right fins
  mirror-built (their yaw and pitch servos turn the other way), so equal rows are mirror
  images;
* ``swim_no_lag``: the shipped swim with Phi'_swim set to zero (no left-right lag).

Usage: manta-drake study readings [--runs out/readings] [--out DIR] [--duration 12]
       [--readings printed,shipped,...] [--gaits swim,trot,...] [--fin-sweep DEG]
Each run goes to its folder ``RUNS/<reading>_<gait>``. Prints a markdown table (u, v, yaw rate
over the window; wall clearance) and writes it to ``OUT/readings.md`` (the template
``templates/readings.md.j2``), with a figure of the swims' paths
(``OUT/figures/swim_paths.png``); ``OUT`` is ``--out DIR``, by default the checkout's
``docs/`` (``studies.report.output_folder``).
"""

from __future__ import annotations

import pathlib

import numpy as np

import manta_drake.control.gaits as G
from manta_drake.scenario import load_scenario
from manta_drake.studies.explicit_gait import run_with_gait

GAITS = ("swim", "trot", "walk", "crab", "turning")
DEFAULT_RUNS = pathlib.Path("out/readings")
TEMPLATE = "readings.md.j2"
LEFT_FIRST = [0, 2, 1, 3]  # our row (fl, fr, rl, rr) <- printed row, when rows are fl, rl, fr, rr


def shipped(name: str) -> G.GaitParams:
    """The gait ``name`` of the package's default reading (``controller.gait_reading: paper``)."""
    return G.get_gait(name, "paper")


def printed(name: str) -> G.GaitParams:
    """The gait ``name`` exactly as printed (``<name>_printed``)."""
    return G.get_gait(f"{name}_printed", "paper")


def mirrored(g: G.GaitParams, from_left: bool) -> G.GaitParams:
    """``g`` with R and X made mirror-symmetric from its printed left (or right) rows."""
    if from_left:
        return G.GaitParams(G.mirror_right_fins(g.R), G.mirror_right_fins(g.X), g.Phi, g.Phi_prime)
    R, X = g.R.copy(), g.X.copy()
    R[[0, 2]], X[[0, 2]] = G.MIRROR_SIGNS * R[[1, 3]], G.MIRROR_SIGNS * X[[1, 3]]
    return G.GaitParams(R, X, g.Phi, g.Phi_prime)


def left_first(g: G.GaitParams) -> G.GaitParams:
    """``g`` with its rows read as fl, rl, fr, rr and the right fins mirror-built."""
    p = LEFT_FIRST
    R, X = g.R[p].copy(), g.X[p].copy()
    R[list(G.RIGHT_LEGS)] *= G.MIRROR_SIGNS
    X[list(G.RIGHT_LEGS)] *= G.MIRROR_SIGNS
    return G.GaitParams(R, X, g.Phi[p], g.Phi_prime[np.ix_(p, p)])


# reading -> (gait name -> the gait under that reading)
READINGS = {
    "printed": printed,
    "shipped": shipped,
    "mirror_left": lambda name: mirrored(printed(name), True),
    "mirror_right": lambda name: mirrored(printed(name), False),
    "left_first": lambda name: left_first(printed(name)),
    "swim_no_lag": lambda name: (
        G.GaitParams(shipped("swim").R, shipped("swim").X, shipped("swim").Phi, np.zeros((4, 4)))
        if name == "swim"
        else shipped(name)
    ),
}


def run_overrides(duration: float, fin_sweep_deg: float | None = None) -> dict:
    """The overrides of a run's locomotion scenario (``run_reading``)."""
    overrides = {"visualization.meshcat": False, "duration": duration, "steady_after": duration / 2}
    if fin_sweep_deg is not None:
        overrides["robot.fin_sweep_deg"] = fin_sweep_deg
    return overrides


def run_reading(
    reading: str,
    gait: str,
    out: pathlib.Path,
    duration: float,
    fin_sweep_deg: float | None = None,
    readings=READINGS,
) -> dict:
    """One locomotion scenario with its gait and stance under ``reading`` (and the fins'
    rest sweep ``fin_sweep_deg``, the scenario's own if None); its metrics.

    Args:
        reading: a key of ``readings``.
        gait: one of ``GAITS`` (the scenario ``locomotion_<gait>``).
        out: the run's output folder.
        duration: the run's duration [s]; the means are over its second half.
        fin_sweep_deg: ``robot.fin_sweep_deg`` of the run (None: the scenario's).
        readings: reading -> (gait name -> GaitParams).
    """
    s = load_scenario(f"locomotion_{gait}", overrides=run_overrides(duration, fin_sweep_deg))
    # The locomotion scenarios start in the stance of the gait they run.
    return run_with_gait(s, readings[reading](gait), out, gait_name=f"{gait}, {reading}")


def shortest_duration() -> float:
    """The shortest run [s] whose second half (the means' window) is long enough for a mean
    velocity (``simulate.MIN_STEADY_WINDOW``)."""
    from manta_drake.simulate import MIN_STEADY_WINDOW

    return 2.0 * MIN_STEADY_WINDOW


def check_arguments(args, prog: str) -> tuple[list[str], list[str], pathlib.Path]:
    """Every option before anything is run; returns the readings, the gaits and the output
    folder; raises ScenarioError naming the option."""
    from manta_drake.config_io import ScenarioError, check_in_range, check_writable_folder
    from manta_drake.scenario import MAX_DURATION_S
    from manta_drake.studies.options import check_names
    from manta_drake.studies.report import output_folder

    lo = shortest_duration()
    check_in_range(
        "--duration",
        args.duration,
        lo,
        MAX_DURATION_S,
        f"[{lo:g}, {MAX_DURATION_S:g}] s (the means are over the second half)",
    )
    readings = check_names("--readings", args.readings, tuple(READINGS))
    gaits = check_names("--gaits", args.gaits, GAITS)
    if args.fin_sweep is not None:  # the scenarios' own check of robot.fin_sweep_deg
        for gait in gaits:
            try:
                load_scenario(
                    f"locomotion_{gait}", overrides=run_overrides(args.duration, args.fin_sweep)
                )
            except ScenarioError as e:
                raise ScenarioError(f"--fin-sweep {args.fin_sweep:g}: {e}") from None
    check_writable_folder(args.runs, "--runs", example=str(DEFAULT_RUNS))
    return readings, gaits, output_folder(args.out, prog)


def measure(reading: str, gait: str, runs: pathlib.Path, duration: float, fin_sweep_deg) -> dict:
    """One run of ``run_reading`` in ``runs/<reading>_<gait>``: its row of the table. No
    mean velocity (the hull came near a wall before the window was long enough): NaN."""
    m = run_reading(reading, gait, runs / f"{reading}_{gait}", duration, fin_sweep_deg)
    u, v = m["mean_velocity_body"] or (float("nan"), float("nan"))
    yaw = m["yaw_rate_deg_s"]
    return {
        "reading": reading,
        "gait": gait,
        "u": u,
        "v": v,
        "yaw_rate": float("nan") if yaw is None else yaw,
        "clearance": m["min_wall_clearance_m"],
    }


def page(rows: list[dict], duration: float) -> str:
    """The page: the rows' table, means over the second half of ``duration`` s runs."""
    from manta_drake.studies.report import render

    return render(TEMPLATE, rows=rows, window=(duration / 2, duration))


def plot_swim_paths(runs: pathlib.Path, readings, duration: float, path: pathlib.Path) -> bool:
    """The swims' paths of ``readings`` (those run in ``runs``) from their start, into
    ``path``; returns whether there was one to draw."""
    swims = [r for r in readings if (runs / f"{r}_swim" / "log.npz").exists()]
    if not swims:
        return False
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(8, 4))
    styles = ["-", "--", ":", "-.", (0, (5, 1)), (0, (3, 1, 1, 1))]
    for i, r in enumerate(swims):
        log = np.load(runs / f"{r}_swim" / "log.npz")
        xy = log["body_xyz"][:, :2] - log["body_xyz"][0, :2]
        ax.plot(xy[:, 0], xy[:, 1], linestyle=styles[i % len(styles)], lw=2, label=r)
    ax.set_xlabel("x [m] (start heading)")
    ax.set_ylabel("y [m]")
    ax.set_aspect("equal")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8, loc="best")
    ax.set_title(f"locomotion_swim, {duration:g} s, under each reading of Eq. (6)")
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return True


def parser(prog: str):
    from manta_drake.studies.options import StudyParser

    p = StudyParser(prog=prog, description=__doc__.splitlines()[0])
    p.add_argument(
        "--runs",
        type=pathlib.Path,
        default=DEFAULT_RUNS,
        metavar="DIR",
        help=f"the runs' folders DIR/<reading>_<gait> (default {DEFAULT_RUNS})",
    )
    p.add_argument(
        "--out",
        metavar="DIR",
        help="the report's folder: DIR/readings.md and DIR/figures/swim_paths.png; "
        "default the checkout's docs/",
    )
    p.add_argument(
        "--duration",
        type=float,
        default=12.0,
        help="each run's duration [s] (the means are over its second half)",
    )
    p.add_argument(
        "--readings", default=",".join(READINGS), help=f"comma-separated, of {', '.join(READINGS)}"
    )
    p.add_argument(
        "--gaits", default=",".join(GAITS), help=f"comma-separated, of {', '.join(GAITS)}"
    )
    p.add_argument(
        "--fin-sweep",
        type=float,
        default=None,
        metavar="DEG",
        help="robot.fin_sweep_deg of every run (default: the scenario's, 10); "
        "docs/stance.md balances each reading's stance",
    )
    return p


ROW = (
    "{reading:<13} {gait:<8} u {u:+.3f}  v {v:+.3f} m/s  yaw {yaw_rate:+6.2f} deg/s  "
    "clearance {clearance:.2f} m"
)


def main(argv=None, prog=None) -> int:
    """The command line (``manta-drake study readings``); returns the exit status."""
    prog = prog or "manta-drake study readings"
    args = parser(prog).parse_args(argv)
    readings, gaits, out = check_arguments(args, prog)
    rows = []
    for reading in readings:
        for gait in gaits:
            if reading == "swim_no_lag" and gait != "swim":
                continue
            rows.append(measure(reading, gait, args.runs, args.duration, args.fin_sweep))
            print(ROW.format(**rows[-1]), flush=True)
    text = page(rows, args.duration)
    out.mkdir(parents=True, exist_ok=True)
    (out / "readings.md").write_text(text)
    print("\n" + text.rstrip("\n"))
    figure = out / "figures" / "swim_paths.png"
    if plot_swim_paths(args.runs, readings, args.duration, figure):
        print(f"figure: {figure}")
    return 0
