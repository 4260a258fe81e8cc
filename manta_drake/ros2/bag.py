"""A run's log as a ROS 2 bag: ``run.mcap`` (MCAP, profile ``ros2``, ``ros2msg`` schemas
from rosbags' type store, CDR messages, zstd chunks) and a rosbag2 ``metadata.yaml``
(version 5, the Humble layout: Humble's ``ros2 bag`` with the mcap storage plugin and
every later distribution read it) in the run folder beside ``log.npz``.

Every message is stamped (header and log time) with its sample's simulated time; each
signal is decimated to its topic's rate (``decimate``). ``write_run_bag`` writes a run's
bag from its log in memory, ``bag_run_folder`` from a run folder's ``log.npz`` and
``scenario.yaml``.
"""

from __future__ import annotations

import dataclasses as dc
import math
import os
import pathlib

import mcap
import numpy as np
import yaml
from mcap.writer import CompressionType, Writer

from manta_drake.ros2 import BAG_FILE, METADATA_FILE
from manta_drake.ros2 import messages as m
from manta_drake.ros2.signals import SIGNALS, Constants
from manta_drake.ros2.topic_map import QOS_PROFILES, TopicMap
from manta_drake.version import __version__

METADATA_VERSION = 5
# Samples this close to a rate's grid time count as on it (a sample at 3 x 0.1 s is
# logged at 0.30000000000000004 s).
GRID_SLACK_S = 1e-9


class _Dumper(yaml.SafeDumper):
    """YAML without anchors and aliases (the metadata's repeated spans stay written out),
    lines unfolded (a QoS profile's text on one line, as rosbag2 writes it)."""

    def ignore_aliases(self, data) -> bool:
        return True


def _yaml(data) -> str:
    return yaml.dump(data, Dumper=_Dumper, sort_keys=False, width=1_000_000)


class BagError(ValueError):
    """A run folder cannot be made into a bag; the message is one line naming it."""


@dc.dataclass
class BagSummary:
    """What a bag holds: topic -> (type, message count), its first and last stamps [ns],
    and its size [bytes]."""

    folder: pathlib.Path
    topics: dict[str, tuple[str, int]]
    start_ns: int
    end_ns: int
    size_bytes: int


def decimate(times, rate_hz: float) -> np.ndarray:
    """Indices of ``times`` (increasing) kept at ``rate_hz``: per grid time k / rate_hz, the
    first sample at or after it; a signal sampled less often keeps every sample."""
    times = np.asarray(times, dtype=float)
    if not len(times):
        return np.zeros(0, dtype=int)
    grid = np.arange(0, math.floor(times[-1] * rate_hz + 1e-6) + 1) / rate_hz
    index = np.searchsorted(times, grid - GRID_SLACK_S, side="left")
    return np.unique(index[index < len(times)])


def camera_intrinsics(camera) -> tuple[int, int, float, float, float, float]:
    """(width, height, fx, fy, cx, cy) [px] of the scenario's ``camera`` section, as the
    station's camera has them (``model.camera.camera_info``)."""
    from manta_drake.model.camera import camera_info

    info = camera_info(camera.width, camera.height, camera.fov_y_deg)
    return (
        info.width(),
        info.height(),
        info.focal_x(),
        info.focal_y(),
        info.center_x(),
        info.center_y(),
    )


def bag_constants(scenario, topic_map: TopicMap, fin_links=True) -> Constants:
    """The conversions' constants of ``scenario`` (``signals.Constants``); ``fin_links``:
    the fin links in ``/tf`` (builds the robot's plant) or the hull only."""
    from manta_drake.model.robot_params import JOINT_NAMES

    imu, pack = scenario.imu, scenario.energy_model().pack
    variances = imu.noise_std() ** 2 + imu.bias_std() ** 2
    hydro = scenario.hydro_coefficients()
    links = None
    if fin_links and topic_map.topics["tf"].enabled:
        from manta_drake.ros2.tf import FinLinks

        links = FinLinks(scenario.robot_params(), topic_map.frames.base)
    return Constants(
        joint_names=JOINT_NAMES,
        world=topic_map.frames.world,
        base=topic_map.frames.base,
        camera=topic_map.frames.camera,
        camera_intrinsics=camera_intrinsics(scenario.camera),
        imu_covariances=tuple(np.diag(variances[k : k + 3]).ravel() for k in (0, 3, 6)),
        density=hydro.water_density.value if hydro else 1000.0,
        gravity=hydro.gravity.value if hydro else 9.81,
        depth_std=scenario.pressure_sensor.noise_std,
        capacity_ah=pack.capacity_ah,
        cells=pack.cells_in_series,
        fin_links=links,
    )


def bag_messages(log: dict, topic_map: TopicMap, constants: Constants) -> dict:
    """Signal name -> [(stamp ns, CDR bytes)], each signal the log holds decimated to its
    topic's rate."""
    out = {}
    for name, entry in topic_map.enabled().items():
        signal = SIGNALS[name]
        if not signal.present(log):
            continue
        convert, times = signal.types[entry.type], log[signal.times]
        assert convert is not None  # present(): a signal with log arrays has conversions
        out[name] = [
            (
                m.to_nanoseconds(times[i]),
                m.serialize(convert(log, i, m.to_nanoseconds(times[i]), constants)),
            )
            for i in decimate(times, entry.rate_hz)
        ]
    return out


def qos_text(profile: str) -> str:
    """A QoS profile as a Humble bag records a topic's ``offered_qos_profiles`` (YAML text
    of a one-element list)."""
    return _yaml([QOS_PROFILES[profile]])


def write_mcap(path: pathlib.Path, topic_map: TopicMap, streams: dict) -> None:
    """``streams`` (``bag_messages``) as an MCAP file at ``path``: one schema per type, one
    channel per topic, the messages in time order."""
    entries = {name: topic_map.topics[name] for name in streams}
    with open(path, "wb") as f:
        writer = Writer(f, compression=CompressionType.ZSTD)
        writer.start(profile="ros2", library=f"manta_drake {__version__}; mcap {mcap.__version__}")
        schemas = {
            e.type: writer.register_schema(e.type, "ros2msg", m.msgdef(e.type).encode())
            for e in entries.values()
        }
        channels = {
            name: writer.register_channel(
                e.topic, "cdr", schemas[e.type], {"offered_qos_profiles": qos_text(e.qos)}
            )
            for name, e in entries.items()
        }
        order = sorted(
            (t_ns, k, name, seq)
            for k, (name, stream) in enumerate(streams.items())
            for seq, (t_ns, _) in enumerate(stream)
        )
        for t_ns, _, name, seq in order:
            writer.add_message(channels[name], t_ns, streams[name][seq][1], t_ns, seq)
        writer.finish()


def rosbag2_metadata(file_name: str, topics: list[dict], start_ns: int, end_ns: int) -> dict:
    """rosbag2's metadata (version 5) of one storage file ``file_name`` holding ``topics``
    (each ``{name, type, qos, count}``, ``qos`` the offered profiles' text) from
    ``start_ns`` to ``end_ns``."""
    count = sum(t["count"] for t in topics)
    span = {
        "starting_time": {"nanoseconds_since_epoch": start_ns},
        "duration": {"nanoseconds": end_ns - start_ns},
    }
    listed = [
        {
            "topic_metadata": {
                "name": t["name"],
                "type": t["type"],
                "serialization_format": "cdr",
                "offered_qos_profiles": t["qos"],
            },
            "message_count": t["count"],
        }
        for t in topics
    ]
    return {
        "rosbag2_bagfile_information": {
            "version": METADATA_VERSION,
            "storage_identifier": "mcap",
            "duration": span["duration"],
            "starting_time": span["starting_time"],
            "message_count": count,
            "topics_with_message_count": listed,
            "compression_format": "",
            "compression_mode": "",
            "relative_file_paths": [file_name],
            "files": [{"path": file_name, **span, "message_count": count}],
        }
    }


def metadata(topic_map: TopicMap, streams: dict) -> dict:
    """The bag's rosbag2 metadata (version 5) as a mapping."""
    stamps = [t for stream in streams.values() for t, _ in stream]
    entries = {name: topic_map.topics[name] for name in streams}
    return rosbag2_metadata(
        BAG_FILE,
        [
            {"name": e.topic, "type": e.type, "qos": qos_text(e.qos), "count": len(streams[name])}
            for name, e in entries.items()
        ],
        min(stamps, default=0),
        max(stamps, default=0),
    )


def write_metadata(path: pathlib.Path, info: dict) -> None:
    """``info`` (``rosbag2_metadata``) as ``metadata.yaml`` at ``path``, through a temporary
    file and a rename."""
    tmp = path.with_name(f".{path.name}.tmp")
    tmp.write_text(_yaml(info))
    os.replace(tmp, path)


def write_bag(folder, log: dict, topic_map: TopicMap, constants: Constants) -> BagSummary:
    """Writes ``log`` as a bag into ``folder``: ``run.mcap``, then ``metadata.yaml`` (each
    through a temporary file and a rename)."""
    folder = pathlib.Path(folder)
    streams = bag_messages(log, topic_map, constants)
    tmp = folder / f".{BAG_FILE}.tmp"
    write_mcap(tmp, topic_map, streams)
    os.replace(tmp, folder / BAG_FILE)
    info = metadata(topic_map, streams)
    write_metadata(folder / METADATA_FILE, info)
    top = info["rosbag2_bagfile_information"]
    start = top["starting_time"]["nanoseconds_since_epoch"]
    return BagSummary(
        folder,
        {topic_map.topics[n].topic: (topic_map.topics[n].type, len(s)) for n, s in streams.items()},
        start,
        start + top["duration"]["nanoseconds"],
        (folder / BAG_FILE).stat().st_size,
    )


def write_run_bag(folder, log: dict, scenario, topic_map: TopicMap) -> BagSummary:
    """A run's bag from its log and scenario (``bag_constants``, ``write_bag``)."""
    return write_bag(folder, log, topic_map, bag_constants(scenario, topic_map))


def bag_run_folder(run_dir, topic_map: TopicMap) -> BagSummary:
    """The bag of a run folder's ``log.npz`` and ``scenario.yaml``, written into it.

    Raises:
        BagError: one line naming the folder: not a folder, or without ``log.npz`` or the
            ``scenario.yaml`` a run writes (a run prepared in code writes none).
    """
    from manta_drake.scenario import load_scenario

    run_dir = pathlib.Path(run_dir)
    if not run_dir.is_dir():
        raise BagError(f"{run_dir}: not a folder (give a run's output folder)")
    for name in ("log.npz", "scenario.yaml"):
        if not (run_dir / name).is_file():
            raise BagError(
                f"{run_dir}: has no {name}; a bag is made from a run folder's "
                "log.npz and scenario.yaml"
            )
    scenario = load_scenario(run_dir / "scenario.yaml")
    with np.load(run_dir / "log.npz") as npz:
        log = {key: npz[key] for key in npz.files}
    return write_run_bag(run_dir, log, scenario, topic_map)
