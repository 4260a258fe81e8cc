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
