"""A balloon rule: the balloon's fill from one 0-1 estimate.

The scenario's time schedule commands the balloon (``scheduled_fill``); a rule lets one of
the controller's 0-1 estimates (``modality``: any estimate a behaviour tree reads, by its
name or its modality's alias, ``manta_drake.modalities.NAMES``: ``z_hat``, ``posture``) take over,
with the weight functions of a tree's node (``weight``, ``behaviour_tree``). The estimate's
coordinate is the tree's, x = min(clip(m, 0, 1) / ``full_at``, 1).

``switch`` (the default): a relay with hysteresis. With the band [lo, hi] = threshold -+
h / 2::

    d <- above   if x > hi
    d <- below   if x < lo
    d <- d       otherwise, and while m is NaN or infinite

    balloon_command = scheduled_fill   if t < after or no decision yet
                      fill_above       if d = above
                      fill_below       if d = below

A band end at 0 or 1 can never be crossed (x is in [0, 1]), which makes a one-way rule:
threshold 0.25 and hysteresis 0.5 (band [0, 0.5]) decide "above" once the estimate passes
0.5 and never "below" (e.g. surface for good when the battery runs low: energy,
fill_above 1). The hysteresis keeps a noisy estimate near the threshold from toggling the
balloon (the relay with hysteresis of on-off control).

``potential``, ``cosine``, ``linear``, ``normalised``: the fill follows the estimate,
fill = w0 fill_below + w1 fill_above with (w0, w1) the tree's weights at x
(``behaviour_tree.pair_weights``), from the first finite estimate at or after ``after``
(NaN or infinite holds the last fill). These read neither ``threshold`` nor ``hysteresis``.

The decision, or the fill, is a discrete state updated every ``period`` seconds at and
after ``after`` (before it the rule neither decides nor commands).
"""

import dataclasses as dc

import numpy as np
from pydrake.systems.framework import LeafSystem

from manta_drake.config_io import (
    ScenarioError,
    check_in_range,
    check_one_of,
    field_name,
    short_repr,
)
from manta_drake.control.behaviour_tree import WEIGHT_FUNCTIONS, pair_weights

NONE, ABOVE, BELOW = 0.0, 1.0, -1.0  # the decision state's values
SWITCH_ONLY = {"threshold": 0.5, "hysteresis": 0.2}  # the switch's fields and defaults


@dc.dataclass
class BalloonRuleParams:
    """The rule (see the module docstring); ``modality`` empty: no rule, the schedule only,
    and every other field left at its default (a rule's parameters without a modality would
    be ignored)."""

    modality: str = ""  # "" or an estimate's name or alias
    weight: str = "switch"  # one of behaviour_tree.WEIGHT_FUNCTIONS
    fill_above: float = 0.0  # the fill at x = 1 (switch: once above threshold + h/2)
    fill_below: float = 1.0  # the fill at x = 0 (switch: once below threshold - h/2)
    full_at: float = 1.0  # x = min(m / full_at, 1), in (0, 1]
    threshold: float = 0.5  # switch only
    hysteresis: float = 0.2  # switch only: h, the width of the band about the threshold
    after: float = 0.0  # [s] the schedule alone before this time

    def estimate(self, names=None) -> str:
        """The controller's estimate the rule reads (``""`` without a rule): ``modality``
        through ``names`` (name or alias -> estimate; None: the name itself)."""
        return (names or {}).get(self.modality, self.modality)

    def validate(self, names=None, where: str = "") -> "BalloonRuleParams":
        """Checks every field's type and range (``modality`` one of ``names``, a mapping of
        the names and aliases a rule may give to their estimates; None: any name);
        ScenarioError names the field (``<where>.<field>``) and the range."""

        def at(name: str) -> str:
            return field_name(where, name)

        if names is not None:
            if self.modality != "" and self.modality not in names:
                raise ScenarioError(
                    f"{at('modality')}: {short_repr(self.modality)} is not an estimate's "
                    f"name; allowed: {', '.join(names)} (empty: no rule)"
                )
        elif not (
            isinstance(self.modality, str) and (self.modality == "" or self.modality.isidentifier())
        ):
            raise ScenarioError(
                f"{at('modality')}: {short_repr(self.modality)} is not an estimate's name"
            )
        check_one_of(at("weight"), self.weight, WEIGHT_FUNCTIONS)
        check_in_range(at("fill_above"), self.fill_above, 0.0, 1.0, "[0, 1] (0 empty, 1 full)")
        check_in_range(at("fill_below"), self.fill_below, 0.0, 1.0, "[0, 1] (0 empty, 1 full)")
        check_in_range(at("full_at"), self.full_at, 0.0, 1.0, "(0, 1]", open_low=True)
        check_in_range(at("threshold"), self.threshold, 0.0, 1.0, "[0, 1]")
        check_in_range(at("hysteresis"), self.hysteresis, 0.0, 1.0, "[0, 1]")
        lo, hi = band(self)
        if lo < 0.0 or hi > 1.0:
            raise ScenarioError(
                f"{at('hysteresis')}: {self.hysteresis!r} puts the band threshold -+ "
                f"hysteresis/2 = [{lo:g}, {hi:g}] outside [0, 1]"
            )
        check_in_range(at("after"), self.after, 0.0, 1e6, "[0, 1e6] s")
        if self.weight != "switch":
            for name, default in SWITCH_ONLY.items():
                if getattr(self, name) != default:
                    raise ScenarioError(
                        f"{at(name)}: {short_repr(getattr(self, name))} is set on a "
                        f"{self.weight} rule, which ignores it (only switch reads "
                        f"{' and '.join(SWITCH_ONLY)}): leave it out"
                    )
        if not self.modality:
            choices = f"one of {', '.join(names)}" if names else "an estimate's name"
            defaults = BalloonRuleParams()
            for f in dc.fields(self):
                value = getattr(self, f.name)
                if f.name != "modality" and value != getattr(defaults, f.name):
                    raise ScenarioError(
                        f"{at(f.name)}: {short_repr(value)} is set but the rule's "
                        "modality is empty (no rule: the schedule alone); set "
                        f"modality to {choices} or leave {f.name} out"
                    )
        return self


def coordinate(modality: float, params: BalloonRuleParams) -> float:
    """x = min(clip(m, 0, 1) / full_at, 1) (the tree's node coordinate)."""
    return min(min(max(float(modality), 0.0), 1.0) / params.full_at, 1.0)


def following_fill(modality: float, params: BalloonRuleParams) -> float:
    """A continuous rule's fill at the estimate ``modality``: fill_below w0 + fill_above w1."""
    w0, w1 = pair_weights(params.weight, coordinate(modality, params))
    return w0 * params.fill_below + w1 * params.fill_above


def band(params: BalloonRuleParams) -> tuple:
    """(lo, hi) = threshold -+ hysteresis / 2."""
    half = 0.5 * params.hysteresis
    return params.threshold - half, params.threshold + half


def next_decision(decision: float, modality: float, params: BalloonRuleParams) -> float:
    """The decision (``NONE``, ``ABOVE`` or ``BELOW``) after reading the estimate
    ``modality``: ABOVE past the band's top, BELOW past its bottom (in the coordinate x),
    else (or NaN or infinite) kept."""
    if not np.isfinite(modality):
        return decision
    x = coordinate(modality, params)
    lo, hi = band(params)
    if x > hi:
        return ABOVE
    if x < lo:
        return BELOW
    return decision  # inside the band


def balloon_command(
    scheduled_fill: float,
    decision: float,
    time: float,
    params: BalloonRuleParams,
    fill: float = 0.0,
) -> float:
    """The fill commanded: the schedule before ``after``, with no rule or no decision (a
    continuous rule: no finite estimate yet); else a switch's ``fill_above`` or
    ``fill_below``, a continuous rule's ``fill``."""
    if not params.modality or time < params.after or decision == NONE:
        return scheduled_fill
    if params.weight != "switch":
        return fill
    return params.fill_above if decision == ABOVE else params.fill_below


class BalloonRule(LeafSystem):
    """The balloon's fill: the time schedule until a 0-1 estimate decides.

    .. pydrake_system::

        name: BalloonRule
        input_ports:
        - scheduled_fill
        - modality
        output_ports:
        - balloon_command

    * ``scheduled_fill`` (1): the time schedule's fill command in [0, 1].
    * ``modality`` (1): the controller's 0-1 estimate the rule follows (``params.modality``);
      NaN or infinite keeps the last decision or fill.
    * ``balloon_command`` (1): ``balloon_command(scheduled_fill, d, t, params)``: depends
      directly on ``scheduled_fill``, on the time and on the state, not on ``modality``.

    Discrete state (2): the decision d (0 none, +1 above, -1 below; a continuous rule: +1
    once it has read a finite estimate) and a continuous rule's fill, updated by
    ``next_decision`` or ``following_fill`` every ``period`` seconds at the updates at or
    after ``after``. With ``modality`` empty no update is declared and the schedule passes
    through.

    Args:
        params: ``BalloonRuleParams`` (None: the defaults, no rule).
        period: the update period [s], in (0, 1].

    Raises:
        ValueError: naming the invalid field and its allowed range.
    """

    def __init__(self, params: BalloonRuleParams | None = None, period: float = 0.02):
        super().__init__()
        self.params = (params if params is not None else BalloonRuleParams()).validate()
        check_in_range("BalloonRule.period", period, 0.0, 1.0, "(0, 1] s", open_low=True)
        self.period = float(period)
        self._state = self.DeclareDiscreteState([NONE, 0.0])
        self._schedule = self.DeclareVectorInputPort("scheduled_fill", 1)
        self._modality = self.DeclareVectorInputPort("modality", 1)
        self.DeclareVectorOutputPort(
            "balloon_command",
            1,
            self._calc_command,
            prerequisites_of_calc={self.time_ticket(), self.xd_ticket(), self._schedule.ticket()},
        )
        if self.params.modality:
            self.DeclarePeriodicDiscreteUpdateEvent(self.period, 0.0, self._update)

    def _calc_command(self, context, output):
        decision, fill = context.get_discrete_state(self._state).get_value()
        output.SetAtIndex(
            0,
            balloon_command(
                float(self._schedule.Eval(context)[0]),
                decision,
                context.get_time(),
                self.params,
                fill,
            ),
        )

    def _update(self, context, discrete_state):
        if context.get_time() < self.params.after:
            return  # the schedule alone: no decision yet
        decision, fill = context.get_discrete_state(self._state).get_value()
        modality = float(self._modality.Eval(context)[0])
        if self.params.weight == "switch":
            decision = next_decision(decision, modality, self.params)
        elif np.isfinite(modality):
            decision, fill = ABOVE, following_fill(modality, self.params)
        discrete_state.get_mutable_vector(self._state).SetFromVector([decision, fill])
