"""PotentialTransition (Eqs. 11-15): targets, descent on the torus, step bound."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from manta_drake.control.gaits import GAITS
from manta_drake.control.transition import (
    PotentialTransition,
    descent_step,
    potential,
    target_params,
    vision_weight,
    wrap,
)

SWIM, TROT, TURN = (GAITS[n].to_vector() for n in ("swim", "trot", "turning"))


def test_targets_at_the_extremes():
    np.testing.assert_allclose(target_params(0.0, 0.0, SWIM, TROT, TURN), SWIM, atol=1e-12)
    np.testing.assert_allclose(target_params(1.0, 0.0, SWIM, TROT, TURN), TROT, atol=1e-12)
    np.testing.assert_allclose(target_params(1.0, 1.0, SWIM, TROT, TURN), TURN, atol=1e-12)
    np.testing.assert_allclose(target_params(0.0, 1.0, SWIM, TROT, TURN), SWIM, atol=1e-12)


def test_eq12_blend_in_between_and_eq11_option():
    z = 0.4
    a = (z - 1.0) * np.pi / 2  # the printed (z_hat - z_t) pi/2 with z_t = 1
    expected = -np.sin(a) * SWIM + np.cos(a) * TROT
    np.testing.assert_allclose(target_params(z, 0.0, SWIM, TROT, TURN), expected, atol=1e-12)
    linear = target_params(z, 0.0, SWIM, TROT, TURN, blend="linear")
    np.testing.assert_allclose(linear, (TROT - SWIM) * z + SWIM, atol=1e-12)
    # z_t < 1 finishes the change at z_hat = z_t
    np.testing.assert_allclose(target_params(0.8, 0.0, SWIM, TROT, TURN, z_t=0.8), TROT, atol=1e-12)


def test_vision_weight_follows_the_text_not_the_printed_sign():
    assert vision_weight(0.0) == 0.0  # no wall: trot (printed formula would give turning)
    assert vision_weight(1.0) == pytest.approx(1.0)  # wall: turning
    s = np.linspace(0, 1, 101)
    w = np.array([vision_weight(x) for x in s])
    assert np.all(np.diff(w) >= 0)


def _run(system, context, z_hat, s_hat, steps):
    system.GetInputPort("z_hat").FixValue(context, [z_hat])
    system.GetInputPort("s_hat").FixValue(context, [s_hat])
    out = [context.get_discrete_state(0).CopyToVector()]
    for _ in range(steps):
        context.SetDiscreteState(system.EvalUniquePeriodicDiscreteUpdate(context))
        out.append(context.get_discrete_state(0).CopyToVector())
    return np.array(out)


@settings(max_examples=25, deadline=None)
@given(st.integers(0, 2**31 - 1), st.floats(0, 1), st.floats(0, 1))
def test_converges_monotonically_without_overshoot_from_any_start(seed, z_hat, s_hat):
    system = PotentialTransition(s_hat_time_constant=0.0)  # a fixed target: pure descent
    context = system.CreateDefaultContext()
    start = np.random.default_rng(seed).uniform(-np.pi, np.pi, 64)  # anywhere on the torus
    system.set_params(context, start)
    psi = _run(system, context, z_hat, s_hat, 1500)  # 30 s
    psi_d = system.target(z_hat, s_hat)
    err = wrap(psi - psi_d)
    # monotone, no overshoot: |e| never grows and e never changes sign
    assert np.all(np.abs(err[1:]) <= np.abs(err[:-1]) + 1e-12)
    assert np.all(err[1:] * err[:-1] >= -1e-15)
    # no update moves a parameter by more than the stated bound alpha g T
    assert np.abs(np.diff(psi, axis=0)).max() <= system.max_step + 1e-12
    # converged (a start at the exact antipode would be the one equilibrium to escape slowly)
    assert np.abs(err[-1]).max() < 0.05
    # each step descends the potential of Eq. (14)
    W = potential(psi, psi_d, system.g, system.T)
    assert np.all(W[1:] <= W[:-1] + 1e-15)


def test_descent_step_closed_form():
    psi_d = np.array([0.0, 1.0, -2.0])
    psi = np.array([0.5, 1.0 + 3.0, -2.0 - 0.1])  # the second wraps to the short way round
    got = descent_step(psi, psi_d, g=0.2, T=0.5, alpha=0.95)
    e = np.array([0.5, 3.0, -0.1])
    expected = psi - 0.95 * 0.2 * 0.5 * np.sin(e) * np.exp(-0.5 * (1 - np.cos(e)))
    np.testing.assert_allclose(got, expected)


def test_swim_to_trot_takes_a_few_seconds():
    """z_hat ramps from 0 to 1 over 2 s (the robot sinking); psi reaches trot in seconds."""
    system = PotentialTransition()
    context = system.CreateDefaultContext()
    system.set_params(context, SWIM)
    psi = [SWIM]
    for k in range(1000):
        z = min(1.0, k * system.period / 2.0)
        psi.append(_run(system, context, z, 0.0, 1)[-1])
    err = np.abs(wrap(np.array(psi) - TROT)).max(axis=1)
    assert err[-1] < 1e-3
    arrival = np.argmax(err < 0.05) * system.period
    assert 2.0 < arrival < 10.0, arrival


def test_exact_antipode_is_the_one_equilibrium_besides_the_target():
    """Eq. (14)'s well has zero slope on the far side of the torus: a parameter exactly
    opposite its target does not move (documented limitation; never reached in practice
    because psi_d moves continuously with z_hat)."""
    system = PotentialTransition()
    context = system.CreateDefaultContext()
    system.set_params(context, TROT + np.pi)
    psi = _run(system, context, 1.0, 0.0, 50)
    np.testing.assert_allclose(psi[-1], TROT + np.pi, atol=1e-9)


@pytest.mark.parametrize("start, s_step, goal", [(TURN, 0.0, TROT), (TROT, 1.0, TURN)])
def test_camera_step_does_not_strand_parameters_on_the_antipode(start, s_step, goal):
    """psi exactly at one gait, s_hat steps: unfiltered, Phi' entries sit opposite their new
    target and never move; with the s_hat filter psi reaches the new gait in seconds."""
    for tau, arrives in ((0.0, False), (1.0, True)):
        system = PotentialTransition(s_hat_time_constant=tau)
        context = system.CreateDefaultContext()
        system.set_params(context, start)
        if tau > 0:  # the filter settled on the old s_hat before the step
            index = system.filter_state_indices["s_hat"]
            context.get_mutable_discrete_state(index).SetAtIndex(0, 1.0 - s_step)
        psi = _run(system, context, 1.0, s_step, 1500)  # 30 s
        err = np.abs(wrap(psi[-1] - goal)).max()
        assert (err < 0.05) == arrives, (tau, err)


def test_s_hat_filter_is_first_order():
    system = PotentialTransition(s_hat_time_constant=1.0)
    context = system.CreateDefaultContext()
    system.GetInputPort("z_hat").FixValue(context, [1.0])
    system.GetInputPort("s_hat").FixValue(context, [1.0])
    for _ in range(50):  # 1 s
        context.SetDiscreteState(system.EvalUniquePeriodicDiscreteUpdate(context))
    index = system.filter_state_indices["s_hat"]
    assert context.get_discrete_state(index).GetAtIndex(0) == pytest.approx(1 - np.exp(-1.0))


def test_bad_parameters_are_rejected():
    with pytest.raises(ValueError, match="overshoot"):
        PotentialTransition(g=5.0, T=1.0, alpha=0.95)
    with pytest.raises(ValueError, match="z_t"):
        PotentialTransition(z_t=1.5)
    with pytest.raises(ValueError, match="blend"):
        PotentialTransition(blend="cubic")
    with pytest.raises(ValueError, match="s_hat_time_constant"):
        PotentialTransition(s_hat_time_constant=-1.0)


def test_switch_baseline_is_abrupt_and_direct_follow_takes_the_target_at_once():
    from manta_drake.control.transition import target_params

    swim, trot, turning = (GAITS[n].to_vector() for n in ("swim", "trot", "turning"))
    np.testing.assert_array_equal(target_params(0.49, 0.0, swim, trot, turning, blend="switch"), swim)
    np.testing.assert_array_equal(target_params(0.51, 0.0, swim, trot, turning, blend="switch"), trot)
    np.testing.assert_array_equal(target_params(0.9, 0.6, swim, trot, turning, blend="switch"),
                                  turning)
    system = PotentialTransition(blend="switch", follow="direct")
    context = system.CreateDefaultContext()
    system.GetInputPort("z_hat").FixValue(context, [1.0])
    system.GetInputPort("s_hat").FixValue(context, [0.0])
    context.SetDiscreteState(system.EvalUniquePeriodicDiscreteUpdate(context))
    np.testing.assert_array_equal(system.GetOutputPort("cpg_params").Eval(context), trot)
    with pytest.raises(ValueError, match="follow: 'jump' is not one of descent, direct"):
        PotentialTransition(follow="jump")
