"""The package version (one place: the package face, the Dask workers' version check)."""

__version__ = "0.2.0"
