"""Flow estimation from the head's flow sensor: a 0-1 estimate of the relative flow.

The sensor (``flow_velocity``, 3) reads the water's velocity relative to the head, in the
body frame (x forward, y left, z up) [m/s], with noise. The vector is low-passed channel by
channel with the sampled first-order lag of ``memberships.low_pass_step`` (time constant
``time_constant``; filtering the vector before taking a speed keeps the noise's
magnitude out of the speed, which a filtered norm would average in), then reduced to one
speed along ``axis``:

* ``magnitude``: ``|v_hat|``, the relative flow from any direction;
* ``surge``: -v_hat_x, the component of the flow against the robot's heading: positive
  when the water comes from ahead (a head current, or the robot's own forward swimming),
  negative when it comes from behind;
* ``sway``: ``|v_hat_y|``, the side flow from either side.

and the estimate is its ramp membership (the piecewise-linear kind of Eq. (9))::

    flow_hat = clip((speed - speed_low) / (speed_high - speed_low), 0, 1)

What it estimates is the *relative* flow: the sensor moves with the robot, so a robot
swimming forward at 5 cm/s in still water reads 5 cm/s of flow from ahead, exactly as a
robot holding station in a 5 cm/s current does. Nothing is subtracted (the robot's own
speed over ground is not measured). For ``flow_hat`` to mean "a current", put
``speed_low`` above the speed the robot moves at in still water in the behaviours where
the estimate is used; with a standing robot (the seabed gaits) the reading is the current.
"""

import dataclasses as dc

import numpy as np

from manta_drake.config_io import check_one_of, field_name
from manta_drake.control.filtered_estimator import FilteredEstimator
from manta_drake.control.memberships import check_ramp, ramp_membership

AXES = ("magnitude", "surge", "sway")


@dc.dataclass
class FlowEstimatorParams:
    """The speed thresholds of ``flow_hat`` [m/s], the filter's time constant [s] and the
    speed's ``axis`` (one of ``AXES``; see the module docstring)."""

    speed_low: float = 0.03  # flow_hat = 0 at or below this speed
    speed_high: float = 0.08  # flow_hat = 1 at or above this speed
    time_constant: float = 1.0  # of the velocity low-pass (0: no filter)
    axis: str = "magnitude"

    def validate(self, where: str = "") -> "FlowEstimatorParams":
        """Checks every field's range; ScenarioError names the field (``<where>.<field>``)
        and the allowed range."""
        check_ramp(self, "speed_low", "speed_high", 10.0, " m/s", where=where)
        check_one_of(field_name(where, "axis"), self.axis, AXES)
        return self


def flow_speed(velocity, axis: str):
    """The speed [m/s] along ``axis`` of relative water velocities ``velocity`` (..., 3)."""
    v = np.asarray(velocity, dtype=float)
    if axis == "magnitude":
        return np.linalg.norm(v, axis=-1)
    if axis == "surge":
        return -v[..., 0]
    if axis == "sway":
        return np.abs(v[..., 1])
    raise ValueError(f"axis: {axis!r} is not one of {', '.join(AXES)}")


class FlowEstimator(FilteredEstimator):
    """The filtered relative flow speed and its 0-1 membership.

    .. pydrake_system::

        name: FlowEstimator
        input_ports:
        - flow_velocity
        output_ports:
        - flow_hat
        - flow_speed_hat

    * ``flow_velocity`` (3): water velocity relative to the head, body frame [m/s]; any
      entry may be NaN (dropout).
    * ``flow_hat`` (1): in [0, 1], the ramp membership of ``flow_speed_hat`` between
      ``speed_low`` and ``speed_high``.
    * ``flow_speed_hat`` (1): the speed along ``axis`` of the filtered velocity [m/s]
      (``surge`` is signed: negative with the water from behind).

    Discrete state (6): the filtered velocity and whether each component has seen a finite
    reading (default: zeros, still water and unseeded). Updated every ``period`` seconds
    from t = 0 with ``alpha = 1 - exp(-period / time_constant)``; a component starts at its
    first finite reading (an initialization event reads the input when a Simulator
    initializes, so a consumer's first update already sees it) and holds its value while its
    input is NaN or infinite. The outputs depend on the state only.

    Args:
        params: ``FlowEstimatorParams`` (None: the defaults).
        period: the update period [s], in (0, 1] (the flow sensor's sample period).

    Raises:
        ValueError: naming the invalid field and its allowed range.
    """

    def __init__(self, params: FlowEstimatorParams | None = None, period: float = 0.02):
        params = (params if params is not None else FlowEstimatorParams()).validate()
        super().__init__("flow_velocity", 3, [0, 1, 2], period, params.time_constant)
        self.params = params
        self.DeclareEstimateOutputPort(
            "flow_hat",
            1,
            lambda v: ramp_membership(
                flow_speed(v, params.axis), params.speed_low, params.speed_high
            ),
        )
        self.DeclareEstimateOutputPort("flow_speed_hat", 1, lambda v: flow_speed(v, params.axis))
