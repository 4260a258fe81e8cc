"""Noise and pixel dropout on a depth image."""

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.systems.framework import LeafSystem
from pydrake.systems.sensors import ImageDepth32F


def noisy_depth(depth, noise_std: float, dropout_rate: float, normal_samples=None,
                uniform_samples=None) -> np.ndarray:
    """``depth + noise_std * normal_samples`` with pixels NaN where ``uniform_samples <
    dropout_rate`` (float32, same shape). Out-of-range pixels (inf) stay inf."""
    out = np.array(depth, dtype=np.float32, copy=True)
    if noise_std > 0 and normal_samples is not None:
        out += (noise_std * np.asarray(normal_samples).reshape(out.shape)).astype(np.float32)
    if dropout_rate > 0 and uniform_samples is not None:
        out[np.asarray(uniform_samples).reshape(out.shape) < dropout_rate] = np.nan
    return out


class DepthImageNoise(LeafSystem):
    """Adds Gaussian range noise and drops pixels (NaN) in a 32-bit depth image.

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
    """

    def __init__(self, width: int, height: int, noise_std: float = 0.0,
                 dropout_rate: float = 0.0):
        super().__init__()
        if not (np.isfinite(noise_std) and noise_std >= 0):
            raise ValueError(f"DepthImageNoise.noise_std: {noise_std} must be >= 0")
        if not 0.0 <= dropout_rate <= 1.0:
            raise ValueError(f"DepthImageNoise.dropout_rate: {dropout_rate} is outside [0, 1]")
        self.noise_std, self.dropout_rate = float(noise_std), float(dropout_rate)
        model = AbstractValue.Make(ImageDepth32F(width, height))
        self._input = self.DeclareAbstractInputPort("depth_image", model)
        self._normal = self.DeclareVectorInputPort("range_noise", width * height)
        self._uniform = self.DeclareVectorInputPort("dropout_sample", width * height)
        self.DeclareAbstractOutputPort("noisy_depth_image", lambda: model.Clone(), self._calc)

    def _calc(self, context, output):
        image = self._input.Eval(context)
        normal = self._normal.Eval(context) if self._normal.HasValue(context) else None
        uniform = self._uniform.Eval(context) if self._uniform.HasValue(context) else None
        depth = noisy_depth(image.data, self.noise_std, self.dropout_rate, normal, uniform)
        output.get_mutable_value().mutable_data[:] = depth
