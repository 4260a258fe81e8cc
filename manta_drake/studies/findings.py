"""Evaluates the five locomotion findings of the paper's section 4.1 over the uncertainty band.

Reads the table of the sweep ``diagrams/sweeps/findings.yaml`` (five gaits x foot-floor friction
0.5 / 0.65 / 0.8 x hull damping x0.7 / 1.0 / 1.3 x deflated net weight 0.6 / 0.85 / 1.1 kg) and
decides, at every band point (one friction, damping and weight), whether each finding holds,
fails or is undetermined:

1. every gait moves forward   the forward gaits swim, trot and walk each have u > U_FORWARD;
2. walk is the fastest gait   u_walk > u of every other gait (swim, trot, crab, turning);
3. swimming is slower than walking   u_swim < u_walk;
4. crab moves mostly sideways |v_crab| > SIDEWAYS_RATIO |u_crab| and |v_crab| > V_SIDEWAYS;
5. turning turns              |yaw rate| of turning >= YAW_TURN and > |yaw rate| of every
                              other gait.

Gaits are compared at the same band point. A gait whose run has no mean velocity (steady
window too short, run not ok, or row missing) is *undetermined*; a finding is evaluated in
three-valued (Kleene) logic: it fails if a determined comparison already fails, is
undetermined if it would need an undetermined value, and holds only if every comparison it
needs is determined and true. The reported fraction is holds / band points, so an
undetermined point never counts as holding.

Variants (reported separately, labelled): walk fastest and turning turns among the gaits on
the floor only (without the swim), and "moves forward" per gait for all five gaits.

Writes the report into ``--out DIR`` (default: the checkout's ``docs/``): a markdown block
(the table, per-gait medians and ranges, per-point verdicts; its prose is the template
``templates/findings.md.j2``) into ``DIR/findings.md`` between the markers
``<!-- findings-report:begin -->`` and ``<!-- findings-report:end -->`` if the page has them
(the hand-written text around them is kept), else as a new page; and the figure
``DIR/figures/findings.png``. ``--page NAME`` and ``--figure NAME`` choose other names in
``DIR`` (docs/stance.md holds the block of the mirrored reading's sweep, with its figure
``findings_mirrored.png``).

``--sensitivity CSV`` adds the findings at every parameter set of another sweep over the
same five gaits: the energy sweep (``diagrams/sweeps/energy.yaml``), whose one-at-a-time
sets move the actuators' and the foil fins' uncertain parameters (servo gains, winding,
gearbox; lift slope, leading-edge suction, stall angle, the fins' added mass with the hull)
and whose hypercube moves them all together.

Usage (either the table of a fresh sweep or the copy shipped in the repository):

    manta-drake sweep diagrams/sweeps/findings.yaml --out out/findings
    manta-drake study findings                      # reads out/findings/results.csv
    manta-drake study findings --results diagrams/sweeps/data/findings_results.csv
    manta-drake study findings --results diagrams/sweeps/data/findings_mirrored_results.csv \\
        --sensitivity '' --page stance --figure findings_mirrored

``--diagnose DIR`` instead runs the targeted simulations behind the explanations in
docs/findings.md (``DIAGNOSTIC_RUNS``: contacts, slip and the water's forces of single gaits at
single band points; ``SHIPPED_RUNS``: the shipped locomotion scenarios with either fin model
and either servo model, with the servos' power; one at a time, about 20 min) and writes
``DIR/diagnostics.json``.
"""

from __future__ import annotations

import argparse
import dataclasses as dc
import math
import pathlib
import re
import shlex
import statistics
import textwrap
from typing import Any

from manta_drake.studies import REPO

# ---------------------------------------------------------------------------------------------
# Criteria (thresholds and what they mean)

# "Moves": mean speed above 0.01 m/s, i.e. 0.14 m over the full 14 s free-water window (6-20 s),
# more than a third of the body length (0.38 m). Gaits that do not walk drift by up to ~0.015 m/s
# (the turning gait's u in the band), so a smaller threshold would count drift as locomotion.
U_FORWARD = 0.01  # m/s
# "Mostly sideways": the mean velocity's direction within atan(1/2) = 26.6 deg of the body's
# lateral axis, and the crab actually moving (the same 0.01 m/s as "moves").
SIDEWAYS_RATIO = 2.0
V_SIDEWAYS = 0.01  # m/s
# "Turns": at least 3 deg/s, 42 deg over the 14 s window (a U-turn within a minute), and more
# than any other gait at the same point (the other gaits drift by up to ~6 deg/s in the band).
YAW_TURN = 3.0  # deg/s
PASS_LINE = 0.8  # a finding "holds over the band" if it holds at >= 80 % of the band points

GAITS = ("swim", "trot", "walk", "crab", "turning")
FORWARD_GAITS = ("swim", "trot", "walk")  # section 4.1's forward locomotion (Figs. 6-7)
FLOOR_GAITS = ("trot", "walk", "crab", "turning")
BAND_KEYS = ("contact.friction", "hull_damping", "net_weight_kg")
BAND_LABELS = {
    "contact.friction": "friction",
    "hull_damping": "hull damping x",
    "net_weight_kg": "net weight kg",
}
MARK_BEGIN = "<!-- findings-report:begin -->"
MARK_END = "<!-- findings-report:end -->"
DEFAULT_RESULTS = "out/findings/results.csv"
SHIPPED_RESULTS = "diagrams/sweeps/data/findings_results.csv"
SENSITIVITY_RESULTS = "diagrams/sweeps/data/energy_results.csv"


@dc.dataclass(frozen=True)
class Motion:
    """One gait's mean motion at one band point; None = undetermined."""

    u: float | None = None  # mean forward velocity [m/s] (body frame, free-water window)
    v: float | None = None  # mean leftward velocity [m/s]
    yaw: float | None = None  # mean yaw rate [deg/s]
    window_s: float | None = None  # length of the free-water window [s]


UNDETERMINED = Motion()


def _and(values) -> bool | None:
    """Kleene AND: False if any is False, else None if any is None, else True."""
    values = list(values)
    if any(v is False for v in values):
        return False
    if any(v is None for v in values):
        return None
    return True


def _get(point: dict, gait: str) -> Motion:
    return point.get(gait) or UNDETERMINED


def moves_forward(point: dict, gait: str) -> bool | None:
    """u of ``gait`` > U_FORWARD (None if its u is undetermined)."""
    u = _get(point, gait).u
    return None if u is None else u > U_FORWARD


def every_gait_forward(point: dict, gaits=FORWARD_GAITS) -> bool | None:
    """Finding 1: every gait in ``gaits`` moves forward."""
    return _and(moves_forward(point, g) for g in gaits)


# The gaits walk and turning are compared with (by default).
_NOT_WALK = tuple(g for g in GAITS if g != "walk")
_NOT_TURNING = tuple(g for g in GAITS if g != "turning")


def walk_fastest(point: dict, others: tuple[str, ...] = _NOT_WALK) -> bool | None:
    """Finding 2: u_walk strictly greater than u of every gait in ``others``."""
    u_walk = _get(point, "walk").u
    if u_walk is None:
        return None
    us = (_get(point, g).u for g in others)
    return _and(None if u is None else u_walk > u for u in us)


def swim_slower_than_walk(point: dict) -> bool | None:
    """Finding 3: u_swim < u_walk."""
    u_swim, u_walk = _get(point, "swim").u, _get(point, "walk").u
    if u_swim is None or u_walk is None:
        return None
    return u_swim < u_walk


def crab_sideways(point: dict) -> bool | None:
    """Finding 4: |v| > SIDEWAYS_RATIO |u| and |v| > V_SIDEWAYS for the crab."""
    m = _get(point, "crab")
    if m.u is None or m.v is None:
        return None
    return abs(m.v) > SIDEWAYS_RATIO * abs(m.u) and abs(m.v) > V_SIDEWAYS


def turning_turns(point: dict, others: tuple[str, ...] = _NOT_TURNING) -> bool | None:
    """Finding 5: |yaw rate| of turning >= YAW_TURN and > |yaw rate| of every gait in ``others``.

    A turning gait that turns less than YAW_TURN fails whatever the others do."""
    y = _get(point, "turning").yaw
    if y is None:
        return None
    if abs(y) < YAW_TURN:
        return False
    yaws = (_get(point, g).yaw for g in others)
    return _and(None if yaw is None else abs(y) > abs(yaw) for yaw in yaws)


# (key, label, criterion text, function); the first five are the paper's findings.
FINDINGS = (
    (
        "forward",
        "1. every gait moves forward",
        f"u > {U_FORWARD} m/s for swim, trot and walk",
        every_gait_forward,
    ),
    (
        "walk_fastest",
        "2. walk is the fastest gait",
        "u_walk > u of swim, trot, crab and turning",
        walk_fastest,
    ),
    ("swim_slower", "3. swimming is slower than walking", "u_swim < u_walk", swim_slower_than_walk),
    (
        "crab_sideways",
        "4. crab moves mostly sideways",
        f"\\|v\\| > {SIDEWAYS_RATIO:g} \\|u\\| and \\|v\\| > {V_SIDEWAYS} m/s",
        crab_sideways,
    ),
    (
        "turning_turns",
        "5. turning turns",
        f"\\|yaw rate\\| >= {YAW_TURN:g} deg/s and > every other gait's",
        turning_turns,
    ),
)
VARIANTS = (
    (
        "walk_fastest_floor",
        "2'. walk fastest among the floor gaits",
        "u_walk > u of trot, crab and turning (swim left out)",
        lambda p: walk_fastest(p, ("trot", "crab", "turning")),
    ),
    (
        "turning_turns_floor",
        "5'. turning turns, compared with the floor gaits",
        f"\\|yaw rate\\| >= {YAW_TURN:g} deg/s and > trot's, walk's and crab's",
        lambda p: turning_turns(p, ("trot", "walk", "crab")),
    ),
) + tuple(
    (
        f"forward_{g}",
        f"{g} moves forward",
        f"u_{g} > {U_FORWARD} m/s",
        (lambda p, g=g: moves_forward(p, g)),
    )
    for g in GAITS
)


# ---------------------------------------------------------------------------------------------
# Reading the table


def _float(cell) -> float | None:
    if cell is None or str(cell).strip() == "":
        return None
    x = float(cell)
    return x if math.isfinite(x) else None


def gait_of(base: str) -> str:
    """``locomotion_walk`` (or a path ending in it, with or without .yaml) -> ``walk``."""
    name = pathlib.Path(str(base)).name
    return name.removesuffix(".yaml").removeprefix("locomotion_")


def motion_of(row: dict) -> Motion:
    """A results.csv row -> Motion; a run that is not ok or has no u/v is undetermined (its
    yaw rate is kept only when the velocities are there: they share the window)."""
    if row.get("status", "ok") != "ok":
        return UNDETERMINED
    u, v = _float(row.get("u")), _float(row.get("v"))
    if u is None or v is None:
        return UNDETERMINED
    start, end = _float(row.get("steady_start_s")), _float(row.get("steady_end_s"))
    window = None if start is None or end is None else end - start
    return Motion(u, v, _float(row.get("yaw_rate_deg_s")), window)


def _grouped(rows, key_of, where) -> dict:
    """{key_of(row): {gait: Motion}}; ValueError naming ``where(key)`` on a gait that
    appears twice under one key."""
    groups: dict = {}
    for row in rows:
        key = key_of(row)
        gait = gait_of(row["base"])
        group = groups.setdefault(key, {})
        if gait in group:
            raise ValueError(f"{gait} appears twice at {where(key)}")
        group[gait] = motion_of(row)
    return groups


def band_points(rows) -> dict:
    """{(friction, damping, weight): {gait: Motion}} from results rows (dicts of strings).

    Raises ValueError on a gait that appears twice at one point (two seeds are not averaged
    silently)."""
    points = _grouped(
        rows,
        lambda row: tuple(float(row[k]) for k in BAND_KEYS),
        lambda key: f"band point {key} (more than one seed?); give one row per gait and point",
    )
    return dict(sorted(points.items()))


def _set_cells(row) -> tuple:
    """The row's parameter cells that are set: the columns between ``seed`` and
    ``status``, in the table's order."""
    names = list(row)
    params = names[names.index("seed") + 1 : names.index("status")]
    return tuple((k, row[k]) for k in params if str(row[k]).strip())


def parameter_sets(rows) -> dict:
    """{((name, value), ...): {gait: Motion}}: the rows grouped by the sweep's parameter
    cells that are set (``_set_cells``; () is the shipped point).

    Raises ValueError on a gait that appears twice in one set."""
    return _grouped(rows, _set_cells, lambda key: f"parameter set {dict(key)}")


def read_results(path) -> list[dict]:
    """The findings sweep's results.csv as rows of strings (at most
    ``config_io.MAX_TABLE_CSV_BYTES``; ScenarioError naming the file otherwise)."""
    from manta_drake.config_io import read_csv_table

    return read_csv_table(path, what="results CSV")


# ---------------------------------------------------------------------------------------------
# Evaluation


@dc.dataclass
class Tally:
    key: str
    label: str
    criterion: str
    holds: int = 0
    fails: int = 0
    undetermined: int = 0

    @property
    def total(self) -> int:
        return self.holds + self.fails + self.undetermined

    @property
    def fraction(self) -> float:
        return self.holds / self.total if self.total else math.nan


def evaluate(points: dict, findings=FINDINGS) -> tuple[list[Tally], dict]:
    """Tallies per finding and the verdicts {point: {key: True/False/None}}."""
    tallies = [Tally(key, label, text) for key, label, text, _ in findings]
    verdicts: dict[object, dict[str, bool | None]] = {}
    for pt, motions in points.items():
        verdicts[pt] = {}
        for tally, (key, _, _, fn) in zip(tallies, findings):
            result = fn(motions)
            verdicts[pt][key] = result
            if result is True:
                tally.holds += 1
            elif result is False:
                tally.fails += 1
            else:
                tally.undetermined += 1
    return tallies, verdicts


def gait_stats(points: dict) -> dict:
    """Per gait: n, undetermined, and (median, min, max) of u, v, yaw and the window length."""
    out = {}
    for gait in GAITS:
        ms = [p.get(gait, UNDETERMINED) for p in points.values()]
        det = [m for m in ms if m.u is not None]
        entry: dict[str, int | tuple[float, float, float] | None] = {
            "n": len(ms),
            "undetermined": len(ms) - len(det),
        }
        for field in ("u", "v", "yaw", "window_s"):
            xs = [getattr(m, field) for m in det if getattr(m, field) is not None]
            entry[field] = (statistics.median(xs), min(xs), max(xs)) if xs else None
        out[gait] = entry
    return out


# ---------------------------------------------------------------------------------------------
# Output: the block's numbers, handed to templates/findings.md.j2


def sensitivity(sets: dict, source: str) -> dict:
    """The findings at the shipped point and one parameter at a time (each set with one
    parameter: its verdicts and the speeds that decide them), and their tallies over the
    sets with more (the sweep's hypercube; [] if none)."""
    multi = {k: p for k, p in sets.items() if len(k) > 1}
    rows = [
        {
            "label": "shipped" if not key else f"{key[0][0]} = {key[0][1]}",
            "verdicts": [fn(point) for _, _, _, fn in FINDINGS],
            "swim_u": _get(point, "swim").u,
            "walk_u": _get(point, "walk").u,
            "crab_v": _get(point, "crab").v,
            "turning_yaw": _get(point, "turning").yaw,
        }
        for key, point in sets.items()
        if len(key) <= 1
    ]
    hypercube = evaluate(multi)[0] if multi else []
    return {"source": source, "rows": rows, "hypercube": hypercube, "points": len(multi)}


def markdown_block(
    tallies, variant_tallies, stats, verdicts, source: str, sensitivity: dict | None = None
) -> str:
    """The page's block, its markers included: the tallies, the variants', the gaits'
    statistics, the verdicts per band point and (if given) the ``sensitivity`` table."""
    from manta_drake.studies.report import render

    return render(
        "findings.md.j2",
        begin=MARK_BEGIN,
        end=MARK_END,
        source=source,
        pass_line=PASS_LINE,
        tallies=tallies,
        variants=variant_tallies,
        stats=stats,
        verdicts=verdicts,
        sensitivity=sensitivity,
    )


def write_markdown(
    path: pathlib.Path, block: str, command: str = "manta-drake study findings"
) -> None:
    """Replaces the marked block of ``path`` (keeping the rest), or writes a new file; a
    changed page's stamp takes today's date and commit (``manta_drake.studies.stamp``)."""
    from manta_drake.studies.stamp import replace_marked_block

    replace_marked_block(
        path,
        block,
        MARK_BEGIN,
        MARK_END,
        what="the table",
        new_page=("Findings of section 4.1 over the uncertainty band", command),
    )


def plot(points, tallies, variant_tallies, path: pathlib.Path) -> None:
    """The figure: the findings' tallies over the band (left) and every gait's u, v and yaw
    rate against friction (right: colour = net weight, marker = hull damping)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig = plt.figure(figsize=(17, 8.5))
    grid = fig.add_gridspec(
        3,
        6,
        width_ratios=[1.6, 1, 1, 1, 1, 1],
        wspace=0.35,
        hspace=0.3,
        left=0.11,
        right=0.99,
        top=0.92,
        bottom=0.08,
    )
    _plot_tallies(fig.add_subplot(grid[:, 0]), tallies, variant_tallies)
    style = _point_style(points, plt.get_cmap("viridis"))
    _plot_motions(fig, grid, points, style)
    _plot_legend(fig, style)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)


def _plot_tallies(ax, tallies, variant_tallies) -> None:
    """Bars: the fraction of the band where each finding (and variant) holds, fails, is
    undetermined."""
    shown = list(tallies) + [t for t in variant_tallies if not t.key.startswith("forward_")]
    y = list(range(len(shown)))[::-1]
    for i, (yi, t) in enumerate(zip(y, shown)):
        n = max(t.total, 1)
        alpha = 1.0 if i < len(tallies) else 0.5
        colour = "tab:green" if t.fraction >= PASS_LINE else "tab:red"
        ax.barh(yi, t.holds / n, color=colour, alpha=alpha)
        ax.barh(
            yi,
            t.fails / n,
            left=t.holds / n,
            color="mistyrose",
            alpha=alpha,
            edgecolor="tab:red",
            lw=0.5,
        )
        ax.barh(yi, t.undetermined / n, left=(t.holds + t.fails) / n, color="0.75")
        ax.text(1.02, yi, f"{t.holds}/{t.total}", va="center", fontsize=9)
    ax.axvline(PASS_LINE, color="k", ls="--", lw=1)
    ax.text(PASS_LINE, len(shown) - 0.45, "80 %", fontsize=9, ha="center")
    ax.set_yticks(y, [textwrap.fill(t.label, 24) for t in shown], fontsize=9)
    ax.set_xlim(0, 1.15)
    ax.set_xticks([0, 0.2, 0.4, 0.6, 0.8, 1.0])
    ax.set_ylim(-0.6, len(shown) - 0.2)
    ax.set_xlabel(
        f"fraction of the {shown[0].total} band points\n"
        "(solid: holds, pale: fails, grey: undetermined)",
        fontsize=9,
    )
    ax.set_title(
        "Findings of section 4.1 over the band\n(lighter: variants without the swim)", fontsize=10
    )


def _point_style(points, cmap) -> dict:
    """A band point's look: colour by net weight, marker and a small horizontal offset by
    hull damping."""
    weights = sorted({p[2] for p in points})
    dampings = sorted({p[1] for p in points})
    return {
        "colour": {w: cmap(i / max(1, len(weights) - 1)) for i, w in enumerate(weights)},
        "marker": dict(zip(dampings, ["v", "o", "^", "s", "D"])),
        "offset": {d: (i - (len(dampings) - 1) / 2) * 0.012 for i, d in enumerate(dampings)},
    }


# The motion panels' rows: (Motion field, axis label, threshold).
MOTION_ROWS = (
    ("u", "u  [m/s]", U_FORWARD),
    ("v", "v  [m/s]", V_SIDEWAYS),
    ("yaw", "yaw rate  [deg/s]", YAW_TURN),
)


def _plot_motions(fig, grid, points, style) -> None:
    """One panel per motion field (rows) and gait (columns), sharing each row's y axis."""
    for r, (field, ylabel, threshold) in enumerate(MOTION_ROWS):
        first = None
        for c, gait in enumerate(GAITS):
            a = fig.add_subplot(grid[r, c + 1], sharey=first)
            first = first or a
            _motion_panel(a, points, gait, field, threshold, style)
            if r == 0:
                a.set_title(gait, fontsize=10)
            if r == len(MOTION_ROWS) - 1:
                a.set_xlabel("foot-floor friction", fontsize=9)
            else:
                a.tick_params(labelbottom=False)
            if c == 0:
                a.set_ylabel(ylabel, fontsize=9)
            else:
                a.tick_params(labelleft=False)


def _motion_panel(a, points, gait: str, field: str, threshold: float, style) -> None:
    """``gait``'s ``field`` at every band point against friction (a red x where it is
    undetermined), with zero and the +-threshold lines."""
    for (fr, dmp, w), motions in points.items():
        val = getattr(motions.get(gait, UNDETERMINED), field)
        x = fr + style["offset"][dmp]
        if val is None:
            a.plot(x, 0, marker="x", color="red", ms=6)
            continue
        a.plot(
            x,
            val,
            marker=style["marker"][dmp],
            color=style["colour"][w],
            ms=5,
            ls="none",
            mec="k",
            mew=0.3,
        )
    a.axhline(0, color="0.5", lw=0.6)
    for s in (1, -1):
        a.axhline(s * threshold, color="0.4", lw=0.7, ls=":")
    a.set_xticks(sorted({p[0] for p in points}))
    a.tick_params(labelsize=8)
    a.grid(alpha=0.3)


def _plot_legend(fig, style) -> None:
    from matplotlib.lines import Line2D

    handles = [
        Line2D([], [], ls="none", marker="o", color=c, label=f"net weight {w:g} kg")
        for w, c in style["colour"].items()
    ]
    handles += [
        Line2D([], [], ls="none", marker=m, color="0.3", label=f"hull damping x{d:g}")
        for d, m in style["marker"].items()
    ]
    thresholds = f"thresholds: {U_FORWARD} m/s, {V_SIDEWAYS} m/s, {YAW_TURN:g} deg/s"
    handles += [Line2D([], [], color="0.4", ls=":", label=thresholds)]
    fig.legend(
        handles=handles,
        loc="upper center",
        ncol=7,
        fontsize=8,
        frameon=False,
        bbox_to_anchor=(0.6, 0.995),
    )


# ---------------------------------------------------------------------------------------------
# Diagnostics (--diagnose DIR): the targeted simulations behind docs/findings.md's explanations.
# Each is a shipped gait scenario at one band point, simulated one at a time with the same
# diagram, seed and step grid as the sweep (its u, v and yaw rate equal the sweep's), sampled
# at every plant step (1 ms): the hull's pose and velocity, every contact with the floor (Drake's
# ContactResults: force, point, slip speed, the robot's geometry) and the water's forces by
# term (recomputed from the state with manta_drake.station.water's functions).

SWEEP_FILE = REPO / "diagrams" / "sweeps" / "findings.yaml"
SAMPLE_PERIOD = 0.001  # s: every plant step (sampling every 10 ms aliased the contact forces:
#                        the traction of a 20 s walk came out 30 % short of the water drag)
SLIDING = 0.005  # m/s: a contact whose slip speed exceeds this is sliding (SAP's regularised
#                  friction lets a stuck contact creep at well under 1 mm/s)
LOADED = 0.1  # N: a leg bearing more of the floor's normal force than this stands on it
#              (1 % of the deflated robot's 8.3 N; a grazing contact carries less)


def band_scenario(
    gait: str,
    friction: float,
    damping: float,
    weight: float,
    duration: float,
    extra: dict | None = None,
):
    """The shipped ``locomotion_<gait>`` at one band point, as the sweep resolves it (with
    the sweep file's ``fixed`` overrides: its fin model)."""
    from manta_drake.scenario import load_scenario
    from manta_drake.sweep import apply_overrides, load_sweep

    overrides = {
        **load_sweep(SWEEP_FILE).fixed,
        "contact.friction": friction,
        "water.coefficient_scales.body.linear_damping": damping,
        "water.coefficient_scales.body.quadratic_damping": damping,
        "net_weight_kg": weight,
        "random_seed": 0,
        "duration": duration,
        "visualization.meshcat": False,
        **(extra or {}),
    }
    return apply_overrides(load_scenario(f"locomotion_{gait}"), overrides)


def swim_without_phase_lag():
    """Diagnostic gait: the shipped swim with Phi'_swim = 0 (the printed matrix asks for a
    left-right lag that no set of phases satisfies, docs/design.md contradiction (d))."""
    import numpy as np

    from manta_drake.control.gaits import GAITS, GaitParams

    g = GAITS["swim"]
    return GaitParams(g.R, g.X, g.Phi, np.zeros((4, 4)))


# Diagnostic gaits the library does not name: run as data (explicit_gait), by these names.
DIAGNOSTIC_GAITS = {"swim_no_phase_lag": swim_without_phase_lag}


SAMPLED = ("t", "xyz", "quat_wxyz", "yaw", "v_world", "hydro", "power")


def sample_run(scenario, period: float = SAMPLE_PERIOD, gait=None) -> dict:
    """Simulates ``scenario`` (with the GaitParams ``gait`` instead of the one it names, if
    given; ``explicit_gait.scenario_with_gait``, its gait file in a temporary folder) and
    samples it every ``period`` s (see the section comment).

    Returns a dict: numpy arrays ``t``, ``xyz`` (N, 3), ``quat_wxyz`` (N, 4), ``yaw`` (N,),
    ``v_world`` (N, 3), ``hydro`` (N, 3, 3): the world force [N] of the hull's damping, the
    16 links' damping and the fin strips (blade elements) at each sample (with the foil fins,
    ``foil_share`` less the two dampings and the buoyancy: the strips, the added-mass
    bodies' normal forces and inertia as their joints pass them on, and the explicit
    residual, whose cycle means vanish in steady motion but the strips', and the vertical
    balloon and weight cancellation); ``power`` (N, 2): the
    servos' and electronics' electrical power and the joints' summed mechanical power [W]
    (empty without the energy model); and ``contacts``:
    per sample a list of tuples (kind, leg, p_W (3), f_W on the robot (3), v_W of the
    robot's point (3), its horizontal speed) of the robot's contacts with the floor
    (``station.foot_contacts.floor_contacts``: hydroelastic patches at their centroids);
    kind: proximal plate, distal plate (a fin plate's box), hull."""
    import numpy as np

    scenario, diagram, h = _sampled_diagram(scenario, gait)
    probe = _probe(scenario, diagram, h)
    steps = max(1, round(period / scenario.time_step))
    n = round(scenario.duration / (steps * scenario.time_step))
    out: dict = {k: [] for k in (*SAMPLED, "contacts")}
    probe.sim.Initialize()
    for k in range(n + 1):
        if k:
            probe.sim.AdvanceTo(k * steps * scenario.time_step)
        _sample(probe, out)
    for key in SAMPLED:
        out[key] = np.array(out[key])
    return out


def _sampled_diagram(scenario, gait):
    """(scenario, diagram, handles): ``scenario`` built as it is, or with the GaitParams
    ``gait`` written to a gait file in a temporary folder (read while the diagram is built)."""
    from manta_drake.wiring.diagram import build_diagram

    if gait is None:
        return (scenario, *build_diagram(scenario))
    import tempfile

    from manta_drake.studies.explicit_gait import scenario_with_gait

    with tempfile.TemporaryDirectory() as folder:
        scenario = scenario_with_gait(scenario, gait, folder, "sampled")
        return (scenario, *build_diagram(scenario))


@dc.dataclass
class _Probe:
    """What ``sample_run`` reads at each sample: the simulator, its context and the systems."""

    sim: Any
    root: Any  # the simulator's (root) context
    plant: Any
    pctx: Any  # the plant's context
    hull: Any  # the hull's body
    robot_bodies: set  # the robot's own body indices
    hydro: Any  # the water system, or None
    cross_flow: bool  # the fin model is the quasi-steady cross-flow one
    hydro_bodies: list  # the water system's bodies
    added_joints: list  # the added-mass bodies' planar joints
    servos: Any  # the servos' power system, or None
    floor: Any  # the floor's geometries
    geometry_body: dict  # the robot's geometries -> body index


def _probe(scenario, diagram, h) -> _Probe:
    from pydrake.multibody.tree import BodyIndex

    from manta_drake.simulate import make_simulator
    from manta_drake.station.foot_contacts import robot_geometry_bodies

    sim = make_simulator(diagram, scenario, diagram.CreateDefaultContext())
    root = sim.get_mutable_context()
    plant, hydro = h.plant, h.systems.get("hydro")
    return _Probe(
        sim=sim,
        root=root,
        plant=plant,
        pctx=plant.GetMyContextFromRoot(root),
        hull=h.plant_handles.body,
        robot_bodies={int(i) for i in plant.GetBodyIndices(h.plant_handles.robot)},
        hydro=hydro,
        cross_flow=scenario.water.fin_model == "cross_flow",
        hydro_bodies=[plant.get_body(BodyIndex(i)) for i in hydro.body_indices] if hydro else [],
        added_joints=added_mass_joints(plant),
        servos=h.systems.get("servo_power"),
        floor=h.systems["foot_contacts"].floor_geometries,
        geometry_body=robot_geometry_bodies(plant, h.plant_handles.robot),
    )


def _sample(p: _Probe, out: dict) -> None:
    """Appends the hull's pose and velocity, the water's forces, the power and the floor
    contacts at the simulator's time to the lists of ``out``."""
    import numpy as np

    X = p.plant.EvalBodyPoseInWorld(p.pctx, p.hull)
    out["t"].append(p.root.get_time())
    out["xyz"].append(X.translation().copy())
    out["quat_wxyz"].append(X.rotation().ToQuaternion().wxyz())
    R = X.rotation().matrix()
    out["yaw"].append(np.arctan2(R[1, 0], R[0, 0]))
    out["v_world"].append(p.plant.EvalBodySpatialVelocityInWorld(p.pctx, p.hull).translational())
    if p.hydro is not None:
        out["hydro"].append(_water_forces(p))
    if p.servos is not None:
        sctx = p.servos.GetMyContextFromRoot(p.root)
        out["power"].append(
            [
                p.servos.GetOutputPort("electrical_power").Eval(sctx)[0],
                p.servos.GetOutputPort("joint_mechanical_power").Eval(sctx).sum(),
            ]
        )
    out["contacts"].append(_floor_contacts(p))


def _water_forces(p: _Probe):
    """(3, 3): the world force [N] of the hull's damping, the links' damping and the fins
    (``sample_run``), recomputed from the state with ``station.water``'s functions."""
    import numpy as np

    from manta_drake.station import water as W

    hydro, plant, pctx = p.hydro, p.plant, p.pctx
    Xs = [plant.EvalBodyPoseInWorld(pctx, b) for b in p.hydro_bodies]
    Vs = [plant.EvalBodySpatialVelocityInWorld(pctx, b) for b in p.hydro_bodies]
    Rb = np.array([x.rotation().matrix() for x in Xs])
    pb = np.array([x.translation() for x in Xs])
    wb = np.array([v.rotational() for v in Vs])
    vb = np.array([v.translational() for v in Vs])
    B, frac, body_frac = W.buoyancy_wrenches(Rb, pb, hydro.el, hydro.rho, hydro.g)
    D = W.damping_wrenches(
        Rb, wb, vb, hydro.current, hydro.d_lin, hydro.d_quad, body_frac, hydro.d_lift
    )
    if p.cross_flow:
        _, fs = W.fin_strip_forces(
            Rb,
            wb,
            vb,
            hydro.current,
            hydro.el,
            frac,
            hydro.rho,
            hydro.c_normal,
            hydro.c_friction,
            hydro.pitch_max,
            hydro.pitch_pressure,
        )
        fins = fs.sum(0)
    else:  # the system's total on the robot less damping and buoyancy, and what the
        #    added-mass bodies' joints pass on: the foil fins' share
        fins = foil_share(plant, pctx, hydro, p.root, p.robot_bodies, p.added_joints)
        fins = fins - D[:, 3:].sum(0) - B[:, 3:].sum(0)
    return np.array([D[0, 3:], D[1:, 3:].sum(0), fins])


# A contact's kind by the robot body's name's last part ("hull" for the body itself).
CONTACT_KINDS = {"link3": "proximal plate", "link4": "distal plate"}


def _floor_contacts(p: _Probe) -> list:
    """The robot's contacts with the floor as ``sample_run`` lists them."""
    import numpy as np
    from pydrake.multibody.tree import BodyIndex

    from manta_drake.station.foot_contacts import floor_contacts

    plant, pctx = p.plant, p.pctx
    results = plant.get_contact_results_output_port().Eval(pctx)
    contacts = []
    for index, f, point in floor_contacts(results, p.floor, p.geometry_body):
        body = plant.get_body(BodyIndex(index))
        name = body.name()
        kind = "hull" if name == "body" else CONTACT_KINDS.get(name.split("_")[-1], name)
        Vb = plant.EvalBodySpatialVelocityInWorld(pctx, body)
        offset = point - plant.EvalBodyPoseInWorld(pctx, body).translation()
        v = Vb.Shift(offset).translational()
        contacts.append(
            (
                kind,
                name.split("_")[0],
                np.array(point),
                np.array(f),
                np.array(v),
                float(np.linalg.norm(v[:2])),
            )
        )
    return contacts


def added_mass_joints(plant) -> list:
    """The planar joints of the added-mass bodies (``model.plant``), or none."""
    from manta_drake.model.plant import FIN_ADDED_MASS_INSTANCE

    if not plant.HasModelInstanceNamed(FIN_ADDED_MASS_INSTANCE):
        return []
    instance = plant.GetModelInstanceByName(FIN_ADDED_MASS_INSTANCE)
    return [plant.get_joint(i) for i in plant.GetJointIndices(instance)]


def foil_share(plant, pctx, hydro, root, robot_bodies, added_joints):
    """The world force [N] the water system's output puts on the robot's own bodies, plus
    what the added-mass bodies' planar joints pass on to the plates and the hull (their
    normal force and inertia; not the in-plane centring force on the bodies alone, which a
    turning or accelerating robot's bodies need to follow it and which never reaches it)."""
    import numpy as np

    forces = hydro.GetOutputPort("spatial_forces").Eval(hydro.GetMyContextFromRoot(root))
    total = sum(
        (np.asarray(f.F_Bq_W.translational()) for f in forces if int(f.body_index) in robot_bodies),
        np.zeros(3),
    )
    reactions = plant.get_reaction_forces_output_port().Eval(pctx)
    for joint in added_joints:  # the reaction on the child at Jc, in Jc: minus on the parent
        R_WJc = joint.frame_on_child().CalcPoseInWorld(pctx).rotation()
        total -= R_WJc @ reactions[int(joint.index())].translational()
    return total


def metric_window(samples: dict, scenario) -> tuple[float, float] | None:
    """The free-water window exactly as ``simulate.compute_metrics`` finds it (from
    ``steady_after``, at most half the run, until the hull comes within
    ``free_water_margin`` of a wall), at the samples' times; None if shorter than 1 s."""
    from manta_drake import metrics as M
    from manta_drake.model.robot_params import DEFAULT_POOL, DEFAULT_ROBOT
    from manta_drake.simulate import MIN_STEADY_WINDOW

    t = samples["t"]
    clearance = M.wall_clearance(
        samples["xyz"],
        samples["quat_wxyz"],
        DEFAULT_ROBOT.body_semi_axes,
        DEFAULT_POOL.length / 2,
        DEFAULT_POOL.width / 2,
    )
    near = M.free_water_end(t, clearance, scenario.free_water_margin)
    start = min(scenario.steady_after, 0.5 * float(t[-1]))
    end = float(t[-1]) if near is None else near
    return (start, end) if end - start >= MIN_STEADY_WINDOW else None


def whole_cycles(window, period_s: float) -> tuple[float, float]:
    """The window shortened to a whole number of gait periods (at least one, if it has one),
    so a mean over it does not keep a part-cycle share of the gait's oscillating forces."""
    n = math.floor((window[1] - window[0]) / period_s + 1e-9)
    return (window[0], window[0] + n * period_s) if n >= 1 else tuple(window)


def heading_frame(yaw):
    """(forward, left) horizontal unit vectors for the heading angle(s) ``yaw``."""
    import numpy as np

    c, s = np.cos(yaw), np.sin(yaw)
    return np.stack([c, s, 0 * c], -1), np.stack([-s, c, 0 * c], -1)


def motion_summary(samples: dict, window) -> dict:
    """u, v [m/s] and yaw rate [deg/s] over the window by the metric's own functions, and the
    hull's mean horizontal speed."""
    import numpy as np

    from manta_drake import metrics as M

    t, q, xyz = samples["t"], samples["quat_wxyz"], samples["xyz"]
    u, v = M.mean_velocity_from_displacement(t, q, xyz, window[0], window[1])
    m = (t >= window[0]) & (t <= window[1])
    return {
        "u": u,
        "v": v,
        "yaw_rate": M.yaw_rate_deg_s(t, q, window[0], window[1]),
        "speed": float(np.linalg.norm(samples["v_world"][m][:, :2], axis=1).mean()),
        "window": [float(window[0]), float(window[1])],
    }


def hydro_summary(samples: dict, window) -> dict:
    """Mean forward (heading-frame) force [N] of each water term over the window."""
    import numpy as np

    t = samples["t"]
    m = (t >= window[0]) & (t < window[1])
    fwd, _ = heading_frame(samples["yaw"][m])
    F = samples["hydro"][m]  # (N, 3 terms, 3)
    mean = np.einsum("ntk,nk->t", F, fwd) / m.sum()
    return dict(zip(("hull_damping", "link_damping", "fin_strips"), map(float, mean)))


def power_summary(samples: dict, window) -> dict:
    """Mean electrical and summed joint mechanical power [W] over the window."""
    t = samples["t"]
    m = (t >= window[0]) & (t < window[1])
    electrical, mechanical = samples["power"][m].mean(axis=0)
    return {"electrical_W": float(electrical), "mechanical_W": float(mechanical)}


def contact_summary(samples: dict, window) -> dict:
    """The robot's floor contacts over the window, in the heading frame of each sample.

    Returns ``load``: the mean total normal force [N]; ``share``: its fraction per kind of
    geometry (``sample_run``); ``traction``: the mean forward friction force [N]; and for
    all contacts together (``all``) and per leg (``legs``): ``share`` of the normal load,
    normal-force-weighted means of the robot's contact point's horizontal velocity
    ``slip_u``, ``slip_v`` [m/s] (zero if nothing slides) and of the hull's velocity
    relative to that point, ``noslip_u``, ``noslip_v`` (the stride's own speed: what the
    hull would do if the loaded points held), ``sliding``: the fraction of the normal
    load on points sliding faster than SLIDING, and ``duty``: the fraction of the window's
    samples in which the leg (any leg, for ``all``) bears more than LOADED of it."""
    import numpy as np

    t = samples["t"]
    sums = _ContactSums()
    for k in np.flatnonzero((t >= window[0]) & (t < window[1])):
        sums.add(samples["contacts"][k], samples["yaw"][k], samples["v_world"][k])
    total = sum(sums.kinds.values())
    return {
        "load": total / max(sums.n, 1),
        "traction": sums.traction / max(sums.n, 1),
        "share": {k: v / total for k, v in sorted(sums.kinds.items())},
        "all": sums.stats(sum(sums.acc.values(), np.zeros(6)), "all", total),
        "legs": {leg: sums.stats(a, leg, total) for leg, a in sorted(sums.acc.items())},
    }


@dc.dataclass
class _ContactSums:
    """``contact_summary``'s sums over the window's samples."""

    kinds: dict = dc.field(default_factory=dict)  # normal force per kind of geometry
    # per leg: [fn, fn slip_u, fn slip_v, fn noslip_u, fn noslip_v, sliding fn]
    acc: dict = dc.field(default_factory=dict)
    loaded: dict = dc.field(default_factory=dict)  # per leg, and "all": samples loaded
    traction: float = 0.0
    n: int = 0  # samples

    def add(self, contacts, yaw, v_hull) -> None:
        """One sample's contacts, with the hull's heading and velocity."""
        import numpy as np

        self.n += 1
        fwd, left = heading_frame(yaw)
        load: dict = {}
        for kind, leg, _, f, v, slip in contacts:
            fn = max(float(f[2]), 0.0)
            load[leg] = load.get(leg, 0.0) + fn
            self.kinds[kind] = self.kinds.get(kind, 0.0) + fn
            rel = v_hull - v  # the hull's velocity relative to the robot's contact point
            row = fn * np.array(
                [1.0, v @ fwd, v @ left, rel @ fwd, rel @ left, 1.0 if slip > SLIDING else 0.0]
            )
            self.acc[leg] = self.acc.get(leg, np.zeros(6)) + row
            self.traction += float(f @ fwd)
        standing = [leg for leg, f in load.items() if f > LOADED]
        for leg in standing + (["all"] if standing else []):
            self.loaded[leg] = self.loaded.get(leg, 0) + 1

    def stats(self, a, leg: str, total: float) -> dict:
        """The sums ``a`` of ``leg`` as ``contact_summary``'s weighted means."""
        w = a[0] if a[0] > 0 else math.nan
        return {
            "share": a[0] / total if total else math.nan,
            "slip_u": a[1] / w,
            "slip_v": a[2] / w,
            "noslip_u": a[3] / w,
            "noslip_v": a[4] / w,
            "sliding": a[5] / w,
            "duty": self.loaded.get(leg, 0) / self.n if self.n else math.nan,
        }


# name: (gait, friction, damping x, net weight kg, duration s, extra overrides, gait override)
DIAGNOSTIC_RUNS: dict[str, tuple[str, float, float, float, float, dict, str | None]] = {
    # What sets the swim's speed and yaw (one band point, 10 s: steady from ~4 s).
    "swim": ("swim", 0.65, 1.0, 0.85, 10.0, {}, None),
    "swim_stall_10deg": (
        "swim",
        0.65,
        1.0,
        0.85,
        10.0,
        {"water.coefficient_scales.fins.stall_angle_deg": 0.667},
        None,
    ),
    "swim_stall_25deg": (
        "swim",
        0.65,
        1.0,
        0.85,
        10.0,
        {"water.coefficient_scales.fins.stall_angle_deg": 1.667},
        None,
    ),
    "swim_hull_damping_x3": ("swim", 0.65, 3.0, 0.85, 10.0, {}, None),
    "swim_no_phase_lag": ("swim", 0.65, 1.0, 0.85, 10.0, {}, "swim_no_phase_lag"),
    "swim_printed": ("swim", 0.65, 1.0, 0.85, 10.0, {}, "swim_printed"),
    # What sets the floor gaits' speeds: contacts and slip (20 s, as the sweep).
    "walk_f0.8_w0.85": ("walk", 0.8, 1.0, 0.85, 20.0, {}, None),
    "walk_f0.5_w0.85": ("walk", 0.5, 1.0, 0.85, 20.0, {}, None),
    "walk_f0.65_w0.6": ("walk", 0.65, 1.0, 0.6, 20.0, {}, None),
    "walk_f0.8_w1.1_d1.3": ("walk", 0.8, 1.3, 1.1, 20.0, {}, None),
    "trot_f0.8_w0.85": ("trot", 0.8, 1.0, 0.85, 20.0, {}, None),
    "trot_f0.65_w0.6": ("trot", 0.65, 1.0, 0.6, 20.0, {}, None),
    "crab_f0.65_w0.85": ("crab", 0.65, 1.0, 0.85, 20.0, {}, None),
    "crab_f0.65_w0.6": ("crab", 0.65, 1.0, 0.6, 20.0, {}, None),
    "crab_f0.5_w1.1_d0.7": ("crab", 0.5, 0.7, 1.1, 20.0, {}, None),
    "turning_f0.65_w0.85": ("turning", 0.65, 1.0, 0.85, 20.0, {}, None),
    # The same with the earlier quasi-steady cross-flow fins (no added mass on the bodies):
    # contacts and slip against the foil runs above, at the gaits' 0.5 Hz and at 0.25 Hz.
    "swim_cross_flow": ("swim", 0.65, 1.0, 0.85, 10.0, {"water.fin_model": "cross_flow"}, None),
    "trot_f0.8_w0.85_cross_flow": (
        "trot",
        0.8,
        1.0,
        0.85,
        20.0,
        {"water.fin_model": "cross_flow"},
        None,
    ),
    "walk_f0.8_w0.85_cross_flow": (
        "walk",
        0.8,
        1.0,
        0.85,
        20.0,
        {"water.fin_model": "cross_flow"},
        None,
    ),
    "trot_f0.8_w0.85_0.25Hz": ("trot", 0.8, 1.0, 0.85, 20.0, {"cpg.frequency_hz": 0.25}, None),
    "trot_f0.8_w0.85_cross_flow_0.25Hz": (
        "trot",
        0.8,
        1.0,
        0.85,
        20.0,
        {"water.fin_model": "cross_flow", "cpg.frequency_hz": 0.25},
        None,
    ),
    # The foil trot with the plates' added mass scaled to 1/1000 (a factor must be > 0).
    "trot_f0.8_w0.85_light_plates": (
        "trot",
        0.8,
        1.0,
        0.85,
        20.0,
        {"water.coefficient_scales.fins.added_mass_factor": 0.001},
        None,
    ),
}


# The shipped locomotion scenarios as they are (20 s, their own friction and weight), with
# either fin model and either servo model (``_ideal``: the plant's PD instead of the
# datasheet servo): the README's table, with the water's forward forces and the power.
SHIPPED_RUNS = {
    f"shipped_{gait}_{fins}{'' if servo == 'datasheet' else '_' + servo}": (gait, fins, servo)
    for gait in ("swim", "trot", "walk", "crab", "turning")
    for fins in ("foil", "cross_flow")
    for servo in ("datasheet", "ideal")
}

DIAGNOSTIC_NAMES = (*DIAGNOSTIC_RUNS, *SHIPPED_RUNS)


def diagnostic_scenario(name: str):
    """(scenario, explicit GaitParams or None) of a DIAGNOSTIC_RUNS or SHIPPED_RUNS entry."""
    from manta_drake.scenario import load_scenario

    if name in SHIPPED_RUNS:
        gait, fins, servo = SHIPPED_RUNS[name]
        scenario = load_scenario(f"locomotion_{gait}")
        scenario.water.fin_model = fins
        scenario.actuators.servo_model = servo
        scenario.visualization.meshcat = False
        return scenario, None
    gait, fr, dmp, w, dur, extra, gait_override = DIAGNOSTIC_RUNS[name]
    scenario = band_scenario(gait, fr, dmp, w, dur, extra)
    if gait_override in DIAGNOSTIC_GAITS:
        return scenario, DIAGNOSTIC_GAITS[gait_override]()
    if gait_override is not None:  # a library gait: named by the scenario
        scenario.controller.gait = gait_override
        scenario.initial_stance = gait_override
    return scenario, None


def diagnose(out_dir: pathlib.Path, names=None) -> dict:
    """Runs DIAGNOSTIC_RUNS and SHIPPED_RUNS (or ``names`` of them) one after another; writes
    and returns ``out_dir/diagnostics.json`` (existing entries are kept, so an interrupted
    call resumes)."""
    import json

    out_dir.mkdir(parents=True, exist_ok=True)
    path = out_dir / "diagnostics.json"
    done = json.loads(path.read_text()) if path.exists() else {}
    for name in DIAGNOSTIC_NAMES:
        if (names and name not in names) or name in done:
            continue
        done[name] = entry = diagnostic_entry(name)
        path.write_text(json.dumps(done, indent=1) + "\n")
        print(f"{name}: {json.dumps(entry)}", flush=True)
    return done


def diagnostic_entry(name: str) -> dict:
    """Simulates the diagnostic run ``name``; its entry of diagnostics.json: the run's
    definition, its wall time, and over its free-water window (if it has one) the motion,
    and over the window's whole cycles the water's forward forces, the power and the
    contacts."""
    import time

    scenario, explicit = diagnostic_scenario(name)
    start = time.perf_counter()
    samples = sample_run(scenario.validate(), gait=explicit)
    window = metric_window(samples, scenario)
    entry = {
        "run": list(DIAGNOSTIC_RUNS[name] if name in DIAGNOSTIC_RUNS else SHIPPED_RUNS[name]),
        "wall_s": time.perf_counter() - start,
    }
    if window is not None:
        cycles = whole_cycles(window, 1.0 / scenario.cpg.frequency_hz)
        entry["motion"] = motion_summary(samples, window)
        entry["force_window"] = list(cycles)
        if len(samples["hydro"]):
            entry["water_forward_N"] = hydro_summary(samples, cycles)
        if len(samples["power"]):
            entry["power"] = power_summary(samples, cycles)
        entry["contacts"] = contact_summary(samples, cycles)
    return entry


# The columns of the sweep's results.csv the report reads.
RESULTS_COLUMNS = (
    "base",
    *BAND_KEYS,
    "status",
    "u",
    "v",
    "yaw_rate_deg_s",
    "steady_start_s",
    "steady_end_s",
)


def _check_name(option: str, name: str, default: str) -> None:
    """``name`` is a plain file name without folder and ending (``--page``, ``--figure``)."""
    from manta_drake.config_io import ScenarioError, short_repr

    if not re.fullmatch(r"[A-Za-z0-9_][A-Za-z0-9_.-]*", name) or name.endswith((".md", ".png")):
        raise ScenarioError(
            f"{option} {short_repr(name)}: a file name without folder or ending "
            f"(letters, digits, _ . -), e.g. {default}"
        )


def check_diagnose_arguments(args) -> None:
    """--diagnose DIR and --only, before anything runs; raises ScenarioError naming them."""
    from manta_drake.config_io import ScenarioError, check_writable_folder
    from manta_drake.studies.options import check_names

    if args.only is not None:
        if not args.only:
            raise ScenarioError(f"--only: name at least one of {', '.join(DIAGNOSTIC_NAMES)}")
        check_names("--only", ",".join(args.only), DIAGNOSTIC_NAMES)
    check_writable_folder(args.diagnose, "--diagnose", example="out/findings_diagnostics")


def check_arguments(args, prog: str = "manta-drake study findings") -> pathlib.Path | None:
    """Every option before anything is read or run; the folder the report goes to (None
    with --diagnose). Raises ScenarioError naming the option."""
    from manta_drake.studies.options import (
        check_figure_file,
        check_output_file,
        check_sweep_results,
        needs,
    )
    from manta_drake.studies.report import output_folder

    needs(
        "--only",
        args.only is not None,
        "--diagnose",
        args.diagnose is not None,
        "it chooses the diagnostic runs",
    )
    if args.diagnose is not None:
        check_diagnose_arguments(args)
        return None
    _check_name("--page", args.page, "findings")
    _check_name("--figure", args.figure, "findings")
    folder = output_folder(args.out, prog)
    check_sweep_results(args.results, RESULTS_COLUMNS, "findings", SHIPPED_RESULTS)
    if args.sensitivity:
        check_sweep_results(
            args.sensitivity, ("base", "seed", *RESULTS_COLUMNS[4:]), "energy", SENSITIVITY_RESULTS
        )
    check_output_file("--page", folder / f"{args.page}.md")
    check_figure_file("--figure", folder / "figures" / f"{args.figure}.png")
    return folder


def regenerate_command(args) -> str:
    """The command that writes the same block and figure again (a new page's stamp)."""
    words = ["manta-drake study findings", f"--results {args.results}"]
    if args.sensitivity != SENSITIVITY_RESULTS:
        words.append(f"--sensitivity {shlex.quote(args.sensitivity)}")
    words += [] if args.out is None else [f"--out {args.out}"]
    words += [] if args.page == "findings" else [f"--page {args.page}"]
    words += [] if args.figure == "findings" else [f"--figure {args.figure}"]
    return " ".join(words)


def parser(prog=None):
    """The command line's options."""
    from manta_drake.studies.options import StudyParser

    p = StudyParser(
        prog=prog,
        description=__doc__.split("\n\n")[0],
        formatter_class=argparse.RawDescriptionHelpFormatter,
        epilog="Without a fresh sweep, use the table shipped in the "
        f"repository: --results {SHIPPED_RESULTS}",
    )
    p.add_argument(
        "--results",
        default=DEFAULT_RESULTS,
        help=f"results.csv of the findings sweep (default {DEFAULT_RESULTS}; "
        f"the shipped copy: {SHIPPED_RESULTS})",
    )
    p.add_argument(
        "--sensitivity",
        default=SENSITIVITY_RESULTS,
        metavar="CSV",
        help="results.csv of a sweep over the same gaits whose parameter sets "
        "are reported one by one (default the shipped energy sweep, "
        f"{SENSITIVITY_RESULTS}; '' for none)",
    )
    _output_options(p)
    p.add_argument(
        "--diagnose",
        metavar="DIR",
        type=pathlib.Path,
        help="instead of the report: run the targeted simulations behind the "
        "explanations in docs/findings.md (one at a time, ~5 min) and write "
        "DIR/diagnostics.json",
    )
    p.add_argument(
        "--only",
        nargs="*",
        help=f"with --diagnose: only these runs ({', '.join(DIAGNOSTIC_NAMES)})",
    )
    return p


def _output_options(p) -> None:
    """--out DIR, --page and --figure: where the report goes."""
    p.add_argument(
        "--out",
        metavar="DIR",
        type=pathlib.Path,
        help="where the report goes: the block of DIR/PAGE.md between its findings-report "
        "markers (a new page if there is none) and DIR/figures/FIGURE.png (default the "
        "checkout's docs/)",
    )
    p.add_argument(
        "--page",
        default="findings",
        metavar="PAGE",
        help="the page's name in DIR, without .md (default findings)",
    )
    p.add_argument(
        "--figure",
        default="findings",
        metavar="FIGURE",
        help="the figure's name in DIR/figures, without .png (default findings)",
    )


def write_report(args, folder: pathlib.Path) -> list:
    """Reads the tables, writes the page's block and the figure; the tallies and the
    variants' tallies."""
    points = band_points(read_results(pathlib.Path(args.results)))
    tallies, verdicts = evaluate(points)
    variant_tallies, _ = evaluate(points, VARIANTS)
    sets = parameter_sets(read_results(args.sensitivity)) if args.sensitivity else None
    block = markdown_block(
        tallies,
        variant_tallies,
        gait_stats(points),
        verdicts,
        args.results,
        None if sets is None else sensitivity(sets, args.sensitivity),
    )
    write_markdown(folder / f"{args.page}.md", block, regenerate_command(args))
    plot(points, tallies, variant_tallies, folder / "figures" / f"{args.figure}.png")
    return list(tallies) + list(variant_tallies)


def main(argv=None, prog=None) -> int:
    """The command line (``manta-drake study findings``); returns the exit status."""
    args = parser(prog).parse_args(argv)
    folder = check_arguments(args, prog or "manta-drake study findings")
    if folder is None:
        diagnose(args.diagnose, args.only)
        return 0
    for t in write_report(args, folder):
        print(
            f"{t.label:52s} {t.holds:3d}/{t.total:<3d} fails {t.fails:3d}  "
            f"undetermined {t.undetermined:3d}  {100 * t.fraction:5.1f} %"
        )
    print(f"wrote {folder / args.page}.md and {folder / 'figures' / args.figure}.png")
    return 0
