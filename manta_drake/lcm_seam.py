"""The old name of ``manta_drake.seam`` (the station and the controller over LCM).

Deprecated, and removed in 0.3.0 (CHANGELOG.md): ``from manta_drake import lcm_seam`` still
gives the seam's public names (its ``__all__``) in 0.2. New code imports ``manta_drake.seam``.
"""

from manta_drake.seam import *  # noqa: F403  (every public name, one list: the seam's)
from manta_drake.seam import __all__  # noqa: F401
