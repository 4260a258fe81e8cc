"""The servo bus: commands to the servos and their readings, once per bus period.

The robot's controller talks to its sixteen servos over one RS-485 bus (ROBOTIS DYNAMIXEL
protocol 2.0): once per period it writes every goal in one sync-write packet and reads every
present position and velocity in one sync read. A servo acts on a goal at its next cycle, and
what it reports is its encoder's count (4096 pulses per turn on the XW540-T140) and its
velocity in the control table's unit (0.229 rev/min), both as integers.
"""

import math

import numpy as np
from pydrake.systems.framework import LeafSystem

# Present Velocity (128)'s unit on the X series: 0.229 rev/min (ROBOTIS e-Manual).
VELOCITY_UNIT = 0.229 * 2.0 * math.pi / 60.0  # rad/s


def quantize_joint_state(x, encoder_resolution: float, velocity_unit: float = VELOCITY_UNIT):
    """The joint state [q (n), qdot (n)] as the servos report it: q to whole encoder pulses
    (2 pi / ``encoder_resolution`` rad), qdot to whole units of ``velocity_unit`` [rad/s]."""
    x = np.asarray(x, dtype=float)
    n = x.size // 2
    pulse = 2.0 * math.pi / encoder_resolution
    return np.concatenate(
        [np.round(x[:n] / pulse) * pulse, np.round(x[n:] / velocity_unit) * velocity_unit]
    )


class ServoBus(LeafSystem):
    """The bus between the controller and the servos at period T.

    .. pydrake_system::

        name: ServoBus
        input_ports:
        - command
        - joint_state
        output_ports:
        - applied_command
        - measured_joint_state

    * ``command`` (2n): the controller's desired joint state.
    * ``applied_command`` (2n): what the servos act on: over [t_k, t_k + T) the command
      written at t_k - T (a sync write every T, taken up at the next cycle:
      applied(t) = command(t_k - T), t_k = k T); before the first command is taken up
      (t < T), ``start``: the servos hold the pose they were switched on in.
    * ``joint_state`` (2n): the joints' true [q, qdot] (the plant's).
    * ``measured_joint_state`` (2n): the last sync read, at t_k:
      ``quantize_joint_state(joint_state(t_k))``; before the first, ``start``'s.

    Both outputs depend on the discrete state only (no direct feedthrough), and nothing
    reads an input before the first cycle: a station alone over the seam, whose first
    command arrives after its initialization, runs exactly as the single diagram.
    """

    def __init__(self, num_joints: int, period: float, encoder_resolution: float, start=None):
        super().__init__()
        if not (math.isfinite(period) and period > 0):
            raise ValueError(f"ServoBus.period: {period!r} must be a finite number > 0 s")
        if not encoder_resolution > 0:
            raise ValueError(f"ServoBus.encoder_resolution: {encoder_resolution!r} must be > 0")
        self.period, self.encoder_resolution = float(period), float(encoder_resolution)
        n = 2 * num_joints
        start = np.zeros(n) if start is None else np.asarray(start, dtype=float)
        if start.shape != (n,) or not np.all(np.isfinite(start)):
            raise ValueError(
                f"ServoBus.start: expected {n} finite numbers [q, qdot], got shape {start.shape}"
            )
        self._command = self.DeclareVectorInputPort("command", n)
        self._joints = self.DeclareVectorInputPort("joint_state", n)
        self._applied = self.DeclareDiscreteState(start)  # taken up at this cycle
        self._written = self.DeclareDiscreteState(start)  # written at this cycle, for the next
        self._read = self.DeclareDiscreteState(quantize_joint_state(start, encoder_resolution))
        self.DeclareStateOutputPort("applied_command", self._applied)
        self.DeclareStateOutputPort("measured_joint_state", self._read)
        self.DeclarePeriodicDiscreteUpdateEvent(self.period, 0.0, self._cycle)

    def _read_joints(self, context):
        return quantize_joint_state(self._joints.Eval(context), self.encoder_resolution)

    def _cycle(self, context, state):
        state.get_mutable_vector(self._applied).SetFromVector(
            context.get_discrete_state(self._written).get_value()
        )
        state.get_mutable_vector(self._written).SetFromVector(self._command.Eval(context))
        state.get_mutable_vector(self._read).SetFromVector(self._read_joints(context))
