"""Message codecs: pure conversions between port values and LCM messages (Drake's
``lcmt_scope`` and ``lcmt_image_array``, the project's ``lcmt_manta_joint_state`` and
``lcmt_manta_pose``), and ``CODECS``, one per kind of port value."""

from __future__ import annotations

import dataclasses as dc
import sys
import zlib
from collections.abc import Callable
from typing import Any, Protocol

import numpy as np
from drake import lcmt_image, lcmt_image_array, lcmt_scope
from pydrake.math import RigidTransform, RotationMatrix
from pydrake.systems.sensors import ImageDepth32F

from manta_drake.lcmtypes import lcmt_manta_joint_state, lcmt_manta_pose
from manta_drake.model.robot_params import JOINT_NAMES
from manta_drake.seam.errors import SeamError


def to_utime(t: float) -> int:
    """Simulation time [s] -> an LCM ``utime`` [us]."""
    return round(t * 1e6)


def vector_message(t: float, values) -> lcmt_scope:
    """A double vector (a port's value) as Drake's ``lcmt_scope``."""
    msg = lcmt_scope()
    msg.utime = to_utime(t)
    msg.value = [float(v) for v in np.atleast_1d(values)]
    msg.size = len(msg.value)
    return msg


def vector_from_message(msg: lcmt_scope) -> np.ndarray:
    """The double vector of an ``lcmt_scope``."""
    return np.array(msg.value, dtype=float)


def joint_state_message(t: float, x, names=JOINT_NAMES) -> lcmt_manta_joint_state:
    """Joint state x = [q (n), v (n)] in ``names`` order as ``lcmt_manta_joint_state``."""
    x = np.asarray(x, dtype=float)
    n = len(names)
    if x.shape != (2 * n,):
        raise SeamError(f"joint state: expected {2 * n} values [q, v], got shape {x.shape}")
    msg = lcmt_manta_joint_state()
    msg.utime = to_utime(t)
    msg.num_joints = n
    msg.joint_name = list(names)
    msg.position = x[:n].tolist()
    msg.velocity = x[n:].tolist()
    return msg


def joint_state_from_message(msg: lcmt_manta_joint_state, names=JOINT_NAMES) -> np.ndarray:
    """[q, v] in ``names`` order, matched by joint name (a driver may send another order).

    Raises:
        SeamError: the message's joints are not exactly ``names``.
    """
    index = {name: i for i, name in enumerate(msg.joint_name)}
    if sorted(index) != sorted(names) or len(index) != len(msg.joint_name):
        missing = sorted(set(names) - set(index))
        extra = sorted(set(index) - set(names))
        raise SeamError(
            f"joint state: joints differ from the robot's (missing {missing}, unknown {extra})"
        )
    order = [index[name] for name in names]
    return np.concatenate(
        [np.asarray(msg.position, dtype=float)[order], np.asarray(msg.velocity, dtype=float)[order]]
    )


def depth_image_message(
    t: float, image: ImageDepth32F, frame_name: str = "camera"
) -> lcmt_image_array:
    """A 32-bit float depth image [m] as Drake's ``lcmt_image_array`` (one image,
    ``PIXEL_FORMAT_DEPTH``, ``CHANNEL_TYPE_FLOAT32``, uncompressed: noisy depth does
    not compress, and zlib would cost more than the datagrams it saves)."""
    data = np.ascontiguousarray(image.data[:, :, 0], dtype=np.float32)
    img = lcmt_image()
    img.header.utime = to_utime(t)
    img.header.frame_name = frame_name
    img.width, img.height = image.width(), image.height()
    img.row_stride = 4 * img.width
    img.data = data.tobytes()
    img.size = len(img.data)
    img.bigendian = sys.byteorder == "big"
    img.pixel_format = lcmt_image.PIXEL_FORMAT_DEPTH
    img.channel_type = lcmt_image.CHANNEL_TYPE_FLOAT32
    img.compression_method = lcmt_image.COMPRESSION_METHOD_NOT_COMPRESSED
    msg = lcmt_image_array()
    msg.header.utime = img.header.utime
    msg.header.frame_name = frame_name
    msg.num_images = 1
    msg.images = [img]
    return msg


def depth_image_from_message(msg: lcmt_image_array) -> ImageDepth32F:
    """The depth image of an ``lcmt_image_array`` (its first image; float32 depth,
    uncompressed or zlib, either byte order: what Drake's ``ImageToLcmImageArrayT``
    or a camera driver sends).

    Raises:
        SeamError: no image, not float32 depth, or a size that does not add up.
    """
    if msg.num_images < 1:
        raise SeamError("depth image: the lcmt_image_array holds no image")
    img = msg.images[0]
    if (
        img.pixel_format != lcmt_image.PIXEL_FORMAT_DEPTH
        or img.channel_type != lcmt_image.CHANNEL_TYPE_FLOAT32
    ):
        raise SeamError(
            f"depth image: pixel_format {img.pixel_format}, channel_type "
            f"{img.channel_type}; expected DEPTH ({lcmt_image.PIXEL_FORMAT_DEPTH}) "
            f"FLOAT32 ({lcmt_image.CHANNEL_TYPE_FLOAT32})"
        )
    if img.width < 1 or img.height < 1:
        raise SeamError(f"depth image: {img.width} x {img.height} pixels")
    data = img.data
    if img.compression_method == lcmt_image.COMPRESSION_METHOD_ZLIB:
        data = zlib.decompress(data)
    elif img.compression_method != lcmt_image.COMPRESSION_METHOD_NOT_COMPRESSED:
        raise SeamError(
            f"depth image: compression_method {img.compression_method} is not "
            "supported (send it uncompressed or zlib)"
        )
    if img.row_stride != 4 * img.width or len(data) != img.row_stride * img.height:
        raise SeamError(
            f"depth image: {len(data)} bytes, row_stride {img.row_stride} for "
            f"{img.width} x {img.height} float32 pixels"
        )
    pixels = np.frombuffer(data, dtype=">f4" if img.bigendian else "<f4")
    image = ImageDepth32F(img.width, img.height)
    image.mutable_data[:, :, 0] = pixels.reshape(img.height, img.width)
    return image


def pose_message(t: float, X: RigidTransform, frame_name: str = "camera") -> lcmt_manta_pose:
    """A RigidTransform X_WF as ``lcmt_manta_pose`` (rotation matrix: bit-exact)."""
    msg = lcmt_manta_pose()
    msg.utime = to_utime(t)
    msg.frame_name = frame_name
    msg.translation = [float(v) for v in X.translation()]
    msg.rotation = [[float(v) for v in row] for row in X.rotation().matrix()]
    return msg


def pose_from_message(msg: lcmt_manta_pose) -> RigidTransform:
    """The RigidTransform of an ``lcmt_manta_pose``."""
    return RigidTransform(
        RotationMatrix(np.array(msg.rotation, dtype=float)), np.array(msg.translation, dtype=float)
    )


class LcmMessage(Protocol):
    """A message of an lcm-gen class (``lcm-gen --python``): what the seam uses of it."""

    def encode(self) -> bytes: ...

    @staticmethod
    def decode(data: bytes) -> Any: ...

    @staticmethod
    def _get_packed_fingerprint() -> bytes: ...


@dc.dataclass(frozen=True)
class Codec:
    """How one kind of port value crosses the seam."""

    lcm_type: type[LcmMessage]
    encode: Callable  # (t, value) -> message
    decode: Callable  # message -> value
    stamp: Callable  # message -> utime


def _utime(msg) -> int:
    return msg.utime


CODECS = {
    "vector": Codec(lcmt_scope, vector_message, vector_from_message, _utime),
    "joint_state": Codec(
        lcmt_manta_joint_state, joint_state_message, joint_state_from_message, _utime
    ),
    "depth_image": Codec(
        lcmt_image_array,
        depth_image_message,
        depth_image_from_message,
        lambda msg: msg.header.utime,
    ),
    "pose": Codec(lcmt_manta_pose, pose_message, pose_from_message, _utime),
}
