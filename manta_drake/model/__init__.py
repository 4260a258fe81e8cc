"""The robot and its world as data: numbers, kinematics, SDFormat, plant, coefficients.

``MODELS_DIR`` is the installed package ``manta_drake.models`` (the repository's top-level
``models/``): ``manta.sdf``, ``pool.sdf``, ``package.xml``, ``hydrodynamics.yaml`` and the
shipped scenarios. ``package://manta_drake/<file>`` URLs resolve there through Drake's
``PackageMap`` (:func:`resolve_path`), confined to that folder.
"""

import importlib.resources
import pathlib

from manta_drake.config_io import ScenarioError, short_repr

MODELS_DIR = pathlib.Path(str(importlib.resources.files("manta_drake.models")))
PACKAGE_NAME = "manta_drake"
PACKAGE_URL = f"package://{PACKAGE_NAME}/"


def package_map():
    """A Drake ``PackageMap`` that knows ``manta_drake`` (from ``models/package.xml``)."""
    from pydrake.multibody.parsing import PackageMap

    packages = PackageMap.MakeEmpty()
    packages.AddPackageXml(str(MODELS_DIR / "package.xml"))
    return packages


def resolve_path(path: str, field: str | None = None) -> pathlib.Path:
    """A file named in a configuration: ``package://manta_drake/<file>`` resolves to the
    installed models (the package's root from Drake's ``PackageMap``) and must stay inside
    them; other paths are absolute or relative to the working directory. Whether the file
    exists is the caller's check (it names the file's kind).

    Raises:
        ScenarioError: a package URL that leaves the package (``..``, an absolute part, a
            link out of it), one line naming ``field`` (if given) and the URL.
    """
    text = str(path)
    if not text.startswith(PACKAGE_URL):
        return pathlib.Path(path)
    where = f"{field}: " if field else ""
    root = pathlib.Path(package_map().GetPath(PACKAGE_NAME)).resolve()
    try:
        resolved = (root / text[len(PACKAGE_URL) :]).resolve()
    except (OSError, ValueError) as e:  # a NUL byte, a link loop
        raise ScenarioError(f"{where}{short_repr(text)} is not a valid path ({e})") from None
    if not resolved.is_relative_to(root):
        raise ScenarioError(
            f"{where}{short_repr(text)} leaves the package {PACKAGE_NAME} "
            f"({root}); a {PACKAGE_URL} URL names a file inside it"
        )
    return resolved
