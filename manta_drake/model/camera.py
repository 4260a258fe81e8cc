"""The head camera's intrinsics: one definition for the renderer and the point-cloud maker."""

import numpy as np
from pydrake.systems.sensors import CameraInfo


def camera_info(width: int, height: int, fov_y_deg: float) -> CameraInfo:
    """A pinhole camera of ``width`` x ``height`` pixels and vertical field of view
    ``fov_y_deg``, centred (Drake's ``CameraInfo(width, height, fov_y)``)."""
    return CameraInfo(int(width), int(height), np.radians(fov_y_deg))
