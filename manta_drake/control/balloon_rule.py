"""A balloon rule: the balloon's fill from one 0-1 estimate, with hysteresis.

The scenario's time schedule commands the balloon (``scheduled_fill``); a rule lets one of
the controller's 0-1 estimates (``modality``: posture, flow or energy, see ``MODALITIES``)
take over once it has made a decision. With the band [lo, hi] = threshold -+ h / 2::

    d <- above   if m > hi          (m: the estimate)
    d <- below   if m < lo
    d <- d       otherwise, and while m is NaN or infinite

    balloon_command = scheduled_fill   if t < after or no decision yet
                      fill_above       if d = above
                      fill_below       if d = below

The decision d is a discrete state updated every ``period`` seconds at and after ``after``
(before it the rule neither decides nor commands). A band end at 0 or 1 can never be
crossed (the estimate is in [0, 1]), which makes a one-way rule: threshold 0.25 and
hysteresis 0.5 (band [0, 0.5]) decide "above" once the estimate passes 0.5 and never
"below" (e.g. surface for good when the battery runs low: energy, fill_above 1). The
hysteresis keeps a noisy estimate near the threshold from toggling the balloon (the relay
with hysteresis of on-off control).
"""

import dataclasses as dc

import numpy as np
from pydrake.systems.framework import LeafSystem

from manta_drake.config_io import check_in_range, check_one_of, short_repr

# The estimates a rule may follow, and the controller ports that carry them.
MODALITIES = {"posture": "posture_hat", "flow": "flow_hat", "energy": "energy_hat"}
NONE, ABOVE, BELOW = 0.0, 1.0, -1.0  # the decision state's values


@dc.dataclass
class BalloonRuleParams:
    """The rule (see the module docstring); ``modality`` empty: no rule, the schedule only,
    and every other field left at its default (a rule's parameters without a modality would
    be ignored)."""

    modality: str = ""  # "" or one of MODALITIES
    fill_above: float = 0.0  # balloon fill once the estimate rose above threshold + h/2
    fill_below: float = 1.0  # balloon fill once the estimate fell below threshold - h/2
    threshold: float = 0.5
    hysteresis: float = 0.2  # h: the width of the band about the threshold
    after: float = 0.0  # [s] the schedule alone before this time

    def validate(self) -> "BalloonRuleParams":
        """Checks every field's type and range; ValueError names the field and the range."""
        check_one_of("modality", self.modality, ("",) + tuple(MODALITIES))
        check_in_range("fill_above", self.fill_above, 0.0, 1.0, "[0, 1] (0 empty, 1 full)")
        check_in_range("fill_below", self.fill_below, 0.0, 1.0, "[0, 1] (0 empty, 1 full)")
        check_in_range("threshold", self.threshold, 0.0, 1.0, "[0, 1]")
        check_in_range("hysteresis", self.hysteresis, 0.0, 1.0, "[0, 1]")
        lo, hi = band(self)
        if lo < 0.0 or hi > 1.0:
            raise ValueError(f"hysteresis: {self.hysteresis!r} puts the band threshold -+ "
                             f"hysteresis/2 = [{lo:g}, {hi:g}] outside [0, 1]")
        check_in_range("after", self.after, 0.0, 1e6, "[0, 1e6] s")
        if not self.modality:
            default = BalloonRuleParams()
            for f in dc.fields(self):
                value = getattr(self, f.name)
                if f.name != "modality" and value != getattr(default, f.name):
                    raise ValueError(f"{f.name}: {short_repr(value)} is set but the rule's "
                                     "modality is empty (no rule: the schedule alone); set "
                                     f"modality to one of {', '.join(MODALITIES)} or leave "
                                     f"{f.name} out")
        return self


def band(params: BalloonRuleParams) -> tuple:
    """(lo, hi) = threshold -+ hysteresis / 2."""
    half = 0.5 * params.hysteresis
    return params.threshold - half, params.threshold + half


def next_decision(decision: float, modality: float, params: BalloonRuleParams) -> float:
    """The decision (``NONE``, ``ABOVE`` or ``BELOW``) after reading the estimate
    ``modality``: ABOVE past the band's top, BELOW past its bottom, else (or NaN or
    infinite) kept."""
    if not np.isfinite(modality):
        return decision
    lo, hi = band(params)
    if modality > hi:
        return ABOVE
    if modality < lo:
        return BELOW
    return decision  # inside the band


def balloon_command(scheduled_fill: float, decision: float, time: float,
                    params: BalloonRuleParams) -> float:
    """The fill commanded: the schedule before ``after``, with no rule or no decision;
    else ``fill_above`` or ``fill_below``."""
    if not params.modality or time < params.after or decision == NONE:
        return scheduled_fill
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
    * ``modality`` (1): the 0-1 estimate the rule follows (``MODALITIES[params.modality]``
      of the controller); NaN or infinite keeps the last decision.
    * ``balloon_command`` (1): ``balloon_command(scheduled_fill, d, t, params)``: depends
      directly on ``scheduled_fill``, on the time and on the state, not on ``modality``.

    Discrete state (1): the decision d (0 none, +1 above, -1 below), updated by
    ``next_decision`` every ``period`` seconds at the updates at or after ``after``. With
    ``modality`` empty no update is declared and the schedule passes through.

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
        self._state = self.DeclareDiscreteState([NONE])
        self._schedule = self.DeclareVectorInputPort("scheduled_fill", 1)
        self._modality = self.DeclareVectorInputPort("modality", 1)
        self.DeclareVectorOutputPort(
            "balloon_command", 1, self._calc_command,
            prerequisites_of_calc={self.time_ticket(), self.xd_ticket(),
                                   self._schedule.ticket()})
        if self.params.modality:
            self.DeclarePeriodicDiscreteUpdateEvent(self.period, 0.0, self._update)

    def _calc_command(self, context, output):
        decision = context.get_discrete_state(self._state).GetAtIndex(0)
        output.SetAtIndex(0, balloon_command(float(self._schedule.Eval(context)[0]), decision,
                                             context.get_time(), self.params))

    def _update(self, context, discrete_state):
        if context.get_time() < self.params.after:
            return  # the schedule alone: no decision yet
        decision = context.get_discrete_state(self._state).GetAtIndex(0)
        modality = float(self._modality.Eval(context)[0])
        discrete_state.get_mutable_vector(self._state).SetAtIndex(
            0, next_decision(decision, modality, self.params))
