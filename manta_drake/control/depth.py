"""Fuzzy depth estimation (section 3.2, Eq. 9).

The depth range [0, D] (D: distance to the floor at initial submersion) is divided
evenly into three layers, surface [0, D/3], mid [D/3, 2D/3] and deep [2D/3, D],
with a trapezoid, a triangle and a trapezoid membership function:

* surface: 1 on [0, D/6], falling linearly to 0 at D/2;
* mid: 0 at D/6, rising to 1 at D/2, falling to 0 at 5D/6;
* deep: 0 at D/2, rising to 1 at 5D/6, 1 on [5D/6, D].

Each is centred on its layer's middle, and where two overlap they sum to one (a
partition of unity). Eq. (9)'s centroid h_hat = sum(mu_i c_i) / sum(mu_i) uses
the centres c = (0, D/2, D), chosen so that z_hat = h_hat / D spans [0, 1]: 0 in
the upper half of the surface layer, 1 in the lower half of the deep layer, and
linear and monotone in between, so the transition system sees a continuous
signal. Depths outside [0, D] clamp; a NaN reading holds the last valid estimate.

D is a parameter (``floor_distance``): the pressure sensor's depth when the robot
stands on the floor. It is not measured on line, so a scenario that starts at the
surface still has it (the paper measures it once, at initial submersion).

Depths are counted from the surface float (``surface_depth``, h_s): the sensor's depth
with the robot floating at rest at the surface, balloon full, as a pressure sensor zeroed
at initial submersion reads. The layers then divide [h_s, D] instead of [0, D]: a robot
swimming at the surface reads z_hat = 0, not the 0.06 (peaks 0.27) that the head's 3-4 cm
of draft and bobbing gave, which kept the transition ~9 % of the way toward the trot while
swimming and made the return to swimming arrive or not by chance.
"""

import numpy as np
from pydrake.systems.framework import LeafSystem

from manta_drake.config_io import Range, check_in_range

# The distance to the floor D [m] (the scenario's depth_estimator.floor_distance): D divides
# h_hat, so it is positive; beyond 10 m it is no pool.
FLOOR_DISTANCE = Range(0.0, 10.0, "m", open_low=True)
# The update period [s]: the pressure sensor's (a scenario's 1 / pressure_sensor.rate_hz,
# which is checked against it with the water on, where this estimator is built).
PERIOD = Range(0.0, 1.0, "s", open_low=True)


def check_surface_depth(field: str, surface_depth, floor_distance: float) -> None:
    """The surface float's depth h_s in [0, floor_distance) m (the layers divide
    [h_s, D], which must not be empty); ScenarioError naming ``field``. The scenario's
    depth_estimator.surface_depth and the estimator's argument are both checked here."""
    check_in_range(
        field,
        surface_depth,
        0.0,
        floor_distance,
        f"[0, floor_distance = {floor_distance}) m",
        open_high=True,
    )


def memberships(h, D: float) -> np.ndarray:
    """Membership degrees (surface, mid, deep) of depths ``h`` in [0, D]; shape (..., 3).

    Depths outside [0, D] are clamped first.
    """
    x = np.clip(np.asarray(h, dtype=float), 0.0, D) / D
    surface = np.clip((0.5 - x) * 3.0, 0.0, 1.0)
    mid = np.clip(1.0 - np.abs(x - 0.5) * 3.0, 0.0, 1.0)
    deep = np.clip((x - 0.5) * 3.0, 0.0, 1.0)
    return np.stack([surface, mid, deep], axis=-1)


def layer_centres(D: float) -> np.ndarray:
    """The centres c_i of Eq. (9) for the surface, mid and deep layers."""
    return np.array([0.0, 0.5 * D, D])


def fuzzy_depth(h, D: float, surface_depth: float = 0.0) -> tuple:
    """Eq. (9): (h_hat, z_hat) for depths ``h``, with the layers on [surface_depth, D]
    (depth measured from the surface float): h_hat = surface_depth + centroid, z_hat =
    centroid / (D - surface_depth)."""
    span = D - surface_depth
    mu = memberships(np.asarray(h, dtype=float) - surface_depth, span)
    centroid = (mu @ layer_centres(span)) / mu.sum(axis=-1)
    return surface_depth + centroid, centroid / span


class FuzzyDepthEstimator(LeafSystem):
    """Fuzzy depth estimator of Eq. (9).

    .. pydrake_system::

        name: FuzzyDepthEstimator
        input_ports:
        - depth
        output_ports:
        - h_hat
        - z_hat

    * ``depth`` (1): measured depth h below the surface [m], positive down; may be NaN
      (sensor dropout).
    * ``h_hat`` (1): centroid depth estimate [m].
    * ``z_hat`` (1): in [0, 1] (0: floating at the surface, 1: on the floor).

    The estimate is a discrete state updated every ``period`` seconds (the pressure
    sensor's rate); a NaN or infinite reading keeps the last valid estimate.
    """

    def __init__(
        self,
        floor_distance: float,
        period: float,
        initial_depth: float = 0.0,
        surface_depth: float = 0.0,
    ):
        super().__init__()
        # The same ranges as the scenario's depth_estimator.* fields (declared above).
        FLOOR_DISTANCE.check(
            "FuzzyDepthEstimator.floor_distance",
            floor_distance,
            "the distance to the floor D divides h_hat",
        )
        check_surface_depth("FuzzyDepthEstimator.surface_depth", surface_depth, floor_distance)
        PERIOD.check("FuzzyDepthEstimator.period", period)
        check_in_range(
            "FuzzyDepthEstimator.initial_depth",
            initial_depth,
            0.0,
            100.0,
            "[0, 100] m below the surface",
        )
        self.surface_depth = float(surface_depth)
        self.D = float(floor_distance)
        h0, z0 = fuzzy_depth(initial_depth, self.D, self.surface_depth)
        self._state = self.DeclareDiscreteState([float(h0), float(z0)])
        self._depth = self.DeclareVectorInputPort("depth", 1)
        self.DeclareVectorOutputPort(
            "h_hat",
            1,
            lambda c, o: o.SetAtIndex(0, c.get_discrete_state(self._state).GetAtIndex(0)),
            prerequisites_of_calc={self.xd_ticket()},
        )
        self.DeclareVectorOutputPort(
            "z_hat",
            1,
            lambda c, o: o.SetAtIndex(0, c.get_discrete_state(self._state).GetAtIndex(1)),
            prerequisites_of_calc={self.xd_ticket()},
        )
        self.DeclarePeriodicDiscreteUpdateEvent(period, 0.0, self._update)

    def _update(self, context, discrete_state):
        h = self._depth.Eval(context)[0]
        if not np.isfinite(h):
            return  # hold the last valid estimate
        h_hat, z_hat = fuzzy_depth(h, self.D, self.surface_depth)
        discrete_state.get_mutable_vector(self._state).SetFromVector([h_hat, z_hat])
