"""BalloonRule: the balloon's fill from a 0-1 estimate, with hysteresis and a start time."""

import dataclasses as dc

import numpy as np
import pytest
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import ConstantVectorSource, TrajectorySource
from pydrake.trajectories import PiecewisePolynomial

from manta_drake.control.balloon_rule import (
    ABOVE,
    BELOW,
    NONE,
    BalloonRule,
    BalloonRuleParams,
    balloon_command,
    band,
    next_decision,
)

T = 0.02
SCHEDULED = 0.3
# threshold 0.5, hysteresis 0.25: the band [0.375, 0.625]; the fills differ from the schedule.
RULE = {
    "modality": "flow",
    "fill_above": 0.9,
    "fill_below": 0.05,
    "threshold": 0.5,
    "hysteresis": 0.25,
}


def test_decision_switches_only_past_the_band():
    p = BalloonRuleParams(**RULE).validate()
    assert band(p) == (0.375, 0.625)
    assert next_decision(NONE, 0.5, p) == NONE  # inside the band: no decision yet
    assert next_decision(NONE, 0.625, p) == NONE  # the edge itself is inside
    assert next_decision(NONE, 0.6251, p) == ABOVE
    assert next_decision(ABOVE, 0.45, p) == ABOVE  # below the threshold, inside the band: kept
    assert next_decision(ABOVE, 0.375, p) == ABOVE
    assert next_decision(ABOVE, 0.3749, p) == BELOW
    assert next_decision(BELOW, 0.6, p) == BELOW
    assert next_decision(BELOW, np.nan, p) == BELOW and next_decision(ABOVE, np.inf, p) == ABOVE


def test_command_is_the_schedule_before_after_and_without_a_decision():
    p = BalloonRuleParams(**RULE, after=2.0).validate()
    assert balloon_command(0.3, ABOVE, 1.99, p) == 0.3
    assert balloon_command(0.3, ABOVE, 2.0, p) == 0.9
    assert balloon_command(0.3, BELOW, 2.5, p) == 0.05
    assert balloon_command(0.3, NONE, 2.5, p) == 0.3
    assert balloon_command(0.3, ABOVE, 2.5, BalloonRuleParams()) == 0.3  # no rule


def _simulate(params, times, modality_knots, schedule=None):
    """BalloonRule with a first-order-hold modality through ``modality_knots`` (t, m) and a
    constant (or ``schedule`` trajectory) fill; the command at ``times``."""
    builder = DiagramBuilder()
    rule = builder.AddSystem(BalloonRule(params, period=T))
    t, m = np.array(modality_knots, dtype=float).T
    modality = builder.AddSystem(TrajectorySource(PiecewisePolynomial.FirstOrderHold(t, m[None])))
    builder.Connect(modality.get_output_port(), rule.GetInputPort("modality"))
    fill = builder.AddSystem(
        schedule if schedule is not None else ConstantVectorSource([SCHEDULED])
    )
    builder.Connect(fill.get_output_port(), rule.GetInputPort("scheduled_fill"))
    simulator = Simulator(builder.Build())
    context = rule.GetMyContextFromRoot(simulator.get_context())
    out = []
    for time in times:
        simulator.AdvanceTo(time)
        out.append(rule.get_output_port().Eval(context)[0])
    return np.array(out)


# The estimate holds 0.5 (inside the band: no decision) for 1 s, rises to 1 at 2 s and falls
# to 0 by 4 s. It passes the band's top (0.625) at t = 1.25 and its bottom (0.375) at
# t = 3.25, both half-way between updates, so the first updates that see it past are at
# 1.26 and 3.26.
TRIANGLE = [(0.0, 0.5), (1.0, 0.5), (2.0, 1.0), (4.0, 0.0), (10.0, 0.0)]


def test_hysteresis_up_and_down_points_in_a_simulator():
    times = [0.5, 1.25, 1.27, 2.0, 2.9, 3.1, 3.25, 3.27, 3.8]
    expected = [SCHEDULED, SCHEDULED, 0.9, 0.9, 0.9, 0.9, 0.9, 0.05, 0.05]
    # At 2.9 and 3.1 the estimate (0.55, 0.45) is inside the band on either side of the
    # threshold: the decision made on the way up holds.
    np.testing.assert_array_equal(_simulate(BalloonRuleParams(**RULE), times, TRIANGLE), expected)


def test_after_gates_the_rule():
    """after = 2: the estimate has been past the band's top since 1.26, but the schedule
    commands until the first update at or after 2 s."""
    out = _simulate(BalloonRuleParams(**RULE, after=2.0), [1.5, 1.99, 2.03, 3.5], TRIANGLE)
    np.testing.assert_array_equal(out, [SCHEDULED, SCHEDULED, 0.9, 0.05])
    # after = 3: the estimate (0.5) is inside the band then; the schedule holds until it
    # leaves the band, here at the bottom (t = 3.26), when fill_below takes over.
    out = _simulate(BalloonRuleParams(**RULE, after=3.0), [2.5, 3.01, 3.25, 3.27], TRIANGLE)
    np.testing.assert_array_equal(out, [SCHEDULED, SCHEDULED, SCHEDULED, 0.05])


def test_without_a_modality_the_schedule_passes_through():
    schedule = TrajectorySource(
        PiecewisePolynomial.ZeroOrderHold([0.0, 0.7, 1.5, 5.0], np.array([[0.2, 1.0, 0.0, 0.0]]))
    )
    rule = BalloonRule(period=T)
    assert rule.params.modality == "" and rule.GetUniquePeriodicDiscreteUpdateAttribute() is None
    out = _simulate(BalloonRuleParams(), [0.5, 1.0, 2.0, 3.5], TRIANGLE, schedule)
    np.testing.assert_array_equal(out, [0.2, 1.0, 0.0, 0.0])


def test_nan_keeps_the_decision():
    rule = BalloonRule(BalloonRuleParams(**RULE), period=T)
    context = rule.CreateDefaultContext()
    rule.GetInputPort("scheduled_fill").FixValue(context, [SCHEDULED])
    for m, expected in ((0.7, 0.9), (np.nan, 0.9), (0.2, 0.05), (np.nan, 0.05), (0.5, 0.05)):
        rule.GetInputPort("modality").FixValue(context, [m])
        context.SetDiscreteState(
            rule.EvalUniquePeriodicDiscreteUpdate(context).get_vector().CopyToVector()
        )
        assert rule.get_output_port().Eval(context)[0] == expected
    assert not rule.HasDirectFeedthrough(rule.GetInputPort("modality").get_index(), 0)
    assert rule.HasDirectFeedthrough(rule.GetInputPort("scheduled_fill").get_index(), 0)


def test_any_estimate_a_tree_reads_and_the_short_names():
    from manta_drake.modalities import ESTIMATES, NAMES

    assert set(ESTIMATES) <= set(NAMES) and {"z_hat", "s_hat", "floor_hat"} <= set(NAMES)
    assert BalloonRuleParams(modality="flow").estimate(NAMES) == "flow_hat"
    assert BalloonRuleParams(modality="altitude").estimate(NAMES) == "floor_hat"
    assert BalloonRuleParams(modality="s_hat").estimate(NAMES) == "s_hat"
    assert BalloonRuleParams().estimate(NAMES) == ""
    with pytest.raises(ValueError, match="modality: 'depth' is not an estimate's name; allowed: "):
        BalloonRuleParams(modality="depth").validate(NAMES)


@pytest.mark.parametrize("weight", ["linear", "cosine", "potential", "normalised"])
def test_a_continuous_rule_follows_the_estimate_by_the_trees_weights(weight):
    """fill = w0 fill_below + w1 fill_above at x = min(m / full_at, 1), the tree's pair
    weights; a NaN holds the last fill; the schedule until the first finite estimate."""
    from manta_drake.control.behaviour_tree import pair_weights

    p = BalloonRuleParams(
        modality="z_hat",
        weight=weight,
        fill_below=1.0,
        fill_above=0.2,
        full_at=0.5,
        threshold=0.5,
        hysteresis=0.2,
    ).validate()
    rule = BalloonRule(p, period=0.02)
    context = rule.CreateDefaultContext()
    rule.GetInputPort("scheduled_fill").FixValue(context, [SCHEDULED])
    for m, x in ((np.nan, None), (0.1, 0.2), (np.nan, 0.2), (0.3, 0.6), (0.9, 1.0)):
        rule.GetInputPort("modality").FixValue(context, [m])
        context.SetDiscreteState(
            rule.EvalUniquePeriodicDiscreteUpdate(context).get_vector().CopyToVector()
        )
        got = rule.get_output_port().Eval(context)[0]
        if x is None:
            assert got == SCHEDULED
        else:
            w0, w1 = pair_weights(weight, x)
            assert got == pytest.approx(1.0 * w0 + 0.2 * w1, rel=1e-12)
    if weight == "linear":
        assert got == pytest.approx(0.2)  # at x = 1 (m 0.9 >= full_at): fill_above


def test_a_switch_reads_the_estimate_through_full_at():
    """The relay's band is in the coordinate x = m / full_at: with full_at 0.5 a z_hat of
    0.35 is x = 0.7, above the band [0.4, 0.6]."""
    p = BalloonRuleParams(modality="z_hat", fill_above=0.0, fill_below=1.0, full_at=0.5)
    assert next_decision(NONE, 0.35, p.validate()) == ABOVE
    assert next_decision(NONE, 0.35, dc.replace(p, full_at=1.0)) == BELOW


@pytest.mark.parametrize(
    "change, message",
    [
        ({"modality": "bad name"}, r"modality: 'bad name' is not an estimate's name"),
        ({"weight": "step"}, r"weight: 'step' is not one of potential, cosine"),
        ({"full_at": 0.0}, r"full_at: 0.0 is outside the allowed range \(0, 1\]"),
        (
            {"modality": "z_hat", "weight": "linear", "hysteresis": 0.3},
            r"hysteresis: 0.3 is set on a linear rule, which ignores it",
        ),
        ({"fill_above": 1.5}, r"fill_above: 1.5 is outside the allowed range \[0, 1\]"),
        ({"fill_below": -0.1}, r"fill_below: -0.1 is outside the allowed range \[0, 1\]"),
        ({"threshold": np.nan}, r"threshold: nan is not finite"),
        ({"threshold": 1.2}, r"threshold: 1.2 is outside the allowed range \[0, 1\]"),
        ({"hysteresis": -0.2}, r"hysteresis: -0.2 is outside the allowed range \[0, 1\]"),
        (
            {"threshold": 0.9, "hysteresis": 0.4},
            r"hysteresis: 0.4 puts the band threshold -\+ hysteresis/2 = \[0.7, 1.1\] "
            r"outside \[0, 1\]",
        ),
        (
            {"threshold": 0.05, "hysteresis": 0.2},
            r"hysteresis: 0.2 puts the band .*\[-0.05, 0.15\]",
        ),
        ({"after": -1.0}, r"after: -1.0 is outside the allowed range \[0, 1e6\] s"),
    ],
)
def test_every_parameter_error_names_the_field_and_range(change, message):
    with pytest.raises(ValueError, match=message):
        dc.replace(BalloonRuleParams(), **change).validate()
    with pytest.raises(ValueError, match=message):
        BalloonRule(dc.replace(BalloonRuleParams(), **change))


def test_period_is_checked_at_construction():
    with pytest.raises(ValueError, match=r"BalloonRule.period: 0.0 is outside .*\(0, 1\] s"):
        BalloonRule(period=0.0)


@pytest.mark.parametrize(
    "field, value",
    [
        ("fill_above", 1.0),
        ("fill_below", 0.0),
        ("threshold", 0.3),
        ("hysteresis", 0.1),
        ("after", 5.0),
    ],
)
def test_a_rule_parameter_without_a_modality_is_refused(field, value):
    """Without a modality the schedule alone commands the balloon: a rule parameter set there
    would be ignored, so it is refused naming the field; with a modality it is the rule's."""
    with pytest.raises(
        ValueError,
        match=rf"^{field}: {value} is set but the rule's modality "
        r"is empty .*set modality to an estimate's name",
    ):
        BalloonRuleParams(**{field: value}).validate()
    assert (
        getattr(BalloonRuleParams(modality="energy", **{field: value}).validate(), field) == value
    )
    BalloonRuleParams().validate()  # the defaults: no rule
