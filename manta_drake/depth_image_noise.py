"""Noise and pixel dropout on a depth image."""

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.systems.framework import LeafSystem
from pydrake.systems.sensors import ImageDepth32F


class DepthImageNoise(LeafSystem):
    """Adds Gaussian range noise and drops pixels (NaN) in a 32-bit depth image.

    .. pydrake_system::

        name: DepthImageNoise
        input_ports:
        - depth_image
        output_ports:
        - noisy_depth_image

    The noise of the frame at time t comes from ``numpy.random.default_rng([seed,
    round(t * 1e6)])``: the same scenario gives the same images, and re-evaluating a
    frame gives the same noise. Pixels outside the camera's range (inf) stay so.
    """

    def __init__(self, width: int, height: int, noise_std: float = 0.0,
                 dropout_rate: float = 0.0, seed: int = 0):
        super().__init__()
        if not (np.isfinite(noise_std) and noise_std >= 0):
            raise ValueError(f"DepthImageNoise.noise_std: {noise_std} must be >= 0")
        if not 0.0 <= dropout_rate <= 1.0:
            raise ValueError(f"DepthImageNoise.dropout_rate: {dropout_rate} is outside [0, 1]")
        self.noise_std, self.dropout_rate, self.seed = noise_std, dropout_rate, int(seed)
        model = AbstractValue.Make(ImageDepth32F(width, height))
        self._input = self.DeclareAbstractInputPort("depth_image", model)
        self.DeclareAbstractOutputPort("noisy_depth_image", lambda: model.Clone(), self._calc)

    def _calc(self, context, output):
        image = self._input.Eval(context)
        depth = np.array(image.data, dtype=np.float32, copy=True)
        rng = np.random.default_rng([self.seed, int(round(context.get_time() * 1e6))])
        if self.noise_std > 0:
            depth += rng.normal(0.0, self.noise_std, depth.shape).astype(np.float32)
        if self.dropout_rate > 0:
            depth[rng.uniform(size=depth.shape) < self.dropout_rate] = np.nan
        out = output.get_mutable_value()
        out.mutable_data[:] = depth
