"""A heading hold for swimming: a PI(D) autopilot steering by differential fin amplitude.

The controller is the classic PID heading autopilot of marine craft (Fossen, *Handbook of
Marine Craft Hydrodynamics and Motion Control*, Wiley 2011, the chapter on autopilot
design): a proportional and integral action on the heading error and a derivative action
on the measured yaw rate (no derivative kick when the target changes). Every ``period``
seconds::

    e   = wrap(yaw_hat - psi_t)                    (in (-pi, pi]; > 0: yawed left of psi_t)
    I  <- I + s e period                           (s: swim_share; frozen when saturated)
    v   = kp e + ki I + kd r_hat                   (r_hat: yaw_rate_hat, > 0 turning left)
    u   = turn_sign clip(v, -max_trim, max_trim)

with yaw counter-clockwise from above (z up), so e > 0 means the robot has turned left of
the target heading psi_t and v > 0 asks for a turn to the right. Anti-windup is by
conditional integration: the integral does not grow while v is saturated and the error
would push it further (``|v| > max_trim`` and ``e v > 0``), and it is clamped to
``|ki I| <= max_trim`` in any case. The integral is weighted by the swim share ``s``, so it
does not wind up while the robot walks (s = 0), when the trim has no effect.

The trim acts the way rays and ray-like robots steer: by a left-right difference of the
pectoral fins' flapping amplitude. The flapping amplitude sets a fin's thrust (Low, Zhou,
Seet, Bi and Cai, "Improvement and testing of a robotic manta ray (RoMan-III)", IEEE
ROBIO 2011), and closed-loop course control of a CPG-driven manta robot by the fins'
amplitude difference is "Course control of a manta robot based on amplitude and phase
differences", J. Mar. Sci. Eng. 10(2), 285, 2022. Here the amplitudes (R) of the two
roll joints (roll1, roll2: the flapping) of the left fins are multiplied by 1 + s u and
those of the right fins by 1 - s u; yaw, pitch, biases and phases are untouched::

    R[left, roll]  <- (1 + s u) R[left, roll]       R[right, roll] <- (1 - s u) R[right, roll]

``turn_sign = +1`` (the default) reads a larger left-fin amplitude as more thrust on the
left, which yaws the robot to the right (clockwise from above): positive error, positive
trim, right turn. Whether the fins of this model do that (a larger flap also changes the
fin's drag and lift) is not assumed here: it is measured on the full model, by a
closed-loop swimming run whose heading error must shrink, and ``turn_sign = -1`` reverses
the sense if it does not.
"""

import dataclasses as dc

import numpy as np
from pydrake.systems.framework import LeafSystem

from manta_drake.config_io import (
    ScenarioError,
    check_boolean,
    check_in_range,
    check_number,
    check_one_of,
    field_name,
)
from manta_drake.control.gaits import RIGHT_LEGS
from manta_drake.control.transition import wrap
from manta_drake.model.robot_params import JOINTS, NUM_CPG_PARAMS, NUM_JOINTS, NUM_LEGS

LEFT_LEGS = tuple(k for k in range(NUM_LEGS) if k not in RIGHT_LEGS)  # fl, rl
ROLL_COLUMNS = (JOINTS.index("roll1"), JOINTS.index("roll2"))  # the fin's flapping joints


@dc.dataclass
class HeadingChange:
    """A change of the held heading, made once: at ``time`` [s], or when the estimate
    ``modality`` (an estimate's name, ``manta_drake.modalities.ESTIMATES``) first rises above
    ``above``. The new
    target is ``heading_deg`` (absolute), or the heading estimate at the change plus
    ``turn_deg`` (e.g. 180: turn back)."""

    time: float | None = None
    modality: str = ""
    above: float = 0.5
    heading_deg: float | None = None
    turn_deg: float | None = None

    def validate(self, where: str = "change", modalities=None) -> "HeadingChange":
        """Exactly one trigger and exactly one new target, each in range, the estimate one
        of ``modalities`` (None: any name); ScenarioError names the field
        (``<where>.<field>``)."""
        if (self.time is None) == (not self.modality):
            raise ScenarioError(
                f"{where}: give either time or modality (a change happens at a "
                f"time or on an estimate), got time={self.time!r}, "
                f"modality={self.modality!r}"
            )
        if self.time is not None:
            check_in_range(f"{where}.time", self.time, 0.0, 1e6, "[0, 1e6] s")
        else:
            if modalities is not None:
                check_one_of(f"{where}.modality", self.modality, tuple(modalities))
            elif not (isinstance(self.modality, str) and self.modality.isidentifier()):
                raise ScenarioError(
                    f"{where}.modality: {self.modality!r} is not an estimate's "
                    "name (an identifier, e.g. s_hat)"
                )
        check_in_range(f"{where}.above", self.above, 0.0, 1.0, "[0, 1)", open_high=True)
        if (self.heading_deg is None) == (self.turn_deg is None):
            raise ScenarioError(
                f"{where}: give either heading_deg (the new target) or turn_deg "
                f"(the heading at the change plus it), got heading_deg="
                f"{self.heading_deg!r}, turn_deg={self.turn_deg!r}"
            )
        if self.heading_deg is not None:
            check_in_range(
                f"{where}.heading_deg", self.heading_deg, -180.0, 180.0, "[-180, 180] deg"
            )
        else:
            check_in_range(f"{where}.turn_deg", self.turn_deg, -360.0, 360.0, "[-360, 360] deg")
        return self


def changed_targets(
    target: float, yaw: float, time: float, estimates: dict, changes, done
) -> tuple[float, tuple]:
    """(the target [rad], which of ``changes`` have been made) after the changes due now, in
    order: a change not yet made (``done`` False) is due at or after its time, or when its
    estimate (``estimates``, modality -> value) is finite and above its threshold; it sets
    the target to its heading, or to ``yaw`` plus its turn."""
    done = list(done)
    for k, c in enumerate(changes):
        if done[k]:
            continue
        value = estimates.get(c.modality, np.nan) if c.modality else np.nan
        if (c.time is not None and time >= c.time) or (np.isfinite(value) and value > c.above):
            target = float(
                wrap(
                    np.radians(c.heading_deg)
                    if c.heading_deg is not None
                    else yaw + np.radians(c.turn_deg)
                )
            )
            done[k] = True
    return target, tuple(done)


@dc.dataclass
class HeadingHoldParams:
    """The heading hold's gains and target (see the module docstring).

    The default gains are a starting point for the swim gait (a 10 deg error asks for
    ~9 % more flapping on one side and 9 % less on the other); tune them on the full model.
    """

    enabled: bool = False
    kp: float = 0.5  # [1/rad]: trim per radian of heading error
    ki: float = 0.05  # [1/(rad s)]
    kd: float = 0.5  # [s/rad]: on the measured yaw rate
    max_trim: float = 0.3  # |u| <= max_trim, in [0, 1): amplitudes stay positive
    heading_deg: float | None = None  # target heading; None: the heading at the first update
    period: float = 0.02  # [s]
    turn_sign: int = 1  # +1: a larger left-fin amplitude turns right; -1 the reverse
    # The behaviour-tree leaves (gait names) the hold trims; its share is their summed
    # weight (behaviour_weights). A fixed gait (controller.mode: gait) is trimmed whole.
    behaviours: list[str] = dc.field(default_factory=lambda: ["swim", "swim_printed"])
    # Changes of the target, each made once, in order (``HeadingChange``): at a time or on
    # an estimate, to a heading or by a turn. The integral restarts at each change.
    changes: list[HeadingChange] = dc.field(default_factory=list)

    def validate(self, modalities=None, where: str = "") -> "HeadingHoldParams":
        """Checks every field's type and range (a change's estimate one of ``modalities``;
        None: any name); ScenarioError names the field (``<where>.<field>``) and the range."""

        def at(name: str) -> str:
            return field_name(where, name)

        check_boolean(at("enabled"), self.enabled)
        check_in_range(at("kp"), self.kp, 0.0, 100.0, "[0, 100] 1/rad")
        check_in_range(at("ki"), self.ki, 0.0, 100.0, "[0, 100] 1/(rad s)")
        check_in_range(at("kd"), self.kd, 0.0, 100.0, "[0, 100] s/rad")
        check_in_range(
            at("max_trim"),
            self.max_trim,
            0.0,
            1.0,
            "[0, 1) (the trimmed amplitudes must stay positive)",
            open_high=True,
        )
        if self.heading_deg is not None:
            check_in_range(
                at("heading_deg"),
                self.heading_deg,
                -180.0,
                180.0,
                "[-180, 180] deg (or null: the heading at the first update)",
            )
        check_in_range(at("period"), self.period, 0.0, 1.0, "(0, 1] s", open_low=True)
        check_number(at("turn_sign"), self.turn_sign)
        if self.turn_sign not in (1, -1):
            raise ScenarioError(f"{at('turn_sign')}: {self.turn_sign!r} is not +1 or -1")
        if not isinstance(self.behaviours, list) or not all(
            isinstance(b, str) and b for b in self.behaviours
        ):
            raise ScenarioError(
                f"{at('behaviours')}: {self.behaviours!r} must be a list of gait names"
            )
        for k, change in enumerate(self.changes):
            change.validate(at(f"changes[{k}]"), modalities)
        return self

    def read(self) -> tuple[str, ...]:
        """The estimates the changes read, each once, in order."""
        return tuple(dict.fromkeys(c.modality for c in self.changes if c.modality))


def heading_trim_step(
    state: float,
    yaw: float,
    yaw_rate: float,
    target: float,
    params: HeadingHoldParams,
    share: float = 1.0,
) -> tuple:
    """One update of the PI(D) autopilot.

    Args:
        state: the integral I of the share-weighted heading error [rad s].
        yaw, target: the heading estimate and the target heading [rad].
        yaw_rate: the measured yaw rate [rad/s].
        params: the gains, ``max_trim``, ``period`` and ``turn_sign``.
        share: the swim share s in [0, 1] weighting the integral.

    Returns:
        (the new integral, the trim u in [-max_trim, max_trim]).
    """
    p = params
    e = float(wrap(yaw - target))
    integral = state + share * e * p.period
    v = p.kp * e + p.ki * integral + p.kd * yaw_rate
    if abs(v) > p.max_trim and e * v > 0.0:
        integral = state  # saturated and the error pushes further: do not integrate
    if p.ki > 0.0:
        bound = p.max_trim / p.ki
        integral = min(max(integral, -bound), bound)
    else:
        integral = 0.0  # no integral action: keep the state bounded
    v = p.kp * e + p.ki * integral + p.kd * yaw_rate
    return integral, p.turn_sign * min(max(v, -p.max_trim), p.max_trim)


def apply_trim(cpg_params, u: float, share: float):
    """The CPG parameters with the left fins' roll amplitudes times (1 + share u) and the
    right fins' times (1 - share u); ``cpg_params`` itself (the same object) when
    share u = 0 or the share is not positive (or NaN).

    Raises:
        ValueError: if ``|share u| >= 1`` (an amplitude would vanish or change sign).
    """
    share = float(share)
    if not share > 0.0:  # also NaN: no swimming, no trim
        return cpg_params
    k = min(share, 1.0) * float(u)
    if k == 0.0:
        return cpg_params
    if not abs(k) < 1.0:
        raise ValueError(f"apply_trim: share * u = {k!r} is outside (-1, 1)")
    out = np.array(cpg_params, dtype=float)
    R = out[:NUM_JOINTS].reshape(NUM_LEGS, -1)  # a view: R is the first 16 entries
    R[np.ix_(LEFT_LEGS, ROLL_COLUMNS)] *= 1.0 + k
    R[np.ix_(RIGHT_LEGS, ROLL_COLUMNS)] *= 1.0 - k
    return out


class HeadingHold(LeafSystem):
    """Trims the CPG parameters to hold a heading while swimming.

    .. pydrake_system::

        name: HeadingHold
        input_ports:
        - cpg_params
        - attitude_hat
        - yaw_rate_hat
        - swim_share
        - <estimate> (one per estimate ``changes`` read)
        output_ports:
        - cpg_params
        - heading_trim

    * ``cpg_params`` (64, in): the behaviours' CPG parameters (R, X, Phi, Phi').
    * ``attitude_hat`` (3): [roll, pitch, yaw] estimate [rad]; only the yaw is used.
    * ``yaw_rate_hat`` (1): yaw rate estimate [rad/s] (the D term).
    * ``swim_share`` (1): the swimming behaviour's weight s in [0, 1] (values outside are
      clipped, NaN reads 0): the trim applied is s u, so it vanishes when not swimming.
    * ``cpg_params`` (64, out): ``apply_trim(cpg_params, u, s)``; the input unchanged
      when disabled or when s u = 0.
    * ``heading_trim`` (1): the autopilot's trim u (before the share).

    * ``<estimate>`` (1): each 0-1 estimate a change reads (e.g. ``s_hat``).

    Discrete state (4 + changes): [I, psi_t, target set (0/1), u, one made (0/1) per
    change], updated every ``period`` seconds from t = 0: first the changes due
    (``changed_targets``; a change restarts the integral), then ``heading_trim_step``.
    With ``heading_deg`` None the target is the yaw estimate at the first update with a
    finite one (at t = 0 the posture estimator's initialization event has already seeded
    it). A non-finite yaw or yaw rate holds the state. The output ``cpg_params`` depends
    directly on the ``cpg_params`` and ``swim_share`` inputs and on the state, never on
    ``attitude_hat`` or ``yaw_rate_hat``: the estimators read the plant, and a feedthrough
    from them would close an algebraic loop through the CPG. Disabled, no update is
    declared.

    Args:
        params: ``HeadingHoldParams`` (None: the defaults, disabled).

    Raises:
        ValueError: naming the invalid field and its allowed range.
    """

    def __init__(self, params: HeadingHoldParams | None = None):
        super().__init__()
        self.params = (params if params is not None else HeadingHoldParams()).validate()
        p = self.params
        target = 0.0 if p.heading_deg is None else float(wrap(np.radians(p.heading_deg)))
        self._state = self.DeclareDiscreteState(
            [0.0, target, 0.0 if p.heading_deg is None else 1.0, 0.0] + [0.0] * len(p.changes)
        )
        self._estimates = {m: self.DeclareVectorInputPort(m, 1) for m in p.read()}
        self._cpg = self.DeclareVectorInputPort("cpg_params", NUM_CPG_PARAMS)
        self._attitude = self.DeclareVectorInputPort("attitude_hat", 3)
        self._yaw_rate = self.DeclareVectorInputPort("yaw_rate_hat", 1)
        self._share = self.DeclareVectorInputPort("swim_share", 1)
        self.DeclareVectorOutputPort(
            "cpg_params",
            NUM_CPG_PARAMS,
            self._calc_cpg_params,
            prerequisites_of_calc={self.xd_ticket(), self._cpg.ticket(), self._share.ticket()},
        )
        self.DeclareVectorOutputPort(
            "heading_trim",
            1,
            lambda c, o: o.SetAtIndex(0, c.get_discrete_state(self._state).GetAtIndex(3)),
            prerequisites_of_calc={self.xd_ticket()},
        )
        if p.enabled:
            self.DeclarePeriodicDiscreteUpdateEvent(p.period, 0.0, self._update)

    def _swim_share(self, context) -> float:
        s = float(self._share.Eval(context)[0])
        return min(max(s, 0.0), 1.0) if np.isfinite(s) else 0.0

    def _calc_cpg_params(self, context, output):
        params = self._cpg.Eval(context)
        if self.params.enabled:
            u = context.get_discrete_state(self._state).GetAtIndex(3)
            params = apply_trim(params, u, self._swim_share(context))
        output.SetFromVector(params)

    def _update(self, context, discrete_state):
        state = context.get_discrete_state(self._state).get_value()
        integral, target, target_set = state[:3]
        yaw = float(self._attitude.Eval(context)[2])
        yaw_rate = float(self._yaw_rate.Eval(context)[0])
        if not (np.isfinite(yaw) and np.isfinite(yaw_rate)):
            return  # hold the trim and the integral through a dropout
        if target_set < 0.5:
            target = yaw
        done = tuple(state[4:] > 0.5)
        if not all(done):
            estimates = {m: float(port.Eval(context)[0]) for m, port in self._estimates.items()}
            target, now = changed_targets(
                target, yaw, context.get_time(), estimates, self.params.changes, done
            )
            if now != done:
                integral, done = 0.0, now
        integral, u = heading_trim_step(
            integral, yaw, yaw_rate, target, self.params, self._swim_share(context)
        )
        discrete_state.get_mutable_vector(self._state).SetFromVector(
            [integral, target, 1.0, u, *map(float, done)]
        )

    def target(self, context) -> float:
        """The held heading in this system's context [rad]."""
        return float(context.get_discrete_state(self._state).GetAtIndex(1))
