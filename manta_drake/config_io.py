"""Configuration I/O: the error type, the one strict YAML reader, key and value checks.

Every file the package reads (scenarios, coefficient files, gait files, sweep, calibration
and optimisation specs) goes through :func:`load_yaml_mapping`, which refuses a key given
twice in one mapping (plain YAML keeps the last one silently), and through
:func:`check_keys`, which walks the data against its dataclass and names the first unknown
key or mistyped value by its full dotted path. Value checks (``check_in_range`` and
friends) raise one-line errors naming the field, the value and the allowed range.

This module is the bottom layer: it imports nothing of the package.
"""

import dataclasses as dc
import math
import numbers
import os
import pathlib
import re
import tempfile
import types
import typing

import yaml


class ScenarioError(ValueError):
    """A configuration file or value is invalid; the message is one line naming the field."""


# --- the strict YAML reader --------------------------------------------------------------

class UniqueKeyLoader(yaml.SafeLoader):
    """A safe YAML loader that refuses a key given twice in one mapping, and reads YAML 1.2
    floats such as ``1e-3`` and ``1.0e9`` as numbers (PyYAML's YAML 1.1 reads them as
    strings; Drake's loader and every other YAML 1.2 tool read them as floats)."""

    def construct_mapping(self, node, deep=False):
        seen = set()
        for key_node, _ in node.value:
            key = self.construct_object(key_node, deep=deep)
            if key in seen:
                raise yaml.constructor.ConstructorError(
                    None, None, f"duplicate key {key!r}", key_node.start_mark)
            seen.add(key)
        return super().construct_mapping(node, deep)


UniqueKeyLoader.add_implicit_resolver(
    "tag:yaml.org,2002:float",
    re.compile(r"^[-+]?(?:[0-9][0-9_]*(?:\.[0-9_]*)?|\.[0-9_]+)[eE][-+]?[0-9]+$"),
    list("-+0123456789."))


def read_text_file(path, error=ScenarioError) -> str:
    """The text of a UTF-8 file; one-line errors naming the file otherwise."""
    path = pathlib.Path(path)
    if not path.is_file():
        raise error(f"{path}: file not found")
    try:
        return path.read_text(encoding="utf-8")
    except UnicodeDecodeError:
        raise error(f"{path}: not a UTF-8 text (YAML) file") from None
    except OSError as e:
        raise error(f"{path}: cannot be read: {e.strerror}") from None


def parse_yaml(text: str, where: str = "", error=ScenarioError):
    """``text`` parsed strictly (duplicate keys refused); the error names ``where``."""
    try:
        return yaml.load(text, Loader=UniqueKeyLoader)
    except yaml.YAMLError as e:
        prefix = f"{where}: " if where else ""
        raise error(f"{prefix}not valid YAML: {' '.join(str(e).split())}") from None


def load_yaml_mapping(path, what: str = "YAML", error=ScenarioError) -> tuple[dict, str]:
    """A YAML file's top-level mapping and its text.

    Args:
        path: the file.
        what: what the file is, for the messages (``sweep``, ``calibration``, ...).
        error: the exception type to raise (a subclass of ScenarioError).

    Raises:
        error: the file is missing, not UTF-8, not YAML, has a duplicate key, or its root is
            not a mapping; one line naming the file.
    """
    path = pathlib.Path(path)
    if not path.is_file():
        raise error(f"{what} file not found: {path}")
    text = read_text_file(path, error)
    data = parse_yaml(text, str(path), error)
    if data is None:
        data = {}
    if not isinstance(data, dict):
        raise error(f"{path}: the {what} file's root must be a mapping, got "
                    f"{type(data).__name__}")
    return data, text


# --- key checks ----------------------------------------------------------------------------

def schema_fields(schema) -> dict | None:
    """Field name -> type of a dataclass or a pydrake config struct, else None."""
    if dc.is_dataclass(schema):
        hints = typing.get_type_hints(schema)
        return {f.name: hints[f.name] for f in dc.fields(schema)}
    if hasattr(schema, "__fields__"):  # pydrake-bound C++ structs (SimulatorConfig, ...)
        return {f.name: f.type for f in schema.__fields__}
    return None


def _type_name(tp) -> str:
    return getattr(tp, "__name__", str(tp))


def _check_scalar(value, tp, path: str) -> None:
    """Checks a YAML scalar against a float/int/str/bool field type."""
    ok = {
        float: lambda v: isinstance(v, (int, float)) and not isinstance(v, bool),
        int: lambda v: isinstance(v, int) and not isinstance(v, bool),
        str: lambda v: isinstance(v, str),
        bool: lambda v: isinstance(v, bool),
    }.get(tp)
    if ok is not None and not ok(value):
        raise ScenarioError(f"{path}: expected a {_type_name(tp)}, got {value!r}")


def check_keys(data, schema, path: str = "scenario") -> None:
    """Walks ``data`` against the schema; raises ScenarioError naming the first bad key.

    Unknown keys (typos) and values of the wrong type are reported with their full
    path, e.g. ``scenario.initial_pose.xyzz``.
    """
    origin = typing.get_origin(schema)
    if origin is dict:
        key_type, value_type = typing.get_args(schema)
        if not isinstance(data, dict):
            raise ScenarioError(f"{path}: expected a mapping, got {data!r}")
        for key, value in data.items():
            check_keys(key, key_type, f"{path} key")
            check_keys(value, value_type, f"{path}.{key}")
        return
    if origin is list:
        (item_type,) = typing.get_args(schema) or (None,)
        if not isinstance(data, list):
            raise ScenarioError(f"{path}: expected a list, got {data!r}")
        for i, item in enumerate(data):
            check_keys(item, item_type, f"{path}[{i}]")
        return
    if origin in (typing.Union, types.UnionType):
        args = [a for a in typing.get_args(schema) if a is not type(None)]
        if data is None or len(args) != 1:
            return
        schema = args[0]
    fields = schema_fields(schema)
    if fields is None:
        if data is not None:
            _check_scalar(data, schema, path)
        return
    if data is None:
        return
    if not isinstance(data, dict):
        raise ScenarioError(f"{path}: expected a mapping with keys {sorted(fields)}, got {data!r}")
    for key, value in data.items():
        if key not in fields:
            raise ScenarioError(
                f"{path}.{key}: unknown key (a typo?); allowed keys: {', '.join(sorted(fields))}"
            )
        check_keys(value, fields[key], f"{path}.{key}")


# --- value checks --------------------------------------------------------------------------

def check_number(field: str, value) -> None:
    """A finite real number (int, float or a numpy scalar; not a bool)."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise ScenarioError(f"{field}: {value!r} is not a number")
    if not math.isfinite(value):
        raise ScenarioError(f"{field}: {value!r} is not finite")


def check_in_range(field, value, lo, hi, text, open_low=False, open_high=False) -> None:
    """A finite number in [lo, hi] (or open at either end); ``text`` states the range."""
    check_number(field, value)
    above = value > lo if open_low else value >= lo
    below = value < hi if open_high else value <= hi
    if not (above and below):
        raise ScenarioError(f"{field}: {value!r} is outside the allowed range {text}")


def check_integer(field: str, value, lo: int, hi: int) -> None:
    """An int (or a numpy integer; not a bool, not 1.7) in [lo, hi]."""
    if isinstance(value, bool) or not isinstance(value, numbers.Integral):
        raise ScenarioError(f"{field}: {value!r} is not an integer (allowed: {lo} to {hi})")
    if not lo <= value <= hi:
        raise ScenarioError(f"{field}: {value!r} is outside the allowed range [{lo}, {hi}]")


def check_boolean(field: str, value) -> None:
    if not isinstance(value, bool):
        raise ScenarioError(f"{field}: {value!r} is not true or false")


def check_text(field: str, value, allow_empty: bool = False) -> None:
    if not isinstance(value, str) or (not allow_empty and not value.strip()):
        raise ScenarioError(f"{field}: {value!r} is not a {'' if allow_empty else 'non-empty '}"
                            "string")


def check_one_of(field: str, value, allowed) -> None:
    if not isinstance(value, str) or value not in allowed:
        raise ScenarioError(f"{field}: {value!r} is not one of {', '.join(map(str, allowed))}")


def check_vector(field: str, value, n: int, bound: float = math.inf, unit: str = "") -> None:
    """``n`` finite numbers whose Euclidean norm is at most ``bound``."""
    if not isinstance(value, (list, tuple)) or len(value) != n:
        raise ScenarioError(f"{field}: expected {n} finite numbers, got {value!r}")
    for i, v in enumerate(value):
        check_number(f"{field}[{i}]", v)
    if math.isfinite(bound) and math.sqrt(sum(v * v for v in value)) > bound:
        raise ScenarioError(f"{field}: {value!r} has magnitude above the allowed {bound}{unit}")


# --- output folders --------------------------------------------------------------------------

def check_writable_folder(out_dir, option: str = "--out", example: str = "out/run",
                          error=ScenarioError, create: bool = False) -> pathlib.Path:
    """Checks that an output folder can be written, before anything expensive starts; the
    one check every command's ``--out`` goes through (runs, the seam's sides, sweeps,
    calibrations), each adding what its own outputs need.

    Refused: an empty path; a path that is a file or under one; a folder that cannot be
    created or written (the permission bits and a real write: a read-only mount, root).
    The folder is created if ``create``; otherwise the nearest existing folder must take it.

    Raises:
        error: one line naming the option, the folder and why.
    """
    if out_dir is None or not str(out_dir).strip():
        raise error(f"{option}: an empty path; name an output folder (e.g. {example})")
    out_dir = pathlib.Path(out_dir)
    if out_dir.exists() and not out_dir.is_dir():
        raise error(f"{option} {out_dir}: is a file, not a folder")
    existing = out_dir
    while not existing.exists():  # the nearest folder that exists must take the new ones
        existing = existing.parent
    if not existing.is_dir():
        raise error(f"{option} {out_dir}: cannot be created ({existing} is a file)")
    if create:
        try:
            out_dir.mkdir(parents=True, exist_ok=True)
        except OSError as e:
            raise error(f"{option} {out_dir}: cannot be created ({e.strerror})") from None
        existing = out_dir

    def refuse(reason: str):
        if existing == out_dir:
            return error(f"{option} {out_dir}: cannot be written ({reason})")
        return error(f"{option} {out_dir}: cannot be created ({existing} is not writable: "
                     f"{reason})")

    if not os.access(existing, os.W_OK | os.X_OK):
        raise refuse("no write permission")
    try:  # the permission bits do not tell everything (read-only mounts, root)
        with tempfile.TemporaryFile(dir=existing, prefix=".write-check-"):
            pass
    except OSError as e:
        raise refuse(e.strerror) from None
    return out_dir
