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

Where the printed paper contradicts its own text we follow the text (docs/design.md, section 6):

(a) Eq. (12) prints w(s) = (1 + cos(pi s)) / 2, which gives *turning* when no wall is
    seen (s = 0); section 4.3 turns when a wall is detected. We use
    w(s) = (1 - cos(pi s)) / 2, so s_hat -> 1 means turning.
(b) Eqs. (14)-(15) as printed climb the potential: W = -g exp(-T (1 - cos e)),
    e = psi - psi_d, has dW/dpsi = g T sin(e) exp(-T (1 - cos e)) = -T sin(e) W, and
    psi <- psi - alpha * (T sin(e) W) = psi + alpha dW/dpsi is ascent. We implement the
    descent the text intends, psi <- psi - alpha dW/dpsi, every ``period`` seconds.

Guarantees (tested): each parameter's error e (wrapped to (-pi, pi], the potential is
on the torus) shrinks monotonically without overshoot from any start, because the
step is -c sin(e) exp(-T (1 - cos e)) with c = alpha g T <= 1 (checked at
construction) and ``|sin e| <= |e|``; and no update moves a parameter by more than
``max_step = alpha g T`` rad (0.059 rad with the defaults).

Defaults: T = 0.5 (a broad well: a parameter starting near the far side of the torus,
e.g. Phi' from -pi/18 to pi, still escapes in ~3 s), g = 0.125, alpha = 0.95, period
0.02 s: near the target the error decays by 5.9 % per update (time constant 0.34 s),
so a swim -> trot change takes a few seconds, as in the paper (Fig. 10: ~8 s including
the sinking).
"""

import numpy as np
from pydrake.systems.framework import LeafSystem

from manta_drake.control.gaits import get_gait

# The behaviours Eq. (12) blends: swim (surface), and in the gait trot or turning (vision).
BEHAVIOURS = ("swim", "trot", "turning")
# Targets: Eq. (12) ("potential"), Eq. (11) ("linear"), or an abrupt switch at half depth
# and half wall rate ("switch", a baseline). How psi follows its target: Eqs. (14)-(15)
# ("descent") or at once ("direct", the baselines).
BLENDS = ("potential", "linear", "switch")
FOLLOWS = ("descent", "direct")


def check_parameters(period: float, g: float, T: float, alpha: float, z_t: float,
                     blend: str, s_hat_time_constant: float = 0.0,
                     follow: str = "descent") -> None:
    """Raises ValueError naming the first invalid parameter and its allowed range."""
    for name, value in (("period", period), ("g", g), ("T", T), ("alpha", alpha)):
        if not (np.isfinite(value) and value > 0):
            raise ValueError(f"{name}: {value} must be a finite number > 0")
    if not (np.isfinite(s_hat_time_constant) and s_hat_time_constant >= 0):
        raise ValueError(f"s_hat_time_constant: {s_hat_time_constant} must be a finite number "
                         ">= 0 (0: no filter)")
    if not 0 < z_t <= 1:
        raise ValueError(f"z_t: {z_t} is outside (0, 1]")
    if blend not in BLENDS:
        raise ValueError(f"blend: {blend!r} is not one of {', '.join(BLENDS)}")
    if follow not in FOLLOWS:
        raise ValueError(f"follow: {follow!r} is not one of {', '.join(FOLLOWS)}")
    if alpha * g * T > 1.0:
        raise ValueError(f"alpha * g * T = {alpha * g * T:.3g} > 1 would overshoot the target; "
                         "reduce g, T or alpha")


def wrap(x):
    """Angles wrapped to (-pi, pi]."""
    return np.pi - np.mod(np.pi - np.asarray(x, dtype=float), 2.0 * np.pi)


def vision_weight(s_hat) -> float:
    """w(s) = (1 - cos(pi s)) / 2, the text's reading of Eq. (12): 0 -> trot, 1 -> turning."""
    s = float(np.clip(s_hat, 0.0, 1.0))
    return 0.5 * (1.0 - np.cos(np.pi * s))


def target_params(z_hat, s_hat, swim, trot, turning, z_t: float = 1.0,
                  blend: str = "potential") -> np.ndarray:
    """psi_d of Eq. (12) (``blend="potential"``), Eq. (11) (``"linear"``) or an abrupt switch
    (``"switch"``: the gait from z_hat >= z_t / 2, turning from w(s_hat) >= 1/2);
    64-vectors in."""
    w = vision_weight(s_hat)
    z = float(np.clip(z_hat, 0.0, 1.0)) if np.isfinite(z_hat) else 0.0
    if blend == "switch":
        gait = np.asarray(turning if w >= 0.5 else trot)
        return np.array(gait if z >= 0.5 * z_t else swim, dtype=float)
    gait = w * np.asarray(turning) + (1.0 - w) * np.asarray(trot)
    if blend == "linear":
        return (gait - swim) * z + swim
    a = 0.5 * np.pi * (min(z / z_t, 1.0) - 1.0)
    return -np.sin(a) * np.asarray(swim) + np.cos(a) * gait


def potential(psi, psi_d, g: float, T: float) -> np.ndarray:
    """Eq. (14): W = -g exp(-T (1 - cos(psi - psi_d))), per parameter."""
    return -g * np.exp(-T * (1.0 - np.cos(np.asarray(psi) - psi_d)))


def descent_step(psi, psi_d, g: float, T: float, alpha: float) -> np.ndarray:
    """Eq. (15) as descent: psi - alpha dW/dpsi, dW/dpsi = g T sin(e) exp(-T (1 - cos e))."""
    e = wrap(np.asarray(psi) - psi_d)
    return psi - alpha * g * T * np.sin(e) * np.exp(-T * (1.0 - np.cos(e)))


class PotentialTransition(LeafSystem):
    """Behaviour transition system: CPG parameters from depth and vision (Eqs. 11-15).

    .. pydrake_system::

        name: PotentialTransition
        input_ports:
        - z_hat
        - s_hat
        output_ports:
        - cpg_params

    * ``z_hat`` (1): estimated depth in [0, 1] (FuzzyDepthEstimator).
    * ``s_hat`` (1): wall detection rate in [0, 1] (WallDetector).
    * ``cpg_params`` (64): psi, the current CPG parameters (R, X, Phi, Phi'), a discrete
      state moved toward psi_d every ``period`` seconds by descent on Eq. (14)'s well.

    s_hat passes a first-order low-pass filter (``s_hat_time_constant``, a second discrete
    state) before it enters Eq. (12). The camera's s_hat is a step signal at its frame rate.
    A step of w(s) from 1 to 0 (or back) would put several Phi' parameters exactly opposite
    their new target (turning Phi'[0, 3] = -pi against trot's 0), where Eq. (14)'s well is
    flat, and they would never move. Filtered, psi_d sweeps continuously and psi follows.
    z_hat comes from a continuous depth and is used as it is.

    Non-finite inputs are treated as z_hat = 0 / s_hat = 0 for that update.

    The three behaviours (``behaviours``: swim, trot, turning) are taken from the gait library
    of ``gait_reading`` (``gaits.READINGS``: ``paper`` or ``mirrored``).
    """

    def __init__(self, period: float = 0.02, g: float = 0.125, T: float = 0.5,
                 alpha: float = 0.95, z_t: float = 1.0, blend: str = "potential",
                 follow: str = "descent",
                 initial_params=None, behaviours=BEHAVIOURS, s_hat_time_constant: float = 1.0,
                 gait_reading: str = "paper"):
        super().__init__()
        try:
            check_parameters(period, g, T, alpha, z_t, blend, s_hat_time_constant, follow)
        except ValueError as e:
            raise ValueError(f"PotentialTransition.{e}") from None
        # Exact discretisation of ds/dt = (s_hat - s) / tau over one period (1: no filter).
        self.s_hat_gain = (1.0 - np.exp(-period / s_hat_time_constant)
                           if s_hat_time_constant > 0 else 1.0)
        self.period, self.g, self.T, self.alpha, self.z_t, self.blend = period, g, T, alpha, z_t, blend
        self.follow = follow
        self.max_step = alpha * g * T
        self.swim, self.trot, self.turning = (get_gait(b, gait_reading).to_vector()
                                              for b in behaviours)
        initial = self.swim if initial_params is None else np.asarray(initial_params, dtype=float)
        if initial.shape != self.swim.shape or not np.all(np.isfinite(initial)):
            raise ValueError(f"PotentialTransition.initial_params: expected {self.swim.size} "
                             f"finite values (R, X, Phi, Phi'), got shape {initial.shape}")
        self._psi = self.DeclareDiscreteState(initial)
        self._s_filtered = self.DeclareDiscreteState([0.0])  # no wall seen at the start
        self._z_hat = self.DeclareVectorInputPort("z_hat", 1)
        self._s_hat = self.DeclareVectorInputPort("s_hat", 1)
        self.DeclareStateOutputPort("cpg_params", self._psi)
        self.DeclarePeriodicDiscreteUpdateEvent(period, 0.0, self._update)

    def target(self, z_hat: float, s_hat: float) -> np.ndarray:
        """psi_d for these sensor values."""
        s_hat = s_hat if np.isfinite(s_hat) else 0.0
        return target_params(z_hat, s_hat, self.swim, self.trot, self.turning, self.z_t,
                             self.blend)

    def _update(self, context, discrete_state):
        psi = context.get_discrete_state(self._psi).get_value()
        s = context.get_discrete_state(self._s_filtered).GetAtIndex(0)
        s_hat = self._s_hat.Eval(context)[0]
        s += self.s_hat_gain * ((s_hat if np.isfinite(s_hat) else 0.0) - s)
        psi_d = self.target(self._z_hat.Eval(context)[0], s)
        if self.follow == "direct":  # the baselines: the target at once
            psi_next = psi_d
        else:
            psi_next = descent_step(psi, psi_d, self.g, self.T, self.alpha)
        discrete_state.get_mutable_vector(self._psi).SetFromVector(psi_next)
        discrete_state.get_mutable_vector(self._s_filtered).SetAtIndex(0, s)

    def set_params(self, context, psi) -> None:
        """Sets psi (64) in this system's context."""
        context.get_mutable_discrete_state(self._psi).SetFromVector(np.asarray(psi, dtype=float))
