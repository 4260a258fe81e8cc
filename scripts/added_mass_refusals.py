#!/usr/bin/env python3
"""Refusal rate of +-50 % hydrodynamic coefficient sets under the explicit added-mass
stability check, before and after its change (commit 3d8aa08), and whether the sets the
change newly accepts simulate stably (issue 12).

The check (``HydrodynamicForces.__init__``): the part of the hull's added mass that is not
in the mass matrix is applied explicitly, -M_res a_prev, which is stable only for
|M_res| < M_eff on every axis.

* BEFORE (reimplemented here, ``old_check``): the translational residual against the hull's
  own rigid mass plus the isotropic added mass in the mass matrix; the rotational residual
  (``split_added_inertia(added_inertia)[1]``) against the hull body's *smallest principal
  moment of inertia alone*.
* AFTER (the package as it is, ``new_check``): ``HydrodynamicForces(...)`` on a plant built
  with the scaled coefficients (``add_plant(DiagramBuilder(), hydro=coeffs)``); refused
  when it raises ``ValueError("explicit added mass ...")``. It compares each axis with the
  whole robot's effective mass / inertia on that axis (rigid + implicit added).

Sets: ``--sets`` M draws from ``numpy.random.default_rng(--seed)``. Two kinds:

* ``per-component`` (the measurement): every component of ``body.added_mass`` (3),
  ``body.added_inertia`` (3), ``body.linear_damping`` (6), ``body.quadratic_damping`` (6)
  and ``fins.hinge_added_inertia`` (4) scaled by its own factor in [0.5, 1.5]. Independent
  factors change the *anisotropy* of the added inertia, which is what the residual is made
  of;
* ``per-entry``: one factor in [0.5, 1.5] per named entry, what a scenario's
  ``water.coefficient_scales`` can express; AFTER is taken through
  ``build_station(scenario)`` (the real path).

Then, for ``--stability`` sets (default 20) refused BEFORE and accepted AFTER (those
closest to the new bound first), a ``--stability-duration`` s (3) ``locomotion_swim`` with
``water.update_period: 0`` (forces at every step, the exact explicit term) and the scaled
coefficients written to a coefficient file: stable = the run ends ok, every logged state is
finite, and the body's angular rate and speed stay bounded (max |w| < 5 rad/s, max |v| <
1 m/s; the unscaled swim has ~0.7 rad/s, ~0.2 m/s) without growing (the last second's
peak |w| no more than 2x the second second's).

Usage:
  python scripts/added_mass_refusals.py [--sets 300] [--seed 7] [--stability 20]
      [--out out/added_mass_refusals]
Writes DIR/sets.csv, DIR/stability.csv and DIR/summary.json and prints the rates.
"""

from __future__ import annotations

import argparse
import copy
import csv
import json
import pathlib
import sys
import tempfile
import time

import numpy as np

PER_COMPONENT = ("body.added_mass", "body.added_inertia", "body.linear_damping",
                 "body.quadratic_damping", "fins.hinge_added_inertia")
PER_ENTRY = PER_COMPONENT
RATE_BOUND = 5.0  # rad/s
SPEED_BOUND = 1.0  # m/s
GROWTH_BOUND = 2.0


def scaled_per_component(base, rng) -> tuple:
    """A copy of ``base`` with every component of the PER_COMPONENT entries scaled by its
    own factor in [0.5, 1.5]; returns (coeffs, {name: factors})."""
    coeffs = copy.deepcopy(base)
    entries = dict(coeffs.entries())
    factors = {}
    for name in PER_COMPONENT:
        entry = entries[name]
        f = rng.uniform(0.5, 1.5, size=len(entry.value))
        entry.value = [float(v) * float(k) for v, k in zip(entry.value, f)]
        entry.source = f"x{np.round(f, 4).tolist()} of: {entry.source}"
        factors[name] = f.round(6).tolist()
    return coeffs, factors


def old_check(plant, robot, coeffs, added_mass_iso: float) -> tuple[bool, str, float]:
    """The check before commit 3d8aa08: (refused, axis, largest |residual| / limit).

    Translational: |added_mass - iso| < hull rigid mass + iso on every axis.
    Rotational: |split_added_inertia(added_inertia)[1]| < the hull body's smallest
    principal moment of inertia (the hull alone: no legs, no implicit added inertia)."""
    from manta_drake.station.water import split_added_inertia

    hull = plant.GetBodyByName("body", robot)
    res_m = np.asarray(coeffs.body.added_mass.value, dtype=float) - added_mass_iso
    lim_m = hull.default_mass() + added_mass_iso
    _, res_i = split_added_inertia(coeffs.body.added_inertia.value)
    lim_i = float(hull.default_rotational_inertia().CalcPrincipalMomentsOfInertia().min())
    ratios = [(abs(v) / lim_m, a) for v, a in zip(res_m, ("surge", "sway", "heave"))]
    ratios += [(abs(v) / lim_i, a) for v, a in zip(res_i, ("roll", "pitch", "yaw"))]
    worst, axis = max(ratios)
    return worst >= 1.0, axis, float(worst)


def new_check(coeffs) -> tuple[bool, str, float, object]:
    """The package's check: (refused, message, largest |residual| / effective, handles)."""
    from pydrake.systems.framework import DiagramBuilder

    from manta_drake.model.plant import add_plant
    from manta_drake.station.hydro import HydrodynamicForces, effective_inertia
    from manta_drake.station.water import split_added_inertia

    h = add_plant(DiagramBuilder(), hydro=coeffs)
    mass, inertia = effective_inertia(h.plant, h.robot)
    res_m = np.asarray(coeffs.body.added_mass.value) - h.added_mass_iso
    res_i = split_added_inertia(coeffs.body.added_inertia.value)[1]
    ratio = float(max(np.max(np.abs(res_m) / mass), np.max(np.abs(res_i) / inertia)))
    try:
        HydrodynamicForces(h.plant, h.robot, coeffs, 1e-3, added_mass_iso=h.added_mass_iso)
    except ValueError as e:
        if "explicit added mass" not in str(e):
            raise
        return True, str(e), ratio, h
    return False, "", ratio, h


def station_refuses(scales: dict) -> tuple[bool, str]:
    """AFTER through the real path: build_station of a scenario with coefficient_scales."""
    from manta_drake.scenario import load_scenario
    from manta_drake.wiring.station import build_station

    scenario = load_scenario("locomotion_swim")
    scenario.visualization.meshcat = False
    scenario.water.coefficient_scales = dict(scales)
    scenario.validate()
    try:
        build_station(scenario)
    except ValueError as e:
        if "explicit added mass" not in str(e):
            raise
        return True, str(e)
    return False, ""


def write_coefficients(coeffs, path: pathlib.Path) -> None:
    from pydrake.common.yaml import yaml_dump_typed

    from manta_drake.model.coefficients import HydroCoefficients

    path.write_text(yaml_dump_typed(coeffs, schema=HydroCoefficients))


def swim_stability(coeff_file: str | None, duration: float, out_dir) -> dict:
    """A locomotion_swim with the forces at every step and the given coefficient file."""
    from manta_drake.scenario import load_scenario
    from manta_drake.simulate import SimulationError, run

    scenario = load_scenario("locomotion_swim")
    scenario.duration = duration
    scenario.visualization.meshcat = False
    scenario.water.update_period = 0.0
    if coeff_file:
        scenario.water.coefficients = coeff_file
    scenario.validate()
    t0 = time.perf_counter()
    row = {}
    try:
        result = run(scenario, out_dir, progress=False, write_outputs=False)
        log, row["status"] = result.log, "ok"
    except SimulationError as e:
        row["status"], row["reason"] = "failed", str(e)
        with np.load(pathlib.Path(out_dir) / "log.npz") as z:
            log = {k: z[k] for k in z.files}
    row["wall_time_s"] = time.perf_counter() - t0
    t = log["t"]
    state = np.hstack([log[k].reshape(len(t), -1) for k in
                       ("body_xyz", "body_quat_wxyz", "body_v_world", "body_w_world",
                        "joint_angles", "joint_velocities")])
    row["finite"] = bool(np.all(np.isfinite(state)))
    w = np.linalg.norm(log["body_w_world"], axis=1)
    v = np.linalg.norm(log["body_v_world"], axis=1)
    row["max_body_rate_rad_s"] = float(np.nanmax(w))
    row["max_body_speed_m_s"] = float(np.nanmax(v))
    early = w[(t >= 1.0) & (t < 2.0)]
    late = w[t >= t[-1] - 1.0]
    row["rate_growth"] = float(np.nanmax(late) / max(np.nanmax(early), 1e-9)) if len(early) else None
    row["stable"] = bool(row["status"] == "ok" and row["finite"]
                         and row["max_body_rate_rad_s"] < RATE_BOUND
                         and row["max_body_speed_m_s"] < SPEED_BOUND
                         and (row["rate_growth"] is None or row["rate_growth"] <= GROWTH_BOUND))
    return row


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--sets", type=int, default=300)
    ap.add_argument("--seed", type=int, default=7)
    ap.add_argument("--stability", type=int, default=20)
    ap.add_argument("--stability-duration", type=float, default=3.0)
    ap.add_argument("--per-entry-sets", type=int, default=100,
                    help="per-entry (coefficient_scales) sets checked through build_station")
    ap.add_argument("--out", default="out/added_mass_refusals")
    args = ap.parse_args(argv)

    from manta_drake.model.coefficients import load_coefficients, scale_coefficients

    out = pathlib.Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(args.seed)
    base = load_coefficients()

    # --- per-component sets: BEFORE vs AFTER ---
    rows, sets = [], []
    t0 = time.perf_counter()
    for i in range(args.sets):
        coeffs, factors = scaled_per_component(base, rng)
        after, message, ratio_after, h = new_check(coeffs)
        before, axis, ratio_before = old_check(h.plant, h.robot, coeffs, h.added_mass_iso)
        rows.append({"set": i, "before_refused": before, "before_axis": axis,
                     "before_ratio": ratio_before, "after_refused": after,
                     "after_ratio": ratio_after, "after_message": message,
                     "added_mass": json.dumps(np.round(coeffs.body.added_mass.value, 6).tolist()),
                     "added_inertia": json.dumps(
                         np.round(coeffs.body.added_inertia.value, 6).tolist()),
                     "factors": json.dumps(factors)})
        sets.append(coeffs)
    n = len(rows)
    nb = sum(r["before_refused"] for r in rows)
    na = sum(r["after_refused"] for r in rows)
    newly = [r for r in rows if r["before_refused"] and not r["after_refused"]]
    lost = [r for r in rows if r["after_refused"] and not r["before_refused"]]
    print(f"per-component sets: {n} (seed {args.seed}), {time.perf_counter() - t0:.0f} s")
    print(f"  refused BEFORE (hull-only limits): {nb}/{n} = {100 * nb / n:.1f} %")
    print(f"  refused AFTER (whole-robot effective): {na}/{n} = {100 * na / n:.1f} %")
    print(f"  refused before, accepted after: {len(newly)}; accepted before, refused after: "
          f"{len(lost)}")
    axes = {}
    for r in rows:
        if r["before_refused"]:
            axes[r["before_axis"]] = axes.get(r["before_axis"], 0) + 1
    print(f"  BEFORE refusals by axis: {axes}")
    ra = np.array([r["after_ratio"] for r in rows])
    rb = np.array([r["before_ratio"] for r in rows])
    print(f"  largest |residual|/limit: before median {np.median(rb):.3f} max {rb.max():.3f}; "
          f"after median {np.median(ra):.3f} max {ra.max():.3f}")
    with open(out / "sets.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)

    # --- per-entry sets through build_station ---
    entry_rows = []
    t0 = time.perf_counter()
    for i in range(args.per_entry_sets):
        scales = {name: float(rng.uniform(0.5, 1.5)) for name in PER_ENTRY}
        coeffs = scale_coefficients(base, scales)
        after, _ = station_refuses(scales)
        _, _, _, h = new_check(coeffs)
        before, axis, ratio = old_check(h.plant, h.robot, coeffs, h.added_mass_iso)
        entry_rows.append({"before": before, "after": after, "ratio_before": ratio})
    ne = len(entry_rows)
    if ne:
        eb = sum(r["before"] for r in entry_rows)
        ea = sum(r["after"] for r in entry_rows)
        print(f"per-entry sets (coefficient_scales, AFTER via build_station): {ne}, "
              f"{time.perf_counter() - t0:.0f} s: refused BEFORE {eb} ({100 * eb / ne:.1f} %), "
              f"AFTER {ea} ({100 * ea / ne:.1f} %); largest before ratio "
              f"{max(r['ratio_before'] for r in entry_rows):.3f}")

    # --- stability of newly accepted sets ---
    stab = []
    if args.stability and newly:
        chosen = sorted(newly, key=lambda r: -r["after_ratio"])[: args.stability]
        tmp = pathlib.Path(tempfile.mkdtemp(prefix="amr-", dir=out))
        base_row = swim_stability(None, args.stability_duration, tmp / "baseline")
        print(f"baseline swim (unscaled, update_period 0): max |w| "
              f"{base_row['max_body_rate_rad_s']:.3f} rad/s, max |v| "
              f"{base_row['max_body_speed_m_s']:.3f} m/s, growth {base_row['rate_growth']:.2f}, "
              f"{base_row['status']}")
        for r in chosen:
            path = out / f"coefficients_set{r['set']:04d}.yaml"
            write_coefficients(sets[r["set"]], path)
            s = swim_stability(str(path.resolve()), args.stability_duration,
                               tmp / f"set{r['set']:04d}")
            s.update(set=r["set"], before_ratio=r["before_ratio"], before_axis=r["before_axis"],
                     after_ratio=r["after_ratio"], coefficients=str(path))
            stab.append(s)
            print(f"  set {r['set']:4d}: before {r['before_ratio']:.2f} ({r['before_axis']}), "
                  f"after {r['after_ratio']:.2f}: {s['status']}, finite {s['finite']}, max |w| "
                  f"{s['max_body_rate_rad_s']:.3f} rad/s, max |v| {s['max_body_speed_m_s']:.3f} "
                  f"m/s, growth {s['rate_growth']:.2f} -> {'stable' if s['stable'] else 'UNSTABLE'}")
        with open(out / "stability.csv", "w", newline="") as f:
            w = csv.DictWriter(f, fieldnames=list(stab[0]))
            w.writeheader()
            w.writerows(stab)
        n_stable = sum(s["stable"] for s in stab)
        print(f"newly accepted sets simulated: {len(stab)}, stable {n_stable}")
    summary = {
        "sets": n, "seed": args.seed, "per_component_entries": PER_COMPONENT,
        "refused_before": nb, "refused_after": na,
        "rate_before": nb / n, "rate_after": na / n,
        "refused_before_accepted_after": len(newly), "accepted_before_refused_after": len(lost),
        "before_refusals_by_axis": axes,
        "per_entry": {"sets": ne, "refused_before": sum(r["before"] for r in entry_rows),
                      "refused_after": sum(r["after"] for r in entry_rows)},
        "stability": {"runs": len(stab), "stable": sum(s["stable"] for s in stab),
                      "duration_s": args.stability_duration,
                      "baseline": base_row if stab else None, "rows": stab},
    }
    (out / "summary.json").write_text(json.dumps(summary, indent=2, default=str) + "\n")
    print(f"wrote {out / 'sets.csv'}, {out / 'summary.json'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
