"""A depth camera's spatial filter on the controller's side of the seam."""

from pydrake.common.value import AbstractValue
from pydrake.systems.framework import LeafSystem
from pydrake.systems.sensors import ImageDepth32F

from manta_drake.control.vision import median_filter_depth


class DepthImageFilter(LeafSystem):
    """Median-filters a 32-bit depth image (``vision.median_filter_depth``).

    .. pydrake_system::

        name: DepthImageFilter
        input_ports:
        - depth_image
        output_ports:
        - filtered_depth_image

    Range noise of a depth camera is mostly independent from pixel to pixel; a small median
    filter (as the spatial filters of RealSense-class cameras) removes most of it while
    keeping the edges of planes, so the wall detector's voxelised planes stay thin.
    ``size`` <= 1 passes the image through.
    """

    def __init__(self, width: int, height: int, size: int = 5):
        super().__init__()
        if (
            isinstance(size, bool)
            or not isinstance(size, int)
            or not 0 <= size <= 15
            or (size > 1 and size % 2 == 0)
        ):
            raise ValueError(
                f"DepthImageFilter.size: {size!r} is not allowed: 0 or 1 (off) or "
                "an odd number of pixels up to 15"
            )
        self.size = size
        model = AbstractValue.Make(ImageDepth32F(width, height))
        self._input = self.DeclareAbstractInputPort("depth_image", model)
        self.DeclareAbstractOutputPort("filtered_depth_image", lambda: model.Clone(), self._calc)

    def _calc(self, context, output):
        image = self._input.Eval(context)
        output.get_mutable_value().mutable_data[:] = median_filter_depth(image.data, self.size)
