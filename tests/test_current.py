"""The time-keyed water current: ``current_at`` against hand-computed values, the
schedule's checks, and HydrodynamicForces reading the current at the Context's time."""

import dataclasses as dc

import numpy as np
import pytest
from pydrake.common.yaml import yaml_load_typed
from pydrake.systems.framework import DiagramBuilder

from manta_drake.model.coefficients import load_coefficients
from manta_drake.model.plant import add_plant, body_pose, set_initial_state
from manta_drake.station.current import (
    CurrentPoint,
    CurrentSchedule,
    check_current_schedule,
    current_at,
)
from manta_drake.station.hydro import HydrodynamicForces

COEFFS = load_coefficients()
RAMP = [
    CurrentPoint(1.0, [0.0, 0.0, 0.0]),
    CurrentPoint(3.0, [0.4, -0.2, 0.0]),
    CurrentPoint(5.0, [0.4, -0.2, 0.1]),
]


# --- the pure maths ----------------------------------------------------------------------------


@pytest.mark.parametrize(
    "t, expected",
    [
        (-2.0, [0.0, 0.0, 0.0]),  # before the first key: the first key
        (0.5, [0.0, 0.0, 0.0]),
        (1.0, [0.0, 0.0, 0.0]),
        (2.0, [0.2, -0.1, 0.0]),  # half way along the first segment
        (2.5, [0.3, -0.15, 0.0]),
        (3.0, [0.4, -0.2, 0.0]),  # on a key
        (4.5, [0.4, -0.2, 0.075]),
        (5.0, [0.4, -0.2, 0.1]),
        (99.0, [0.4, -0.2, 0.1]),  # after the last key: the last key
    ],
)
def test_current_is_piecewise_linear_and_constant_outside_the_keys(t, expected):
    times = [p.time for p in RAMP]
    velocities = [p.velocity for p in RAMP]
    np.testing.assert_allclose(current_at(t, times, velocities), expected, rtol=0, atol=1e-15)
    np.testing.assert_allclose(CurrentSchedule(points=RAMP).at(t), expected, rtol=0, atol=1e-15)


def test_equal_times_make_a_step_to_the_later_key():
    times, velocities = [0.0, 2.0, 2.0, 4.0], [[0, 0, 0], [0.2, 0, 0], [-0.3, 0, 0], [-0.3, 0, 0]]
    assert current_at(1.0, times, velocities)[0] == pytest.approx(0.1, abs=1e-15)
    assert current_at(np.nextafter(2.0, 0.0), times, velocities)[0] == pytest.approx(0.2)
    assert current_at(2.0, times, velocities)[0] == -0.3  # right-continuous at the step
    assert current_at(3.0, times, velocities)[0] == -0.3


def test_current_at_writes_into_out():
    out = np.full(3, np.nan)
    got = current_at(2.0, [1.0, 3.0], [[0, 0, 0], [0.4, -0.2, 0.0]], out=out)
    assert got is out
    np.testing.assert_allclose(out, [0.2, -0.1, 0.0], atol=1e-15)


def test_schedule_without_keys_is_its_constant_bitwise():
    c = [0.1, -0.05, 0.02]
    s = CurrentSchedule(c)
    assert s.is_constant
    for t in (0.0, 1.7, 1e3):
        np.testing.assert_array_equal(s.at(t), np.array(c))
    np.testing.assert_array_equal(s.times, [0.0])
    np.testing.assert_array_equal(s.velocities, [c])
    np.testing.assert_array_equal(s.constant, c)


def test_schedule_keys_replace_the_constant_and_are_frozen():
    s = CurrentSchedule([0.3, 0.0, 0.0], RAMP)
    assert not s.is_constant
    np.testing.assert_array_equal(s.times, [1.0, 3.0, 5.0])
    np.testing.assert_array_equal(s.at(0.0), [0.0, 0.0, 0.0])  # the first key, not 0.3
    assert CurrentSchedule(
        points=[CurrentPoint(0.0, [0.1, 0, 0]), CurrentPoint(9.0, [0.1, 0, 0])]
    ).is_constant
    points = [CurrentPoint(0.0, [0.1, 0.0, 0.0]), CurrentPoint(2.0, [0.2, 0.0, 0.0])]
    s = CurrentSchedule(points=points)
    points[1].velocity[0] = 0.9  # the caller's list changes; the schedule does not
    assert s.at(5.0)[0] == 0.2
    with pytest.raises(ValueError, match="read-only"):
        s.velocities[0, 0] = 1.0
    with pytest.raises(AttributeError):
        s.foo = 1


def test_schedule_loads_from_yaml_with_drake():
    @dc.dataclass
    class Water:
        current: list[float] = dc.field(default_factory=lambda: [0.0, 0.0, 0.0])
        current_schedule: list[CurrentPoint] = dc.field(default_factory=list)

    w = yaml_load_typed(
        schema=Water,
        data="""
current_schedule:
  - {time: 0.0, velocity: [0.0, 0.0, 0.0]}
  - {time: 2.0, velocity: [0.2, 0.1, 0.0]}
""",
    )
    s = CurrentSchedule(w.current, w.current_schedule)
    np.testing.assert_allclose(s.at(1.0), [0.1, 0.05, 0.0], atol=1e-15)


@pytest.mark.parametrize(
    "points, constant, match",
    [
        (
            [CurrentPoint(-0.1)],
            [0, 0, 0],
            r"water.current_schedule\[0\].time: -0.1 is outside "
            r"the allowed range \[0, 3600\] s",
        ),
        (
            [CurrentPoint(0.0), CurrentPoint(4000.0)],
            [0, 0, 0],
            r"water.current_schedule\[1\].time: 4000.0 is outside",
        ),
        ([CurrentPoint(float("nan"))], [0, 0, 0], r"\[0\].time: nan is outside"),
        ([CurrentPoint(True)], [0, 0, 0], r"\[0\].time: True is outside"),
        (
            [CurrentPoint(2.0), CurrentPoint(1.0)],
            [0, 0, 0],
            r"water.current_schedule\[1\].time: 1.0 is before the previous key's time 2.0",
        ),
        (
            [CurrentPoint(0.0, [0.1, 0.0])],
            [0, 0, 0],
            r"water.current_schedule\[0\].velocity: \[0.1, 0.0\] must be 3 finite numbers",
        ),
        ([CurrentPoint(0.0, [0.1, float("inf"), 0.0])], [0, 0, 0], r"\[0\].velocity: .* finite"),
        (
            [CurrentPoint(0.0), CurrentPoint(1.0, [0.8, 0.8, 0.0])],
            [0, 0, 0],
            r"water.current_schedule\[1\].velocity: .* magnitude 1.13 m/s, outside the allowed "
            r"range \[0, 1\] m/s",
        ),
        ([CurrentPoint(0.0, "east")], [0, 0, 0], r"\[0\].velocity: 'east' must be"),
        ([(0.0, [0, 0, 0])], [0, 0, 0], r"water.current_schedule\[0\]: .* is not a CurrentPoint"),
        ([], [2.0, 0.0, 0.0], r"water.current: \[2.0, 0.0, 0.0\] has magnitude 2 m/s"),
        ([], [0.0, 0.0], r"water.current: .* must be 3 finite numbers"),
    ],
)
def test_bad_schedules_name_the_field_and_range(points, constant, match):
    with pytest.raises(ValueError, match=match):
        check_current_schedule(points, constant)
    with pytest.raises(ValueError, match=match):
        CurrentSchedule(constant, points)


def test_good_schedule_edges_pass():
    check_current_schedule(
        [
            CurrentPoint(0.0, [1.0, 0.0, 0.0]),
            CurrentPoint(0.0),
            CurrentPoint(3600.0, [0.0, -1.0, 0.0]),
        ],
        [0.0, 0.0, 1.0],
    )


# --- HydrodynamicForces with a schedule -------------------------------------------------------


def _hydro(inputs: str, backend: str, **kwargs):
    """(hydro, its context, PlantHandles, the plant's context) in one diagram."""
    builder = DiagramBuilder()
    h = add_plant(builder, hydro=COEFFS)
    hydro = HydrodynamicForces.AddToBuilder(
        builder,
        h.plant,
        h.robot,
        COEFFS,
        1e-3,
        added_mass_iso=h.added_mass_iso,
        inputs=inputs,
        backend=backend,
        **kwargs,
    )
    diagram = builder.Build()
    context = diagram.CreateDefaultContext()
    hydro_context = hydro.GetMyMutableContextFromRoot(context)
    hydro.GetInputPort("balloon_volume").FixValue(hydro_context, [0.0])
    return hydro, context, h, h.plant.GetMyMutableContextFromRoot(context)


def _hull_force(hydro, context) -> np.ndarray:
    forces = hydro.GetOutputPort("spatial_forces").Eval(hydro.GetMyContextFromRoot(context))
    return np.array([f.F_Bq_W.get_coeffs() for f in forces])


@pytest.mark.slow
@pytest.mark.parametrize("inputs", ["plant_state", "contract"])
def test_robot_at_rest_in_a_current_ramp_feels_the_damping_of_that_times_current(inputs):
    """The hull at rest deep under water, yawed 30 deg: the water moves past it at the
    schedule's current, so Eq. (2) gives (d_lin + d_quad |c_B|) c_B per hull axis, c_B
    the current in the hull's frame, at each time; the two backends agree to 1e-12."""
    schedule = CurrentSchedule(points=RAMP)
    yaw = np.radians(30.0)
    Rz = np.array([[np.cos(yaw), -np.sin(yaw), 0], [np.sin(yaw), np.cos(yaw), 0], [0, 0, 1]])
    d_lin = np.asarray(COEFFS.body.linear_damping.value[:3])
    d_quad = np.asarray(COEFFS.body.quadratic_damping.value[:3])
    Y_uv, Z_uw = COEFFS.body.body_lift.value[:2]
    results = {}
    for backend in ("compiled", "numpy"):
        hydro, context, h, plant_context = _hydro(inputs, backend, current_schedule=schedule)
        set_initial_state(
            h, plant_context, body_pose([0.0, 0.0, -1.0], [0.0, 0.0, 30.0]), np.zeros(16)
        )
        for t, c in ((2.5, [0.3, -0.15, 0.0]), (4.0, [0.4, -0.2, 0.05])):
            context.SetTime(t)
            F = _hull_force(hydro, context)
            c_B = Rz.T @ np.asarray(c)
            # The hull moves at -c_B through the water: Eq. (2) and the body lift
            # Y = -Y_uv |u| v, Z = -Z_uw |u| w of that.
            u, v, w = -c_B
            lift = -np.array([0.0, Y_uv * abs(u) * v, Z_uw * abs(u) * w])
            expected = Rz @ ((d_lin + d_quad * np.abs(c_B)) * c_B + lift)
            # x, y: damping only (buoyancy and the weight cancellation are vertical).
            np.testing.assert_allclose(F[0, 3:5], expected[:2], rtol=1e-12, atol=1e-14)
            assert np.linalg.norm(expected[:2]) > 0.1  # the current's drag is there
            results[backend, t] = F
    for t in (2.5, 4.0):
        np.testing.assert_allclose(
            results["compiled", t], results["numpy", t], rtol=1e-12, atol=1e-12
        )
    # The vertical key (0.05 m/s at t = 4) reaches the heave damping too.
    dz = results["numpy", 4.0][0, 5] - results["numpy", 2.5][0, 5]
    u_4 = abs((Rz.T @ np.array([0.4, -0.2, 0.0]))[0])
    heave = (
        COEFFS.body.linear_damping.value[2]
        + COEFFS.body.quadratic_damping.value[2] * 0.05
        + Z_uw * u_4
    )
    assert dz == pytest.approx(heave * 0.05, rel=1e-9)


@pytest.mark.parametrize("backend", ["compiled", "numpy"])
def test_varying_schedule_equals_a_fixed_current_of_that_time(backend, rng):
    """At a moving state (the fins' strips see the current too), the schedule read at t
    gives exactly the forces of a system whose fixed current is the schedule's at t."""
    schedule = CurrentSchedule(points=RAMP)
    varying, context, h, plant_context = _hydro("plant_state", backend, current_schedule=schedule)
    set_initial_state(
        h,
        plant_context,
        body_pose([0.1, -0.2, -0.1], [10.0, -20.0, 40.0]),
        rng.uniform(-1.0, 1.0, 16),
    )
    h.plant.SetVelocities(plant_context, rng.normal(scale=0.5, size=h.plant.num_velocities()))
    x = h.plant.GetPositionsAndVelocities(plant_context)
    v_prev = np.tile(np.r_[np.zeros(6), -1.0], 2)
    for t in (0.0, 2.2, 4.6, 7.0):
        fixed = HydrodynamicForces(
            h.plant,
            h.robot,
            COEFFS,
            1e-3,
            current=current_at(t, schedule.times, schedule.velocities),
            added_mass_iso=h.added_mass_iso,
            inputs="plant_state",
            backend=backend,
        )
        np.testing.assert_array_equal(
            varying.compute_from_state(x, 1e-3, t, v_prev),
            fixed.compute_from_state(x, 1e-3, t, v_prev),
        )
        context.SetTime(t)
        np.testing.assert_array_equal(
            _hull_force(varying, context), fixed.compute_from_state(x, 0.0, t, v_prev)
        )
    # The fixed (packed) parameters are untouched by the per-evaluation current.
    np.testing.assert_array_equal(varying.current, [0.0, 0.0, 0.0])
    np.testing.assert_array_equal(
        varying._packed[3],
        HydrodynamicForces(h.plant, h.robot, COEFFS, 1e-3, added_mass_iso=h.added_mass_iso)._packed[
            3
        ],
    )


@pytest.mark.parametrize("backend", ["compiled", "numpy"])
@pytest.mark.parametrize("inputs", ["plant_state", "contract"])
def test_constant_schedule_is_the_fixed_current_bitwise(inputs, backend, rng):
    c = [0.2, -0.1, 0.03]
    a, context_a, h, plant_context = _hydro(inputs, backend, current=c)
    b, context_b, hb, plant_context_b = _hydro(inputs, backend, current_schedule=CurrentSchedule(c))
    set_initial_state(
        h,
        plant_context,
        body_pose([0.0, 0.1, -0.05], [5.0, 10.0, -30.0]),
        rng.uniform(-1.0, 1.0, 16),
    )
    h.plant.SetVelocities(plant_context, rng.normal(scale=0.5, size=h.plant.num_velocities()))
    hb.plant.SetPositionsAndVelocities(
        plant_context_b, h.plant.GetPositionsAndVelocities(plant_context)
    )
    for t in (0.0, 3.0):
        context_a.SetTime(t)
        context_b.SetTime(t)
        np.testing.assert_array_equal(_hull_force(a, context_a), _hull_force(b, context_b))
    np.testing.assert_array_equal(b.current, c)
    assert b.current_schedule.is_constant and a.current_schedule is None


def test_hydro_rejects_a_bad_schedule_argument():
    builder = DiagramBuilder()
    h = add_plant(builder, hydro=COEFFS)
    with pytest.raises(
        ValueError,
        match="HydrodynamicForces.current_schedule: .* must be None or a CurrentSchedule",
    ):
        HydrodynamicForces(h.plant, h.robot, COEFFS, 1e-3, current_schedule=RAMP)
    with pytest.raises(
        ValueError,
        match=r"HydrodynamicForces.current: \(0.1, 0.0, 0.0\) "
        "differs from the current_schedule's constant",
    ):
        HydrodynamicForces(
            h.plant,
            h.robot,
            COEFFS,
            1e-3,
            current=(0.1, 0.0, 0.0),
            current_schedule=CurrentSchedule([0.2, 0.0, 0.0]),
        )
    # The schedule's own constant (what a scenario passes as both) is accepted.
    hydro = HydrodynamicForces(
        h.plant,
        h.robot,
        COEFFS,
        1e-3,
        current=(0.2, 0.0, 0.0),
        current_schedule=CurrentSchedule([0.2, 0.0, 0.0], RAMP),
    )
    np.testing.assert_array_equal(hydro.current, [0.0, 0.0, 0.0])  # the schedule at t = 0


def test_every_component_interpolates_from_nonzero_keys():
    """Keys whose three components all differ and none is zero, so each component's own
    index and its own key values are used (before, between and after the keys)."""
    points = [CurrentPoint(2.0, [0.1, -0.2, 0.3]), CurrentPoint(6.0, [-0.3, 0.2, 0.5])]
    s = CurrentSchedule(points=points)
    for t, expected in (
        (0.0, [0.1, -0.2, 0.3]),
        (3.0, [0.0, -0.1, 0.35]),
        (5.0, [-0.2, 0.1, 0.45]),
        (8.0, [-0.3, 0.2, 0.5]),
    ):
        np.testing.assert_allclose(s.at(t), expected, rtol=0, atol=1e-15)
        np.testing.assert_allclose(
            current_at(t, s.times, s.velocities), expected, rtol=0, atol=1e-15
        )
