"""HeadingHold: the PI(D) heading autopilot and its differential fin-amplitude trim."""

import dataclasses as dc

import numpy as np
import pytest
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import ConstantVectorSource

from manta_drake.control.gaits import GAITS
from manta_drake.control.heading_hold import (
    HeadingHold,
    HeadingHoldParams,
    apply_trim,
    heading_trim_step,
)
from manta_drake.control.posture import PostureEstimator

SWIM = GAITS["swim"].to_vector()
TROT = GAITS["trot"].to_vector()
T = 0.02


def _params(**kw):
    base = {"enabled": True, "kp": 0.0, "ki": 0.0, "kd": 0.0, "max_trim": 0.5, "period": T}
    return HeadingHoldParams(**{**base, **kw}).validate()


# --- the autopilot -----------------------------------------------------------------------------


def test_positive_error_asks_for_a_right_turn_as_more_left_flapping():
    """yaw above the target (turned left, counter-clockwise from above) gives u > 0, which
    raises the left fins' flapping and lowers the right fins' (turn_sign = +1); turn_sign
    -1 reverses the trim."""
    _, u = heading_trim_step(0.0, 0.2, 0.0, 0.0, _params(kp=0.5))
    assert u == pytest.approx(0.1)
    trimmed = apply_trim(SWIM, u, 1.0).reshape(4, 4, 4)[0]  # R
    R = SWIM.reshape(4, 4, 4)[0]
    assert np.all(trimmed[[0, 2]][:, [1, 3]] > R[[0, 2]][:, [1, 3]])  # fl, rl flap more
    assert np.all(trimmed[[1, 3]][:, [1, 3]] < R[[1, 3]][:, [1, 3]])  # fr, rr flap less
    _, u_reversed = heading_trim_step(0.0, 0.2, 0.0, 0.0, _params(kp=0.5, turn_sign=-1))
    assert u_reversed == -u
    # Turning left (positive yaw rate) also asks for the right turn, through kd.
    assert heading_trim_step(0.0, 0.0, 0.3, 0.0, _params(kd=0.5))[1] == pytest.approx(0.15)


def test_pid_closed_form_on_a_yaw_ramp():
    """yaw_k = c k T, target 0, yaw rate c: I_n = c T^2 n (n + 1) / 2 and
    u_n = kp c n T + ki I_n + kd c while unsaturated."""
    c, kp, ki, kd = 0.05, 0.8, 0.3, 0.4
    p = _params(kp=kp, ki=ki, kd=kd, max_trim=0.9)
    integral = 0.0
    for n in range(1, 201):
        integral, u = heading_trim_step(integral, c * n * T, c, 0.0, p)
        assert integral == pytest.approx(c * T**2 * n * (n + 1) / 2, rel=1e-12)
        assert u == pytest.approx(kp * c * n * T + ki * integral + kd * c, rel=1e-12)
    assert u < 0.9  # never saturated


def test_the_integral_is_weighted_by_the_swim_share():
    p = _params(ki=1.0)
    assert heading_trim_step(0.0, 0.1, 0.0, 0.0, p, share=0.25)[0] == pytest.approx(0.1 * 0.25 * T)
    assert heading_trim_step(0.07, 0.1, 0.0, 0.0, p, share=0.0)[0] == 0.07  # walking: frozen


def test_heading_error_is_wrapped():
    """Target 179 deg, yaw -179 deg: the robot is 2 deg counter-clockwise of the target."""
    p = _params(kp=1.0)
    _, u = heading_trim_step(0.0, np.radians(-179.0), 0.0, np.radians(179.0), p)
    assert u == pytest.approx(np.radians(2.0), rel=1e-9)


def test_saturation_and_anti_windup():
    """A constant error e = 0.4 rad with kp = 0.1, ki = 1, max_trim = 0.3: the integral
    grows by e T = 0.008 per update while kp e + ki I <= 0.3, i.e. for 32 updates
    (0.04 + 0.256 = 0.296), then stops for good; the trim never exceeds max_trim, and when
    the error reverses the integral unwinds at once."""
    p = _params(kp=0.1, ki=1.0, max_trim=0.3)
    integral, history = 0.0, []
    for _ in range(300):
        integral, u = heading_trim_step(integral, 0.4, 0.0, 0.0, p)
        history.append((integral, u))
    integrals, trims = np.array(history).T
    np.testing.assert_allclose(integrals[:32], 0.008 * np.arange(1, 33), rtol=1e-12)
    assert np.all(integrals[32:] == integrals[31])  # stops growing at saturation
    assert integrals[-1] == pytest.approx(0.256)
    assert np.all(trims <= 0.3)
    # A proportional action alone beyond the bound: u = max_trim and the integral never grows.
    integral = 0.0
    for _ in range(100):
        integral, u = heading_trim_step(
            integral, 1.0, 0.0, 0.0, _params(kp=0.5, ki=1.0, max_trim=0.3)
        )
        assert integral == 0.0 and u == 0.3
    # The error reverses: the held integral starts unwinding at the first update.
    integral2, u2 = heading_trim_step(integrals[-1], -0.1, 0.0, 0.0, p)
    assert integral2 == pytest.approx(0.256 - 0.1 * T) and u2 == pytest.approx(-0.01 + integral2)


def test_integral_clamped_to_the_trim_bound_and_zero_without_integral_action():
    p = _params(ki=2.0, max_trim=0.3)
    assert heading_trim_step(10.0, 0.0, 0.0, 0.0, p) == (pytest.approx(0.15), pytest.approx(0.3))
    assert heading_trim_step(-10.0, 0.0, 0.0, 0.0, p)[0] == pytest.approx(-0.15)
    assert heading_trim_step(3.0, 0.5, 0.0, 0.0, _params(kp=0.1))[0] == 0.0


# --- the trim ----------------------------------------------------------------------------------


def test_trim_scales_only_the_roll_amplitudes_in_the_stated_ratio():
    u, share = 0.2, 0.5  # s u = 0.1
    out = apply_trim(SWIM, u, share)
    changed = np.zeros((4, 4, 4), dtype=bool)
    changed[0][np.ix_([0, 1, 2, 3], [1, 3])] = True  # R's roll1, roll2 of every fin
    flat = changed.ravel()
    np.testing.assert_array_equal(out[~flat], SWIM[~flat])  # the other 56 entries: bitwise
    R, R0 = out[:16].reshape(4, 4), SWIM[:16].reshape(4, 4)
    np.testing.assert_allclose(R[[0, 2]][:, [1, 3]], 1.1 * np.pi / 4, rtol=1e-15)
    np.testing.assert_allclose(R[[1, 3]][:, [1, 3]], 0.9 * np.pi / 4, rtol=1e-15)
    np.testing.assert_allclose(R[0, [1, 3]] / R[1, [1, 3]], 1.1 / 0.9, rtol=1e-14)
    assert R0[0, 1] == np.pi / 4  # the input is not modified
    np.testing.assert_allclose(
        apply_trim(SWIM, -u, share)[:16].reshape(4, 4)[[0, 2]][:, [1, 3]],
        0.9 * np.pi / 4,
        rtol=1e-15,
    )


def test_no_trim_is_the_input_itself():
    assert apply_trim(SWIM, 0.2, 0.0) is SWIM
    assert apply_trim(SWIM, 0.0, 1.0) is SWIM
    assert apply_trim(TROT, 0.2, np.nan) is TROT
    assert apply_trim(TROT, 0.2, -0.5) is TROT
    with pytest.raises(ValueError, match=r"apply_trim: share \* u = 1.0 is outside \(-1, 1\)"):
        apply_trim(SWIM, 1.0, 1.0)
    # A share above 1 counts as 1.
    np.testing.assert_array_equal(apply_trim(SWIM, 0.2, 3.0), apply_trim(SWIM, 0.2, 1.0))


# --- the system --------------------------------------------------------------------------------


def _fix(system, context, cpg=SWIM, yaw=0.0, yaw_rate=0.0, share=1.0):
    system.GetInputPort("cpg_params").FixValue(context, cpg)
    system.GetInputPort("attitude_hat").FixValue(context, [0.01, -0.02, yaw])
    system.GetInputPort("yaw_rate_hat").FixValue(context, [yaw_rate])
    system.GetInputPort("swim_share").FixValue(context, [share])


def _update(system, context, **inputs):
    _fix(system, context, **inputs)
    context.SetDiscreteState(
        system.EvalUniquePeriodicDiscreteUpdate(context).get_vector().CopyToVector()
    )
    return system.GetOutputPort("heading_trim").Eval(context)[0]


def test_disabled_or_share_zero_is_bitwise_identity():
    disabled = HeadingHold()  # the default: disabled
    assert disabled.params.enabled is False
    context = disabled.CreateDefaultContext()
    _fix(disabled, context, cpg=SWIM, yaw=1.0)
    out = disabled.GetOutputPort("cpg_params").Eval(context)
    assert out.tobytes() == SWIM.tobytes()
    assert disabled.GetOutputPort("heading_trim").Eval(context)[0] == 0.0
    assert disabled.GetUniquePeriodicDiscreteUpdateAttribute() is None  # no update declared
    # Enabled, a trim held in the state, but the share is 0: the trot passes bitwise.
    system = HeadingHold(_params(kp=1.0, heading_deg=0.0))
    assert system.GetUniquePeriodicDiscreteUpdateAttribute().period_sec() == T
    context = system.CreateDefaultContext()
    assert _update(system, context, cpg=TROT, yaw=0.2, share=0.0) == pytest.approx(0.2)
    out = system.GetOutputPort("cpg_params").Eval(context)
    assert out.tobytes() == TROT.tobytes()
    system.GetInputPort("swim_share").FixValue(context, [np.nan])
    assert system.GetOutputPort("cpg_params").Eval(context).tobytes() == TROT.tobytes()


def test_system_follows_the_closed_form_and_captures_the_first_heading():
    """heading_deg None: the target is the yaw at the first update (e = 0 there); then a
    yaw ramp of c per update period gives the closed form of the ramp test shifted by one."""
    c, kp, ki, kd = 0.05, 0.8, 0.3, 0.4
    system = HeadingHold(_params(kp=kp, ki=ki, kd=kd, max_trim=0.9))
    context = system.CreateDefaultContext()
    yaw0 = 2.5
    assert _update(system, context, yaw=yaw0, yaw_rate=0.0) == 0.0
    assert context.get_discrete_state_vector().GetAtIndex(1) == yaw0
    for n in range(1, 60):
        u = _update(system, context, yaw=yaw0 + c * n * T, yaw_rate=c)
        integral = c * T**2 * n * (n + 1) / 2
        assert u == pytest.approx(kp * c * n * T + ki * integral + kd * c, rel=1e-9)
    # The output is the trimmed input at the current u and share.
    system.GetInputPort("swim_share").FixValue(context, [0.5])
    R = system.GetOutputPort("cpg_params").Eval(context)[:16].reshape(4, 4)
    np.testing.assert_allclose(R[[0, 2]][:, [1, 3]], (1 + 0.5 * u) * np.pi / 4, rtol=1e-14)
    np.testing.assert_allclose(R[[1, 3]][:, [1, 3]], (1 - 0.5 * u) * np.pi / 4, rtol=1e-14)


def test_system_holds_through_a_dropout_and_honours_a_given_heading():
    system = HeadingHold(_params(kp=1.0, ki=0.5, heading_deg=-90.0))
    context = system.CreateDefaultContext()
    assert context.get_discrete_state_vector().GetAtIndex(1) == pytest.approx(-np.pi / 2)
    u = _update(system, context, yaw=-np.pi / 2 + 0.1)
    assert u == pytest.approx(0.1 + 0.5 * 0.1 * T)
    held = context.get_discrete_state_vector().CopyToVector()
    _update(system, context, yaw=np.nan)
    np.testing.assert_array_equal(context.get_discrete_state_vector().CopyToVector(), held)
    _update(system, context, yaw=0.3, yaw_rate=np.inf)
    np.testing.assert_array_equal(context.get_discrete_state_vector().CopyToVector(), held)


def test_feedthrough_on_the_cpg_params_and_share_only():
    system = HeadingHold(_params(kp=1.0))
    out = system.GetOutputPort("cpg_params").get_index()
    trim = system.GetOutputPort("heading_trim").get_index()
    port = {
        name: system.GetInputPort(name).get_index()
        for name in ("cpg_params", "attitude_hat", "yaw_rate_hat", "swim_share")
    }
    assert system.HasDirectFeedthrough(port["cpg_params"], out)
    assert system.HasDirectFeedthrough(port["swim_share"], out)
    assert not system.HasDirectFeedthrough(port["attitude_hat"], out)
    assert not system.HasDirectFeedthrough(port["yaw_rate_hat"], out)
    assert not any(system.HasDirectFeedthrough(i, trim) for i in port.values())


def test_in_a_simulator_the_pi_trim_reaches_its_closed_form():
    """A constant 0.1 rad error, kp = 0.5, ki = 0.1: at t = 1.01 s the updates at 0, 0.02,
    ..., 1.0 (51) have run, I = 51 e T and u = kp e + ki I; the swim's left roll amplitudes
    are pi/4 (1 + u), the right ones pi/4 (1 - u)."""
    builder = DiagramBuilder()
    system = builder.AddSystem(HeadingHold(_params(kp=0.5, ki=0.1, heading_deg=0.0)))
    for name, value in (
        ("cpg_params", SWIM),
        ("attitude_hat", [0.0, 0.0, 0.1]),
        ("yaw_rate_hat", [0.0]),
        ("swim_share", [1.0]),
    ):
        source = builder.AddSystem(ConstantVectorSource(np.asarray(value, dtype=float)))
        builder.Connect(source.get_output_port(), system.GetInputPort(name))
    simulator = Simulator(builder.Build())
    simulator.AdvanceTo(1.01)
    context = system.GetMyContextFromRoot(simulator.get_context())
    u = 0.5 * 0.1 + 0.1 * 51 * 0.1 * T
    assert system.GetOutputPort("heading_trim").Eval(context)[0] == pytest.approx(u, rel=1e-12)
    R = system.GetOutputPort("cpg_params").Eval(context)[:16].reshape(4, 4)
    np.testing.assert_allclose(R[[0, 2]][:, [1, 3]], np.pi / 4 * (1 + u), rtol=1e-12)
    np.testing.assert_allclose(R[[1, 3]][:, [1, 3]], np.pi / 4 * (1 - u), rtol=1e-12)


def test_behind_the_posture_estimator_the_first_heading_is_the_imus():
    """heading_deg None: the hold's update at t = 0 reads attitude_hat, which the
    estimator's initialization event has already set to the IMU's yaw (not its default 0),
    so the target is the heading the robot starts at and a robot that keeps it gets no
    trim."""
    builder = DiagramBuilder()
    posture = builder.AddSystem(PostureEstimator(period=T))
    system = builder.AddSystem(HeadingHold(_params(kp=1.0, ki=0.5)))
    yaw = np.radians(-135.0)
    imu = builder.AddSystem(ConstantVectorSource([0.0, 0.0, yaw, 0, 0, 0, 0, 0, 9.81]))
    builder.Connect(imu.get_output_port(), posture.get_input_port())
    for name in ("attitude_hat", "yaw_rate_hat"):
        builder.Connect(posture.GetOutputPort(name), system.GetInputPort(name))
    for name, value in (("cpg_params", SWIM), ("swim_share", [1.0])):
        source = builder.AddSystem(ConstantVectorSource(np.asarray(value, dtype=float)))
        builder.Connect(source.get_output_port(), system.GetInputPort(name))
    simulator = Simulator(builder.Build())
    simulator.AdvanceTo(0.5)
    context = system.GetMyContextFromRoot(simulator.get_context())
    assert context.get_discrete_state_vector().GetAtIndex(1) == pytest.approx(yaw, rel=1e-12)
    assert system.GetOutputPort("heading_trim").Eval(context)[0] == 0.0


@pytest.mark.parametrize(
    "change, message",
    [
        ({"enabled": 1}, r"enabled: 1 is not true or false"),
        ({"kp": -0.1}, r"kp: -0.1 is outside the allowed range \[0, 100\] 1/rad"),
        ({"ki": 101.0}, r"ki: 101.0 is outside the allowed range \[0, 100\] 1/\(rad s\)"),
        ({"kd": np.inf}, r"kd: inf is not finite"),
        ({"max_trim": 1.0}, r"max_trim: 1.0 is outside the allowed range \[0, 1\)"),
        ({"max_trim": -0.1}, r"max_trim: -0.1 is outside the allowed range \[0, 1\)"),
        ({"heading_deg": 190.0}, r"heading_deg: 190.0 is outside the allowed range \[-180, 180\]"),
        ({"heading_deg": "north"}, r"heading_deg: 'north' is not a number"),
        ({"period": 0.0}, r"period: 0.0 is outside the allowed range \(0, 1\] s"),
        ({"turn_sign": 0}, r"turn_sign: 0 is not \+1 or -1"),
        ({"turn_sign": 2.0}, r"turn_sign: 2.0 is not \+1 or -1"),
    ],
)
def test_every_parameter_error_names_the_field_and_range(change, message):
    with pytest.raises(ValueError, match=message):
        dc.replace(HeadingHoldParams(), **change).validate()
    with pytest.raises(ValueError, match=message):
        HeadingHold(dc.replace(HeadingHoldParams(), **change))


def test_default_gains_ask_for_about_9_percent_at_10_degrees():
    """The documented starting point: with the default gains a 10 deg heading error asks for
    ~9 % more flapping on one side (kp e = 0.5 x 0.1745 = 0.087, plus one update of the
    small integral action)."""
    p = HeadingHoldParams().validate()
    e = np.radians(10.0)
    _, u = heading_trim_step(0.0, e, 0.0, 0.0, p)
    assert 0.085 < u < 0.095
    assert u == pytest.approx(p.kp * e + p.ki * e * p.period, rel=1e-12)


def test_swim_share_input_is_clipped_to_0_1_before_it_weights_the_integral():
    """A share of 3 counts as 1 (the integral grows by e T, not 3 e T); a negative share
    as 0 (the integral is frozen and the input passes unchanged)."""
    e = 0.1
    for share, integral in ((3.0, e * T), (1.0, e * T), (-0.5, 0.0)):
        system = HeadingHold(_params(ki=1.0, heading_deg=0.0))
        context = system.CreateDefaultContext()
        _update(system, context, yaw=e, share=share)
        assert context.get_discrete_state_vector().GetAtIndex(0) == pytest.approx(
            integral, abs=1e-15
        )
    assert system.GetOutputPort("cpg_params").Eval(context).tobytes() == SWIM.tobytes()


@pytest.mark.parametrize("heading", [-180.0, 180.0])
def test_heading_edges_pass_and_wrap_to_the_same_target(heading):
    """-180 and 180 deg are both allowed and are one heading: the target pi, in (-pi, pi]."""
    context = HeadingHold(_params(heading_deg=heading)).CreateDefaultContext()
    assert context.get_discrete_state_vector().GetAtIndex(1) == pytest.approx(np.pi, rel=1e-15)
    with pytest.raises(ValueError, match=r"heading_deg: -190.0 is outside the allowed range"):
        _params(heading_deg=-190.0)


# --- changes of the held heading ---------------------------------------------------------------


def test_changed_targets_by_hand():
    from manta_drake.control.heading_hold import HeadingChange, changed_targets

    changes = [
        HeadingChange(time=5.0, heading_deg=90.0),
        HeadingChange(modality="s_hat", above=0.8, turn_deg=180.0),
    ]
    # Neither is due: the target stays.
    assert changed_targets(0.3, 1.0, 4.9, {"s_hat": 0.5}, changes, (False, False)) == (
        0.3,
        (False, False),
    )
    # The wall is seen: the heading then (1.0 rad) plus pi, wrapped.
    target, done = changed_targets(0.3, 1.0, 4.9, {"s_hat": 0.9}, changes, (False, False))
    assert target == pytest.approx(1.0 + np.pi - 2 * np.pi) and done == (False, True)
    # Later the time comes: 90 deg; the wall change made already does not come again.
    target, done = changed_targets(target, 0.0, 6.0, {"s_hat": 0.95}, changes, done)
    assert target == pytest.approx(np.pi / 2) and done == (True, True)
    # A NaN estimate triggers nothing.
    assert changed_targets(0.3, 1.0, 0.0, {"s_hat": np.nan}, changes[1:], (False,))[1] == (False,)


def test_the_system_turns_back_when_the_wall_is_seen_and_restarts_its_integral():
    from manta_drake.control.heading_hold import HeadingChange

    p = _params(
        kp=1.0,
        ki=0.5,
        heading_deg=0.0,
        changes=[HeadingChange(modality="s_hat", above=0.8, turn_deg=180.0)],
    )
    system = HeadingHold(p)
    context = system.CreateDefaultContext()
    system.GetInputPort("s_hat").FixValue(context, [0.1])
    _update(system, context, yaw=0.2)
    assert system.target(context) == 0.0
    assert context.get_discrete_state_vector().GetAtIndex(0) != 0.0  # an integral built up
    system.GetInputPort("s_hat").FixValue(context, [0.9])
    u = _update(system, context, yaw=0.2)
    assert system.target(context) == pytest.approx(0.2 + np.pi - 2 * np.pi)
    # e = wrap(0.2 - (0.2 - pi)) = pi: the integral restarted, and the saturated trim does
    # not wind it up again (conditional integration).
    assert context.get_discrete_state_vector().GetAtIndex(0) == 0.0
    assert u == pytest.approx(p.max_trim)
    assert context.get_discrete_state_vector().GetAtIndex(4) == 1.0  # made, once


@pytest.mark.parametrize(
    "change, message",
    [
        ({}, "changes\\[0\\]: give either time or modality"),
        ({"time": 3.0, "modality": "s_hat", "turn_deg": 90.0}, "give either time or modality"),
        ({"time": 3.0}, "changes\\[0\\]: give either heading_deg .* or turn_deg"),
        ({"modality": "a b", "turn_deg": 90.0}, "changes\\[0\\].modality: 'a b' is not an "),
        ({"time": 3.0, "turn_deg": 400.0}, "changes\\[0\\].turn_deg: 400.0 is outside"),
        ({"modality": "s_hat", "above": 1.0, "turn_deg": 90.0}, "changes\\[0\\].above: 1.0"),
    ],
)
def test_a_bad_change_names_its_field(change, message):
    from manta_drake.control.heading_hold import HeadingChange

    with pytest.raises(ValueError, match=message):
        _params(changes=[HeadingChange(**change)])


def test_a_change_on_an_estimate_outside_the_given_names_is_refused():
    from manta_drake.control.heading_hold import HeadingChange
    from manta_drake.modalities import ESTIMATES

    change = HeadingChange(modality="depth", turn_deg=90.0)
    with pytest.raises(ValueError, match="changes\\[0\\].modality: 'depth' is not one of z_hat"):
        HeadingHoldParams(changes=[change]).validate(ESTIMATES)
    assert HeadingHoldParams(changes=[change]).validate().changes == [change]  # any name
