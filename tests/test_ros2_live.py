"""The live view (manta-drake run --foxglove): a plain `websockets` client speaking the
foxglove-sdk subprotocol to a real run's server on an ephemeral port, decoding the frames
with rosbags and holding them against the run's own log.npz."""

import asyncio
import json
import pathlib
import struct
import subprocess
import sys
import time

import numpy as np
import pytest
from rosbags.typesys import Stores, get_typestore

from manta_drake.ros2.live import SUBPROTOCOL, LiveViewError, parse_address

REPO = pathlib.Path(__file__).resolve().parents[1]
HUMBLE = get_typestore(Stores.ROS2_HUMBLE)


def test_the_address_is_checked_in_one_line():
    assert parse_address("127.0.0.1:0") == ("127.0.0.1", 0)
    assert parse_address(":9000") == ("127.0.0.1", 9000)
    assert parse_address("localhost") == ("localhost", 8765)
    with pytest.raises(LiveViewError, match=r"--foxglove 'x:99999': expected HOST:PORT"):
        parse_address("x:99999")


async def _watch(url: str, until_closed: float) -> tuple[dict, list]:
    """Subscribes to every advertised channel; returns (channel id -> advertisement,
    [(channel id, log time, payload)]) until the server closes."""
    from websockets.asyncio.client import connect
    from websockets.exceptions import ConnectionClosed

    channels, frames, subscribed = {}, [], {}
    async with connect(url, subprotocols=[SUBPROTOCOL], max_size=None) as ws:
        assert ws.subprotocol == SUBPROTOCOL
        deadline = time.monotonic() + until_closed
        try:
            while time.monotonic() < deadline:
                message = await asyncio.wait_for(ws.recv(), deadline - time.monotonic())
                if isinstance(message, str):
                    op = json.loads(message)
                    if op.get("op") == "advertise":
                        new = [c for c in op["channels"] if c["id"] not in channels]
                        channels.update({c["id"]: c for c in new})
                        subs = [
                            {"id": len(subscribed) + k + 1, "channelId": c["id"]}
                            for k, c in enumerate(new)
                        ]
                        subscribed.update({s["id"]: s["channelId"] for s in subs})
                        await ws.send(json.dumps({"op": "subscribe", "subscriptions": subs}))
                elif message[0] == 0x01:  # messageData: sub id u32, log time u64, payload
                    sub, log_time = struct.unpack_from("<IQ", message, 1)
                    frames.append((subscribed[sub], log_time, bytes(message[13:])))
        except (TimeoutError, ConnectionClosed):
            pass
    return channels, frames


@pytest.mark.slow
def test_a_run_is_served_live_with_ros2_cdr_and_simulated_stamps(tmp_path):
    """1 s of four_behaviors with --foxglove 127.0.0.1:0: the client sees the bag's topics
    advertised with ros2msg schemas and cdr encoding, and every frame decodes with rosbags'
    Humble store; each header stamp is its log time, the joint states equal log.npz at those
    times, /tf carries the hull and the 16 fin links."""
    out = tmp_path / "run"
    proc = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "manta_drake.cli",
            "run",
            "four_behaviors",
            "--out",
            str(out),
            "--duration",
            "1",
            "--no-meshcat",
            "--quiet",
            "--foxglove",
            "127.0.0.1:0",
        ],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        cwd=REPO,
    )
    try:
        line = proc.stderr.readline()
        assert line.startswith("live view: ws://127.0.0.1:"), line + proc.stderr.read()
        url = line.split()[2]
        assert not url.endswith(":0")  # the free port it took
        channels, frames = asyncio.run(_watch(url, until_closed=120))
        proc.wait(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 0, proc.stderr.read()
    topics = {c["topic"]: c for c in channels.values()}
    assert {"/clock", "/manta/joint_states", "/manta/imu", "/tf"} <= set(topics)
    for c in channels.values():
        assert (c["encoding"], c["schemaEncoding"]) == ("cdr", "ros2msg")
    log = dict(np.load(out / "log.npz"))
    by_topic = {}
    for channel_id, log_time, payload in frames:
        c = channels[channel_id]
        msg = HUMBLE.deserialize_cdr(payload, c["schemaName"])
        by_topic.setdefault(c["topic"], []).append((log_time, msg))
        stamp = (
            msg.clock
            if c["topic"] == "/clock"
            else msg.transforms[0].header.stamp
            if c["topic"] == "/tf"
            else getattr(msg, "header", None) and msg.header.stamp
        )
        if stamp:
            assert stamp.sec * 1_000_000_000 + stamp.nanosec == log_time, c["topic"]
    joints = by_topic["/manta/joint_states"]
    assert 90 <= len(joints) <= 101  # 100 Hz for 1 s, from the first chunk it served
    t_ns = np.round(log["t"] * 1e9).astype(np.int64)
    for log_time, msg in joints:
        row = int(np.searchsorted(t_ns, log_time))
        np.testing.assert_array_equal(msg.position, log["joint_angles"][row])
    assert len(by_topic["/tf"][-1][1].transforms) == 17
    assert joints[-1][0] == 1_000_000_000  # served to the end
