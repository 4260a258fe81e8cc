"""Behaviour transitions by potential functions (section 3.2, Eqs. 11-15).

Target (psi_d, the 64 CPG parameters wanted now) from the estimated depth z_hat and
the wall detection rate s_hat:

* Eq. (12), default::

      Theta_gait = w(s_hat) Theta_turning + (1 - w(s_hat)) Theta_trot
      a          = pi/2 (min(z_hat / z_t, 1) - 1)          (in [-pi/2, 0])
      psi_d      = -sin(a) Theta_swim + cos(a) Theta_gait

  With z_t = 1 (default) ``a`` is the printed (z_hat - z_t) pi/2 on [0, 1]: swim at the
  surface (z_hat = 0), the gait on the floor (z_hat = 1), a non-linear blend between.
  z_t < 1 finishes the change at z_hat = z_t (the printed form only has pure
  endpoints for z_t = 1).
* Eq. (11), option ``blend="linear"``: psi_d = (Theta_gait - Theta_swim) z_hat + Theta_swim.
* ``blend="normalised"``: Eq. (12) with its two weights divided by their sum. As printed,
  -sin(a) + cos(a) reaches sqrt(2) at half depth and the target leaves the range between
  the gaits; the normalised blend is convex.

The system blends by a behaviour tree (``manta_drake.control.behaviour_tree``): each node
reads one estimate (depth, wall, flow, posture, low battery) and blends its children, gaits
or other nodes. The default tree (``behaviour_tree.default_tree(blend, z_t)``) is the
formula above, bit for bit: Eq. (12) is the tree root = blend(z_hat; swim, gait), gait =
cosine(s_hat; trot, turning).

Where the printed paper contradicts its own text we follow the text (docs/design.md, section 6):

(a) Eq. (12) prints w(s) = (1 + cos(pi s)) / 2, which gives *turning* when no wall is
    seen (s = 0); section 4.3 turns when a wall is detected. We use
    w(s) = (1 - cos(pi s)) / 2, so s_hat -> 1 means turning.
(b) Eqs. (14)-(15) as printed climb the potential: W = -g exp(-T (1 - cos e)),
    e = psi - psi_d, has dW/dpsi = g T sin(e) exp(-T (1 - cos e)) = -T sin(e) W, and
    psi <- psi - alpha * (T sin(e) W) = psi + alpha dW/dpsi is ascent. We implement the
    descent the text intends, psi <- psi - alpha dW/dpsi, every ``period`` seconds.

(c) Eq. (14)'s well is flat on the far side of the torus: a parameter exactly opposite its
    target (e = pi) has zero slope and never moves, and one near it escapes slowly. A
    target that jumps (a ``switch`` node, an estimate that steps) can put a parameter
    there, and the gait then runs with that parameter stranded. The descent breaks the
    tie: within ``TIE_BAND`` (0.25 rad) of the antipode the slope sin(e) is held at
    sin(0.25) with the sign of e wrapped to (-pi, pi], so e = pi steps psi down (the
    parameter goes the negative way round); a parameter at the antipode leaves the band
    in ~0.9 s with the defaults.

Guarantees (tested): each parameter's error e (wrapped to (-pi, pi], the potential is
on the torus) shrinks monotonically without overshoot from any start, the antipode
included, because the step is -c s(e) exp(-T (1 - cos e)) with c = alpha g T <= 1
(checked at construction), s the tie-broken sine, ``0 < |s(e)| <= |e|`` for e != 0;
and no update moves a parameter by more than ``max_step = alpha g T`` rad (0.059 rad
with the defaults).

Defaults: T = 0.5 (a broad well: a parameter starting near the far side of the torus,
e.g. Phi' from -pi/18 to pi, still escapes in ~3 s), g = 0.125, alpha = 0.95, period
0.02 s: near the target the error decays by 5.9 % per update (time constant 0.34 s),
so a swim -> trot change takes a few seconds, as in the paper (Fig. 10: ~8 s including
the sinking).
"""

import numpy as np
from pydrake.systems.framework import LeafSystem

from manta_drake.config_io import ScenarioError, field_name
from manta_drake.control.behaviour_tree import BehaviourTree, compile_tree, default_tree
from manta_drake.control.gaits import get_gait
from manta_drake.model.robot_params import NUM_CPG_PARAMS

# The behaviours Eq. (12) blends: swim (surface), and in the gait trot or turning (vision).
BEHAVIOURS = ("swim", "trot", "turning")
# Targets: Eq. (12) ("potential"), its convex form ("normalised"), Eq. (11) ("linear"), or an
# abrupt switch at half depth and half wall rate ("switch", a baseline). How psi follows its
# target: Eqs. (14)-(15) ("descent") or at once ("direct", the baselines).
BLENDS = ("potential", "normalised", "linear", "switch")
FOLLOWS = ("descent", "direct")


def check_parameters(
    period: float,
    g: float,
    T: float,
    alpha: float,
    z_t: float,
    blend: str,
    s_hat_time_constant: float = 0.0,
    follow: str = "descent",
    where: str = "",
) -> None:
    """Raises ScenarioError naming the first invalid parameter (``<where>.<name>``) and its
    allowed range: the constructor's check and the scenario's (``transition``)."""

    def at(name: str) -> str:
        return field_name(where, name)

    for name, value in (("period", period), ("g", g), ("T", T), ("alpha", alpha)):
        if not (np.isfinite(value) and value > 0):
            raise ScenarioError(f"{at(name)}: {value} must be a finite number > 0")
    if not (np.isfinite(s_hat_time_constant) and s_hat_time_constant >= 0):
        raise ScenarioError(
            f"{at('s_hat_time_constant')}: {s_hat_time_constant} must be a finite number "
            ">= 0 (0: no filter)"
        )
    if not 0 < z_t <= 1:
        raise ScenarioError(f"{at('z_t')}: {z_t} is outside (0, 1]")
    if blend not in BLENDS:
        raise ScenarioError(f"{at('blend')}: {blend!r} is not one of {', '.join(BLENDS)}")
    if follow not in FOLLOWS:
        raise ScenarioError(f"{at('follow')}: {follow!r} is not one of {', '.join(FOLLOWS)}")
    if alpha * g * T > 1.0:
        raise ScenarioError(
            f"{at('alpha')} * g * T = {alpha * g * T:.3g} > 1 would overshoot the target; "
            "reduce g, T or alpha"
        )


def wrap(x):
    """Angles wrapped to (-pi, pi]."""
    return np.pi - np.mod(np.pi - np.asarray(x, dtype=float), 2.0 * np.pi)


def vision_weight(s_hat) -> float:
    """w(s) = (1 - cos(pi s)) / 2, the text's reading of Eq. (12): 0 -> trot, 1 -> turning."""
    s = float(np.clip(s_hat, 0.0, 1.0))
    return 0.5 * (1.0 - np.cos(np.pi * s))


def target_params(
    z_hat, s_hat, swim, trot, turning, z_t: float = 1.0, blend: str = "potential"
) -> np.ndarray:
    """psi_d of Eq. (12) (``blend="potential"``), its convex form (``"normalised"``: the two
    weights -sin(a), cos(a) divided by their sum), Eq. (11) (``"linear"``) or an abrupt
    switch (``"switch"``: the gait from z_hat >= z_t / 2, turning from s_hat >= 1/2, where
    w(s_hat) = 1/2); 64-vectors in. Non-finite z_hat or s_hat count as 0.

    ``behaviour_tree.default_tree(blend, z_t)`` is this function as a tree, bit for bit.
    """
    s = float(np.clip(s_hat, 0.0, 1.0)) if np.isfinite(s_hat) else 0.0
    w = vision_weight(s)
    z = float(np.clip(z_hat, 0.0, 1.0)) if np.isfinite(z_hat) else 0.0
    if blend == "switch":
        # s >= 1/2, not w(s) >= 1/2: w(1/2) rounds to 0.49999999999999994.
        gait = np.asarray(turning if s >= 0.5 else trot)
        return np.array(gait if z >= 0.5 * z_t else swim, dtype=float)
    gait = w * np.asarray(turning) + (1.0 - w) * np.asarray(trot)
    if blend == "linear":
        return (gait - swim) * z + swim
    a = 0.5 * np.pi * (min(z / z_t, 1.0) - 1.0)
    if blend == "normalised":
        w_swim, w_gait = -np.sin(a), np.cos(a)
        total = w_swim + w_gait
        return (w_swim / total) * np.asarray(swim) + (w_gait / total) * gait
    return -np.sin(a) * np.asarray(swim) + np.cos(a) * gait


def potential(psi, psi_d, g: float, T: float) -> np.ndarray:
    """Eq. (14): W = -g exp(-T (1 - cos(psi - psi_d))), per parameter."""
    return -g * np.exp(-T * (1.0 - np.cos(np.asarray(psi) - psi_d)))


# Within this much of the far side of the torus [rad] the descent's slope sin(e) is held
# at sin(TIE_BAND), with the sign of e wrapped to (-pi, pi] (e = pi steps psi down).
TIE_BAND = 0.25


def tie_broken_sine(e) -> np.ndarray:
    """sin(e), except within ``TIE_BAND`` of the antipode ``abs(e) = pi``, where Eq. (14)'s
    slope vanishes: there sign(e) sin(TIE_BAND), sign(pi) = +1. Continuous at
    ``abs(e) = pi - TIE_BAND``, never larger in magnitude than e, and nonzero wherever e
    is."""
    e = np.asarray(e, dtype=float)
    held = np.where(e >= 0.0, 1.0, -1.0) * np.sin(TIE_BAND)
    return np.where(np.abs(e) > np.pi - TIE_BAND, held, np.sin(e))


def descent_step(psi, psi_d, g: float, T: float, alpha: float) -> np.ndarray:
    """Eq. (15) as descent: psi - alpha dW/dpsi, dW/dpsi = g T sin(e) exp(-T (1 - cos e)),
    with sin(e) tie-broken at the antipode (``tie_broken_sine``)."""
    e = wrap(np.asarray(psi) - psi_d)
    return psi - alpha * g * T * tie_broken_sine(e) * np.exp(-T * (1.0 - np.cos(e)))


def _transition_tree(
    tree: BehaviourTree | None, blend: str, z_t: float, behaviours, gait_reading: str
) -> BehaviourTree:
    """``tree`` checked, or without one the default tree of ``blend`` and ``z_t`` over the
    three gaits ``behaviours`` of the ``gait_reading`` library."""
    if tree is None:
        behaviours = tuple(behaviours)
        if len(behaviours) != 3:
            raise ValueError(
                f"PotentialTransition.behaviours: expected 3 gait names "
                f"(surface, floor, wall), got {len(behaviours)}"
            )
        gaits = {b: get_gait(b, gait_reading).to_vector() for b in behaviours}
        try:
            return compile_tree(default_tree(blend, z_t, behaviours=behaviours), gaits)
        except ValueError as e:
            raise ValueError(f"PotentialTransition.behaviours: {e}") from None
    if not isinstance(tree, BehaviourTree):
        raise ValueError(
            f"PotentialTransition.tree: expected a BehaviourTree "
            f"(behaviour_tree.compile_tree), got {type(tree).__name__}"
        )
    return tree


def _check_time_constants(taus: dict, tree: BehaviourTree) -> None:
    """Each key of ``taus`` a modality ``tree`` reads (or s_hat), each value >= 0."""
    for m, tau in taus.items():
        if m != "s_hat" and m not in tree.modalities:
            raise ValueError(
                f"PotentialTransition.time_constants: {m!r} is not a "
                f"modality the tree reads ({', '.join(tree.modalities)})"
            )
        if not (isinstance(tau, (int, float)) and np.isfinite(tau) and tau >= 0):
            raise ValueError(
                f"PotentialTransition.time_constants.{m}: {tau!r} must be a "
                "finite number >= 0 (0: no filter)"
            )


def _initial_params(tree: BehaviourTree, initial_params) -> np.ndarray:
    """psi at t = 0: ``initial_params`` checked, or None: the tree's first leaf gait."""
    initial = (
        tree.gait_vectors[tree.leaves[0]]
        if initial_params is None
        else np.asarray(initial_params, dtype=float)
    )
    if initial.shape != (NUM_CPG_PARAMS,) or not np.all(np.isfinite(initial)):
        raise ValueError(
            f"PotentialTransition.initial_params: expected {NUM_CPG_PARAMS} "
            f"finite values (R, X, Phi, Phi'), got shape {initial.shape}"
        )
    return initial


class PotentialTransition(LeafSystem):
    """Behaviour transition system: CPG parameters from the estimates (Eqs. 11-15).

    .. pydrake_system::

        name: PotentialTransition
        input_ports:
        - z_hat (default tree)
        - s_hat (default tree)
        output_ports:
        - cpg_params
        - behaviour_weights

    The input ports vary with the tree: one per modality it reads (``tree.modalities``, each
    of size 1, named by the modality, e.g. ``flow_hat`` or ``posture_hat``). Drawn above are
    the default tree's, z_hat and s_hat.

    * ``z_hat`` (1): estimated depth in [0, 1] (FuzzyDepthEstimator).
    * ``s_hat`` (1): wall detection rate in [0, 1] (WallDetector).
    * ``cpg_params`` (64): psi, the current CPG parameters (R, X, Phi, Phi'), a discrete
      state moved toward psi_d every ``period`` seconds by descent on Eq. (14)'s well.
    * ``behaviour_weights`` (len(tree.leaves)): each leaf gait's weight in the last update's
      target psi_d (``BehaviourTree.leaf_weights``; the default tree: swim, trot, turning),
      a discrete state.

    A modality with a time constant (``time_constants``; by default s_hat's,
    ``s_hat_time_constant``) passes a first-order low-pass filter (a discrete state each,
    starting at 0) before it enters the tree. The camera's s_hat is a step signal at its frame
    rate. A step of w(s) from 1 to 0 (or back) would put several Phi' parameters exactly
    opposite their new target (turning Phi'[0, 3] = -pi against trot's 0), where Eq. (14)'s
    well is flat, and they would never move. Filtered, psi_d sweeps continuously and psi
    follows. z_hat comes from a continuous depth and is used as it is.

    Switch nodes hold their chosen child in a discrete state (``tree.num_switches``; starting
    from the threshold rule at the initial estimates). Non-finite inputs are treated as 0 for
    that update.

    Without a ``tree`` the default tree of ``blend`` and ``z_t`` blends the three behaviours
    ``behaviours`` (the surface, floor and wall gaits, by default swim, trot, turning) taken
    from the gait library of ``gait_reading`` (``gaits.READINGS``: ``paper`` or ``mirrored``).
    With a ``tree``, ``blend``, ``z_t``, ``behaviours`` and ``gait_reading`` are not used.
    ``initial_params`` (64) is psi at t = 0; None: the tree's first leaf (the surface gait of
    the default tree). ``time_constants`` (modality -> tau [s], 0: raw) overrides
    ``{"s_hat": s_hat_time_constant}`` entry by entry; each key a modality the tree reads
    (s_hat's default is ignored by a tree without it). ``filter_state_indices`` maps each
    filtered modality to its discrete state. ``initial_values`` (modality -> estimate) are
    the estimates at t = 0, which the switches, the filters and ``behaviour_weights`` start
    from (None or a missing modality: 0, nothing seen yet).
    """

    def __init__(
        self,
        period: float = 0.02,
        g: float = 0.125,
        T: float = 0.5,
        alpha: float = 0.95,
        z_t: float = 1.0,
        blend: str = "potential",
        follow: str = "descent",
        initial_params=None,
        behaviours=BEHAVIOURS,
        s_hat_time_constant: float = 1.0,
        gait_reading: str = "paper",
        *,
        tree: BehaviourTree | None = None,
        time_constants: dict[str, float] | None = None,
        initial_values: dict[str, float] | None = None,
    ):
        super().__init__()
        check_parameters(
            period, g, T, alpha, z_t, blend, s_hat_time_constant, follow, "PotentialTransition"
        )
        self.tree = tree = _transition_tree(tree, blend, z_t, behaviours, gait_reading)
        taus = {"s_hat": s_hat_time_constant, **(time_constants or {})}
        _check_time_constants(taus, tree)
        # Exact discretisation of dx/dt = (input - x) / tau over one period.
        self.time_constants = {m: float(taus.get(m, 0.0)) for m in tree.modalities}
        gains = {
            m: 1.0 - np.exp(-period / tau) for m, tau in self.time_constants.items() if tau > 0
        }
        self.s_hat_gain = gains.get("s_hat", 1.0)
        self.period, self.g, self.T = period, g, T
        self.alpha, self.z_t, self.blend = alpha, z_t, blend
        self.follow = follow
        self.max_step = alpha * g * T
        initial = _initial_params(tree, initial_params)
        start = {m: float((initial_values or {}).get(m, 0.0)) for m in tree.modalities}
        self._psi, self._filters, self._switches, self._weights = self._declare_state(
            initial, gains, start
        )
        self.filter_state_indices = {m: index for m, (index, _) in self._filters.items()}
        self._inputs = self._declare_ports()
        self.DeclarePeriodicDiscreteUpdateEvent(period, 0.0, self._update)

    def _declare_state(self, initial: np.ndarray, gains: dict[str, float], start: dict):
        """Declares the discrete states, in this order: psi (from ``initial``), one filter per
        filtered modality (``gains``: modality -> gain per update; from its estimate at the
        start), the switches' and the leaf weights (from the estimates ``start``); returns
        (psi, {modality: (filter state, gain)}, switches, weights), the state indices."""
        psi = self.DeclareDiscreteState(initial)
        filters = {m: (self.DeclareDiscreteState([start[m]]), gain) for m, gain in gains.items()}
        switches = self.tree.initial_switch_state(start)
        switch_state = self.DeclareDiscreteState(switches)
        weights = self.DeclareDiscreteState(self.tree.leaf_weights(start, switches)[0])
        return psi, filters, switch_state, weights

    def _declare_ports(self) -> dict:
        """Declares one input per modality the tree reads (its order), then the outputs
        ``cpg_params`` and ``behaviour_weights``; returns the inputs by modality."""
        inputs = {m: self.DeclareVectorInputPort(m, 1) for m in self.tree.modalities}
        self.DeclareStateOutputPort("cpg_params", self._psi)
        self.DeclareStateOutputPort("behaviour_weights", self._weights)
        return inputs

    def target(self, z_hat: float = 0.0, s_hat: float = 0.0, **values: float) -> np.ndarray:
        """psi_d for these estimates (switches by the threshold rule, without memory);
        ``values``: the tree's other modalities."""
        return self.tree.target({"z_hat": z_hat, "s_hat": s_hat, **values})[0]

    def _update(self, context, discrete_state):
        values = {}
        for m, port in self._inputs.items():
            x = port.Eval(context)[0]
            x = x if np.isfinite(x) else 0.0
            if m in self._filters:
                index, gain = self._filters[m]
                s = context.get_discrete_state(index).GetAtIndex(0)
                x = s + gain * (x - s)
                discrete_state.get_mutable_vector(index).SetAtIndex(0, x)
            values[m] = x
        held = context.get_discrete_state(self._switches).get_value()
        psi_d, weights, held = self.tree.evaluate(values, held)
        psi = context.get_discrete_state(self._psi).get_value()
        if self.follow == "direct":  # the baselines: the target at once
            psi_next = psi_d
        else:
            psi_next = descent_step(psi, psi_d, self.g, self.T, self.alpha)
        discrete_state.get_mutable_vector(self._psi).SetFromVector(psi_next)
        discrete_state.get_mutable_vector(self._switches).SetFromVector(held)
        discrete_state.get_mutable_vector(self._weights).SetFromVector(weights)

    def set_params(self, context, psi) -> None:
        """Sets psi (64) in this system's context."""
        context.get_mutable_discrete_state(self._psi).SetFromVector(np.asarray(psi, dtype=float))
