"""The depth sensor's range along each ray, range noise and pixel dropout on a depth image."""

import math

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.systems.framework import LeafSystem
from pydrake.systems.sensors import CameraInfo, ImageDepth32F

from manta_drake.config_io import check_in_range, check_integer

# The largest image side the system takes [px]: two width x height noise vectors are
# allocated with it (4096 x 4096: 2 x 134 MB); a depth camera's is at most 1280.
MAX_IMAGE_SIDE = 4096


def ray_scale(width: int, height: int, fx: float, fy: float, cx: float, cy: float) -> np.ndarray:
    """Per pixel, distance along the pixel's ray per unit of depth (along the optical axis):
    sqrt(1 + ((u - cx) / fx)^2 + ((v - cy) / fy)^2), shape (height, width), float32."""
    u = (np.arange(width) - cx) / fx
    v = (np.arange(height) - cy) / fy
    return np.sqrt(1.0 + u[None, :] ** 2 + v[:, None] ** 2).astype(np.float32)


def beyond_ray_range(depth, scale, max_range: float) -> np.ndarray:
    """``depth`` (along the optical axis) with every pixel whose distance along its own ray
    (``depth * scale``) exceeds ``max_range`` set to +inf (out of range), float32.

    The renderer's depth range cuts at a depth along the optical axis; the range of an
    underwater depth sensor is the distance light travels (absorption), i.e. along each
    ray. With an axis cut a wall facing the camera squarely vanishes as a whole at
    max_range while a tilted view of the same wall at the same distance keeps a slice;
    along the rays every view sees the same sphere.
    """
    out = np.array(depth, dtype=np.float32, copy=True)
    with np.errstate(invalid="ignore"):
        out[out * np.asarray(scale, dtype=np.float32).reshape(out.shape) > max_range] = np.inf
    return out


def noisy_depth(
    depth, noise_std: float, dropout_rate: float, normal_samples=None, uniform_samples=None
) -> np.ndarray:
    """``depth + noise_std * normal_samples`` with pixels NaN where ``uniform_samples <
    dropout_rate`` (float32, same shape). Out-of-range pixels (inf) stay inf."""
    out = np.array(depth, dtype=np.float32, copy=True)
    if noise_std > 0 and normal_samples is not None:
        out += (noise_std * np.asarray(normal_samples).reshape(out.shape)).astype(np.float32)
    if dropout_rate > 0 and uniform_samples is not None:
        out[np.asarray(uniform_samples).reshape(out.shape) < dropout_rate] = np.nan
    return out


class DepthImageNoise(LeafSystem):
    """The depth sensor's physics after the renderer: range limit along each ray, Gaussian
    range noise and pixel dropout (NaN) in a 32-bit depth image.

    .. pydrake_system::

        name: DepthImageNoise
        input_ports:
        - depth_image
        - range_noise (optional)
        - dropout_sample (optional)
        output_ports:
        - noisy_depth_image

    * ``range_noise`` (width x height): standard normal samples, one per pixel.
    * ``dropout_sample`` (width x height): uniform [0, 1) samples; a pixel whose sample is
      below ``dropout_rate`` is dropped.

    Both come from Drake ``RandomSource`` systems sampled at the camera's rate, so the
    noise is state in the Context: the same seed gives the same images and
    ``SetRandomContext`` draws new ones. Unconnected, that part of the noise is off.

    With ``max_range`` and the camera's intrinsics (``camera_info``), pixels farther than
    ``max_range`` along their ray are out of range (+inf) before the noise
    (``beyond_ray_range``); the renderer's own depth range (along the axis, never shorter
    for those pixels) stays as it is.

    Args:
        width, height: the image's size [px], whole numbers in [1, MAX_IMAGE_SIDE].
        noise_std: the range noise's standard deviation [m], >= 0.
        dropout_rate: the probability of a dropped pixel, in [0, 1].
        max_range: the range along each ray [m], > 0, or None (no range limit); given
            together with ``camera_info``.
        camera_info: the camera's ``CameraInfo`` (of the image's size), or None.

    Raises:
        ValueError: one line naming the argument and what is allowed.
    """

    def __init__(
        self,
        width: int,
        height: int,
        noise_std: float = 0.0,
        dropout_rate: float = 0.0,
        max_range: float | None = None,
        camera_info=None,
    ):
        super().__init__()
        check_integer("DepthImageNoise.width", width, 1, MAX_IMAGE_SIDE)
        check_integer("DepthImageNoise.height", height, 1, MAX_IMAGE_SIDE)
        width, height = int(width), int(height)
        check_in_range("DepthImageNoise.noise_std", noise_std, 0.0, math.inf, "[0, inf) m")
        check_in_range("DepthImageNoise.dropout_rate", dropout_rate, 0.0, 1.0, "[0, 1]")
        if (max_range is None) != (camera_info is None):
            raise ValueError("DepthImageNoise: max_range and camera_info go together")
        if max_range is not None:
            check_in_range(
                "DepthImageNoise.max_range", max_range, 0.0, math.inf, "(0, inf) m", open_low=True
            )
            if not isinstance(camera_info, CameraInfo):
                raise ValueError(
                    f"DepthImageNoise.camera_info: expected a CameraInfo, got "
                    f"{type(camera_info).__name__}"
                )
            if (camera_info.width(), camera_info.height()) != (width, height):
                raise ValueError(
                    f"DepthImageNoise.camera_info: {camera_info.width()}x"
                    f"{camera_info.height()} is not the image's {width}x{height}"
                )
            self._ray_scale = ray_scale(
                width,
                height,
                camera_info.focal_x(),
                camera_info.focal_y(),
                camera_info.center_x(),
                camera_info.center_y(),
            )
        self.max_range = None if max_range is None else float(max_range)
        self.noise_std, self.dropout_rate = float(noise_std), float(dropout_rate)
        model = AbstractValue.Make(ImageDepth32F(width, height))
        self._input = self.DeclareAbstractInputPort("depth_image", model)
        self._normal = self.DeclareVectorInputPort("range_noise", width * height)
        self._uniform = self.DeclareVectorInputPort("dropout_sample", width * height)
        self.DeclareAbstractOutputPort("noisy_depth_image", lambda: model.Clone(), self._calc)

    def _calc(self, context, output):
        image = self._input.Eval(context)
        depth = image.data
        if self.max_range is not None:
            depth = beyond_ray_range(depth[:, :, 0], self._ray_scale, self.max_range)
        normal = self._normal.Eval(context) if self._normal.HasValue(context) else None
        uniform = self._uniform.Eval(context) if self._uniform.HasValue(context) else None
        depth = noisy_depth(depth, self.noise_std, self.dropout_rate, normal, uniform)
        output.get_mutable_value().mutable_data[:] = depth.reshape(image.data.shape)
