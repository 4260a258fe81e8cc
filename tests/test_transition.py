"""PotentialTransition (Eqs. 11-15): targets, descent on the torus, step bound."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from manta_drake.control.gaits import GAITS
from manta_drake.control.transition import (
    TIE_BAND,
    PotentialTransition,
    descent_step,
    potential,
    target_params,
    tie_broken_sine,
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


@pytest.mark.slow
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
    # converged
    assert np.abs(err[-1]).max() < 0.05
    # each step descends the potential of Eq. (14)
    W = potential(psi, psi_d, system.g, system.T)
    assert np.all(W[1:] <= W[:-1] + 1e-15)


def test_descent_step_closed_form():
    psi_d = np.array([0.0, 1.0, -2.0])
    psi = np.array([0.5, 1.0 + 4.0, -2.0 - 0.1])  # the second wraps to the short way round
    got = descent_step(psi, psi_d, g=0.2, T=0.5, alpha=0.95)
    e = np.array([0.5, 4.0 - 2 * np.pi, -0.1])
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


def test_tie_broken_sine_closed_form():
    e = np.array([0.0, 0.3, -1.0, np.pi - 0.25, np.pi - 0.2, np.pi, -np.pi + 0.1, -np.pi + 0.3])
    s = tie_broken_sine(e)
    np.testing.assert_allclose(s[[0, 1, 2, 3, 7]], np.sin(e[[0, 1, 2, 3, 7]]))
    np.testing.assert_allclose(s[[4, 5]], np.sin(0.25))  # e = pi counts as positive
    np.testing.assert_allclose(s[6], -np.sin(0.25))
    assert TIE_BAND == 0.25
    # Continuous at the band's edge, never larger than |e|.
    edge = np.pi - TIE_BAND
    assert tie_broken_sine(edge + 1e-12) == pytest.approx(tie_broken_sine(edge - 1e-12))
    grid = np.linspace(-np.pi, np.pi, 10001)[1:]
    assert np.all(np.abs(tie_broken_sine(grid)) <= np.abs(grid) + 1e-15)


def test_exact_antipode_escapes_in_the_documented_direction():
    """Eq. (14)'s well has zero slope on the far side of the torus; the descent breaks the
    tie: a parameter exactly opposite its target steps down (e = pi wraps to +pi) by
    c sin(0.25) exp(-T (1 + cos 0.25)) per update, so leaves the band in ~0.9 s and
    arrives in a few seconds."""
    system = PotentialTransition()
    context = system.CreateDefaultContext()
    system.set_params(context, TROT + np.pi)
    psi = _run(system, context, 1.0, 0.0, 500)  # 10 s
    c = system.alpha * system.g * system.T
    first = c * np.sin(TIE_BAND) * np.exp(-system.T * (1.0 - np.cos(np.pi)))
    np.testing.assert_allclose(psi[1] - psi[0], -first, rtol=1e-9)
    leaves = np.argmax(np.abs(wrap(psi - TROT)).max(axis=1) < np.pi - TIE_BAND) * system.period
    assert 0.7 < leaves < 1.1, leaves
    assert np.abs(wrap(psi[-1] - TROT)).max() < 0.05


@pytest.mark.slow
@pytest.mark.parametrize("start, s_step, goal", [(TURN, 0.0, TROT), (TROT, 1.0, TURN)])
@pytest.mark.parametrize("tau", [0.0, 1.0])
def test_a_camera_step_does_not_strand_parameters_on_the_antipode(start, s_step, goal, tau):
    """psi exactly at one gait, s_hat steps (unfiltered: the Phi' entries that differ by pi
    land exactly opposite their new target; filtered: the target moves within a second):
    psi reaches the new gait within 30 s either way."""
    system = PotentialTransition(s_hat_time_constant=tau)
    context = system.CreateDefaultContext()
    system.set_params(context, start)
    if tau > 0:  # the filter settled on the old s_hat before the step
        index = system.filter_state_indices["s_hat"]
        context.get_mutable_discrete_state(index).SetAtIndex(0, 1.0 - s_step)
    psi = _run(system, context, 1.0, s_step, 1500)  # 30 s
    assert np.abs(wrap(psi[-1] - goal)).max() < 0.05, tau


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
    np.testing.assert_array_equal(
        target_params(0.49, 0.0, swim, trot, turning, blend="switch"), swim
    )
    np.testing.assert_array_equal(
        target_params(0.51, 0.0, swim, trot, turning, blend="switch"), trot
    )
    np.testing.assert_array_equal(
        target_params(0.9, 0.6, swim, trot, turning, blend="switch"), turning
    )
    system = PotentialTransition(blend="switch", follow="direct")
    context = system.CreateDefaultContext()
    system.GetInputPort("z_hat").FixValue(context, [1.0])
    system.GetInputPort("s_hat").FixValue(context, [0.0])
    context.SetDiscreteState(system.EvalUniquePeriodicDiscreteUpdate(context))
    np.testing.assert_array_equal(system.GetOutputPort("cpg_params").Eval(context), trot)
    with pytest.raises(ValueError, match="follow: 'jump' is not one of descent, direct"):
        PotentialTransition(follow="jump")


# -- the transition blends by a behaviour tree ---------------------------------------------


def _inputs(k):
    """Varying estimates for update k: a sinking and rising depth, a wall seen on and off,
    and now and then an out-of-range or non-finite sample."""
    z = 0.5 + 0.6 * np.sin(0.013 * k)  # spans [-0.1, 1.1]
    s = 1.0 if (k // 70) % 2 else 0.1 * np.cos(0.2 * k)
    if k % 97 == 13:
        z = np.nan
    if k % 89 == 5:
        s = np.inf
    return z, s


@pytest.mark.slow
@pytest.mark.parametrize(
    "blend, tau",
    [
        ("potential", 1.0),
        ("potential", 0.3),
        ("linear", 1.0),
        ("switch", 1.0),
        ("normalised", 0.5),
        ("potential", 0.0),
    ],
)
def test_default_tree_reproduces_the_formula_path_bit_for_bit(blend, tau):
    """An independent re-implementation of the transition's update with target_params and
    descent_step (Eqs. 11-15 and the s_hat low-pass), against the system."""
    z_t, period = 0.8, 0.02
    system = PotentialTransition(period=period, z_t=z_t, blend=blend, s_hat_time_constant=tau)
    context = system.CreateDefaultContext()
    gain = 1.0 - np.exp(-period / tau) if tau > 0 else None
    psi, s = SWIM.copy(), 0.0
    for k in range(400):
        z_hat, s_hat = _inputs(k)
        system.GetInputPort("z_hat").FixValue(context, [z_hat])
        system.GetInputPort("s_hat").FixValue(context, [s_hat])
        context.SetDiscreteState(system.EvalUniquePeriodicDiscreteUpdate(context))
        x = s_hat if np.isfinite(s_hat) else 0.0
        s = s + gain * (x - s) if gain is not None else x
        psi = descent_step(
            psi,
            target_params(z_hat, s, SWIM, TROT, TURN, z_t, blend),
            system.g,
            system.T,
            system.alpha,
        )
        np.testing.assert_array_equal(
            system.GetOutputPort("cpg_params").Eval(context), psi, err_msg=f"update {k}"
        )


def test_behaviour_weights_are_the_leaf_weights_of_the_last_target():
    system = PotentialTransition()  # s_hat filtered with tau = 1 s
    context = system.CreateDefaultContext()
    assert system.num_input_ports() == 2
    assert system.GetOutputPort("behaviour_weights").size() == 3
    # before any update: the weights at z_hat = s_hat = 0, all swim
    np.testing.assert_allclose(
        system.GetOutputPort("behaviour_weights").Eval(context), [1.0, 0.0, 0.0], atol=1e-15
    )
    system.GetInputPort("z_hat").FixValue(context, [0.4])
    system.GetInputPort("s_hat").FixValue(context, [1.0])
    for _ in range(10):
        context.SetDiscreteState(system.EvalUniquePeriodicDiscreteUpdate(context))
    s = 1.0 - np.exp(-10 * 0.02)  # the filtered wall rate after 10 updates
    w = (1 - np.cos(np.pi * s)) / 2
    c, d = np.cos(np.pi * 0.4 / 2), np.sin(np.pi * 0.4 / 2)
    np.testing.assert_allclose(
        system.GetOutputPort("behaviour_weights").Eval(context), [c, d * (1 - w), d * w], atol=1e-12
    )


def test_the_weights_switches_and_filters_start_from_the_initial_estimates():
    """On the floor at t = 0 (z_hat 1) and a wall already at half (s_hat 0.5): before any
    update the weights are Eq. (12)'s there, and the s_hat filter starts at 0.5, not 0."""
    system = PotentialTransition(initial_values={"z_hat": 1.0, "s_hat": 0.5})
    context = system.CreateDefaultContext()
    w = (1 - np.cos(np.pi * 0.5)) / 2
    np.testing.assert_allclose(
        system.GetOutputPort("behaviour_weights").Eval(context), [0.0, 1 - w, w], atol=1e-15
    )
    index = system.filter_state_indices["s_hat"]
    assert context.get_discrete_state(index).GetAtIndex(0) == 0.5
    from manta_drake.control.behaviour_tree import BlendNode, compile_tree

    tree = compile_tree(
        {"root": BlendNode("floor_hat", "switch", ["swim", "trot"], threshold=0.5, hysteresis=0.2)},
        {"swim": SWIM, "trot": TROT},
    )
    on_floor = PotentialTransition(tree=tree, initial_values={"floor_hat": 0.9})
    np.testing.assert_array_equal(
        on_floor.GetOutputPort("behaviour_weights").Eval(on_floor.CreateDefaultContext()),
        [0.0, 1.0],
    )  # the switch starts on the trot's side


def test_a_tree_of_other_modalities_sets_the_ports_filters_and_switch_memory():
    from manta_drake.control.behaviour_tree import BlendNode, compile_tree

    walk = GAITS["walk"].to_vector()
    tree = compile_tree(
        {
            "root": BlendNode(
                "energy_hat", "switch", ["moving", "swim"], threshold=0.5, hysteresis=0.4
            ),
            "moving": BlendNode("flow_hat", "linear", ["trot", "walk"]),
        },
        {"swim": SWIM, "trot": TROT, "walk": walk},
    )
    system = PotentialTransition(follow="direct", tree=tree, time_constants={"flow_hat": 0.5})
    assert [system.get_input_port(i).get_name() for i in range(system.num_input_ports())] == [
        "energy_hat",
        "flow_hat",
    ]  # in the order the tree reads them
    assert system.tree is tree and set(system.filter_state_indices) == {"flow_hat"}
    context = system.CreateDefaultContext()
    assert tree.leaves == ("trot", "walk", "swim")  # depth first
    # psi starts at the first leaf
    np.testing.assert_array_equal(system.GetOutputPort("cpg_params").Eval(context), TROT)
    system.GetInputPort("flow_hat").FixValue(context, [1.0])
    held = []
    for energy in (0.2, 0.6, 0.71, 0.5, 0.31, 0.29, 0.5):
        system.GetInputPort("energy_hat").FixValue(context, [energy])
        context.SetDiscreteState(system.EvalUniquePeriodicDiscreteUpdate(context))
        held.append(system.GetOutputPort("behaviour_weights").Eval(context)[2])  # swim's
    # on at >= 0.7, off below 0.3, held in between
    assert held == [0.0, 0.0, 1.0, 1.0, 1.0, 0.0, 0.0]
    # flow_hat passed the 0.5 s low-pass for 7 updates; the target is linear in it
    f = 1.0 - np.exp(-7 * 0.02 / 0.5)
    np.testing.assert_allclose(
        system.GetOutputPort("cpg_params").Eval(context), (walk - TROT) * f + TROT, atol=1e-12
    )
    np.testing.assert_allclose(
        system.GetOutputPort("behaviour_weights").Eval(context), [1 - f, f, 0.0], atol=1e-12
    )
    np.testing.assert_array_equal(system.target(flow_hat=0.0, energy_hat=1.0), SWIM)


def test_tree_arguments_are_checked():
    with pytest.raises(ValueError, match="PotentialTransition.tree: expected a BehaviourTree"):
        PotentialTransition(tree={"root": None})
    with pytest.raises(ValueError, match="PotentialTransition.time_constants: 'depth' is not"):
        PotentialTransition(time_constants={"depth": 1.0})
    with pytest.raises(ValueError, match=r"PotentialTransition.time_constants.z_hat: -1.0"):
        PotentialTransition(time_constants={"z_hat": -1.0})
    with pytest.raises(ValueError, match="PotentialTransition.behaviours: expected 3"):
        PotentialTransition(behaviours=("swim", "trot"))
    with pytest.raises(
        ValueError,
        match="PotentialTransition.blend: 'cubic' is not one of "
        "potential, normalised, linear, switch",
    ):
        PotentialTransition(blend="cubic")
