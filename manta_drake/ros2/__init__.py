"""ROS 2 without a ROS 2 installation: a run as a ROS 2 bag, and measured bags read back.

One module per part:

* ``messages``: pure conversions of port and log values into standard ROS 2 messages
  (rosbags' message classes) and their CDR bytes; what a bag holds and what a DDS seam
  would publish.
* ``signals``: the signals a bag carries, the log arrays each is made of and the message
  types each may be written as.
* ``topic_map``: the topic, type, QoS profile and rate of each signal, and the frame ids
  (``models/ros2_topics.yaml``, or a user's file laid over it).
* ``tf``: the fin links' transforms from the robot's plant.
* ``bag``: a run's log written as an MCAP file with ROS 2 schemas and a rosbag2
  ``metadata.yaml`` (version 5, the Humble layout later distributions read).
* ``reading``: a measured bag (a rosbag2 folder or a bare ``.mcap``) read with rosbags.

This package face imports nothing heavy: ``manta_drake.run_folder`` reads the bag's file
names from it before pydrake is imported.
"""

BAG_FILE = "run.mcap"
METADATA_FILE = "metadata.yaml"
# The files a bag is, in the order they are written (the metadata last: it names the rest).
BAG_FILES = (BAG_FILE, METADATA_FILE)

# The optional packages of the live ROS 2 parts: module -> (the option that needs it, its
# PyPI name). pip install 'manta_drake[ros2]' installs both.
OPTIONAL = {"cyclonedds": ("--ros2", "cyclonedds"), "foxglove": ("--foxglove", "foxglove-sdk")}


class MissingExtraError(ImportError):
    """An option's optional package is not installed; one line naming both."""


def require(module: str) -> None:
    """Raises MissingExtraError, naming the option and the install command, unless
    ``module`` (a key of ``OPTIONAL``) can be imported."""
    import importlib.util

    if importlib.util.find_spec(module) is None:
        option, package = OPTIONAL[module]
        raise MissingExtraError(
            f"{option} needs the {package} package, not installed here: "
            "pip install 'manta_drake[ros2]'"
        )
