"""One fin's mean thrust by the fin strips' model against pterasoftware's unsteady vortex lattice.

``manta-drake study validation --section vortex-lattice [--runs DIR] [--out DIR] [--quick]``.

One fin of the model (``RobotParams``: the proximal plate d3 x proximal_chord, the distal plate
dE x distal_chord, mid-chords in line, the roll1 and pitch axes through the root's mid-chord,
the roll2 hinge along the chord at d3; ``model_sdf.fin_plate_geometry``, ``kinematics``) swims
at a speed U through still water with a prescribed stroke, and both models give its mean
thrust over a cycle:

* **pterasoftware** (PyPI 5.1, the ``vortex-lattice`` extra): the unsteady ring-vortex lattice
  method with a prescribed wake, rho = 1000 kg/m^3, the two plates as one planar wing of four
  cross-sections (a 4 mm step between them where the chord drops), ``nc`` chordwise panels at
  a fixed time step; the roll1 and pitch angles are the wing's x-y' rotation about the root's
  mid-chord, roll2 the rotation of the distal cross-sections about their chord;
* **the strip model** (``station.foil``: DeLaurier's modified strip theory, the terms the
  simulator applies to each fin strip) driven by the same motion
  (``foil.prescribed_motion_forces``), each strip's mid-chord velocity U + d/dt r from the
  model's own DH chain (``kinematics.leg_frames_ned``); lift slope 2 pi or Helmbold's at the
  fin's aspect ratio, suction efficiency 1, no friction (the inviscid comparison), attached
  flow only or with the stall blend;
* **Garrick** (1936), 2-D strip theory of small-amplitude plunge (pure roll only): each strip
  heaving with amplitude r theta0.

Cases: (a) pure roll +-45 deg at the swim gait's frequency and 0.4 m/s (St ~ 0.57: the regime
where attached-flow theory applies), a chordwise-panel convergence and the cycles to
periodicity; the acceptance: the strip model within +-30 % of the converged UVLM.
(b) the swim gait's stroke of the right front fin (``models/gaits.yaml`` ``swim``: roll1,
pitch and roll2 with the gait's amplitudes and locked phases) at 0.1, 0.2 and 0.4 m/s, an
inviscid upper bound at the gait's high Strouhal number, with its convergence table.

The added-mass (non-circulatory) force on a plate is -d/dt of its impulse (Kirchhoff,
``foil.kirchhoff_plate_force`` is exactly -d/dt(m q n)), so it has no mean over a periodic
stroke: the strip model's mean thrust is its circulatory, suction and separated terms alone,
while UVLM's holds every pressure force.

Each pterasoftware case is cached as ``RUNS/cases/<key>.json`` (``--runs``) and skipped when
present (the runs are restartable; the full run is about 30 min of solver time on 2 shared
cores, ``--quick`` about 3 min); ``RUNS/vortex_lattice.yaml`` is the summary, also written to the
committed ``models/reference/vortex_lattice.yaml`` (``--reference``), and the ``vortex-lattice``
block of ``OUT/validation.md`` (``--out``, the checkout's ``docs/`` by default) is rendered from
it by ``templates/vortex_lattice.md.j2``.
``--from-yaml`` runs nothing and renders the page from the committed numbers; ``--no-run``
summarizes the cases already cached.
"""

from __future__ import annotations

import dataclasses as dc
import datetime
import json
import math
import pathlib
import sys
import time

import numpy as np

from manta_drake.model.kinematics import X_BODYDRAKE_BODYNED, leg_frames_ned, rot_z
from manta_drake.model.robot_params import DEFAULT_ROBOT, LEGS, RobotParams
from manta_drake.station import foil
from manta_drake.studies import REPO
from manta_drake.studies.options import StudyParser
from manta_drake.studies.validation import (
    PAGE_COMMAND,
    PAGE_TITLE,
    ValidationError,
    add_folder_options,
    check_runs,
    page_path,
    reference_file,
    render_template,
    round_floats,
    run_module,
)

SECTION = "vortex-lattice"
COMMAND = "manta-drake study validation --section vortex-lattice"
YAML_PATH = REPO / "models" / "reference" / "vortex_lattice.yaml"
TEMPLATE = "vortex_lattice.md.j2"

RHO = 1000.0  # kg/m^3, models/hydrodynamics.yaml water_density
NU = 1.0e-6  # m^2/s, water at 20 C (pterasoftware's friction-free solver only records it)
LEG = "fr"  # the right front fin: it spans pterasoftware's +y (a right wing)
GAIT = "swim"
ROLL_ONLY_DEG = 45.0  # case (a): the gait's roll1 amplitude, alone
SPEEDS = (0.1, 0.2, 0.4)  # m/s: the swim speeds of case (b)
ROLL_SPEED = 0.4  # m/s, case (a)
STEPS_PER_CYCLE = 60  # the fixed time step T/60 of every UVLM case
SPANWISE_PANELS = (8, 5)  # UVLM spanwise panels on the proximal and distal plates
STEP_GAP = 0.004  # m: the spanwise width of the UVLM panel row where the chord steps down
STRIPS_PER_PLATE = 10  # the strip model's spanwise strips per plate
STRIP_STEPS_PER_CYCLE = 400
STRIP_CYCLES = 8  # the strip model's run (periodic to 0.1 % from cycle 3-4); the last counts


def shipped_stall() -> dict:
    """The stall terms of the strip model as models/hydrodynamics.yaml ships them."""
    from manta_drake.model.coefficients import load_coefficients

    fins = load_coefficients().fins
    return {
        "stall_angle": math.radians(fins.stall_angle_deg.value),
        "stall_width": math.radians(fins.stall_width_deg.value),
        "cross_flow_coefficient": float(fins.normal_force_coefficient.value),
        "separation_lag": float(fins.separation_lag.value),
    }


STALL = shipped_stall()
ATTACHED = {
    "stall_angle": math.pi,
    "stall_width": 1e-3,
    "cross_flow_coefficient": STALL["cross_flow_coefficient"],
}
ACCEPT = 0.30  # the acceptance: |strip / UVLM - 1| <= 30 % in pure roll at 0.4 m/s
PERIODIC_TOL = 0.02  # a cycle is periodic when its mean thrust is within 2 % of the previous

# The full run: (a) nc 4..10 over 4 cycles; (b) nc 4..12, 4 cycles (0.1 m/s: 8, its prescribed
# wake moves only ~1.4 chords a cycle).
ROLL_NC = (4, 6, 8, 10)
GAIT_NC = (4, 6, 8, 10, 12)
CYCLES = {0.1: 8, 0.2: 4, 0.4: 4}
# (a)'s other resolutions at one nc: the time step (steps per cycle) and the spanwise panels.
CHECK_NC = 8
DT_CHECK = (40, 90)  # steps per cycle, beside STEPS_PER_CYCLE
ROLL_DT_CHECK = (40, 90, 120)
SPANWISE_CHECK = ((16, 10),)
GAIT_DT_CHECK_SPEEDS = (0.4, 0.1)
QUICK_NC = (4,)
QUICK_CYCLES = 2


# --- the fin and its stroke ---------------------------------------------------------------------


def unswept(params: RobotParams = DEFAULT_ROBOT) -> RobotParams:
    """The robot with its fins unswept: the roll axes along the body's x, as pterasoftware's
    wing x-rotation is (the shipped 10 deg sweep turns the stroke plane by cos 10 = 0.985)."""
    return params.with_fin_sweep(0.0)


FIN_ROBOT = unswept(DEFAULT_ROBOT)  # the robot every case of this study uses


@dc.dataclass(frozen=True)
class Stroke:
    """A fin's prescribed joint motion: q_j = amp_j sin(2 pi f t + phase_j) for roll1, pitch
    and roll2 (yaw held at 0); amplitudes may be negative (the gait's signs)."""

    name: str
    amp_deg: tuple  # roll1, pitch, roll2
    phase_deg: tuple
    frequency_hz: float

    @property
    def period(self) -> float:
        return 1.0 / self.frequency_hz

    def angles(self, t) -> np.ndarray:
        """(nt, 4) joint angles yaw, roll1, pitch, roll2 [rad] at the times t."""
        t = np.atleast_1d(np.asarray(t, dtype=float))
        q = np.zeros((len(t), 4))
        w = 2.0 * np.pi * self.frequency_hz
        for j, (a, p) in enumerate(zip(self.amp_deg, self.phase_deg), start=1):
            q[:, j] = math.radians(a) * np.sin(w * t + math.radians(p))
        return q

    def sine(self, j: int) -> tuple[float, float]:
        """Joint j's (1 roll1, 2 pitch, 3 roll2) motion as pterasoftware's non-negative
        amplitude [deg] and phase in (-180, 180] [deg]."""
        a, p = self.amp_deg[j - 1], self.phase_deg[j - 1]
        if a < 0:
            a, p = -a, p + 180.0
        p = (p + 180.0) % 360.0 - 180.0
        return float(a), float(180.0 if p == -180.0 else p)


def swim_frequency() -> float:
    """The swim scenario's CPG frequency (models/scenarios/locomotion_swim.yaml, cpg.frequency_hz
    or the scenario default)."""
    from manta_drake.scenario import load_scenario

    return float(load_scenario("locomotion_swim").cpg.frequency_hz)


def gait_stroke(gait: str = GAIT, leg: str = LEG, frequency_hz: float | None = None) -> Stroke:
    """The gait's stroke of one fin: its R row and the CPG's locked phases (relative to roll1)."""
    from manta_drake.control.cpg import locked_phases
    from manta_drake.control.gaits import get_gait

    g = get_gait(gait)
    k = LEGS.index(leg)
    phases = np.degrees(locked_phases(g.to_vector())).reshape(4, 4)[k]
    amp = np.degrees(g.R[k])
    rel = phases - phases[1]
    return Stroke(
        gait,
        tuple(round(float(a), 9) for a in amp[1:]),
        tuple(round(float(p), 9) for p in rel[1:]),
        swim_frequency() if frequency_hz is None else frequency_hz,
    )


def roll_stroke(frequency_hz: float | None = None) -> Stroke:
    """Case (a): roll1 +-ROLL_ONLY_DEG alone."""
    return Stroke(
        "pure_roll",
        (ROLL_ONLY_DEG, 0.0, 0.0),
        (0.0, 0.0, 0.0),
        swim_frequency() if frequency_hz is None else frequency_hz,
    )


def fin_dimensions(params: RobotParams = FIN_ROBOT) -> dict:
    d3, dE = params.d3, params.dE
    c1, c2 = params.proximal_chord, params.distal_chord
    area = d3 * c1 + dE * c2
    span = d3 + dE
    return {
        "d3": d3,
        "dE": dE,
        "proximal_chord": c1,
        "distal_chord": c2,
        "span": span,
        "area": area,
        "aspect_ratio": span * span / area,
    }


def plate_frames(q, params: RobotParams = FIN_ROBOT, leg: str = LEG):
    """Link 3 (proximal plate) and link 4 (distal plate) frames in Drake's body frame, origins
    relative to the fin root (the roll1/pitch axes' point): (R3, o3, R4, o4), (nt, 3, 3) and
    (nt, 3). Link 3: x normal, y chord (aft), z span; link 4: x normal, -y span, z chord."""
    q = np.atleast_2d(q)
    out = [
        np.empty((len(q), 3, 3)),
        np.empty((len(q), 3)),
        np.empty((len(q), 3, 3)),
        np.empty((len(q), 3)),
    ]
    for i, qi in enumerate(q):
        F = leg_frames_ned(leg, qi, params)
        root = (X_BODYDRAKE_BODYNED @ F[1])[:3, 3]
        X3 = X_BODYDRAKE_BODYNED @ F[2] @ rot_z(qi[2])
        X4 = X_BODYDRAKE_BODYNED @ F[3] @ rot_z(qi[3])
        out[0][i], out[1][i] = X3[:3, :3], X3[:3, 3] - root
        out[2][i], out[3][i] = X4[:3, :3], X4[:3, 3] - root
    return tuple(out)


def strip_layout(params: RobotParams = FIN_ROBOT, n: int = STRIPS_PER_PLATE) -> dict:
    """The strips of the two plates: plate index (0 proximal, 1 distal), span coordinate of the
    strip's middle from its plate's hinge, width and chord."""
    d = fin_dimensions(params)
    plate, s, width, chord = [], [], [], []
    for k, (length, c) in enumerate(((d["d3"], d["proximal_chord"]), (d["dE"], d["distal_chord"]))):
        w = length / n
        plate += [k] * n
        s += list((np.arange(n) + 0.5) * w)
        width += [w] * n
        chord += [c] * n
    return {
        "plate": np.array(plate),
        "s": np.array(s),
        "width": np.array(width),
        "chord": np.array(chord),
    }


def _strip_points(q, layout, params):
    """Mid-chord points (nt, ns, 3) and axes (normal, chord_dir to the leading edge, span)."""
    R3, o3, R4, o4 = plate_frames(q, params)
    prox = layout["plate"] == 0
    s = layout["s"]
    nt, ns = len(q), len(s)
    p = np.empty((nt, ns, 3))
    n, c, sp = (np.empty((nt, ns, 3)) for _ in range(3))
    # Proximal: link 3 (0, 0, s); distal: link 4 (0, -s, 0).
    p[:, prox] = o3[:, None, :] + s[prox][None, :, None] * R3[:, None, :, 2]
    p[:, ~prox] = o4[:, None, :] - s[~prox][None, :, None] * R4[:, None, :, 1]
    n[:, prox], n[:, ~prox] = R3[:, None, :, 0], R4[:, None, :, 0]
    c[:, prox], c[:, ~prox] = -R3[:, None, :, 1], -R4[:, None, :, 2]  # forward (leading edge)
    sp[:, prox], sp[:, ~prox] = R3[:, None, :, 2], -R4[:, None, :, 1]
    return p, n, c, sp, (R3, R4)


def _omega(Rp, Rm, h):
    """Angular velocity (nt, 3) from the rotations at t + h and t - h."""
    S = Rp @ np.transpose(Rm, (0, 2, 1))
    A = 0.5 * (S - np.transpose(S, (0, 2, 1)))
    return np.stack([A[:, 2, 1], A[:, 0, 2], A[:, 1, 0]], axis=1) / (2.0 * h)


def strip_motion(
    stroke: Stroke,
    speed: float,
    t,
    params: RobotParams = FIN_ROBOT,
    n_strips: int = STRIPS_PER_PLATE,
) -> dict:
    """The strips' prescribed motion at the times t: the inputs of
    ``foil.prescribed_motion_forces`` (the body swims at +speed along its x through still
    water: v_mid = speed x_hat + d/dt r, central differences of the DH chain)."""
    layout = strip_layout(params, n_strips)
    h = 1e-5 * stroke.period
    p0, n, c, sp, _ = _strip_points(stroke.angles(t), layout, params)
    pp, _, _, _, (R3p, R4p) = _strip_points(stroke.angles(t + h), layout, params)
    pm, _, _, _, (R3m, R4m) = _strip_points(stroke.angles(t - h), layout, params)
    v = (pp - pm) / (2.0 * h)
    v[..., 0] += speed
    w3, w4 = _omega(R3p, R3m, h), _omega(R4p, R4m, h)
    prox = layout["plate"] == 0
    omega = np.where(prox[None, :, None], w3[:, None, :], w4[:, None, :])
    return {
        "p": p0,
        "v_mid": v,
        "omega": omega,
        "normal": n,
        "chord_dir": c,
        "span_dir": sp,
        "area": layout["width"] * layout["chord"],
        "chord": layout["chord"],
        "layout": layout,
    }


def strip_params(lift_slope: float, stall: bool) -> dict:
    return {
        "rho": RHO,
        "lift_slope": float(lift_slope),
        "suction_efficiency": 1.0,
        "friction_coefficient": 0.0,
        **(STALL if stall else ATTACHED),
    }


def lift_slopes(params: RobotParams = FIN_ROBOT) -> dict:
    """The two lift slopes compared: 2-D (2 pi) and Helmbold's at the single fin's AR."""
    ar = fin_dimensions(params)["aspect_ratio"]
    return {"2d": 2.0 * math.pi, "helmbold": float(foil.helmbold_lift_slope(ar))}


def cycle_means(x, steps_per_cycle: int) -> list[float]:
    """Means of x over each whole cycle (x sampled at k dt, k = 0.. ; the mean of a cycle uses
    the trapezoid rule over its steps_per_cycle + 1 samples, as pterasoftware's final mean)."""
    x = np.asarray(x, dtype=float)
    out = []
    for k in range((len(x) - 1) // steps_per_cycle):
        seg = x[k * steps_per_cycle : (k + 1) * steps_per_cycle + 1]
        out.append(float(np.trapezoid(seg) / steps_per_cycle))
    return out


def cycles_to_periodic(means, tol: float = PERIODIC_TOL) -> int | None:
    """The first cycle (1-based) whose mean every later cycle's mean is within tol of
    (relative to the last cycle's magnitude); None if none is (at least one later cycle)."""
    m = np.asarray(means, dtype=float)
    scale = max(abs(m[-1]), 1e-12) if len(m) else 1.0
    for k in range(len(m) - 1):
        if np.all(np.abs(m[k + 1 :] - m[k]) <= tol * scale):
            return k + 1
    return None


def strip_thrust(
    stroke: Stroke,
    speed: float,
    lift_slope: float,
    stall: bool,
    params: RobotParams = FIN_ROBOT,
    n_strips: int = STRIPS_PER_PLATE,
    steps_per_cycle: int = STRIP_STEPS_PER_CYCLE,
    cycles: int = STRIP_CYCLES,
) -> dict:
    """The strip model's mean thrust [N] (force along the body's +x, the swimming direction)
    over the last cycle, its per-cycle means, the mean side (y, the fin's outward -y is
    positive outward) and lift (z) forces, and the peak |thrust|."""
    dt = stroke.period / steps_per_cycle
    t = np.arange(cycles * steps_per_cycle + 1) * dt
    m = strip_motion(stroke, speed, t, params, n_strips)
    f = foil.prescribed_motion_forces(
        dt,
        m["v_mid"],
        m["omega"],
        m["normal"],
        m["chord_dir"],
        m["span_dir"],
        m["area"],
        m["chord"],
        strip_params(lift_slope, stall),
    )
    total = f.sum(axis=1)
    per_cycle = cycle_means(total[:, 0], steps_per_cycle)
    last = slice(-steps_per_cycle - 1, None)
    prox = m["layout"]["plate"] == 0
    plates = {
        name: float(np.trapezoid(f[last][:, sel, 0].sum(axis=1)) / steps_per_cycle)
        for name, sel in (("proximal", prox), ("distal", ~prox))
    }
    return {
        "thrust": per_cycle[-1],
        "per_cycle": per_cycle,
        "plates": plates,
        "cycles_to_periodic": cycles_to_periodic(per_cycle),
        "side_outward": float(-np.trapezoid(total[last, 1]) / steps_per_cycle),
        "lift": float(np.trapezoid(total[last, 2]) / steps_per_cycle),
        "peak_thrust": float(np.abs(total[last, 0]).max()),
        "lift_slope": float(lift_slope),
        "stall": bool(stall),
        "strips": int(len(m["chord"])),
    }


def stalled_area_fraction(
    stroke: Stroke,
    speed: float,
    params: RobotParams = FIN_ROBOT,
    n_strips: int = STRIPS_PER_PLATE,
    steps: int = 200,
) -> float:
    """The share of the fin's area whose geometric angle of attack at the 3/4 chord
    (``foil.strip_kinematics``) passes the stall angle during the stroke."""
    t = np.arange(steps) * stroke.period / steps
    m = strip_motion(stroke, speed, t, params, n_strips)
    peak = np.zeros(len(m["chord"]))
    for i in range(steps):
        kin = foil.strip_kinematics(
            m["v_mid"][i],
            m["omega"][i],
            m["normal"][i],
            m["chord_dir"][i],
            m["span_dir"][i],
            m["chord"],
        )
        peak = np.maximum(peak, kin["alpha"])
    return float(m["area"][peak > STALL["stall_angle"]].sum() / m["area"].sum())


def garrick_strip_thrust(
    stroke: Stroke, speed: float, params: RobotParams = FIN_ROBOT, n_strips: int = 40
) -> float:
    """Garrick's 2-D small-amplitude plunge thrust summed over strips, each heaving with the
    amplitude r theta0 of its mid-span radius r from the roll1 axis (pure roll only)."""
    if stroke.amp_deg[1] != 0.0 or stroke.amp_deg[2] != 0.0:
        raise ValueError("Garrick's plunge estimate is for pure roll only")
    lay = strip_layout(params, n_strips)
    r = np.where(lay["plate"] == 0, lay["s"], params.d3 + lay["s"])
    h0 = r * math.radians(abs(stroke.amp_deg[0]))
    omega = 2.0 * math.pi * stroke.frequency_hz
    tp = foil.garrick_plunge_thrust(RHO, lay["chord"] / 2.0, omega, h0, speed)
    return float((tp * lay["width"]).sum())


def strouhal(stroke: Stroke, speed: float, params: RobotParams = FIN_ROBOT) -> float:
    """f A / U with A the tip's peak-to-peak excursion (roll1 and roll2 about parallel axes)."""
    t = np.linspace(0.0, stroke.period, 721)
    layout = {
        "plate": np.array([1]),
        "s": np.array([params.dE]),
        "width": np.array([1.0]),
        "chord": np.array([params.distal_chord]),
    }
    p = _strip_points(stroke.angles(t), layout, params)[0][:, 0, :]
    d = p[:, None, :] - p[None, :, :]
    return float(stroke.frequency_hz * np.sqrt((d * d).sum(-1)).max() / speed)


# --- pterasoftware -------------------------------------------------------------------------------


def pterasoftware_version() -> str:
    from importlib.metadata import version

    return version("pterasoftware")


def _ps():
    try:
        import pterasoftware as ps
    except ImportError as e:  # pragma: no cover - the optional extra
        raise ValidationError(
            "pterasoftware is not installed: pip install "
            "'manta_drake[vortex-lattice]' (about 1.1 GB)"
        ) from e
    return ps


@dc.dataclass(frozen=True)
class Case:
    """One UVLM run."""

    stroke: Stroke
    speed: float
    nc: int
    cycles: int
    steps_per_cycle: int = STEPS_PER_CYCLE
    spanwise: tuple = SPANWISE_PANELS

    @property
    def key(self) -> str:
        return (
            f"{self.stroke.name}_U{self.speed:.2f}_nc{self.nc}_ns{self.spanwise[0]}-"
            f"{self.spanwise[1]}_cyc{self.cycles}_spc{self.steps_per_cycle}"
        )

    @property
    def dt(self) -> float:
        return self.stroke.period / self.steps_per_cycle


def uvlm_movement(case: Case, params: RobotParams = FIN_ROBOT):
    """The pterasoftware Movement of ``case``: the fin as a right wing in geometry axes (x aft,
    y outward, z up: Drake's body frame turned by pi about z, for the right fin), roll1 and
    pitch as the wing's intrinsic x-y' angles about the root's mid-chord, roll2 as the distal
    cross-sections' x angle about their chord (relative to the proximal plate's, as the joint)."""
    ps = _ps()
    d = fin_dimensions(params)
    c1, c2, g = d["proximal_chord"], d["distal_chord"], STEP_GAP
    n1, n2 = case.spanwise
    af = ps.geometry.airfoil.Airfoil(name="naca0012")  # camber line only: a flat plate
    WCS = ps.geometry.wing_cross_section.WingCrossSection
    sections = [
        WCS(af, n1, chord=c1, Lp_Wcsp_Lpp=(0.0, 0.0, 0.0), spanwise_spacing="uniform"),
        WCS(af, 1, chord=c1, Lp_Wcsp_Lpp=(0.0, d["d3"] - g / 2, 0.0), spanwise_spacing="uniform"),
        WCS(af, n2, chord=c2, Lp_Wcsp_Lpp=((c1 - c2) / 2, g, 0.0), spanwise_spacing="uniform"),
        WCS(af, None, chord=c2, Lp_Wcsp_Lpp=(0.0, d["dE"] - g / 2, 0.0)),
    ]
    wing = ps.geometry.wing.Wing(
        sections, name="fin", num_chordwise_panels=case.nc, chordwise_spacing="uniform"
    )
    airplane = ps.geometry.airplane.Airplane([wing], name="fin")
    T = case.stroke.period
    WCSM = ps.movements.wing_cross_section_movement.WingCrossSectionMovement
    section_moves = [WCSM(s) for s in sections]
    a2, p2 = case.stroke.sine(3)
    if a2 != 0.0:
        section_moves[2] = WCSM(
            sections[2],
            ampAngles_Wcsp_to_Wcs_ixyz=(a2, 0.0, 0.0),
            periodAngles_Wcsp_to_Wcs_ixyz=(T, 0.0, 0.0),
            phaseAngles_Wcsp_to_Wcs_ixyz=(p2, 0.0, 0.0),
        )
    amp, period, phase = [0.0] * 3, [0.0] * 3, [0.0] * 3
    for axis, joint in ((0, 1), (1, 2)):
        a, p = case.stroke.sine(joint)
        if a != 0.0:
            amp[axis], period[axis], phase[axis] = a, T, p
    wing_move = ps.movements.wing_movement.WingMovement(
        wing,
        section_moves,
        ampAngles_Gs_to_Wn_ixyz=amp,
        periodAngles_Gs_to_Wn_ixyz=period,
        phaseAngles_Gs_to_Wn_ixyz=phase,
        rotationPointOffset_Gs_Ler=(c1 / 2, 0.0, 0.0),
    )
    plane_move = ps.movements.airplane_movement.AirplaneMovement(airplane, [wing_move])
    op = ps.operating_point.OperatingPoint(rho=RHO, vCg__E=case.speed, alpha=0.0, nu=NU)
    op_move = ps.movements.operating_point_movement.OperatingPointMovement(op)
    return ps.movements.movement.Movement(
        [plane_move], op_move, delta_time=case.dt, num_steps=case.cycles * case.steps_per_cycle + 1
    )


def uvlm_panel_corners(movement, step: int) -> np.ndarray:
    """(nc, ns, 4, 3) panel corners (front left, front right, back right, back left) of the
    wing at ``step`` in Drake's body frame, relative to the fin root (the check that the
    UVLM moves the model's fin)."""
    wing = movement.airplanes[0][step].wings[0]
    P = wing.panels
    out = np.empty(P.shape + (4, 3))
    for i in range(P.shape[0]):
        for j in range(P.shape[1]):
            pan = P[i, j]
            out[i, j] = [pan.Flpp_G_Cg, pan.Frpp_G_Cg, pan.Brpp_G_Cg, pan.Blpp_G_Cg]
    # geometry axes (x aft, y outward right, z up) -> Drake body (x fwd, y left, z up); root
    # mid-chord at the origin.
    c1 = fin_dimensions()["proximal_chord"]
    out[..., 0] -= c1 / 2
    return out * np.array([-1.0, -1.0, 1.0])


def run_uvlm(case: Case, params: RobotParams = FIN_ROBOT) -> dict:
    """Runs ``case`` and returns its results: per-step forces in the body frame, per-cycle mean
    thrust, the last cycle's means, panels, timings."""
    ps = _ps()
    started = time.time()
    movement = uvlm_movement(case, params)
    built = time.time()
    problem = ps.problems.UnsteadyProblem(movement)
    solver = ps.unsteady_ring_vortex_lattice_method.UnsteadyRingVortexLatticeMethodSolver(problem)
    solver.run(prescribed_wake=True, calculate_streamlines=False, show_progress=False)
    done = time.time()
    n = movement.num_steps
    f_w = np.array([solver._get_steady_problem_at(i).airplanes[0].forces_W for i in range(n)])
    # Wind axes at alpha = beta = 0 are the geometry axes turned by pi about y: +x_W forward
    # (the thrust), y_W along the geometry's +y (the right fin's outward span), z_W down.
    thrust = f_w[:, 0]
    per_cycle = cycle_means(thrust, case.steps_per_cycle)
    last = slice(-case.steps_per_cycle - 1, None)
    mean_w = np.asarray(problem.finalMeanForces_W[0], dtype=float)
    # The last cycle's mean thrust of each plate's panels (and of the step row between them).
    n1 = case.spanwise[0]
    rows = np.zeros((case.steps_per_cycle + 1, 3))
    for k, i in enumerate(range(n - case.steps_per_cycle - 1, n)):
        panels = solver._get_steady_problem_at(i).airplanes[0].wings[0].panels
        fx = -np.array([[pan.forces_GP1[0] for pan in row] for row in panels]).sum(axis=0)
        rows[k] = fx[:n1].sum(), fx[n1], fx[n1 + 1 :].sum()
    plates = dict(
        zip(
            ("proximal", "step", "distal"),
            (float(x) for x in np.trapezoid(rows, axis=0) / case.steps_per_cycle),
        )
    )
    wing = movement.airplanes[0][0].wings[0]
    return {
        "key": case.key,
        "stroke": case.stroke.name,
        "speed": case.speed,
        "nc": case.nc,
        "spanwise": list(case.spanwise),
        "panels": int(wing.num_panels),
        "cycles": case.cycles,
        "steps_per_cycle": case.steps_per_cycle,
        "dt": case.dt,
        "num_steps": int(n),
        "thrust": per_cycle[-1],
        "per_cycle": per_cycle,
        "plates": plates,
        "cycles_to_periodic": cycles_to_periodic(per_cycle),
        "final_mean_forces_W": [float(x) for x in mean_w],
        "side_outward": float(np.trapezoid(f_w[last, 1]) / case.steps_per_cycle),
        "lift": float(-np.trapezoid(f_w[last, 2]) / case.steps_per_cycle),
        "lift_up": True,
        "peak_thrust": float(np.abs(thrust[last]).max()),
        "finite": bool(np.all(np.isfinite(f_w))),
        "seconds_build": round(built - started, 1),
        "seconds_solve": round(done - built, 1),
        "pterasoftware": pterasoftware_version(),
    }


def cached_uvlm(case: Case, out: pathlib.Path, params: RobotParams = FIN_ROBOT, log=print) -> dict:
    """``run_uvlm`` through the cache ``out/cases/<key>.json`` (skipped when present)."""
    path = pathlib.Path(out) / "cases" / f"{case.key}.json"
    if path.is_file():
        return json.loads(path.read_text())
    log(f"running {case.key} ...")
    result = run_uvlm(case, params)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(".tmp")
    tmp.write_text(json.dumps(result, indent=1))
    tmp.replace(path)
    log(
        f"  {case.key}: thrust {result['thrust']:.3f} N, per cycle "
        f"{[round(x, 3) for x in result['per_cycle']]}, {result['seconds_solve']} s"
    )
    return result


# --- the study ----------------------------------------------------------------------------------


def cases(quick: bool = False) -> dict:
    """The UVLM cases of (a) and (b), by part."""
    roll = roll_stroke()
    gait = gait_stroke()
    if quick:
        return {
            "a": [Case(roll, ROLL_SPEED, nc, QUICK_CYCLES) for nc in QUICK_NC],
            "b": [Case(gait, u, nc, QUICK_CYCLES) for nc in QUICK_NC for u in SPEEDS],
        }
    # By nc, then speed: an interrupted run has whole coarse tables first.
    return {
        "a": [Case(roll, ROLL_SPEED, nc, CYCLES[ROLL_SPEED]) for nc in ROLL_NC],
        "b": [Case(gait, u, nc, CYCLES[u]) for nc in GAIT_NC for u in SPEEDS[::-1]],
        "a_checks": [
            Case(roll, ROLL_SPEED, CHECK_NC, CYCLES[ROLL_SPEED], steps_per_cycle=n)
            for n in ROLL_DT_CHECK
        ]
        + [
            Case(roll, ROLL_SPEED, CHECK_NC, CYCLES[ROLL_SPEED], spanwise=ns)
            for ns in SPANWISE_CHECK
        ],
        "b_checks": [
            Case(gait, u, CHECK_NC, CYCLES[u], steps_per_cycle=n)
            for u in GAIT_DT_CHECK_SPEEDS
            for n in DT_CHECK
        ],
        "plates": [
            Case(st, u, CHECK_NC, cyc)
            for st, u, cyc in ((roll, ROLL_SPEED, 3), (gait, 0.4, 3), (gait, 0.1, 4))
        ],
    }


def _converged(rows: list[dict]) -> dict:
    """The finest nc's thrust, the change from the next coarser, and a Richardson estimate
    from the three finest when their changes shrink (monotone, ratio < 1)."""
    t = [r["thrust"] for r in rows]
    out = {"nc": rows[-1]["nc"], "thrust": t[-1], "change_last": None, "richardson": None}
    if len(t) >= 2:
        out["change_last"] = (t[-1] - t[-2]) / abs(t[-1])
    if len(t) >= 3:
        d1, d2 = t[-2] - t[-3], t[-1] - t[-2]
        if d1 != 0 and 0 < d2 / d1 < 1:
            r = d2 / d1
            out["richardson"] = t[-1] + d2 * r / (1 - r)
    return out


def _checks(main: list[dict], checks: list[dict]) -> list[dict]:
    """The other resolutions at CHECK_NC, with their change from the main run at CHECK_NC."""
    base = next((r for r in main if r["nc"] == CHECK_NC), None)
    return [
        {
            "nc": r["nc"],
            "steps_per_cycle": r["steps_per_cycle"],
            "dt": r["dt"],
            "spanwise": r["spanwise"],
            "panels": r["panels"],
            "thrust": r["thrust"],
            "cycles_to_periodic": r["cycles_to_periodic"],
            "seconds_solve": r["seconds_solve"],
            "change": None
            if base is None
            else (r["thrust"] - base["thrust"]) / abs(base["thrust"]),
        }
        for r in checks
    ]


def strip_table(stroke: Stroke, speed: float, params: RobotParams = FIN_ROBOT) -> dict:
    """The strip model's thrust for both lift slopes, attached and with stall."""
    out = {}
    for name, a in lift_slopes(params).items():
        for stall in (False, True):
            out[f"{name}_{'stall' if stall else 'attached'}"] = strip_thrust(
                stroke, speed, a, stall, params
            )
    return out


def summarize(
    out: pathlib.Path,
    quick: bool = False,
    run: bool = True,
    params: RobotParams = FIN_ROBOT,
    log=print,
    command: str = COMMAND,
) -> dict:
    """Runs (or reads from the cache) every case and returns the summary."""
    started = time.time()
    parts = cases(quick)
    roll, gait = roll_stroke(), gait_stroke()
    uv = _case_results(parts, out, run, params, log)
    a = _pure_roll_summary(uv, parts["a"][0].cycles, roll, params)
    b = _gait_summary(uv, gait, params)
    plates = _plates_summary(uv, roll, gait, params)
    slopes = lift_slopes(params)
    summary = {
        "provenance": _provenance(uv, quick, command, roll, started),
        "fin": {
            **fin_dimensions(params),
            "lift_slope_2d": slopes["2d"],
            "lift_slope_helmbold": slopes["helmbold"],
            "stall": {k: float(v) for k, v in STALL.items()},
        },
        "strokes": {
            s.name: {
                "amp_deg": list(s.amp_deg),
                "phase_deg": list(s.phase_deg),
                "frequency_hz": s.frequency_hz,
                "sines_deg": [list(s.sine(j)) for j in (1, 2, 3)],
            }
            for s in (roll, gait)
        },
        "a_pure_roll": a,
        "b_gait": b,
        "plates": plates,
    }
    return round_floats(summary, 5)


def _case_results(parts: dict, out, run: bool, params: RobotParams, log) -> dict:
    """Each part's UVLM results, run or cached (``run`` False: only the cases already in
    the cache, an interrupted run's), each with its periodicity by this module's rule."""

    def cached(c):
        path = pathlib.Path(out) / "cases" / f"{c.key}.json"
        return json.loads(path.read_text()) if path.is_file() else None

    uv = {
        k: [
            r
            for r in (cached_uvlm(c, out, params, log) if run else cached(c) for c in v)
            if r is not None
        ]
        for k, v in parts.items()
    }
    if not uv["a"]:
        raise ValidationError(f"{out}: no pure-roll case in the cache")
    for rows in uv.values():  # periodicity by this module's rule, whatever the cache holds
        for r in rows:
            r["cycles_to_periodic"] = cycles_to_periodic(r["per_cycle"])
    return uv


# What the summary keeps of each UVLM result.
_SLIM_KEYS = (
    "nc",
    "panels",
    "thrust",
    "per_cycle",
    "cycles_to_periodic",
    "side_outward",
    "lift",
    "peak_thrust",
    "seconds_solve",
    "num_steps",
    "finite",
)


def _slim(r: dict) -> dict:
    return {k: r[k] for k in _SLIM_KEYS}


def _strip_entry(v: dict, reference: float) -> dict:
    """A strip model's result against the converged UVLM thrust ``reference``."""
    return {
        "thrust": v["thrust"],
        "ratio": v["thrust"] / reference,
        "cycles_to_periodic": v["cycles_to_periodic"],
        "side_outward": v["side_outward"],
        "peak_thrust": v["peak_thrust"],
    }


def _pure_roll_summary(uv: dict, cycles: int, roll: Stroke, params: RobotParams) -> dict:
    """Part (a): the pure roll's UVLM convergence against the strip model and Garrick."""
    dims = fin_dimensions(params)
    a_rows = [_slim(r) for r in uv["a"]]
    a_conv = _converged(a_rows)
    reference = a_conv["thrust"]
    a = {
        "speed": ROLL_SPEED,
        "strouhal": strouhal(roll, ROLL_SPEED, params),
        "reduced_frequency_root": math.pi * roll.frequency_hz * dims["proximal_chord"] / ROLL_SPEED,
        "tip_heave_speed": 2.0
        * math.pi
        * roll.frequency_hz
        * dims["span"]
        * math.radians(ROLL_ONLY_DEG),
        "stalled_area_fraction": stalled_area_fraction(roll, ROLL_SPEED, params),
        "cycles": cycles,
        "uvlm": a_rows,
        "converged": a_conv,
        "garrick_2d": garrick_strip_thrust(roll, ROLL_SPEED, params),
        "strip": {
            k: {
                **_strip_entry(v, reference),
                "within_acceptance": bool(abs(v["thrust"] / reference - 1) <= ACCEPT),
            }
            for k, v in strip_table(roll, ROLL_SPEED, params).items()
        },
    }
    a["garrick_ratio"] = a["garrick_2d"] / reference
    a["checks"] = _checks(uv["a"], uv.get("a_checks", []))
    return a


def _gait_summary(uv: dict, gait: Stroke, params: RobotParams) -> dict:
    """Part (b): the gait's stroke at each speed with UVLM results, by ``f"{speed:.1f}"``."""
    b = {}
    for u in SPEEDS:
        rows = sorted((_slim(r) for r in uv["b"] if r["speed"] == u), key=lambda r: r["nc"])
        if not rows:
            continue
        conv = _converged(rows)
        b[f"{u:.1f}"] = {
            "speed": u,
            "strouhal": strouhal(gait, u, params),
            "stalled_area_fraction": stalled_area_fraction(gait, u, params),
            "cycles": rows[0]["num_steps"] // STEPS_PER_CYCLE,
            "uvlm": rows,
            "converged": conv,
            "strip": {
                k: _strip_entry(v, conv["thrust"]) for k, v in strip_table(gait, u, params).items()
            },
            "checks": _checks(
                [r for r in uv["b"] if r["speed"] == u],
                [r for r in uv.get("b_checks", []) if r["speed"] == u],
            ),
        }
    return b


def _plates_summary(uv: dict, roll: Stroke, gait: Stroke, params: RobotParams) -> list:
    """Each plate's UVLM thrust against the strip model's, per ``plates`` case."""
    plates = []
    for r in uv.get("plates", []):
        stroke = roll if r["stroke"] == roll.name else gait
        strip = {
            k: strip_thrust(stroke, r["speed"], a, False, params)["plates"]
            for k, a in lift_slopes(params).items()
        }
        plates.append(
            {
                "stroke": r["stroke"],
                "speed": r["speed"],
                "nc": r["nc"],
                "cycles": r["cycles"],
                "uvlm": r["plates"],
                "uvlm_thrust": r["thrust"],
                "strip_2d": strip["2d"],
                "strip_helmbold": strip["helmbold"],
            }
        )
    return plates


def _provenance(uv: dict, quick: bool, command: str, roll: Stroke, started: float) -> dict:
    """How the summary was made: the command, the versions, the date, the settings."""
    from manta_drake.studies.stamp import commit

    return {
        "generator": "manta_drake.studies.validation.vortex_lattice",
        "command": command + (" --quick" if quick else ""),
        "pterasoftware": pterasoftware_version(),
        "date": datetime.date.today().isoformat(),
        "commit": commit(),
        "quick": quick,
        "seconds_total_uvlm": round(
            sum(r["seconds_solve"] + r.get("seconds_build", 0) for v in uv.values() for r in v),
            1,
        ),
        "seconds_this_run": round(time.time() - started, 1),
        "solver": "UnsteadyRingVortexLatticeMethodSolver.run(prescribed_wake=True)",
        "rho": RHO,
        "nu": NU,
        "leg": LEG,
        "fin_sweep_deg": 0.0,
        "steps_per_cycle": STEPS_PER_CYCLE,
        "dt": roll.period / STEPS_PER_CYCLE,
        "spanwise_panels": list(SPANWISE_PANELS),
        "step_gap": STEP_GAP,
        "chordwise_spacing": "uniform",
        "strips_per_plate": STRIPS_PER_PLATE,
        "strip_steps_per_cycle": STRIP_STEPS_PER_CYCLE,
        "strip_cycles": STRIP_CYCLES,
        "acceptance": ACCEPT,
        "periodic_tol": PERIODIC_TOL,
    }


# --- files --------------------------------------------------------------------------------------

HEADER = (
    "# Mean thrust of one fin of the model by pterasoftware (unsteady ring-vortex lattice, "
    "prescribed\n# wake) against the fin strips' model (station/foil.py) and Garrick. "
    "Generated by\n# `{command}` (manta_drake/studies/validation/vortex_lattice.py);\n"
    '# docs/validation.md\'s "Vortex lattice" section is rendered from it. Do not edit.\n'
)


def write_yaml(path, summary: dict) -> pathlib.Path:
    import yaml

    path = pathlib.Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(
        HEADER.format(command=summary["provenance"]["command"])
        + yaml.safe_dump(summary, sort_keys=False, default_flow_style=None, width=100)
    )
    return path


def load_summary(path=YAML_PATH) -> dict:
    from manta_drake.config_io import load_yaml_mapping

    data, _ = load_yaml_mapping(path, "vortex-lattice results", ValidationError)
    return data


STRIP_LABELS = {
    "2d_attached": "2 pi, attached",
    "2d_stall": "2 pi, with stall",
    "helmbold_attached": "Helmbold, attached",
    "helmbold_stall": "Helmbold, with stall",
}


def render_section(summary: dict) -> str:
    from manta_drake.studies.validation import section_markers

    begin, end = section_markers(SECTION)
    command = COMMAND + (" --quick" if summary["provenance"]["quick"] else "")
    body = render_template(
        TEMPLATE, s=summary, p=summary["provenance"], labels=STRIP_LABELS, command=command
    )
    return f"{begin}\n{body.strip()}\n{end}"


def write_page(path, summary: dict) -> None:
    from manta_drake.studies.stamp import replace_marked_block
    from manta_drake.studies.validation import section_markers

    begin, end = section_markers(SECTION)
    replace_marked_block(
        pathlib.Path(path),
        render_section(summary),
        begin,
        end,
        new_page=(PAGE_TITLE, PAGE_COMMAND),
        what="the vortex-lattice section",
    )


# --- the command --------------------------------------------------------------------------------


def parse_args(argv, prog):
    parser = StudyParser(prog=prog, description=__doc__.splitlines()[0])
    add_folder_options(
        parser,
        SECTION,
        "the case cache DIR/cases/*.json (a case there is not run again), the summary "
        "DIR/vortex_lattice.yaml and DIR/vortex_lattice.md",
    )
    parser.add_argument(
        "--quick",
        action="store_true",
        help="nc 4 and 2 cycles only (a smoke run of a few minutes); writes "
        "neither the committed summary nor the page unless named",
    )
    parser.add_argument(
        "--no-run",
        action="store_true",
        help="run no UVLM case: summarize the cases already in DIR/cases",
    )
    parser.add_argument(
        "--reference",
        default=None,
        metavar="FILE",
        help="the committed summary (default models/reference/"
        "vortex_lattice.yaml of the checkout); '' writes none",
    )
    parser.add_argument(
        "--from-yaml",
        action="store_true",
        help="run nothing: render the page from --reference as committed",
    )
    args = parser.parse_args(argv)
    if args.reference is None and args.quick and not args.from_yaml:
        args.reference = ""
    args.reference = reference_file(args.reference, prog, "--reference FILE", YAML_PATH.name)
    args.page = None if args.quick and args.out is None else page_path(args.out, prog)
    check_runs(args.runs)
    if args.from_yaml and not pathlib.Path(args.reference or YAML_PATH).is_file():
        raise ValidationError(
            f"--from-yaml: no summary {args.reference or YAML_PATH}; run without --from-yaml first"
        )
    return args


def main(argv=None, prog=None) -> int:
    prog = prog or "python -m manta_drake.studies.validation.vortex_lattice"
    argv = sys.argv[1:] if argv is None else list(argv)
    args = parse_args(argv, prog)
    runs = pathlib.Path(args.runs)
    runs.mkdir(parents=True, exist_ok=True)
    if args.from_yaml:
        summary = load_summary(args.reference or YAML_PATH)
    else:
        summary = summarize(
            runs, quick=args.quick, run=not args.no_run, log=lambda m: print(m, flush=True)
        )
        write_yaml(runs / "vortex_lattice.yaml", summary)
        if args.reference:
            write_yaml(args.reference, summary)
            print(f"wrote {args.reference}")
    (runs / "vortex_lattice.md").write_text(render_section(summary) + "\n")
    if args.page is not None:
        write_page(args.page, summary)
        print(f"wrote the {SECTION} block of {args.page}")
    print(
        f"wrote {'' if args.from_yaml else str(runs / 'vortex_lattice.yaml') + ' and '}"
        f"{runs / 'vortex_lattice.md'}"
    )
    return 0


if __name__ == "__main__":
    run_module(main)
