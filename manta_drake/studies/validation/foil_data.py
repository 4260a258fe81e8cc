"""The fin strips' flapping-foil model against a published heaving-pitching foil experiment:
``manta-drake study validation --section foil-data [--runs DIR] [--out DIR]``.

**The data** (``models/reference/heaving_pitching_foil.yaml``, its ``data`` block, curated by hand
with its exact source): thrust coefficient C_T and efficiency eta against the Strouhal number of
a NACA0012 foil heaving h = h0 sin(wt) and pitching theta = theta0 sin(wt + psi) about the
third-chord point in a water tunnel, h0/c = 0.75, psi = 90 deg, the pitch amplitude set at each
Strouhal number for a maximum angle of attack of 15 deg (the MIT experiments: Read, Hover &
Triantafyllou 2003, J. Fluids Struct. 17:163-183; Schouveiler, Hover & Triantafyllou 2005,
J. Fluids Struct. 20:949-959), as digitized from Pan, Dong, Zhu & Yue 2012 (J. Fluid Mech.
698:446-467, their figure 9) by the authors of the public Julia code ``wagenhoffer/Puffer``
(``test/pan_comparisons.jl``). The YAML records why no other data set was used (only figures, or
unverifiable quotations, were reachable).

**The model**: one strip of ``station/foil.py`` (DeLaurier's modified strip theory: the
circulatory normal force from the three-quarter-chord downwash with lift slope a, the
leading-edge suction with efficiency eta_s, Wagner's lag in Jones's form, the separated
cross-flow force past the stall blend, skin friction), unit span and the experiment's chord,
driven by the same kinematics through ``foil.prescribed_motion_forces`` (the mid-chord velocity
relative to the water, the angular velocity theta_dot and the plate's axes at each step). The
foil swims at U along -x through still water (the tunnel's stream +U x); theta > 0 lifts the
leading edge; the kinematic angle of attack at the pivot alpha(t) = atan(h_dot / U) - theta(t)
is the experiments' (Puffer's script: alpha_max = max_t |alpha^h + theta|, alpha^h =
-atan(h_dot / U)), and theta0 is solved from alpha_max on the feathering branch. The mean thrust
(-F_x) of the last whole cycle gives C_T = T / (1/2 rho U^2 c s); the power is the one the
heave-pitch drive delivers, P = -F . v_tunnel of the mid-chord point where the model applies its
force, C_P = P / (1/2 rho U^3 c s), eta = C_T / C_P. Enough cycles run for the Wagner lag's slow
pole (b = 0.0455 per half-chord travelled) to die out: at least ``MIN_TRAVEL`` half-chords.

The added-mass force of a plate (``foil.kirchhoff_plate_force``, -d/dt of its impulse) has no
mean over a periodic motion, nor does its power: the strip model's mean thrust and power are
its circulatory, suction, separated and friction terms alone, as in the simulator.

Cases: the model's lift-slope law at the experiment's own foil (``experiment``: Helmbold's
slope at the data foil's aspect ratio, span / chord = 6, a = 4.53; the acceptance case, since the
model applies Helmbold at each plate's aspect ratio), the shipped ``fins:`` parameters of
``models/hydrodynamics.yaml`` as they are (lift slope 3.1, Helmbold at the robot's fin, aspect
ratio 2.6: what the robot's plates have, not the experiment's foil) and the 2-D lift slope 2 pi
(the infinite-span end), each with the share of every term in the mean thrust (the forces are
linear in eta_s, C_dcf and C_f with the kinematics and the lag fixed, so each share is exact),
and the sensitivity to each parameter over its band as stated in hydrodynamics.yaml (the shipped
values are never tuned to the data); Garrick's small-amplitude plunge as the sanity rows.
Acceptance: the ``experiment`` case's C_T within +-30 % of the data.
"""

from __future__ import annotations

import datetime
import math
import pathlib
import sys
import time

import numpy as np

from manta_drake.station import foil
from manta_drake.studies import REPO
from manta_drake.studies.options import StudyParser
from manta_drake.studies.validation import (
    ValidationError,
    add_folder_options,
    check_runs,
    page_path,
    reference_file,
    render_template,
    round_floats,
    run_module,
    write_results,
)
from manta_drake.studies.validation.vortex_lattice import cycle_means

SECTION = "foil-data"
COMMAND = "manta-drake study validation --section foil-data"
YAML_PATH = REPO / "models" / "reference" / "heaving_pitching_foil.yaml"
TEMPLATE = "foil_data.md.j2"

RHO = 1000.0  # kg/m^3 (C_T, C_P and eta of the model do not depend on it)
SPEED = 0.4  # m/s: Re = U c / nu = 4e4 at the 0.1 m chord (the model is Re-free: C_f is fixed)
STEPS_PER_CYCLE = 200
MIN_TRAVEL = 150.0  # half-chords travelled before the last cycle: Wagner's slow pole e^-6.8
MIN_CYCLES = 6
ACCEPT = 0.30  # |model C_T / data C_T - 1| <= 30 %
GARRICK_TOL = 0.05
# Garrick's sanity rows: small-amplitude pure plunge, attached flow, a = 2 pi, eta_s = 1, no
# friction, at reduced frequencies k = omega c / (2 U) spanning the data's (0.4-0.9).
GARRICK_H0C = 0.05
GARRICK_K = (0.3, math.pi / 4.0, math.pi / 2.0)

# The bands of models/hydrodynamics.yaml's ``fins:`` sources (lift_slope "band 3.1-4.3",
# suction_efficiency "band 0.5-1.0", stall_angle_deg "band 10-25 deg", stall_width_deg "band
# 1-5 deg", separation_lag "band 2-4"); each end is one sensitivity case, the others held.
BANDS = {
    "lift_slope": (3.1, 4.3),
    "suction_efficiency": (0.5, 1.0),
    "stall_angle_deg": (10.0, 25.0),
    "stall_width_deg": (1.0, 5.0),
    "separation_lag": (2.0, 4.0),
}
# Diagnostic cases (not bands): which term or switch makes the difference.
DIAGNOSTICS = {
    "attached (no stall)": {"stall_angle_deg": 180.0},
    "no separation lag (geometric switch)": {"separation_lag": 0.0},
    "no friction": {"friction_coefficient": 0.0},
}
BASES = ("experiment", "shipped", "2d")
ACCEPTED_BASE = "experiment"
BASE_LABELS = {
    "experiment": "Helmbold at the experiment's aspect ratio",
    "shipped": "shipped (Helmbold at the robot's fin)",
    "2d": "2-D lift slope a = 2 pi",
}
# The experiment's band of effective aspect ratio: its geometric span / chord (both ends free)
# to twice that (one end on a reflection plane: a wall or end plate, which the reachable texts
# do not settle).
REFLECTED_ASPECT_FACTOR = 2.0
TERMS = ("circulatory", "suction", "separated", "friction")


# --- parameters ---------------------------------------------------------------------------------


def shipped_parameters(path=None) -> dict:
    """The fins' strip-model parameters as ``models/hydrodynamics.yaml`` ships them (degrees
    for the angles), the ones ``station.hydro`` hands the foil model."""
    from manta_drake.model.coefficients import DEFAULT_COEFFICIENTS_FILE, load_coefficients

    fins = load_coefficients(DEFAULT_COEFFICIENTS_FILE if path is None else path).fins
    return {
        "lift_slope": float(fins.lift_slope.value),
        "suction_efficiency": float(fins.suction_efficiency.value),
        "cross_flow_coefficient": float(fins.normal_force_coefficient.value),
        "friction_coefficient": float(fins.skin_friction_coefficient.value),
        "stall_angle_deg": float(fins.stall_angle_deg.value),
        "stall_width_deg": float(fins.stall_width_deg.value),
        "separation_lag": float(fins.separation_lag.value),
    }


def experiment_aspect_ratio(data: dict) -> float:
    """The data foil's geometric aspect ratio span / chord."""
    cond = data["conditions"]
    return float(cond["span_m"]) / float(cond["chord_m"])


def base_parameters(
    base: str, shipped: dict | None = None, aspect_ratio: float | None = None
) -> dict:
    """``shipped`` as is; ``experiment``: the same with Helmbold's lift slope at
    ``aspect_ratio`` (the data foil's); ``2d``: with the 2-D lift slope 2 pi."""
    p = dict(shipped_parameters() if shipped is None else shipped)
    if base == "2d":
        p["lift_slope"] = 2.0 * math.pi
    elif base == "experiment":
        if aspect_ratio is None or not aspect_ratio > 0.0:
            raise ValueError(
                f"base_parameters: 'experiment' needs the foil's aspect ratio > 0, "
                f"got {aspect_ratio!r}"
            )
        p["lift_slope"] = float(foil.helmbold_lift_slope(aspect_ratio))
    elif base != "shipped":
        raise ValueError(f"base_parameters: {base!r} is not one of {', '.join(BASES)}")
    return p


def foil_params(p: dict) -> dict:
    """The ``params`` dict of ``foil.prescribed_motion_forces`` (radians, rho)."""
    return {
        "rho": RHO,
        "lift_slope": p["lift_slope"],
        "suction_efficiency": p["suction_efficiency"],
        "cross_flow_coefficient": p["cross_flow_coefficient"],
        "friction_coefficient": p["friction_coefficient"],
        "stall_angle": math.radians(p["stall_angle_deg"]),
        "stall_width": math.radians(p["stall_width_deg"]),
        "separation_lag": p.get("separation_lag", 0.0),
    }


# --- kinematics ---------------------------------------------------------------------------------


def _phases(n: int = 7200) -> np.ndarray:
    return np.linspace(0.0, 2.0 * math.pi, n, endpoint=False)


def alpha_max_of(strouhal: float, theta0: float, psi: float) -> float:
    """max_t |atan(h_dot / U) - theta(t)| [rad]; h_dot / U = pi St cos(wt), St = 2 f h0 / U."""
    ph = _phases()
    return float(
        np.max(np.abs(np.arctan(math.pi * strouhal * np.cos(ph)) - theta0 * np.sin(ph + psi)))
    )


def pitch_amplitude(strouhal: float, alpha_max: float, psi: float = math.pi / 2) -> float:
    """theta0 [rad] whose kinematic angle of attack peaks at alpha_max [rad]: the smallest root
    (the feathering branch, theta0 <= atan(pi St)); 0 if pure heave stays below alpha_max."""
    from scipy.optimize import brentq

    heave = math.atan(math.pi * strouhal)
    if heave <= alpha_max:
        return 0.0
    g = lambda th: alpha_max_of(strouhal, th, psi) - alpha_max  # noqa: E731
    return float(brentq(g, 0.0, heave, xtol=1e-13, rtol=1e-13))


def motion(
    strouhal: float,
    h0_over_c: float,
    theta0: float,
    psi: float,
    pivot: float,
    chord: float,
    speed: float,
    t,
) -> dict:
    """The strip's prescribed motion at the times t, as ``foil.prescribed_motion_forces``
    takes it ((nt, 1, 3) arrays), and the tunnel-frame velocity of the mid-chord point."""
    t = np.asarray(t, dtype=float)
    h0 = h0_over_c * chord
    w = math.pi * strouhal * speed / h0  # 2 pi f, f = St U / (2 h0)
    z = np.zeros_like(t)
    h_dot = h0 * w * np.cos(w * t)
    th = theta0 * np.sin(w * t + psi)
    th_dot = theta0 * w * np.cos(w * t + psi)
    chord_dir = np.stack([-np.cos(th), z, np.sin(th)], axis=1)  # to the leading edge
    normal = np.stack([np.sin(th), z, np.cos(th)], axis=1)
    span = np.tile([0.0, 1.0, 0.0], (len(t), 1))
    omega = np.stack([z, th_dot, z], axis=1)
    v_pivot = np.stack([np.full_like(t, -speed), z, h_dot], axis=1)  # relative to the water
    r_mid = -(0.5 - pivot) * chord * chord_dir  # pivot -> mid-chord (aft of a 1/3 pivot)
    v_mid = v_pivot + np.cross(omega, r_mid)
    v_tunnel = v_mid + np.array([speed, 0.0, 0.0])
    col = lambda x: x[:, None, :]  # noqa: E731
    return {
        "v_mid": col(v_mid),
        "omega": col(omega),
        "normal": col(normal),
        "chord_dir": col(chord_dir),
        "span_dir": col(span),
        "v_tunnel": v_tunnel,
        "frequency": w / (2.0 * math.pi),
    }


def cycles_needed(strouhal: float, h0_over_c: float) -> int:
    """Whole cycles for MIN_TRAVEL half-chords before the last one: 2 U T / c = 4 (h0/c) / St
    half-chords a cycle."""
    per_cycle = 4.0 * h0_over_c / strouhal
    return max(MIN_CYCLES, int(math.ceil(MIN_TRAVEL / per_cycle)) + 1)


# --- the model on one case ----------------------------------------------------------------------


def run_case(
    strouhal: float,
    h0_over_c: float,
    alpha_max_deg: float | None,
    p: dict,
    psi_deg: float = 90.0,
    pivot: float = 1.0 / 3.0,
    chord: float = 0.1,
    speed: float = SPEED,
    theta0: float | None = None,
    steps_per_cycle: int = STEPS_PER_CYCLE,
    cycles: int | None = None,
    terms: bool = False,
) -> dict:
    """The strip model's C_T, C_P and eta of one case (last whole cycle), its per-cycle C_T,
    theta0, the peak angle of attack of the model's own three-quarter-chord flow and the
    cycle-mean attached share; with ``terms`` the share of each term in C_T."""
    psi = math.radians(psi_deg)
    if theta0 is None:
        theta0 = pitch_amplitude(strouhal, math.radians(alpha_max_deg), psi)
    cycles = cycles_needed(strouhal, h0_over_c) if cycles is None else cycles
    h0 = h0_over_c * chord
    f = strouhal * speed / (2.0 * h0)
    dt = 1.0 / (f * steps_per_cycle)
    t = np.arange(cycles * steps_per_cycle + 1) * dt
    m = motion(strouhal, h0_over_c, theta0, psi, pivot, chord, speed, t)
    q = 0.5 * RHO * speed * speed * chord  # per unit span
    F = _strip_forces(m, dt, chord, p)
    out = {
        "strouhal": strouhal,
        "h0_over_c": h0_over_c,
        "alpha_max_deg": alpha_max_deg,
        "psi_deg": psi_deg,
        "pivot": pivot,
        "theta0_deg": math.degrees(theta0),
        "frequency_hz": f,
        "reduced_frequency": math.pi * f * chord / speed,
        "cycles": cycles,
        "steps_per_cycle": steps_per_cycle,
        **_thrust_and_power(F, m["v_tunnel"], q, speed, steps_per_cycle),
        **_last_cycle_flow(m, cycles, steps_per_cycle, chord, p),
    }
    if terms:
        out["terms"] = _thrust_terms(m, dt, chord, p, F, out["ct"], q, steps_per_cycle)
    return out


def _strip_forces(m: dict, dt: float, chord: float, p: dict) -> np.ndarray:
    """The strip's force (n, 3) along the motion ``m`` (``motion``) with parameters ``p``."""
    return foil.prescribed_motion_forces(
        dt,
        m["v_mid"],
        m["omega"],
        m["normal"],
        m["chord_dir"],
        m["span_dir"],
        np.array([chord]),
        np.array([chord]),
        foil_params(p),
    )[:, 0, :]


def _thrust_and_power(F, v_tunnel, q: float, speed: float, steps_per_cycle: int) -> dict:
    """C_T, C_P and eta of the last whole cycle, and C_T's change over that cycle, from the
    force ``F`` and the mid-chord point's velocity in the tunnel ``v_tunnel``."""
    thrust = -F[:, 0]
    power = -(F * v_tunnel).sum(axis=1)
    ct = [x / q for x in cycle_means(thrust, steps_per_cycle)]
    cp = cycle_means(power, steps_per_cycle)[-1] / (q * speed)
    return {
        "ct": ct[-1],
        "cp": cp,
        "eta": ct[-1] / cp if cp else None,
        "ct_change_last_cycle": ct[-1] - ct[-2],
    }


def _last_cycle_flow(m: dict, cycles: int, steps_per_cycle: int, chord: float, p: dict) -> dict:
    """The last cycle's peak angle of attack of the three-quarter-chord flow and its
    cycle-mean attached share."""
    last = slice((cycles - 1) * steps_per_cycle, cycles * steps_per_cycle + 1)
    kin = foil.strip_kinematics(
        m["v_mid"][last, 0],
        m["omega"][last, 0],
        m["normal"][last, 0],
        m["chord_dir"][last, 0],
        m["span_dir"][last, 0],
        np.full(len(m["v_mid"][last]), chord),
    )
    attached = foil.attached_fraction(
        kin["alpha"], math.radians(p["stall_angle_deg"]), math.radians(p["stall_width_deg"])
    )
    return {
        "alpha34_max_deg": math.degrees(float(np.max(kin["alpha"]))),
        "attached_mean": float(np.trapezoid(attached) / steps_per_cycle),
    }


def _thrust_terms(
    m: dict, dt: float, chord: float, p: dict, F, ct: float, q: float, steps_per_cycle: int
) -> dict:
    """Each term's share in the last cycle's C_T ``ct`` (TERMS order): the suction,
    separated and friction terms by setting their coefficient to 0, the circulatory the
    rest."""
    # Each term is linear in its coefficient with the kinematics and lag fixed.
    thrust = -F[:, 0]
    share = {}
    for name, key in (
        ("suction", "suction_efficiency"),
        ("separated", "cross_flow_coefficient"),
        ("friction", "friction_coefficient"),
    ):
        without = -_strip_forces(m, dt, chord, {**p, key: 0.0})[:, 0]
        share[name] = cycle_means(thrust - without, steps_per_cycle)[-1] / q
    share["circulatory"] = ct - sum(share.values())
    return {k: share[k] for k in TERMS}


def garrick_rows(ks=GARRICK_K) -> list[dict]:
    """Small-amplitude pure plunge against Garrick (1936) at the reduced frequencies ``ks``: the
    strip model (a = 2 pi, eta_s = 1, attached, no friction), Garrick with Theodorsen's C(k)
    and with Jones's C(k) (the one the model's lag reproduces)."""
    p = {
        "lift_slope": 2.0 * math.pi,
        "suction_efficiency": 1.0,
        "cross_flow_coefficient": 1.17,
        "friction_coefficient": 0.0,
        "stall_angle_deg": 180.0,
        "stall_width_deg": 0.1,
    }
    rows = []
    chord, speed = 0.1, SPEED
    for k in ks:
        st = 4.0 * GARRICK_H0C * k / (2.0 * math.pi)  # k = pi f c / U, St = 2 f h0 / U
        r = run_case(st, GARRICK_H0C, None, p, theta0=0.0, chord=chord, speed=speed)
        w = 2.0 * math.pi * r["frequency_hz"]
        q = 0.5 * RHO * speed * speed * chord
        theo = foil.garrick_plunge_thrust(RHO, chord / 2, w, GARRICK_H0C * chord, speed) / q
        jones = theo * abs(foil.jones_theodorsen(k)) ** 2 / abs(foil.theodorsen(k)) ** 2
        rows.append(
            {
                "reduced_frequency": k,
                "strouhal": st,
                "h0_over_c": GARRICK_H0C,
                "ct_model": r["ct"],
                "ct_garrick": float(theo),
                "ct_garrick_jones": float(jones),
                "ratio": r["ct"] / float(theo),
                "ratio_jones": r["ct"] / float(jones),
                "within_tol": abs(r["ct"] / float(theo) - 1.0) <= GARRICK_TOL,
            }
        )
    return rows


# --- the comparison -----------------------------------------------------------------------------


def data_points(data: dict) -> list[dict]:
    """The data's points: St, C_T and (at the nearest digitized St, if within 0.01) eta."""
    cond = data["conditions"]
    st_t, ct = data["thrust_coefficient"]["strouhal"], data["thrust_coefficient"]["value"]
    eff = data.get("efficiency")
    pts = []
    for s, c in zip(st_t, ct):
        e = None
        if eff:
            j = int(np.argmin(np.abs(np.asarray(eff["strouhal"]) - s)))
            if abs(eff["strouhal"][j] - s) <= 0.01:
                e = eff["value"][j]
        pts.append(
            {
                "strouhal": float(s),
                "ct": float(c),
                "eta": e,
                "h0_over_c": float(cond["h0_over_c"]),
                "alpha_max_deg": float(cond["alpha_max_deg"]),
                "psi_deg": float(cond["psi_deg"]),
                "pivot": float(cond["pivot_from_leading_edge"]),
                "chord": float(cond["chord_m"]),
            }
        )
    return pts


def model_point(pt: dict, p: dict, terms: bool = False) -> dict:
    return run_case(
        pt["strouhal"],
        pt["h0_over_c"],
        pt["alpha_max_deg"],
        p,
        psi_deg=pt["psi_deg"],
        pivot=pt["pivot"],
        chord=pt["chord"],
        terms=terms,
    )


def sensitivity_cases(base: dict, name: str = "shipped", aspect_ratio: float | None = None) -> dict:
    """name -> parameters: each band end of BANDS (the rest of ``base`` held; not the lift
    slope's for the ``2d`` and ``experiment`` bases, which replace it: the latter gets the end
    of its aspect-ratio band instead) and the diagnostics."""
    cases = {}
    for key, (lo, hi) in BANDS.items():
        if key == "lift_slope" and name != "shipped":
            continue
        for v in (lo, hi):
            if not math.isclose(v, base[key]):
                cases[f"{key} = {v:g}"] = {**base, key: v}
    if name == "experiment":
        ar = REFLECTED_ASPECT_FACTOR * aspect_ratio
        a = float(foil.helmbold_lift_slope(ar))
        cases[f"lift_slope = {a:.3g} (aspect ratio {ar:g}: one end reflected)"] = {
            **base,
            "lift_slope": a,
        }
    for label, over in DIAGNOSTICS.items():
        cases[label] = {**base, **over}
    return cases


def compare(data: dict, shipped: dict | None = None, log=print) -> dict:
    """The model on every data point for every base (with the terms), the sensitivity, and
    Garrick's rows: the ``model`` block of the reference file."""
    shipped = shipped_parameters() if shipped is None else shipped
    pts = data_points(data)
    ar = experiment_aspect_ratio(data)
    out = {"aspect_ratio": ar, "accepted_base": ACCEPTED_BASE, "bases": {}, "garrick": None}
    for base in BASES:
        p = base_parameters(base, shipped, ar)
        rows = []
        for pt in pts:
            r = model_point(pt, p, terms=True)
            r["ct_data"], r["eta_data"] = pt["ct"], pt["eta"]
            r["ratio"] = r["ct"] / pt["ct"]
            r["within_acceptance"] = abs(r["ratio"] - 1.0) <= ACCEPT
            r["eta_ratio"] = r["eta"] / pt["eta"] if (pt["eta"] and r["eta"]) else None
            rows.append(r)
            log(
                f"{base}: St {pt['strouhal']:.3f} C_T {r['ct']:.4f} (data {pt['ct']:.3f}, "
                f"ratio {r['ratio']:.2f}), eta {r['eta']:.3f}"
            )
        sens = {}
        for name, pp in sensitivity_cases(p, base, ar).items():
            vals = [model_point(pt, pp)["ct"] for pt in pts]
            sens[name] = {
                "parameters": pp,
                "ct": vals,
                "ratio": [v / pt["ct"] for v, pt in zip(vals, pts)],
            }
            log(f"{base}: {name}: ratios " + ", ".join(f"{x:.2f}" for x in sens[name]["ratio"]))
        # The time step: the highest St again at twice the steps a cycle.
        fine = run_case(
            pts[-1]["strouhal"],
            pts[-1]["h0_over_c"],
            pts[-1]["alpha_max_deg"],
            p,
            psi_deg=pts[-1]["psi_deg"],
            pivot=pts[-1]["pivot"],
            chord=pts[-1]["chord"],
            steps_per_cycle=2 * STEPS_PER_CYCLE,
        )
        step = {
            "strouhal": pts[-1]["strouhal"],
            "steps_per_cycle": 2 * STEPS_PER_CYCLE,
            "ct": fine["ct"],
            "eta": fine["eta"],
            "ct_change": fine["ct"] / rows[-1]["ct"] - 1.0,
        }
        out["bases"][base] = {
            "label": BASE_LABELS[base],
            "parameters": p,
            "points": rows,
            "sensitivity": sens,
            "time_step_check": step,
        }
    out["acceptance"] = acceptance(out["bases"][ACCEPTED_BASE]["points"])
    out["garrick"] = garrick_rows()
    return out


def acceptance(points: list[dict]) -> dict:
    """The accepted base's worst ratio model / data (farthest from 1) and whether every point
    is within ACCEPT."""
    worst = max(points, key=lambda r: abs(r["ratio"] - 1.0))
    return {
        "worst_ratio": worst["ratio"],
        "worst_strouhal": worst["strouhal"],
        "within": all(r["within_acceptance"] for r in points),
    }


# --- files --------------------------------------------------------------------------------------

HEADER = (
    "# A published heaving-pitching foil data set (`data`, curated by hand with its "
    "source) and\n# the fin strips' model (station/foil.py) on the same kinematics "
    "(`model`, generated by\n# `{command}`,\n# manta_drake/studies/validation/"
    'foil_data.py; docs/validation.md\'s "Foil data" section is\n# rendered from it). '
    "Edit `data` only with its source; regenerate `model`.\n"
)
PROVENANCE_FIELDS = (
    "repository",
    "path",
    "commit",
    "url",
    "variables",
    "digitized_from",
    "experiment",
    "digitized_by",
    "retrieved",
)


def load_reference(path=YAML_PATH) -> dict:
    """The reference file, checked for its data's provenance and shape."""
    from manta_drake.config_io import load_yaml_mapping

    ref, _ = load_yaml_mapping(path, "heaving-pitching foil reference", ValidationError)
    data = ref.get("data")
    if not isinstance(data, dict):
        raise ValidationError(f"{path}: no `data` mapping")
    src = data.get("source", {})
    missing = [k for k in PROVENANCE_FIELDS if not src.get(k)]
    if missing:
        raise ValidationError(f"{path}: data.source lacks {', '.join(missing)}")
    for key in ("thrust_coefficient", "efficiency"):
        block = data.get(key, {})
        if len(block.get("strouhal", [])) != len(block.get("value", [])) or not block.get("value"):
            raise ValidationError(f"{path}: data.{key}: strouhal and value differ in length")
    return ref


def provenance(seconds: float) -> dict:
    from manta_drake.studies.stamp import commit

    return {
        "generator": "manta_drake.studies.validation.foil_data",
        "command": COMMAND,
        "date": datetime.date.today().isoformat(),
        "commit": commit(),
        "seconds": round(seconds, 1),
        "rho": RHO,
        "speed": SPEED,
        "steps_per_cycle": STEPS_PER_CYCLE,
        "min_travel_half_chords": MIN_TRAVEL,
        "acceptance": ACCEPT,
        "garrick_tol": GARRICK_TOL,
    }


def write_reference(path, ref: dict) -> pathlib.Path:
    import yaml

    class Dumper(yaml.SafeDumper):
        """Mappings as blocks, lists of numbers on one line."""

    def seq(dumper, v):
        flat = all(x is None or isinstance(x, (bool, int, float)) for x in v)
        return dumper.represent_sequence("tag:yaml.org,2002:seq", v, flow_style=flat)

    def mapping(dumper, v):
        return dumper.represent_mapping("tag:yaml.org,2002:map", v.items(), flow_style=False)

    Dumper.add_representer(list, seq)
    Dumper.add_representer(dict, mapping)
    path = pathlib.Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(
        HEADER.format(command=COMMAND)
        + yaml.dump(ref, Dumper=Dumper, sort_keys=False, width=100, allow_unicode=True),
        encoding="utf-8",
    )
    return path


def run_study(ref: dict, log=print) -> dict:
    """The reference with a fresh ``model`` block (the data block as given)."""
    started = time.time()
    model = round_floats(compare(ref["data"], log=log), 10)
    return {
        "data": ref["data"],
        "model": {"provenance": provenance(time.time() - started), **model},
    }


# --- the page -----------------------------------------------------------------------------------


def render_section(ref: dict) -> str:
    from manta_drake.studies.validation import section_markers

    begin, end = section_markers(SECTION)
    m = ref["model"]
    body = render_template(
        TEMPLATE,
        d=ref["data"],
        m=m,
        p=m["provenance"],
        bases=m["bases"],
        garrick=m["garrick"],
        terms=TERMS,
        command=COMMAND,
    )
    return f"{begin}\n{body.strip()}\n{end}"


def write_page(path, ref: dict) -> None:
    from manta_drake.studies.validation import write_section

    write_section(pathlib.Path(path), SECTION, render_section(ref))


# --- the command --------------------------------------------------------------------------------


def parse_args(argv, prog):
    parser = StudyParser(prog=prog, description=__doc__.splitlines()[0])
    add_folder_options(
        parser,
        SECTION,
        "writes DIR/foil_data.json (data and model) and DIR/foil_data.md (the section)",
    )
    parser.add_argument(
        "--yaml",
        default=None,
        metavar="FILE",
        help="the reference file: its `data` is read and its `model` block "
        "rewritten (default models/reference/heaving_pitching_foil.yaml of "
        "the checkout)",
    )
    parser.add_argument(
        "--no-write-yaml",
        action="store_true",
        help="leave --yaml as it is (the results go to DIR only)",
    )
    parser.add_argument(
        "--from-yaml",
        action="store_true",
        help="compute nothing: render the page from --yaml's committed `model`",
    )
    args = parser.parse_args(argv)
    args.yaml = reference_file(args.yaml, prog, "--yaml FILE", YAML_PATH.name)
    args.page = page_path(args.out, prog)
    check_runs(args.runs)
    if not pathlib.Path(args.yaml).is_file():
        raise ValidationError(f"--yaml {args.yaml}: no such file (it holds the data)")
    return args


def main(argv=None, prog=None) -> int:
    prog = prog or "python -m manta_drake.studies.validation.foil_data"
    argv = sys.argv[1:] if argv is None else list(argv)
    args = parse_args(argv, prog)
    ref = load_reference(args.yaml)
    if args.from_yaml:
        if "model" not in ref:
            raise ValidationError(
                f"--from-yaml: {args.yaml} has no `model` block; run without --from-yaml first"
            )
    else:
        ref = run_study(ref, log=lambda msg: print(msg, flush=True))
        if not args.no_write_yaml:
            print(f"reference: {write_reference(args.yaml, ref)}")
    written = write_results(args.runs, "foil_data", ref, render_section(ref))
    write_page(args.page, ref)
    print(f"page: {args.page}")
    print(f"wrote {written[0]} and {written[1]}")
    return 0


if __name__ == "__main__":
    run_module(main)
