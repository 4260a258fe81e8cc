"""Floor estimation from the altimeter: a 0-1 estimate of standing on the floor.

The altimeter (``altitude``, 1) gives the echo sounder's range to the floor [m] (NaN: no
reading). The range is low-passed with the sampled first-order lag of
``memberships.low_pass_step`` (time constant ``time_constant``, a dropout holding the
estimate) and the estimate is the falling ramp membership (the piecewise-linear kind of
Eq. (9)) of the filtered range::

    floor_hat = 1 - clip((range_hat - on_floor_range) / (off_floor_range - on_floor_range), 0, 1)

1 at or below ``on_floor_range`` (on the floor), 0 at or above ``off_floor_range`` (in
free water), linear between: the same reading as the depth estimate ``z_hat`` gives at
the floor and the surface, from a sensor on the hull's underside instead of the head.

Why it is independent of the hull's pitch: the transducer sits under the hull's centre,
about which the hull pitches, and its beam's first echo is the floor's normal distance
while the tilt is within the beam's half-angle (``station.altimeter``); the head's
pressure sensor, 0.19 m ahead, rises by 0.19 sin(pitch) when the nose lifts.
"""

import dataclasses as dc

from manta_drake.config_io import check_in_range
from manta_drake.control.filtered_estimator import FilteredEstimator
from manta_drake.control.memberships import check_ramp, ramp_membership


@dc.dataclass
class AltimeterEstimatorParams:
    """The range thresholds of ``floor_hat`` [m] and the filter's time constant [s].

    Measured with the default altimeter in the paper's 0.5 m pool (docs/behaviours.md,
    "Floor detection from the altimeter"): in the trot's stance the filtered range is
    0.17-0.18 m, in the nose-up trot's and other floor gaits' 0.17-0.22 m; the swim at the
    surface porpoises the transducer down to a raw 0.21 m, 0.28-0.36 m once filtered with a
    1 s time constant (0.24 m with 0.3 s). The band [0.23, 0.28] m lies between the two
    with 1-0.5 cm to spare; the 1 s lag averages the swim's 2 s heave and delays the
    estimate by about 1 s, short against the seconds a sink or a rise takes."""

    on_floor_range: float = 0.23  # floor_hat = 1 at or below this range
    off_floor_range: float = 0.28  # floor_hat = 0 at or above this range
    time_constant: float = 1.0  # of the range's low-pass (0: no filter)

    def validate(self, where: str = "") -> "AltimeterEstimatorParams":
        """Checks every field's range; ScenarioError names the field (``<where>.<field>``)
        and the allowed range."""
        check_ramp(self, "on_floor_range", "off_floor_range", 100.0, " m", where=where)
        return self


def floor_membership(range_m, params: AltimeterEstimatorParams):
    """``floor_hat`` of ranges ``range_m``: 1 - the ramp from on_floor to off_floor range."""
    return 1.0 - ramp_membership(range_m, params.on_floor_range, params.off_floor_range)


class AltimeterEstimator(FilteredEstimator):
    """The filtered range to the floor and its on-the-floor membership.

    .. pydrake_system::

        name: AltimeterEstimator
        input_ports:
        - altitude
        output_ports:
        - altitude_hat
        - floor_hat

    * ``altitude`` (1): the altimeter's range to the floor [m]; NaN: no reading.
    * ``altitude_hat`` (1): the filtered range [m] (``initial_range`` until the first
      reading).
    * ``floor_hat`` (1): in [0, 1], 1 - the ramp membership of ``altitude_hat`` between
      ``on_floor_range`` and ``off_floor_range`` (1: on the floor).

    Discrete state (2): the filtered range and whether it has seen a finite reading.
    Updated every ``period`` seconds from t = 0 (``FilteredEstimator``).

    Args:
        params: ``AltimeterEstimatorParams`` (None: the defaults).
        period: the update period [s], in (0, 1] (the altimeter's ping period).
        initial_range: the range [m] before the first reading (None: ``off_floor_range``,
            free water); the controller gives the start pose's.

    Raises:
        ValueError: naming the invalid field and its allowed range.
    """

    def __init__(
        self,
        params: AltimeterEstimatorParams | None = None,
        period: float = 0.1,
        initial_range: float | None = None,
    ):
        params = (params if params is not None else AltimeterEstimatorParams()).validate()
        initial = params.off_floor_range if initial_range is None else initial_range
        check_in_range("AltimeterEstimator.initial_range", initial, 0.0, 100.0, "[0, 100] m")
        super().__init__("altitude", 1, [0], period, params.time_constant, initial=[initial])
        self.params = params
        self.DeclareEstimateOutputPort("altitude_hat", 1, lambda r: r[0])
        self.DeclareEstimateOutputPort("floor_hat", 1, lambda r: floor_membership(r[0], params))
