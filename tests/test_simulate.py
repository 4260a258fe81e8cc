"""The one place that runs a Simulator: a caller's context is kept, the noise is seeded
from the scenario, and the same seed gives the same run."""

import numpy as np
import pytest
from pydrake.common import RandomGenerator
from pydrake.math import RigidTransform

from manta_drake.scenario import load_scenario
from manta_drake.simulate import make_simulator, random_sources, seed_context
from manta_drake.wiring.diagram import build_diagram

NUM_OSC = 16


@pytest.fixture(scope="module")
def swim():
    s = load_scenario(
        "locomotion_swim", overrides={"duration": 0.1, "visualization.meshcat": False}
    )
    diagram, handles = build_diagram(s)
    return s, diagram, handles


def _pressure_noise(diagram, handles, context):
    source = handles.station.GetSubsystemByName("pressure_noise_normal")
    return source.get_output_port().Eval(source.GetMyContextFromRoot(context)).copy()


def test_make_simulator_keeps_a_pose_and_a_cpg_phase_set_on_the_context(swim):
    s, diagram, handles = swim
    context = diagram.CreateDefaultContext()
    plant, body = handles.plant, handles.plant_handles.body
    plant_context = plant.GetMyMutableContextFromRoot(context)
    X_WB = RigidTransform([1.25, -0.3, -0.06])
    plant.SetFreeBodyPose(plant_context, body, X_WB)
    cpg = handles.systems["cpg"]
    cpg_context = cpg.GetMyMutableContextFromRoot(context)
    phase = np.linspace(0.1, 1.6, NUM_OSC)
    cpg.set_state(cpg_context, phi=phase)

    simulator = make_simulator(diagram, s, context=context)
    assert simulator.get_context() is context
    # Nothing reset before the first step ...
    p0 = plant.EvalBodyPoseInWorld(plant_context, body).translation()
    np.testing.assert_array_equal(p0, X_WB.translation())
    x = cpg_context.get_continuous_state_vector().CopyToVector()
    np.testing.assert_array_equal(x[:NUM_OSC], phase)
    # ... and the run goes on from there: 50 ms later the body is within centimetres of the
    # set pose, far from the scenario's start at the origin, and the phases are near the
    # set ones (2 pi f t = 0.16 rad of drive plus the couplings' pull in 50 ms), not near
    # where the default start's phases have gone.
    simulator.AdvanceTo(0.05)
    p = plant.EvalBodyPoseInWorld(plant_context, body).translation()
    assert np.linalg.norm(p[:2] - X_WB.translation()[:2]) < 0.02
    start = np.asarray(s.initial_pose.xyz)
    assert np.linalg.norm(p[:2] - start[:2]) > 1.0
    phi = cpg_context.get_continuous_state_vector().CopyToVector()[:NUM_OSC]
    assert np.abs(phi - phase).max() < 0.5
    default = make_simulator(diagram, s)
    default.AdvanceTo(0.05)
    phi_default = (
        cpg.GetMyContextFromRoot(default.get_context())
        .get_continuous_state_vector()
        .CopyToVector()[:NUM_OSC]
    )
    assert np.abs(phi - phi_default).mean() > 2 * np.abs(phi - phase).mean()


def test_seeding_draws_the_noise_of_diagram_set_random_context(swim):
    """seed_context touches only the random sources, in the order Diagram.SetRandomContext
    draws them: a default context seeded either way has the same noise."""
    s, diagram, handles = swim
    assert len(random_sources(diagram)) >= 2  # the pressure sensor's normal and uniform
    ours = diagram.CreateDefaultContext()
    seed_context(diagram, ours, 7)
    drakes = diagram.CreateDefaultContext()
    diagram.SetRandomContext(drakes, RandomGenerator(7))
    np.testing.assert_array_equal(
        _pressure_noise(diagram, handles, ours), _pressure_noise(diagram, handles, drakes)
    )
    other = diagram.CreateDefaultContext()
    seed_context(diagram, other, 8)
    assert not np.array_equal(
        _pressure_noise(diagram, handles, ours), _pressure_noise(diagram, handles, other)
    )


def test_default_context_is_the_scenarios_start(swim):
    s, diagram, handles = swim
    context = diagram.CreateDefaultContext()
    p = handles.plant.EvalBodyPoseInWorld(
        handles.plant.GetMyContextFromRoot(context), handles.plant_handles.body
    ).translation()
    np.testing.assert_allclose(p, s.initial_pose.xyz, atol=1e-12)
