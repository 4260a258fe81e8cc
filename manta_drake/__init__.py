"""manta_drake: a Drake simulation of the multi-jointed manta-ray robot of Asada et al. (2026)."""

__version__ = "0.1.0"
