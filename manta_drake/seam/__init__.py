"""The seam: the station and the controller in two processes, over LCM or ROS 2.

``build_station`` and ``build_controller`` meet at ports of the same names; here each
half runs alone, in its own process, and the ports cross the seam as LCM messages, or as
standard ROS 2 messages over DDS (``--ros2``: ``ros2_link``, docs/ros2.md)::

    manta-drake station SCENARIO --lcm URL       # the simulated robot (or: the robot)
    manta-drake controller SCENARIO --lcm URL    # what runs on the robot
    manta-drake station SCENARIO --ros2 [--domain N]     # the same over ROS 2

``CHANNELS`` is the one table of what crosses the seam: channel, port, sender,
message type and period (docs/lcm.md prints it, ``channel_table_markdown``).
Drake's lcmtypes are used where they fit (``lcmt_scope`` for short double vectors,
``lcmt_image_array`` for the depth image); the two project types are in
``manta_drake.lcmtypes`` (``.lcm`` sources beside the generated Python; regenerate with
``lcm-gen -p --ppath DIR manta_drake/lcmtypes/*.lcm`` and copy ``DIR/manta_drake/lcmtypes/*.py``).

Two ways to run:

* **lockstep** (default): the station's time is the clock, and the split run is
  the single diagram bit for bit. Both sides walk the same ``exchange_schedule``:
  every plant step t_k = k h and every sample time j P of a sensor channel (the
  consumer's periodic event, computed as Drake computes it: a camera sample at
  3 x 0.2 = 0.6000000000000001 s falls just *after* the plant step at 0.6 s and sees
  its result, as in the single diagram). The station advances to tau (tau's events
  stay pending: its outputs are what the single diagram's updates at tau read),
  publishes the sensors due, and at a plant step waits for the commands stamped tau,
  fixes them on its inputs and goes on. The controller advances to tau, publishes
  its commands for tau (the CPG's state and the transition's pre-update parameters:
  what the plant's step at tau reads; no sensor at tau feeds them directly), then
  waits for the sensors stamped tau and fixes them before it advances past tau. So
  the controller runs up to ``MAX_LEAD_STEPS`` steps ahead (it watches the station's
  clock channel) and the two processes work at the same time. A ``PlantStepTick``
  gives the controller's RK2 steps the single diagram's end points. First of all the
  station sends its sensors' values from before its initialization (stamped
  ``BEFORE_START_UTIME``): the controller initializes on them, as the single diagram's
  initialization events read the state from before initialization.
* **wall clock** (``--wall-clock``, both sides): the station runs paced to real time
  with the latest command (from the first one on), the controller on its own wall
  clock with the latest sensor messages, as on the robot.

The first exchange is a handshake (``handshake``): run ids, duration, plant step, clock
mode and the channels each side publishes, so a second station or controller on the URL,
or a peer that runs otherwise, is named at once in one line on both sides. What crosses
is screened (``limits``): the station clips commands to its servos' and pump's limits and
holds the last good one instead of a non-finite one; the controller treats readings
outside their physical range as dropped readings; a message that does not decode is
skipped. Each kind is named once per channel and every one is counted (``Incidents``).

Either side re-sends what the other may not have received while it waits (lost
UDP datagrams, a peer that starts later), warns on stderr when its peer has been
silent for ``STALE_AFTER_S`` and gives up with a one-line error after ``--timeout``
seconds: nothing waits forever. The controller does not hold its last command when the
station falls silent: it commands the safe state (``failsafe``: the start stance, the
balloon full). docs/lcm.md has the whole story.

The package, one module per part: ``messages`` (the codecs), ``channels`` (the channel
table), ``schedule`` (the exchange schedule), ``handshake``, ``limits`` (what passes),
``link`` (the Link and the LCM transport), ``ros2_link`` (the ROS 2 transport),
``failsafe``, ``result``, ``plant_step_tick``, ``station_process`` (``run_station``),
``controller_process`` (``run_controller``), ``errors`` and ``cli``.
"""

from manta_drake.seam.channels import (
    CHANNEL_BY_NAME,
    CHANNELS,
    CLOCK,
    ENERGY_ESTIMATOR_PERIOD_S,
    Channel,
    battery_period,
    channel_table_markdown,
    controller_channels,
    monitor_channels,
    reads_battery,
    station_channels,
    unexchanged_reads,
)
from manta_drake.seam.cli import (
    add_controller_parser,
    add_station_parser,
    check_options,
    check_out_folder,
    controller_main,
    station_main,
)
from manta_drake.seam.controller_process import (
    MAX_LEAD_STEPS,
    MONITORED_OUTPUTS,
    has_feedthrough,
    run_controller,
)
from manta_drake.seam.errors import Incidents, PeerStopped, SeamError
from manta_drake.seam.failsafe import (
    DEFAULT_FAILSAFE_AFTER_S,
    FAILSAFE_UTIME,
    Failsafe,
    safe_commands,
)
from manta_drake.seam.handshake import (
    HANDSHAKE_CHANNEL,
    Greeting,
    Handshake,
    Hello,
    hello_for,
    hello_from_message,
    hello_message,
    mismatches,
)
from manta_drake.seam.limits import (
    Guard,
    JointLimits,
    SensorRanges,
    screen_balloon_command,
    screen_battery,
    screen_depth,
    screen_joint_command,
    screen_reading,
)
from manta_drake.seam.link import (
    DEFAULT_STARTUP_TIMEOUT_S,
    DEFAULT_TIMEOUT_S,
    DEFAULT_URL,
    QUEUE_CAPACITY,
    RESEND_PERIOD_S,
    STALE_AFTER_S,
    LcmTransport,
    Link,
    check_url,
)
from manta_drake.seam.messages import (
    CODECS,
    Codec,
    depth_image_from_message,
    depth_image_message,
    joint_state_from_message,
    joint_state_message,
    pose_from_message,
    pose_message,
    to_utime,
    vector_from_message,
    vector_message,
)
from manta_drake.seam.plant_step_tick import PlantStepTick, controller_with_tick
from manta_drake.seam.result import SeamResult
from manta_drake.seam.ros2_link import Ros2Transport
from manta_drake.seam.schedule import (
    BEFORE_START_TIME,
    BEFORE_START_UTIME,
    Exchange,
    exchange_schedule,
    sample_times,
)
from manta_drake.seam.station_process import initial_commands, run_station

__all__ = [
    "BEFORE_START_TIME",
    "BEFORE_START_UTIME",
    "CHANNELS",
    "CHANNEL_BY_NAME",
    "CLOCK",
    "CODECS",
    "DEFAULT_FAILSAFE_AFTER_S",
    "DEFAULT_STARTUP_TIMEOUT_S",
    "DEFAULT_TIMEOUT_S",
    "DEFAULT_URL",
    "ENERGY_ESTIMATOR_PERIOD_S",
    "FAILSAFE_UTIME",
    "HANDSHAKE_CHANNEL",
    "MAX_LEAD_STEPS",
    "MONITORED_OUTPUTS",
    "QUEUE_CAPACITY",
    "RESEND_PERIOD_S",
    "Ros2Transport",
    "STALE_AFTER_S",
    "Channel",
    "Codec",
    "Exchange",
    "Failsafe",
    "Greeting",
    "Guard",
    "Handshake",
    "Hello",
    "Incidents",
    "JointLimits",
    "LcmTransport",
    "Link",
    "PeerStopped",
    "PlantStepTick",
    "SeamError",
    "SeamResult",
    "SensorRanges",
    "add_controller_parser",
    "add_station_parser",
    "battery_period",
    "channel_table_markdown",
    "check_options",
    "check_out_folder",
    "check_url",
    "controller_channels",
    "controller_main",
    "controller_with_tick",
    "depth_image_from_message",
    "depth_image_message",
    "exchange_schedule",
    "has_feedthrough",
    "hello_for",
    "hello_from_message",
    "hello_message",
    "initial_commands",
    "joint_state_from_message",
    "joint_state_message",
    "mismatches",
    "monitor_channels",
    "pose_from_message",
    "pose_message",
    "reads_battery",
    "run_controller",
    "run_station",
    "safe_commands",
    "sample_times",
    "screen_balloon_command",
    "screen_battery",
    "screen_depth",
    "screen_reading",
    "screen_joint_command",
    "station_channels",
    "station_main",
    "to_utime",
    "unexchanged_reads",
    "vector_from_message",
    "vector_message",
]
