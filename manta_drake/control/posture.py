"""Posture estimation from the IMU: filtered attitude, yaw rate and a 0-1 tilt estimate.

The IMU (``imu``, 9) gives the AHRS attitude [roll, pitch, yaw], the body-frame gyro rates
[wx, wy, wz] and the specific force. Three of its channels are low-passed with the
sampled first-order lag of ``memberships.low_pass_step`` (time constant
``time_constant``): roll, pitch and yaw on the circle, and the gyro's z rate. The
posture estimate is the membership of the tilt, the angle between the body z axis and
the vertical, whose cosine is the (3, 3) entry of the roll-pitch-yaw rotation::

    tilt        = arccos(cos(roll_hat) cos(pitch_hat))             (in [0, pi])
    posture_hat = clip((tilt - tilt_low) / (tilt_high - tilt_low), 0, 1)

0 while level within ``tilt_low_deg``, 1 when tilted by ``tilt_high_deg`` or more (a ramp
membership, the piecewise-linear kind Eq. (9)'s layers use). The yaw does not enter the
tilt, so the estimate does not change as the robot turns.

``yaw_rate_hat`` is the body-frame gyro z rate, low-passed; it equals the heading's rate
only while the robot is level, and it keeps the gyro's constant bias (no bias is
estimated: a heading hold's integrator absorbs what it does to a derivative term).
The specific force is not used: the AHRS attitude already fuses it.
"""

import dataclasses as dc

import numpy as np

from manta_drake.control.filtered_estimator import FilteredEstimator
from manta_drake.control.memberships import check_ramp, ramp_membership

IMU_SIZE = 9  # [roll, pitch, yaw] rad, [wx, wy, wz] rad/s, [fx, fy, fz] m/s^2
# The IMU channels filtered, in the state's order: roll, pitch, yaw, wz.
_CHANNELS = np.array([0, 1, 2, 5])
_CIRCULAR = np.array([True, True, True, False])


def tilt_angle(roll, pitch):
    """The angle [rad] between the body z axis and the vertical, arccos(cos roll cos pitch),
    in [0, pi]."""
    c = np.cos(np.asarray(roll, dtype=float)) * np.cos(np.asarray(pitch, dtype=float))
    return np.arccos(np.clip(c, -1.0, 1.0))


@dc.dataclass
class PostureEstimatorParams:
    """The tilt thresholds of ``posture_hat`` [deg] and the filter's time constant [s]."""

    tilt_low_deg: float = 10.0  # posture_hat = 0 at or below this tilt
    tilt_high_deg: float = 30.0  # posture_hat = 1 at or above this tilt
    time_constant: float = 0.2  # of the attitude and yaw-rate low-pass (0: no filter)

    def validate(self, where: str = "") -> "PostureEstimatorParams":
        """Checks every field's range; ScenarioError names the field (``<where>.<field>``)
        and the allowed range."""
        check_ramp(self, "tilt_low_deg", "tilt_high_deg", 180.0, " deg", where=where)
        return self


def posture_membership(roll, pitch, params: PostureEstimatorParams):
    """``posture_hat`` of an attitude: the ramp membership of its tilt (see the module)."""
    return ramp_membership(
        np.degrees(tilt_angle(roll, pitch)), params.tilt_low_deg, params.tilt_high_deg
    )


class PostureEstimator(FilteredEstimator):
    """The filtered attitude, yaw rate and tilt membership from the IMU.

    .. pydrake_system::

        name: PostureEstimator
        input_ports:
        - imu
        output_ports:
        - attitude_hat
        - yaw_rate_hat
        - posture_hat

    * ``imu`` (9): [roll, pitch, yaw] rad, [wx, wy, wz] rad/s (body frame),
      [fx, fy, fz] m/s^2; any entry may be NaN (dropout).
    * ``attitude_hat`` (3): [roll, pitch, yaw] low-passed on the circle, in (-pi, pi].
    * ``yaw_rate_hat`` (1): the gyro's body z rate, low-passed [rad/s].
    * ``posture_hat`` (1): in [0, 1], the ramp membership of
      tilt = arccos(cos(roll_hat) cos(pitch_hat)) between ``tilt_low_deg`` and
      ``tilt_high_deg`` (0 level, 1 tilted).

    Discrete state (8): the four filtered channels (roll, pitch, yaw, wz) and whether each
    has seen a finite reading (default: zeros, level and unseeded). Updated every ``period``
    seconds from t = 0 with ``alpha = 1 - exp(-period / time_constant)``; a channel starts
    at its first finite reading (an initialization event reads the input when a Simulator
    initializes, so a consumer's first update already sees it) and holds its value while its
    input is NaN or infinite. The outputs depend on the state only (no direct feedthrough).

    Args:
        params: ``PostureEstimatorParams`` (None: the defaults).
        period: the update period [s], in (0, 1] (the IMU's sample period).

    Raises:
        ValueError: naming the invalid field and its allowed range.
    """

    def __init__(self, params: PostureEstimatorParams | None = None, period: float = 0.02):
        params = (params if params is not None else PostureEstimatorParams()).validate()
        super().__init__(
            "imu", IMU_SIZE, _CHANNELS, period, params.time_constant, circular=_CIRCULAR
        )
        self.params = params
        self.DeclareEstimateOutputPort("attitude_hat", 3, lambda x: x[:3])
        self.DeclareEstimateOutputPort("yaw_rate_hat", 1, lambda x: x[3])
        self.DeclareEstimateOutputPort(
            "posture_hat", 1, lambda x: posture_membership(x[0], x[1], params)
        )
