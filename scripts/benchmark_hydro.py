#!/usr/bin/env python3
"""Prints the cost of one HydrodynamicForces evaluation (microseconds per call).

Two figures: the force maths alone (``HydrodynamicForces.compute`` on numpy arrays), and the
full output-port evaluation as the plant sees it (reading the pose and velocity ports,
the maths, and filling the ExternallyAppliedSpatialForce list). The robot is in the swim
stance at the surface with a random velocity, so every term is active.

Usage: python scripts/benchmark_hydro.py [--calls 3000]
"""

import argparse
import sys
import time

import numpy as np
from pydrake.systems.framework import DiagramBuilder

from manta_drake.control.gaits import GAITS
from manta_drake.model.coefficients import load_coefficients
from manta_drake.model.plant import add_plant, body_pose, set_initial_state
from manta_drake.station.hydro import HydrodynamicForces


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--calls", type=int, default=3000)
    args = parser.parse_args()
    coeffs = load_coefficients()
    builder = DiagramBuilder()
    h = add_plant(builder, hydro=coeffs)
    hydro = builder.AddSystem(HydrodynamicForces(h.plant, h.robot, coeffs, 1e-3,
                                                 added_mass_iso=h.added_mass_iso))
    builder.Connect(h.plant.get_body_poses_output_port(), hydro.GetInputPort("body_poses"))
    builder.Connect(h.plant.get_body_spatial_velocities_output_port(),
                    hydro.GetInputPort("body_spatial_velocities"))
    diagram = builder.Build()
    context = diagram.CreateDefaultContext()
    plant_context = h.plant.GetMyMutableContextFromRoot(context)
    set_initial_state(h, plant_context, body_pose([0, 0, -0.04], [3, 2, 10]),
                      GAITS["swim"].R.ravel() * 0.7)
    rng = np.random.default_rng(0)
    v0 = rng.normal(scale=0.3, size=h.plant.num_velocities())
    h.plant.SetVelocities(plant_context, v0)
    hydro_context = hydro.GetMyMutableContextFromRoot(context)
    hydro.GetInputPort("balloon_volume").FixValue(hydro_context, [1.5e-3])
    port = hydro.GetOutputPort("spatial_forces")

    R, p, w, v = hydro._kinematics(hydro_context)
    start = time.perf_counter()
    for _ in range(args.calls):
        hydro.compute(R, p, w, v, 1.5e-3, np.zeros(3), np.zeros(3))
    maths = (time.perf_counter() - start) / args.calls

    start = time.perf_counter()
    for i in range(args.calls):
        v0[0] = 1e-6 * i  # a new state each call, so the port is really re-evaluated
        h.plant.SetVelocities(plant_context, v0)
        port.Eval(hydro_context)
    full = (time.perf_counter() - start) / args.calls

    n_el, n_strips = len(hydro.el["body"]), len(hydro.el["strip_body"])
    print(f"HydrodynamicForces: {len(hydro.body_indices)} bodies, {n_el} volume elements, "
          f"{n_strips} blade-element strips")
    print(f"  force maths (compute):          {maths * 1e6:7.1f} us per call")
    print(f"  output port (ports+maths+list): {full * 1e6:7.1f} us per call")
    print(f"  at a 1 ms plant step that is {full * 1e3 * 100:.0f} % of real time")
    return 0


if __name__ == "__main__":
    sys.exit(main())
