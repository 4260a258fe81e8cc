"""The old name of ``manta_drake.seam`` (the station and the controller over LCM).

Kept importable for one release: ``from manta_drake import lcm_seam`` still gives the
seam's public names (its ``__all__``). New code imports ``manta_drake.seam``.
"""

from manta_drake.seam import *  # noqa: F403  (every public name, one list: the seam's)
from manta_drake.seam import __all__  # noqa: F401
