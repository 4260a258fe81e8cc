"""The simulator's effective inertia in water, measured as a pool test would: the robot
released at rest fully submerged, fins held flat, balloon empty. The sixteen joints are
locked for the test (``Joint.Lock``: the discrete solver holds them exactly), so the robot
moves as one rigid body with its water; held by the servos' position loop instead, the
fins would lag the hull by the loop's compliance for the first ~0.1 s and the hull would
first accelerate with little of the fins' water.

* **heave**: level at mid-depth; its net weight W - B pulls it down, and before any
  velocity-dependent force builds up its acceleration is a_z = (W - B) / (m + A_33):
  ``M_eff = F_z / a_z``.
* **roll**: tilted by ``ROLL_DEG``; the righting moment of buoyancy above gravity turns it
  back, alpha_x = M_x / (I_xx + A_44): ``I_eff = M_x / alpha_x``.

F_z and M_x are the plant's own generalized forces on the floating hull at the release
(gravity plus the water's forces, the hull's [w, v] components: the whole tree's wrench
about the hull's origin); the accelerations are least-squares fits of the logged hull
motion over the first ``FIT_S`` seconds (z = z0 + v0 t + a t^2 / 2, w_x = w0 + alpha t). The
rigid robot's mass and inertia about the hull's origin come from the plant, so the added part
is M_eff - m (I_eff - I) and compares with the whole robot's BEM value of the same
geometry (``models/reference/added_mass_bem.yaml``, ``added_mass.py``).
"""

from __future__ import annotations

import numpy as np

ROLL_DEG = 5.0  # small: the righting moment is linear and the fins stay under water
DEPTH_M = -0.25  # the hull's centre at mid-depth: 0.25 m from the surface and the floor
FIT_S = 0.03  # s: the hull moves < 0.2 mm; drag is < 1e-4 of the net force
DURATION_S = 0.06


def released_scenario(kind: str, fin_model: str):
    """The shipped ``float_sink`` scenario turned into a release test: ``kind`` heave or
    roll, ``fin_model`` as ``water.fin_model``."""
    from manta_drake.scenario import load_scenario

    if kind not in ("heave", "roll"):
        raise ValueError(f"released_scenario.kind: {kind!r} is not heave or roll")
    roll = ROLL_DEG if kind == "roll" else 0.0
    return load_scenario(
        "float_sink",
        overrides={
            "name": f"released_{kind}_{fin_model}",
            "duration": DURATION_S,
            "initial_pose.xyz": [0.0, 0.0, DEPTH_M],
            "initial_pose.rpy_deg": [roll, 0.0, 0.0],
            "balloon.initial_fill": 0.0,
            "balloon.schedule": [],
            "water.fin_model": fin_model,
            "visualization.meshcat": False,
        },
    )


def release_wrench(diagram, handles) -> np.ndarray:
    """The generalized forces on the floating hull at the default context (the release):
    gravity plus the applied forces, [tau_W (3), f_W (3)] about the hull's origin."""
    plant = handles.plant
    context = diagram.CreateDefaultContext()
    diagram.ForcedPublish(context)  # initialization-free evaluation of the inputs
    plant_context = plant.GetMyContextFromRoot(context)
    tau = plant.CalcGravityGeneralizedForces(plant_context)
    port = plant.get_applied_generalized_force_input_port()
    if port.HasValue(plant_context):
        tau = tau + port.Eval(plant_context)
    start = handles.plant_handles.body.floating_velocities_start_in_v()
    return np.asarray(tau[start : start + 6])


def rigid_inertia(handles) -> tuple[float, np.ndarray]:
    """The robot's own mass and 3x3 rotational inertia about the hull's origin (world axes
    at the default pose), without any added mass."""
    plant = handles.plant
    context = plant.CreateDefaultContext()
    robot = handles.plant_handles.robot
    M = plant.CalcSpatialInertia(
        context, handles.plant_handles.body.body_frame(), plant.GetBodyIndices(robot)
    )
    return float(M.get_mass()), M.CalcRotationalInertia().CopyToFullMatrix3()


def _lock_joints(handles, context) -> None:
    """Locks the robot's joints in the run's context (the ``prepare`` hook of ``run``)."""
    plant = handles.plant
    plant_context = plant.GetMyMutableContextFromRoot(context)
    for name in handles.plant_handles.joint_names:
        plant.GetJointByName(name, handles.plant_handles.robot).Lock(plant_context)


def fit_acceleration(t, y, order: int) -> float:
    """The acceleration of a motion: y = y0 + v0 t + a t^2 / 2 (order 2, a position) or
    y = y0 + a t (order 1, a rate), least squares on the samples given. The offsets are free:
    the explicit part of the hull's added mass acts from the second step on (it needs an
    acceleration sample), so the first step moves a little faster than the rest."""
    t = np.asarray(t, dtype=float)
    y = np.asarray(y, dtype=float)
    if order == 2:
        A = np.column_stack([np.ones_like(t), t, 0.5 * t * t])
        return float(np.linalg.lstsq(A, y, rcond=None)[0][2])
    A = np.column_stack([np.ones_like(t), t])
    return float(np.linalg.lstsq(A, y, rcond=None)[0][1])


def measure(kind: str, fin_model: str, out_dir) -> dict:
    """Releases the robot and measures its effective heave mass or roll inertia."""
    from manta_drake.simulate import run
    from manta_drake.wiring.diagram import build_diagram

    scenario = released_scenario(kind, fin_model)
    diagram, handles = build_diagram(scenario)
    wrench = release_wrench(diagram, handles)
    mass, inertia = rigid_inertia(handles)
    log = run(scenario, out_dir, progress=False, write_outputs=False, prepare=_lock_joints).log
    t = log["t"]
    early = t <= FIT_S + 1e-12
    if kind == "heave":
        a = fit_acceleration(t[early], log["body_xyz"][early, 2], 2)
        effective, rigid, force = wrench[5] / a, mass, wrench[5]
    else:
        a = fit_acceleration(t[early], log["body_w_world"][early, 0], 1)
        effective, rigid, force = wrench[0] / a, inertia[0, 0], wrench[0]
    return {
        "kind": kind,
        "fin_model": fin_model,
        "force": float(force),
        "acceleration": a,
        "effective": float(effective),
        "rigid": float(rigid),
        "added": float(effective - rigid),
    }


# --- the section ---------------------------------------------------------------------------------

SECTION = "released"
TEMPLATE = "released.md.j2"
COMMAND = "manta-drake study validation --section released"
FIN_MODELS = ("cross_flow", "foil")


def bem_flat(results: dict) -> dict:
    """The whole robot's heave and roll added mass at the flat pose, finest mesh, from the
    committed BEM results (``added_mass.load_results``)."""
    matrix = np.array(results["robot"]["poses"]["flat"]["meshes"][-1]["matrix"])
    return {"heave": float(matrix[2, 2]), "roll": float(matrix[3, 3])}


def run_all(out_dir) -> dict:
    """Both releases with both fin models, against the whole-robot BEM values."""
    import datetime
    import pathlib

    from manta_drake.studies.stamp import commit
    from manta_drake.studies.validation import added_mass

    out_dir = pathlib.Path(out_dir)
    bem = bem_flat(added_mass.load_results())
    rows = []
    for model in FIN_MODELS:
        for kind in ("heave", "roll"):
            row = measure(kind, model, out_dir / f"{kind}_{model}")
            row["bem"] = bem[kind]
            row["ratio"] = row["added"] / bem[kind]
            rows.append(row)
    return {
        "rows": rows,
        "provenance": {
            "date": datetime.date.today().isoformat(),
            "commit": commit(),
            "command": COMMAND,
            "fit_s": FIT_S,
            "roll_deg": ROLL_DEG,
            "depth_m": DEPTH_M,
        },
    }


def render_section(results: dict) -> str:
    """The section's block (markers included) from its template."""
    from manta_drake.studies.validation import render_template, section_markers

    begin, end = section_markers(SECTION)
    body = render_template(TEMPLATE, p=results["provenance"], rows=results["rows"], command=COMMAND)
    return f"{begin}\n{body.strip()}\n{end}"


def main(argv=None, prog=None) -> int:
    """``manta-drake study validation --section released [--runs DIR] [--out DIR]``."""
    import json
    import pathlib
    import sys

    from manta_drake.studies.options import StudyParser
    from manta_drake.studies.validation import (
        add_folder_options,
        check_runs,
        page_path,
        write_section,
    )

    prog = prog or "python -m manta_drake.studies.validation.released"
    parser = StudyParser(prog=prog, description=__doc__.splitlines()[0])
    add_folder_options(parser, SECTION, "the runs and DIR/released.json")
    args = parser.parse_args(sys.argv[1:] if argv is None else argv)
    page = page_path(args.out, prog)
    runs = check_runs(args.runs)
    results = run_all(runs)
    runs.mkdir(parents=True, exist_ok=True)
    (pathlib.Path(runs) / "released.json").write_text(json.dumps(results, indent=1) + "\n")
    write_section(page, SECTION, render_section(results))
    for row in results["rows"]:
        print(
            f"{row['kind']:>5} {row['fin_model']:<10} effective {row['effective']:.4g}, "
            f"added {row['added']:.4g}, BEM {row['bem']:.4g} ({row['ratio']:.3f})"
        )
    print(f"page: {page}")
    return 0
