"""The robot and its world as data: numbers, kinematics, SDFormat, plant, coefficients.

``MODELS_DIR`` is the installed package ``manta_drake.models`` (the repository's top-level
``models/``): ``manta.sdf``, ``pool.sdf``, ``package.xml``, ``hydrodynamics.yaml`` and the
shipped scenarios. ``package://manta_drake/<file>`` URLs resolve there through Drake's
``PackageMap`` (:func:`resolve_package_url`).
"""

import importlib.resources
import pathlib

MODELS_DIR = pathlib.Path(str(importlib.resources.files("manta_drake.models")))
PACKAGE_NAME = "manta_drake"
PACKAGE_URL = f"package://{PACKAGE_NAME}/"


def package_map():
    """A Drake ``PackageMap`` that knows ``manta_drake`` (from ``models/package.xml``)."""
    from pydrake.multibody.parsing import PackageMap

    packages = PackageMap.MakeEmpty()
    packages.AddPackageXml(str(MODELS_DIR / "package.xml"))
    return packages


def resolve_path(path: str) -> pathlib.Path:
    """A file named in a configuration: ``package://manta_drake/<file>`` resolves through
    Drake's ``PackageMap`` to the installed models; other paths are absolute or relative to
    the working directory."""
    if str(path).startswith(PACKAGE_URL):
        return pathlib.Path(package_map().ResolveUrl(str(path)))
    return pathlib.Path(path)
