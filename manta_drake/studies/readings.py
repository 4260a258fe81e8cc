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

Usage: manta-drake study readings [--out out/gait_readings] [--duration 12]
       [--readings printed,shipped,...] [--gaits swim,trot,...] [--fin-sweep DEG]
Prints a markdown table (u, v, yaw rate over the window; wall clearance) and writes it to
OUT/readings.md, with a figure of the swims' paths (OUT/swim_paths.png).
"""

from __future__ import annotations

import pathlib

import numpy as np

import manta_drake.control.gaits as G
from manta_drake.scenario import load_scenario
from manta_drake.studies.explicit_gait import run_with_gait

GAITS = ("swim", "trot", "walk", "crab", "turning")
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


def check_arguments(args) -> tuple[list[str], list[str]]:
    """Every option before anything is run; returns the readings and the gaits; raises
    ScenarioError naming the option."""
    from manta_drake.config_io import ScenarioError, check_in_range, check_writable_folder
    from manta_drake.scenario import MAX_DURATION_S
    from manta_drake.studies.options import check_names

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
    check_writable_folder(args.out, "--out", example="out/gait_readings")
    return readings, gaits


def main(argv=None, prog=None) -> int:
    """The command line (``manta-drake study readings``); returns the exit status."""
    from manta_drake.studies.options import StudyParser

    parser = StudyParser(prog=prog, description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=pathlib.Path, default=pathlib.Path("out/gait_readings"))
    parser.add_argument(
        "--duration",
        type=float,
        default=12.0,
        help="each run's duration [s] (the means are over its second half)",
    )
    parser.add_argument(
        "--readings", default=",".join(READINGS), help=f"comma-separated, of {', '.join(READINGS)}"
    )
    parser.add_argument(
        "--gaits", default=",".join(GAITS), help=f"comma-separated, of {', '.join(GAITS)}"
    )
    parser.add_argument(
        "--fin-sweep",
        type=float,
        default=None,
        metavar="DEG",
        help="robot.fin_sweep_deg of every run (default: the scenario's, 10); "
        "docs/stance.md balances each reading's stance",
    )
    args = parser.parse_args(argv)
    readings, gaits = check_arguments(args)
    rows = []
    for reading in readings:
        for gait in gaits:
            if reading == "swim_no_lag" and gait != "swim":
                continue
            out = args.out / f"{reading}_{gait}"
            m = run_reading(reading, gait, out, args.duration, args.fin_sweep)
            # No mean velocity (the hull came near a wall before the window was long
            # enough): NaN in the table.
            u, v = m["mean_velocity_body"] or (float("nan"), float("nan"))
            yaw = m["yaw_rate_deg_s"]
            row = (
                reading,
                gait,
                u,
                v,
                float("nan") if yaw is None else yaw,
                m["min_wall_clearance_m"],
            )
            rows.append(row)
            print(
                "{:<13} {:<8} u {:+.3f}  v {:+.3f} m/s  yaw {:+6.2f} deg/s  clearance "
                "{:.2f} m".format(*row),
                flush=True,
            )
    w0, w1 = args.duration / 2, args.duration
    table = [
        f"Mean over {w0:g}-{w1:g} s of {w1:g} s runs (`manta-drake study readings"
        f" --duration {w1:g}`):",
        "",
        "| reading | gait | u m/s | v m/s | yaw rate deg/s | min wall clearance m |",
        "| --- | --- | --- | --- | --- | --- |",
    ]
    table += ["| {} | {} | {:+.3f} | {:+.3f} | {:+.2f} | {:.2f} |".format(*row) for row in rows]
    (args.out / "readings.md").write_text("\n".join(table) + "\n")
    print("\n" + "\n".join(table))
    swims = [r for r in readings if (args.out / f"{r}_swim" / "log.npz").exists()]
    if swims:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        fig, ax = plt.subplots(figsize=(8, 4))
        styles = ["-", "--", ":", "-.", (0, (5, 1)), (0, (3, 1, 1, 1))]
        for i, r in enumerate(swims):
            log = np.load(args.out / f"{r}_swim" / "log.npz")
            xy = log["body_xyz"][:, :2] - log["body_xyz"][0, :2]
            ax.plot(xy[:, 0], xy[:, 1], linestyle=styles[i % len(styles)], lw=2, label=r)
        ax.set_xlabel("x [m] (start heading)")
        ax.set_ylabel("y [m]")
        ax.set_aspect("equal")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8, loc="best")
        ax.set_title(f"locomotion_swim, {w1:g} s, under each reading of Eq. (6)")
        fig.tight_layout()
        fig.savefig(args.out / "swim_paths.png", dpi=120)
        print(f"figure: {args.out / 'swim_paths.png'}")
    return 0
