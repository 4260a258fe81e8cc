#!/usr/bin/env python3
"""Prints what one HydrodynamicForces evaluation costs (microseconds per call), piece by piece.

The robot is in the swim stance at the surface with a random velocity, so every term is
active. Rows, each the median of --rounds interleaved rounds of --calls calls:

* the force maths on numpy arrays: ``compute_reference`` (the numpy functions of
  ``manta_drake.station.water``, ``backend="numpy"``) and ``compute_compiled`` (the numba
  kernel, ``backend="compiled"``);
* reading the kinematics: the plant's per-body ``body_poses`` / ``body_spatial_velocities``
  ports into arrays (the contract's inputs), the plant's per-body Eval functions, and the
  kernel's forward kinematics from the
  ``state`` vector (pydrake does not bind ``CalcAllBodyPosesInWorld``; the per-body
  ``EvalBodyPoseInWorld`` / ``EvalBodySpatialVelocityInWorld`` stand in for it);
* the outputs: writing the list of 17 ExternallyAppliedSpatialForce, and J^T F (kernel);
* whole port evaluations as the plant sees them (a new state each call): the contract path
  (``inputs="contract", backend="numpy"``: per-body ports, numpy maths, force list) and the
  compiled path (``inputs="plant_state", backend="compiled"``: state vector, kernels,
  generalized forces), each built by ``HydrodynamicForces.AddToBuilder``.

Usage: python scripts/benchmark_hydro.py [--calls 2000] [--rounds 5]
"""

import argparse
import statistics
import sys
import time

import numpy as np
from pydrake.multibody.tree import BodyIndex
from pydrake.systems.framework import DiagramBuilder

from manta_drake.control.gaits import GAITS
from manta_drake.model.coefficients import load_coefficients
from manta_drake.model.plant import add_plant, body_pose, set_initial_state
from manta_drake.station.hydro import HydrodynamicForces


def make(inputs: str, backend: str):
    """The plant with a HydrodynamicForces of that port set and backend, wired both ways
    (the plant's outputs that the forces read do not depend on the forces)."""
    coeffs = load_coefficients()
    builder = DiagramBuilder()
    h = add_plant(builder, hydro=coeffs)
    hydro = HydrodynamicForces.AddToBuilder(
        builder,
        h.plant,
        h.robot,
        coeffs,
        1e-3,
        added_mass_iso=h.added_mass_iso,
        inputs=inputs,
        backend=backend,
    )
    diagram = builder.Build()
    context = diagram.CreateDefaultContext()
    plant_context = h.plant.GetMyMutableContextFromRoot(context)
    set_initial_state(
        h, plant_context, body_pose([0, 0, -0.04], [3, 2, 10]), GAITS["swim"].R.ravel() * 0.7
    )
    v0 = np.random.default_rng(0).normal(scale=0.3, size=h.plant.num_velocities())
    h.plant.SetVelocities(plant_context, v0)
    hydro_context = hydro.GetMyMutableContextFromRoot(context)
    hydro.GetInputPort("balloon_volume").FixValue(hydro_context, [1.5e-3])
    return h, hydro, plant_context, hydro_context, v0


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--calls", type=int, default=2000)
    parser.add_argument("--rounds", type=int, default=5)
    args = parser.parse_args()
    h, fast, plant_context, fast_context, v0 = make("plant_state", "compiled")
    h2, slow, plant_context2, slow_context, v2 = make("contract", "numpy")
    plant = h.plant
    R, p, w, v = fast._kinematics(fast_context)
    a, alpha = np.zeros(3), np.zeros(3)
    F = fast.compute_compiled(R, p, w, v, 1.5e-3, a, alpha)
    x = plant.get_state_output_port().Eval(plant_context)
    out = fast.GetOutputPort("spatial_forces").Allocate()
    counter = [0]

    def new_state(h_, pc, v_):  # a new state each call, so ports are really re-evaluated
        counter[0] += 1
        v_[0] = 1e-6 * counter[0]
        h_.plant.SetVelocities(pc, v_)

    bodies = [plant.get_body(BodyIndex(i)) for i in fast.body_indices]

    def all_poses():  # pydrake binds no CalcAllBodyPosesInWorld: the per-body Eval calls
        X = np.array([plant.EvalBodyPoseInWorld(plant_context, b).GetAsMatrix34() for b in bodies])
        V = np.array(
            [plant.EvalBodySpatialVelocityInWorld(plant_context, b).get_coeffs() for b in bodies]
        )
        return X, V

    gen_port = fast.GetOutputPort("generalized_forces")
    list_port = slow.GetOutputPort("spatial_forces")
    rows = {
        "maths, numpy reference (compute_reference)": lambda: fast.compute_reference(
            R, p, w, v, 1.5e-3, a, alpha
        ),
        "maths, numba kernel (compute_compiled)": lambda: fast.compute_compiled(
            R, p, w, v, 1.5e-3, a, alpha
        ),
        "kinematics: per-body ports -> arrays": lambda: slow._kinematics(slow_context),
        "kinematics: EvalBodyPose/SpatialVelocityInWorld": all_poses,
        "kinematics: state port + kernel FK": lambda: fast._kinematics(fast_context),
        "state -> forces, one kernel (forces_from_state)": lambda: fast._forces_now(fast_context),
        "output: 17 ExternallyAppliedSpatialForce": lambda: fast._write(F, out),
        "output: J^T F kernel at the current state": lambda: fast.generalized_forces(x, F),
        "set a new plant state (subtracted below)": lambda: new_state(h, plant_context, v0),
        "port eval, contract path (numpy, lists)": lambda: (
            new_state(h2, plant_context2, v2),
            list_port.Eval(slow_context),
        ),
        "port eval, compiled path (state, kernels, J^T F)": lambda: (
            new_state(h, plant_context, v0),
            gen_port.Eval(fast_context),
        ),
    }
    times = {k: [] for k in rows}
    for _ in range(args.rounds):
        for name, fn in rows.items():
            fn()
            start = time.perf_counter()
            for _ in range(args.calls):
                fn()
            times[name].append((time.perf_counter() - start) / args.calls)
    med = {k: statistics.median(v) * 1e6 for k, v in times.items()}
    n_el, n_strips = len(fast.el["body"]), len(fast.el["strip_body"])
    print(
        f"HydrodynamicForces: {len(fast.body_indices)} bodies, {n_el} volume elements, "
        f"{n_strips} blade-element strips; medians of {args.rounds} rounds x {args.calls} calls"
    )
    set_state = med["set a new plant state (subtracted below)"]
    for name, value in med.items():
        offset = set_state if name.startswith("port eval") else 0.0
        value -= offset
        spread = f"[{min(times[name]) * 1e6 - offset:7.1f}, {max(times[name]) * 1e6 - offset:7.1f}]"
        print(f"  {name:52s} {value:8.1f} us   {spread}")
    speedup = (
        med["maths, numpy reference (compute_reference)"]
        / med["maths, numba kernel (compute_compiled)"]
    )
    print(f"  kernel vs reference maths: {speedup:.0f}x faster")
    return 0


if __name__ == "__main__":
    sys.exit(main())
