"""Gait files: gaits as data, in degrees, loaded, checked and written.

A gait file is YAML::

    description: optional text
    provenance: {optional mapping: who made these gaits and how}
    gaits:
      NAME:
        description: optional text
        base: optional name of a gait defined before (shipped, or earlier in the files)
        R_deg: [[yaw, roll1, pitch, roll2] of fl, ... of fr, ... of rl, ... of rr]
        X_deg: ...
        Phi_deg: ...
        Phi_prime_deg: ...
        mirror_keep: [R_deg.pitch]    # optional, see below

Each matrix is 4x4 in degrees, rows the leg-fins fl, fr, rl, rr, columns the joints yaw,
roll1, pitch, roll2 (``Phi_prime_deg``: rows and columns are leg-fins). A matrix left out is
the ``base`` gait's (a gait without a base must give all four). The package's gaits, the
paper's Eqs. (6)-(8) and our readings of them with every ``<name>_printed`` form, are
``models/gaits.yaml``; a scenario adds its own with ``controller.gait_files``.

The mirrored reading (``controller.gait_reading: mirrored``) applies one rule to every
gait: each right fin's R and X rows become the mirror image of its left partner's
(``gaits.MIRROR_SIGNS``: yaw and pitch change sign). ``mirror_keep`` lists what a gait
keeps as written under that rule, each either a matrix (``X_deg``) or one of its columns
(``R_deg.pitch``): the crab keeps its antisymmetric pitch amplitudes, the ``_printed``
gaits keep everything.

Degrees convert to radians exactly as the package's Python constants did (``pi * n / m``
for a whole or simply fractional number of degrees), so a gait read from a file is
bit-identical to the matrix written as ``PI / 18`` etc.
"""

from __future__ import annotations

import dataclasses as dc
import functools
import math
import pathlib
import re
import types
from collections.abc import Mapping
from fractions import Fraction

import numpy as np
import yaml

from manta_drake.config_io import ScenarioError, load_yaml_mapping, short_repr
from manta_drake.control.gait_params import GaitParams, mirror_right_fins
from manta_drake.model import MODELS_DIR, resolve_path
from manta_drake.model.robot_params import GAIT_SHAPE

MATRICES = ("R_deg", "X_deg", "Phi_deg", "Phi_prime_deg")
FIELD_OF_MATRIX = {"R_deg": "R", "X_deg": "X", "Phi_deg": "Phi", "Phi_prime_deg": "Phi_prime"}
JOINT_COLUMNS = ("yaw", "roll1", "pitch", "roll2")
LEG_ROWS = ("fl", "fr", "rl", "rr")
GAIT_KEYS = MATRICES + ("description", "base", "mirror_keep")
FILE_KEYS = ("gaits", "description", "provenance")
# The mirror rule changes R and X only; these are what ``mirror_keep`` may name.
MIRRORED_MATRICES = ("R_deg", "X_deg")
MIRROR_KEEPS = MIRRORED_MATRICES + tuple(
    f"{m}.{c}" for m in MIRRORED_MATRICES for c in JOINT_COLUMNS
)
_NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_]*\Z")
RESERVED_NAMES = ("zero",)  # ``initial_stance: zero`` is the zero pose, not a gait
# Largest degree value a gait entry may hold: a phase of two turns is already the same
# phase, an amplitude or bias beyond it a units mistake (radians written as degrees is
# the other way round and passes; the joint limits catch it in the run).
MAX_DEGREES = 720.0


@dc.dataclass(frozen=True)
class GaitEntry:
    """One gait of a file, in radians: the matrices by field (R, X, Phi, Phi_prime),
    what the mirrored reading keeps, and where it came from."""

    name: str
    matrices: dict
    mirror_keep: tuple
    source: str
    description: str = ""


def degrees_to_radians(degrees) -> np.ndarray:
    """Degrees to radians, element-wise; a whole or simply fractional number of degrees d
    (d / 180 = n / m with m <= 3600) as ``math.pi * n / m``, which is the double that
    ``PI / 18``, ``5 * PI / 18``, ``-PI`` ... give, anything else as ``d * pi / 180``."""
    flat = np.asarray(degrees, dtype=float).ravel()
    out = np.empty_like(flat)
    for i, d in enumerate(flat):
        f = Fraction(repr(float(d))) / 180
        if f.denominator <= 3600:
            out[i] = math.pi * f.numerator / f.denominator
        else:
            out[i] = float(d) * math.pi / 180.0
    return out.reshape(np.shape(degrees))


def radians_to_degrees(radians) -> list:
    """A 4x4 matrix in radians as nested lists of degrees, whole numbers where they are
    within 1e-9 deg of one (as a file is written)."""
    deg = np.asarray(radians, dtype=float) * (180.0 / math.pi)
    rounded = np.round(deg)
    deg = np.where(np.abs(deg - rounded) < 1e-9, rounded, np.round(deg, 9))
    return [[(int(v) if float(v).is_integer() else float(v)) + 0 for v in row] for row in deg]


def _matrix(value, where: str) -> np.ndarray:
    """A gait matrix from its YAML value (4x4 degrees), or a one-line error."""
    shape_text = (
        "expected 4 rows (fl, fr, rl, rr) of 4 numbers (yaw, roll1, pitch, roll2) in degrees"
    )
    if not isinstance(value, list) or len(value) != GAIT_SHAPE[0]:
        got = f"{len(value)} rows" if isinstance(value, list) else short_repr(value)
        raise ScenarioError(f"{where}: {shape_text}, got {got}")
    for i, row in enumerate(value):
        if not isinstance(row, list) or len(row) != GAIT_SHAPE[1]:
            got = f"{len(row)} numbers" if isinstance(row, list) else short_repr(row)
            raise ScenarioError(f"{where}[{LEG_ROWS[i]}]: {shape_text}, got {got}")
        for j, x in enumerate(row):
            if isinstance(x, bool) or not isinstance(x, (int, float)):
                raise ScenarioError(
                    f"{where}[{LEG_ROWS[i]}, {JOINT_COLUMNS[j]}]: {short_repr(x)} is not a number"
                )
            if not math.isfinite(x) or abs(x) > MAX_DEGREES:
                raise ScenarioError(
                    f"{where}[{LEG_ROWS[i]}, {JOINT_COLUMNS[j]}]: "
                    f"{short_repr(x)} is outside "
                    f"[-{MAX_DEGREES:g}, {MAX_DEGREES:g}] deg"
                )
    return degrees_to_radians(value)


def parse_gait_file(data, source: str, known: Mapping[str, GaitEntry]) -> dict[str, GaitEntry]:
    """The gaits of one file's data (a mapping), checked; ``known`` are the gaits defined
    before it (a ``base`` may name them; a name already there is a clash).

    Raises:
        ScenarioError: one line naming the file, the gait, the field and the problem.
    """
    gaits = _file_gaits(data, source)
    out: dict[str, GaitEntry] = {}
    for name, spec in gaits.items():
        out[name] = _parse_gait(name, spec, source, known, out)
    return out


def _file_gaits(data, source: str) -> dict:
    """The ``gaits`` mapping of one file's data, the file's keys checked."""
    if not isinstance(data, dict):
        raise ScenarioError(f"{source}: expected a mapping with a 'gaits' key")
    for key in data:
        if key not in FILE_KEYS:
            raise ScenarioError(
                f"{source}: unknown key {short_repr(key)}; allowed: {', '.join(FILE_KEYS)}"
            )
    gaits = data.get("gaits")
    if not isinstance(gaits, dict) or not gaits:
        raise ScenarioError(f"{source}: gaits: expected a mapping of gait names to gaits")
    if "provenance" in data and not isinstance(data["provenance"], dict):
        raise ScenarioError(f"{source}: provenance: expected a mapping")
    return gaits


def _parse_gait(
    name, spec, source: str, known: Mapping[str, GaitEntry], earlier: Mapping[str, GaitEntry]
) -> GaitEntry:
    """One gait of a file, checked; ``earlier``: the gaits before it in the same file."""
    if not isinstance(name, str) or not _NAME.match(name) or name in RESERVED_NAMES:
        raise ScenarioError(
            f"{source}: gaits: {short_repr(name)} is not a gait name "
            "(letters, digits and _, not starting with a digit; not "
            "'zero')"
        )
    where = f"{source}: gaits.{name}"
    if name in known:
        raise ScenarioError(
            f"{where}: the name is already defined in "
            f"{known[name].source}; gait names must be unique"
        )
    if not isinstance(spec, dict):
        raise ScenarioError(f"{where}: expected a mapping with {', '.join(MATRICES)}")
    for key in spec:
        if key not in GAIT_KEYS:
            raise ScenarioError(
                f"{where}: unknown key {short_repr(key)}; allowed: {', '.join(GAIT_KEYS)}"
            )
    matrices = _gait_matrices(spec, where, known, earlier)
    keep = spec.get("mirror_keep", [])
    if not isinstance(keep, list) or any(k not in MIRROR_KEEPS for k in keep):
        raise ScenarioError(
            f"{where}.mirror_keep: {short_repr(keep)}: expected a list of "
            f"{', '.join(MIRRORED_MATRICES)} or MATRIX.COLUMN with a "
            f"column of {', '.join(JOINT_COLUMNS)}"
        )
    description = spec.get("description", "")
    if not isinstance(description, str):
        raise ScenarioError(f"{where}.description: expected text")
    return GaitEntry(name, matrices, tuple(keep), source, description)


def _gait_matrices(
    spec: dict, where: str, known: Mapping[str, GaitEntry], earlier: Mapping[str, GaitEntry]
) -> dict:
    """A gait's matrices by field (radians): its own, the rest from its ``base`` (a gait of
    ``earlier`` or ``known``)."""
    base = spec.get("base")
    matrices = {}
    if base is not None:
        if not isinstance(base, str):
            raise ScenarioError(
                f"{where}.base: {short_repr(base)}: expected the name of a gait defined before it"
            )
        parent = earlier.get(base) or known.get(base)
        if parent is None:
            raise ScenarioError(f"{where}.base: {short_repr(base)} is not a gait defined before it")
        matrices.update(parent.matrices)
    for m in MATRICES:
        if m in spec:
            matrices[FIELD_OF_MATRIX[m]] = _matrix(spec[m], f"{where}.{m}")
        elif base is None:
            raise ScenarioError(
                f"{where}: {m} missing (give all four matrices, or a "
                "base gait to take the missing ones from)"
            )
    return matrices


def load_gait_file(path, known: Mapping[str, GaitEntry] | None = None) -> dict[str, GaitEntry]:
    """The gaits of the file at ``path`` (see the module docstring), checked."""
    data, _ = load_yaml_mapping(path, "gait file")
    return parse_gait_file(data, str(path), known or {})


def mirrored_matrices(entry: GaitEntry) -> dict:
    """``entry``'s matrices under the mirrored reading: each right fin's R and X rows the
    mirror image of its left partner's, except what ``mirror_keep`` names."""
    out = dict(entry.matrices)
    for m in MIRRORED_MATRICES:
        if m in entry.mirror_keep:
            continue
        field = FIELD_OF_MATRIX[m]
        mirrored = mirror_right_fins(entry.matrices[field])
        for j, column in enumerate(JOINT_COLUMNS):
            if f"{m}.{column}" in entry.mirror_keep:
                mirrored[:, j] = entry.matrices[field][:, j]
        out[field] = mirrored
    return out


def _file_stamp(path: pathlib.Path) -> tuple:
    try:
        st = path.stat()
    except OSError:
        return (str(path), None)
    return (str(path), st.st_mtime_ns, st.st_size)


@functools.lru_cache(maxsize=64)
def _entries(stamps: tuple) -> dict[str, GaitEntry]:
    known: dict[str, GaitEntry] = {}
    for stamp in stamps:
        if stamp[1] is None:
            raise ScenarioError(f"gait file not found: {stamp[0]}")
        known.update(load_gait_file(stamp[0], known))
    return known


def gait_entries(files=()) -> dict[str, GaitEntry]:
    """Every gait of the shipped ``models/gaits.yaml`` and then of ``files`` (paths), in
    order; cached on the files' modification times."""
    paths = [SHIPPED_GAITS] + [resolve_path(str(f)) for f in files]
    return _entries(tuple(_file_stamp(pathlib.Path(p)) for p in paths))


@functools.lru_cache(maxsize=64)
def _library(stamps: tuple, reading: str):
    entries = _entries(stamps)
    if reading == "paper":
        lib = {n: GaitParams(**e.matrices) for n, e in entries.items()}
    elif reading == "mirrored":
        lib = {n: GaitParams(**mirrored_matrices(e)) for n, e in entries.items()}
    else:
        raise ScenarioError(
            f"controller.gait_reading: {short_repr(reading)} is not one of paper, mirrored"
        )
    return types.MappingProxyType(lib)


def gait_library(files=(), reading: str = "paper") -> Mapping:
    """The gaits (name -> GaitParams) of the shipped file and ``files`` under ``reading``
    (``paper`` or ``mirrored``), read-only."""
    paths = [SHIPPED_GAITS] + [resolve_path(str(f)) for f in files]
    return _library(tuple(_file_stamp(pathlib.Path(p)) for p in paths), reading)


def gait_file_data(
    gaits: Mapping,
    description: str = "",
    provenance: Mapping | None = None,
    mirror_keep: Mapping | None = None,
    descriptions: Mapping | None = None,
) -> dict:
    """The mapping a gait file holds for ``gaits`` (name -> GaitParams)."""
    out: dict = {}
    if description:
        out["description"] = description
    if provenance:
        out["provenance"] = dict(provenance)
    out["gaits"] = {}
    for name, gait in gaits.items():
        spec: dict = {}
        if descriptions and descriptions.get(name):
            spec["description"] = descriptions[name]
        for m in MATRICES:
            spec[m] = radians_to_degrees(getattr(gait, FIELD_OF_MATRIX[m]))
        if mirror_keep and mirror_keep.get(name):
            spec["mirror_keep"] = list(mirror_keep[name])
        out["gaits"][name] = spec
    return out


class _FlowRows(yaml.SafeDumper):
    """Writes each matrix row on one line."""


def _represent_list(dumper, value):
    flow = all(not isinstance(v, (list, dict)) for v in value)
    return dumper.represent_sequence("tag:yaml.org,2002:seq", value, flow_style=flow)


_FlowRows.add_representer(list, _represent_list)


def gait_file_text(data: Mapping, header: str = "") -> str:
    """A gait file's text for ``data`` (``gait_file_data``), with ``header`` as comments."""
    comment = "".join(f"# {line}\n" if line else "#\n" for line in header.splitlines())
    return comment + yaml.dump(dict(data), Dumper=_FlowRows, sort_keys=False, width=100)


def write_gait_file(
    path, gaits: Mapping, description: str = "", provenance: Mapping | None = None, header: str = ""
) -> pathlib.Path:
    """Writes ``gaits`` (name -> GaitParams) as a gait file at ``path``; reading it back
    gives the same matrices to the last digit for whole-degree entries and to 1e-9 deg
    otherwise."""
    path = pathlib.Path(path)
    text = gait_file_text(gait_file_data(gaits, description, provenance), header)
    path.write_text(text)
    return path


# The package's gaits: the paper's and our readings of them.
SHIPPED_GAITS = MODELS_DIR / "gaits.yaml"
