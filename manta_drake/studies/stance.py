"""The stance behind each reading of the gait matrices (docs/stance.md).

The paper prints the gait matrices of Eqs. (6)-(8) but not the leg-fins' rest sweep
(Table 2's theta_offset). ``controller.gait_reading`` chooses how the matrices are read:
``paper`` (the legged gaits as printed, the swim's right fins mirrored) or ``mirrored`` (each
right fin mirrors its left partner in every gait, the crab's pitch excepted);
``robot.fin_sweep_deg`` chooses the sweep. This study answers two questions:

1. Kinematics (Eq. 1, no simulation): with the fins at the trot's stance (X_gait), where do
   the two support diagonals pass relative to the CG, for each reading and sweep? And how
   big is the robot at the zero pose (Table 1: 0.38 m x 0.85 m x 0.14 m)?
2. Dynamics: every gait under each (reading, sweep) of the sweep ``diagrams/sweeps/stance.yaml``
   (20 s, the shipped defaults): u, v, yaw rate over the free-water window, and the mean body
   roll and pitch there (from each run's log: a stance that tips shows as pitch).

Usage:
    manta-drake sweep diagrams/sweeps/stance.yaml --out out/stance
    manta-drake study stance --sweep-out out/stance
    manta-drake study stance            # from the shipped table, no simulation

``--sweep-out`` also writes the dynamics table to ``--table`` (shipped as
diagrams/sweeps/data/stance_table.csv, the default in a checkout). Writes the markdown block
between ``<!-- stance-study:begin -->`` and ``<!-- stance-study:end -->`` of ``OUT/stance.md``
(the template ``templates/stance.md.j2``) and the figure ``OUT/figures/stance.png``; ``OUT`` is
``--out DIR``, by default the checkout's ``docs/`` (``studies.report.output_folder``).
"""

from __future__ import annotations

import csv
import pathlib

import numpy as np

from manta_drake.config_io import read_csv_table
from manta_drake.control.gaits import get_gait
from manta_drake.model.kinematics import fin_tips_xy, support_diagonal_offsets
from manta_drake.model.robot_params import robot_with_fin_sweep_deg
from manta_drake.scenario import load_scenario
from manta_drake.studies import REPO as ROOT

MARK_BEGIN = "<!-- stance-study:begin -->"
MARK_END = "<!-- stance-study:end -->"
READINGS = ("paper", "mirrored")
SWEEPS_DEG = (0.0, 10.0, 20.0, 30.0, 40.0)
GAITS = ("swim", "trot", "walk", "crab", "turning")
# (reading, sweep) pairs of diagrams/sweeps/stance.yaml, the balanced ones first.
CONFIGS = (("paper", 10.0), ("mirrored", 30.0), ("mirrored", 10.0), ("paper", 30.0))
COLUMNS = (
    "gait_reading",
    "fin_sweep_deg",
    "gait",
    "u",
    "v",
    "yaw_rate_deg_s",
    "mean_roll_deg",
    "mean_pitch_deg",
    "steady_start_s",
    "steady_end_s",
)


def stance_tips(reading: str, sweep_deg: float) -> np.ndarray:
    """Fin tips (x, y) [m] in the body frame (Drake: x forward, y left) at the trot's X."""
    return fin_tips_xy(get_gait("trot", reading).X, robot_with_fin_sweep_deg(sweep_deg))


def zero_pose_size(sweep_deg: float) -> np.ndarray:
    """L, W, H [m]: the axis-aligned box around the robot's illustration geometry at q = 0."""
    from pydrake.systems.framework import DiagramBuilder

    from manta_drake.model.plant import add_plant

    builder = DiagramBuilder()
    h = add_plant(builder, with_pool=False, robot_params=robot_with_fin_sweep_deg(sweep_deg))
    diagram = builder.Build()
    context = h.plant.GetMyContextFromRoot(diagram.CreateDefaultContext())
    query = h.plant.get_geometry_query_input_port().Eval(context)
    inspector = query.inspector()
    lo, hi = np.full(3, np.inf), np.full(3, -np.inf)
    from pydrake.geometry import Role

    for body in h.plant.GetBodyIndices(h.robot):
        for gid in inspector.GetGeometries(h.plant.GetBodyFrameIdOrThrow(body), Role.kIllustration):
            shape, X = inspector.GetShape(gid), query.GetPoseInWorld(gid)
            R = np.abs(X.rotation().matrix())
            kind = type(shape).__name__
            if kind == "Box":
                ext = R @ (np.array([shape.width(), shape.depth(), shape.height()]) / 2)
            elif kind == "Ellipsoid":
                A = np.diag([shape.a(), shape.b(), shape.c()])
                Rm = X.rotation().matrix()
                ext = np.sqrt(np.diag(Rm @ A @ A @ Rm.T))
            elif kind == "Sphere":
                ext = np.full(3, shape.radius())
            else:
                raise RuntimeError(f"zero_pose_size: unexpected shape {kind}")
            lo = np.minimum(lo, X.translation() - ext)
            hi = np.maximum(hi, X.translation() + ext)
    return hi - lo


def kinematics_rows() -> list[dict]:
    rows = []
    for sweep in SWEEPS_DEG:
        size = zero_pose_size(sweep)
        for reading in READINGS:
            tips = stance_tips(reading, sweep)
            d1, d2 = support_diagonal_offsets(
                get_gait("trot", reading).X, robot_with_fin_sweep_deg(sweep)
            )
            rows.append(
                {
                    "reading": reading,
                    "sweep": sweep,
                    "fl_rr": d1,
                    "fr_rl": d2,
                    "centroid_x": float(tips[:, 0].mean()),
                    "L": size[0],
                    "W": size[1],
                }
            )
    return rows


def table_from_sweep(sweep_out: pathlib.Path) -> list[dict]:
    """The dynamics table from a sweep's results.csv and its runs' logs."""
    rows = []
    results = read_csv_table(sweep_out / "results.csv", what="results CSV")
    for r in results:
        run = sweep_out / "runs" / r["run_id"]
        s = load_scenario(run / "scenario.yaml")  # the run's resolved scenario
        reading, sweep = s.controller.gait_reading, s.fin_sweep_deg()
        gait = r["base"].removeprefix("locomotion_")
        row = {"gait_reading": reading, "fin_sweep_deg": sweep, "gait": gait}
        if r["status"] != "ok" or not r["u"]:
            raise SystemExit(
                f"error: run {r['run_id']} ({reading}, {sweep:g} deg, {gait}) "
                f"is {r['status']}: {r['reason']}"
            )
        t0, t1 = float(r["steady_start_s"]), float(r["steady_end_s"])
        log = np.load(run / "log.npz")
        window = (log["t"] >= t0) & (log["t"] <= t1)
        roll, pitch = np.degrees(log["body_rpy"][window, :2]).mean(axis=0)
        row.update(
            u=float(r["u"]),
            v=float(r["v"]),
            yaw_rate_deg_s=float(r["yaw_rate_deg_s"]),
            mean_roll_deg=float(roll),
            mean_pitch_deg=float(pitch),
            steady_start_s=t0,
            steady_end_s=t1,
        )
        rows.append(row)
    return rows


def write_table(rows: list[dict], path: pathlib.Path) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    with open(path, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=COLUMNS)
        w.writeheader()
        for row in rows:
            w.writerow({k: row[k] for k in COLUMNS})


def read_table(path: pathlib.Path) -> list[dict]:
    return [
        {k: (v if k in ("gait_reading", "gait") else float(v)) for k, v in r.items()}
        for r in read_csv_table(path, what="table CSV")
    ]


TEMPLATE = "stance.md.j2"
PAGE_TITLE = "The stance behind each reading of the gait matrices"


def page_context(kin: list[dict], dyn: list[dict], table_path: str) -> dict:
    """What the block shows: per sweep (sweep, the paper row, the mirrored row) of ``kin``;
    the rows of ``dyn`` in CONFIGS' then GAITS' order (the first of each, those present)."""
    kin_first: dict[tuple[float, str], dict] = {}  # (sweep, reading) -> row
    dyn_first: dict[tuple[str, float, str], dict] = {}  # (reading, sweep, gait) -> row
    for r in kin:
        kin_first.setdefault((r["sweep"], r["reading"]), r)
    for r in dyn:
        dyn_first.setdefault((r["gait_reading"], r["fin_sweep_deg"], r["gait"]), r)
    order = [(reading, sweep, gait) for reading, sweep in CONFIGS for gait in GAITS]
    return {
        "begin": MARK_BEGIN,
        "end": MARK_END,
        "kinematics": [
            (sweep, kin_first[(sweep, "paper")], kin_first[(sweep, "mirrored")])
            for sweep in SWEEPS_DEG
        ],
        "dynamics": [dyn_first[key] for key in order if key in dyn_first],
        "table_path": table_path,
    }


def markdown(kin: list[dict], dyn: list[dict], table_path: str) -> str:
    """The block of docs/stance.md (its markers included)."""
    from manta_drake.studies.report import render

    return render(TEMPLATE, **page_context(kin, dyn, table_path)).rstrip("\n")


def write_markdown(path: pathlib.Path, block: str) -> None:
    """Replaces the marked block of ``path`` (a missing page is written with its title and
    stamp); a changed page's stamp takes today's date and commit
    (``manta_drake.studies.stamp``)."""
    from manta_drake.studies.stamp import replace_marked_block

    replace_marked_block(
        path, block, MARK_BEGIN, MARK_END, new_page=(PAGE_TITLE, "manta-drake study stance")
    )


def plot(dyn: list[dict], path: pathlib.Path) -> None:
    """Left: the fin tips at the trot's stance and its support diagonals under each reading
    on its balanced sweep; middle and right: every gait's u and yaw rate under each
    (reading, sweep) of CONFIGS (hatched: each reading on the other's sweep)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 3, figsize=(14, 4.2), gridspec_kw={"width_ratios": [1.0, 1.3, 1.3]})
    _stance_panel(axes[0])
    _gait_bars(axes[1:], dyn)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=120)
    plt.close(fig)


def _stance_panel(ax) -> None:
    for (reading, sweep), style in zip(CONFIGS[:2], ("o-", "s--")):
        tips = stance_tips(reading, sweep)
        order = [0, 1, 3, 2, 0]  # fl fr rr rl: the support rectangle
        ax.plot(tips[order, 0], tips[order, 1], style, lw=1.5, label=f"{reading}, {sweep:g} deg")
        for diag in ((0, 3), (1, 2)):
            ax.plot(tips[list(diag), 0], tips[list(diag), 1], ":", color=ax.lines[-1].get_color())
    ax.plot(0, 0, "k+", ms=12, mew=2, label="CG")
    ax.set_aspect("equal")
    ax.set_xlabel("x [m] (forward)")
    ax.set_ylabel("y [m] (left)")
    ax.set_title("trot stance: fin tips, diagonals")
    ax.legend(fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.16), ncol=2)
    ax.grid(alpha=0.3)


def _gait_bars(axes, dyn: list[dict]) -> None:
    width = 0.8 / len(CONFIGS)
    x = np.arange(len(GAITS))
    for k, (reading, sweep) in enumerate(CONFIGS):
        sel = {
            r["gait"]: r
            for r in dyn
            if r["gait_reading"] == reading and r["fin_sweep_deg"] == sweep
        }
        for ax, key in zip(axes, ("u", "yaw_rate_deg_s")):
            ax.bar(
                x + (k - 1.5) * width,
                [sel[g][key] if g in sel else np.nan for g in GAITS],
                width,
                label=f"{reading}, {sweep:g} deg",
                hatch="" if k < 2 else "//",
                alpha=1.0 if k < 2 else 0.5,
            )
    for ax, label in zip(axes, ("u [m/s]", "yaw rate [deg/s]")):
        ax.set_xticks(x, GAITS)
        ax.axhline(0, color="k", lw=0.8)
        ax.set_ylabel(label)
        ax.grid(axis="y", alpha=0.3)
    axes[0].set_title("forward speed (free-water window)")
    axes[1].set_title("yaw rate")
    axes[0].legend(fontsize=7)


# The columns of the stance sweep's results.csv that ``table_from_sweep`` reads.
SWEEP_COLUMNS = (
    "run_id",
    "base",
    "status",
    "reason",
    "u",
    "v",
    "yaw_rate_deg_s",
    "steady_start_s",
    "steady_end_s",
)


TABLE = "stance_table.csv"  # the shipped dynamics table, in the checkout's diagrams/sweeps/data/


def check_arguments(args, prog: str) -> pathlib.Path:
    """Every option before anything is read or computed (a missing ``--table`` becomes the
    checkout's shipped table); returns the output folder; raises ScenarioError naming the
    option."""
    from manta_drake.studies.options import check_output_file, check_results_csv
    from manta_drake.studies.report import output_folder

    if args.table is None:
        data = output_folder(None, prog, default="diagrams/sweeps/data", option="--table FILE")
        args.table = data / TABLE
    if args.sweep_out is not None:
        check_results_csv(
            "--sweep-out",
            args.sweep_out / "results.csv",
            SWEEP_COLUMNS,
            hint=" (DIR is the output folder of `manta-drake sweep diagrams/sweeps/stance.yaml`)",
        )
        check_output_file("--table", args.table)
    else:
        check_results_csv(
            "--table", args.table, COLUMNS, hint="; run the sweep and pass --sweep-out"
        )
    return output_folder(args.out, prog)


def parser(prog: str):
    from manta_drake.studies.options import StudyParser

    p = StudyParser(prog=prog, description=__doc__.splitlines()[0])
    p.add_argument(
        "--sweep-out",
        type=pathlib.Path,
        help="output folder of `manta-drake sweep diagrams/sweeps/stance.yaml`",
    )
    p.add_argument(
        "--table",
        type=pathlib.Path,
        help="the dynamics table: read (written with --sweep-out); default the "
        f"checkout's diagrams/sweeps/data/{TABLE}",
    )
    p.add_argument(
        "--out",
        metavar="DIR",
        help="the report's folder: DIR/stance.md (its generated block is rewritten) and "
        "DIR/figures/stance.png; default the checkout's docs/",
    )
    return p


def main(argv=None, prog=None) -> int:
    """The command line (``manta-drake study stance``); returns the exit status."""
    prog = prog or "manta-drake study stance"
    args = parser(prog).parse_args(argv)
    out = check_arguments(args, prog)
    if args.sweep_out is not None:
        dyn = table_from_sweep(args.sweep_out)
        write_table(dyn, args.table)
        print(f"wrote {args.table}")
    else:
        dyn = read_table(args.table)
    try:
        shown = str(args.table.resolve().relative_to(ROOT))
    except ValueError:
        shown = str(args.table)
    block = markdown(kinematics_rows(), dyn, shown)
    print(block)
    write_markdown(out / "stance.md", block)
    plot(dyn, out / "figures" / "stance.png")
    print(f"wrote {out / 'stance.md'} and {out / 'figures' / 'stance.png'}")
    return 0
