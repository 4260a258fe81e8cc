"""Configuration I/O: the error type, the one strict YAML reader, key and value checks.

Every file the package reads (scenarios, coefficient files, gait files, sweep, calibration
and optimisation specs) goes through :func:`load_yaml_mapping`, which refuses a key given
twice in one mapping (plain YAML keeps the last one silently) and bounds every input before
anything is built from it (the input limits: ``MAX_YAML_BYTES`` checked with ``os.stat``
before reading, ``MAX_YAML_DEPTH`` and ``MAX_YAML_NODES``, aliases expanded, checked on the
parser's events; CSV files have their own sizes), and through
:func:`check_keys`, which walks the data against its dataclass and names the first unknown
key or mistyped value by its full dotted path. Value checks (``check_in_range`` and
friends) raise one-line errors naming the field, the value (``short_repr``: bounded) and
the allowed range.

This module is the bottom layer: it imports nothing of the package.
"""

import csv
import dataclasses as dc
import io
import math
import numbers
import os
import pathlib
import re
import reprlib
import tempfile
import types
import typing

import yaml


class ScenarioError(ValueError):
    """A configuration file or value is invalid; the message is one line naming the field."""


# --- bounded reprs for the messages ---------------------------------------------------------

_REPR = reprlib.Repr()
_REPR.maxlevel = 3
_REPR.maxlist = _REPR.maxtuple = _REPR.maxdict = _REPR.maxset = _REPR.maxfrozenset = 6
_REPR.maxdeque = _REPR.maxarray = 6
_REPR.maxstring = _REPR.maxother = 60
_REPR.maxlong = 40


def short_repr(value, limit: int = 80) -> str:
    """``repr(value)`` for an error message, bounded in length and in work: at most three
    levels and six items per level are visited (a huge or aliased structure is never
    walked), and the text is cut to ``limit`` characters ending in ``...``."""
    try:
        text = _REPR.repr(value)
    except Exception:  # noqa: BLE001 - a message must never fail (e.g. a 5000-digit int)
        text = f"<{type(value).__name__} too large to print>"
    return short_text(text, limit)


def short_text(text: str, limit: int = 80) -> str:
    """``text`` on one line, cut to ``limit`` characters ending in ``...``."""
    text = " ".join(text.split())
    return text if len(text) <= limit else text[: max(limit - 3, 0)] + "..."


# --- the strict YAML reader --------------------------------------------------------------


class UniqueKeyLoader(yaml.SafeLoader):
    """A safe YAML loader that refuses a key given twice in one mapping, and reads YAML 1.2
    floats such as ``1e-3`` and ``1.0e9`` as numbers (PyYAML's YAML 1.1 reads them as
    strings; Drake's loader and every other YAML 1.2 tool read them as floats)."""

    def construct_mapping(self, node, deep=False):
        seen = set()
        for key_node, _ in node.value:
            key = self.construct_object(key_node, deep=deep)
            if not isinstance(key, typing.Hashable):
                raise yaml.constructor.ConstructorError(
                    None, None, f"a {type(key).__name__} as a mapping key", key_node.start_mark
                )
            if key in seen:
                raise yaml.constructor.ConstructorError(
                    None, None, f"duplicate key {short_repr(key)}", key_node.start_mark
                )
            seen.add(key)
        return super().construct_mapping(node, deep)


UniqueKeyLoader.add_implicit_resolver(
    "tag:yaml.org,2002:float",
    re.compile(r"^[-+]?(?:[0-9][0-9_]*(?:\.[0-9_]*)?|\.[0-9_]+)[eE][-+]?[0-9]+$"),
    list("-+0123456789."),
)


# --- input limits: every file is bounded before it is parsed ------------------------------

MB = 1_000_000
# The largest YAML file (scenario, coefficients, actuators, gait file, sweep, calibration,
# optimisation spec) read; the largest shipped one is 14 kB.
MAX_YAML_BYTES = 1 * MB
# The most values (scalars, mappings, lists) one YAML document may hold, each alias counted
# as the values it repeats: an "alias bomb" (a few lines expanding to millions of values)
# is refused while parsing, before anything walks it. The largest shipped file has ~1000;
# reading 50 000 takes about a second (a scenario is read three times: its layers).
MAX_YAML_NODES = 50_000
# The deepest nesting of mappings and lists a YAML document may have (the shipped files
# nest at most 6); deeper is refused while parsing, before any recursive walk.
MAX_YAML_DEPTH = 64
# The largest measured trajectory CSV (``t, x, y, z, yaw``; a calibration's pool logs):
# an hour at 240 Hz is ~45 MB. It is read row by row into arrays.
MAX_MEASURED_CSV_BYTES = 50 * MB
# The largest table CSV (a sweep's results.csv, an optimisation's history.csv, a study's
# data table), read whole; the largest shipped one is 0.2 MB.
MAX_TABLE_CSV_BYTES = 16 * MB


def _size_text(n: int) -> str:
    return f"{n / MB:.3g} MB" if n >= MB / 10 else f"{n} bytes"


def _kind(what: str) -> str:
    return what.removesuffix(" file")


def check_file_size(path, limit: int, what: str = "YAML", error=ScenarioError) -> int:
    """The size of the file at ``path`` (``os.stat``, nothing read), refused above ``limit``
    bytes with one line naming the file, its size and the limit."""
    try:
        size = os.stat(path).st_size
    except OSError as e:
        raise error(f"{path}: cannot be read: {e.strerror}") from None
    if size > limit:
        raise error(
            f"{path}: the file is {_size_text(size)}, larger than the "
            f"{_size_text(limit)} limit for {_kind(what)} files"
        )
    return size


def read_text_file(
    path, error=ScenarioError, limit: int = MAX_YAML_BYTES, what: str = "YAML", fmt: str = "YAML"
) -> str:
    """The text of a UTF-8 file of at most ``limit`` bytes (checked before reading; at most
    ``limit`` bytes are read even if the file grows); one-line errors naming the file,
    ``what`` it is for the size and ``fmt`` (YAML, CSV) for the encoding."""
    path = pathlib.Path(path)
    if not path.is_file():
        raise error(f"{path}: file not found")
    check_file_size(path, limit, what, error)
    try:
        with open(path, "rb") as f:
            data = f.read(limit + 1)
    except OSError as e:
        raise error(f"{path}: cannot be read: {e.strerror}") from None
    if len(data) > limit:
        raise error(
            f"{path}: the file is larger than the {_size_text(limit)} limit for {_kind(what)} files"
        )
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError:
        raise error(f"{path}: not a UTF-8 text ({fmt}) file") from None


def _path_text(frames) -> str:
    """The dotted path (``gaits.trot.mirror_keep[3]``) of the node the parser is at."""
    parts = []
    for f in frames:
        if not f.is_mapping:
            parts.append(f"[{f.children}]")
        elif f.children % 2 and f.key is not None:  # at a value: name its key
            key = short_text(f.key, 50)
            parts.append(f".{key}" if parts else key)
        else:
            break
    return short_text("".join(parts), 80)


@dc.dataclass
class _Frame:
    """An open mapping or list while parsing."""

    is_mapping: bool
    anchor: str | None
    start: int  # values counted before it
    children: int = 0  # keys and values (a mapping) or items (a list) done
    key: str | None = None  # a mapping's latest scalar key


class LimitedLoader(UniqueKeyLoader):
    """The strict loader with the input limits, checked on the parser's events as the
    composer takes them, so before any value is built or walked: more than
    ``MAX_YAML_DEPTH`` nested mappings/lists, more than ``MAX_YAML_NODES`` values with
    every alias expanded (counted with one number per anchor: no expansion happens), and an
    alias inside the value its anchor names (a recursive structure) are refused with one
    line naming ``where``, the line and the path in the document."""

    def __init__(self, text: str, where: str = "", error=ScenarioError):
        super().__init__(text)
        self._where, self._error = where, error
        self._nodes = 0
        self._frames: list[_Frame] = []
        self._sizes: dict[str, int] = {}  # anchor -> values it stands for

    def get_event(self):
        event = super().get_event()
        if isinstance(event, yaml.NodeEvent):
            self._count(event)
        elif isinstance(event, yaml.CollectionEndEvent):
            frame = self._frames.pop()
            if frame.anchor is not None:
                self._sizes[frame.anchor] = self._nodes - frame.start
            self._child_done()
        return event

    def _refuse(self, event, problem: str):
        prefix = f"{self._where}: " if self._where else ""
        path = _path_text(self._frames)
        raise self._error(
            f"{prefix}line {event.start_mark.line + 1}: {path + ': ' if path else ''}{problem}"
        )

    def _child_done(self):
        if self._frames:
            self._frames[-1].children += 1

    def _count(self, event):
        parent = self._frames[-1] if self._frames else None
        if parent is not None and parent.is_mapping and parent.children % 2 == 0:
            parent.key = event.value if isinstance(event, yaml.ScalarEvent) else None
        if isinstance(event, yaml.AliasEvent):
            anchor = typing.cast(str, event.anchor)  # an alias always names its anchor
            if any(f.anchor == anchor for f in self._frames):
                self._refuse(
                    event,
                    f"the alias *{short_text(anchor, 40)} is inside "
                    "the value it names (a recursive structure)",
                )
            self._nodes += self._sizes.get(anchor, 1)  # undefined: the composer says
            self._child_done()
        elif isinstance(event, yaml.ScalarEvent):
            self._nodes += 1
            if event.anchor is not None:
                self._sizes[event.anchor] = 1
            self._child_done()
        else:
            if len(self._frames) >= MAX_YAML_DEPTH:
                self._refuse(
                    event,
                    f"nested more than {MAX_YAML_DEPTH} levels deep (mappings "
                    f"and lists); a file may nest at most {MAX_YAML_DEPTH}",
                )
            self._frames.append(
                _Frame(isinstance(event, yaml.MappingStartEvent), event.anchor, self._nodes)
            )
            self._nodes += 1
        if self._nodes > MAX_YAML_NODES:
            self._refuse(
                event,
                f"more than {MAX_YAML_NODES} values with its aliases "
                f"expanded (an alias bomb?); a file may hold at most "
                f"{MAX_YAML_NODES}",
            )


def parse_yaml(text: str, where: str = "", error=ScenarioError):
    """``text`` parsed strictly (duplicate keys refused) within the input limits
    (``MAX_YAML_BYTES``, ``MAX_YAML_DEPTH``, ``MAX_YAML_NODES``); the error names
    ``where``."""
    prefix = f"{where}: " if where else ""
    if len(text) > MAX_YAML_BYTES:
        raise error(
            f"{prefix}{len(text)} characters of YAML, more than the "
            f"{_size_text(MAX_YAML_BYTES)} allowed"
        )
    loader = None
    try:
        loader = LimitedLoader(text, where, error)  # its reader refuses control characters
        return loader.get_single_data()
    except yaml.YAMLError as e:
        raise error(f"{prefix}not valid YAML: {' '.join(str(e).split())}") from None
    except ValueError as e:  # a constructor's: 2020-02-30, an int of 5000 digits
        if isinstance(e, (ScenarioError, error)):  # the limits' own
            raise
        reason = short_text(str(e).split(";")[0], 120)
        raise error(f"{prefix}a value cannot be read: {reason}") from None
    finally:
        if loader is not None:
            loader.dispose()


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
    text = read_text_file(path, error, what=what)
    data = parse_yaml(text, str(path), error)
    if data is None:
        data = {}
    if not isinstance(data, dict):
        raise error(f"{path}: the {what} file's root must be a mapping, got {type(data).__name__}")
    return data, text


def read_csv_table(
    path, error=ScenarioError, what: str = "table CSV", limit: int = MAX_TABLE_CSV_BYTES
) -> list[dict]:
    """A CSV file with a header row as a list of dicts of strings (``csv.DictReader``), the
    file at most ``limit`` bytes (checked before reading).

    Raises:
        error: one line naming the file: missing, larger than ``limit``, not UTF-8 text,
            holding NUL bytes, or a malformed row (its line).
    """
    text = read_text_file(path, error, limit, what, "CSV")
    if "\0" in text:
        raise error(f"{path}: not a text (CSV) file (it holds NUL bytes)")
    reader = csv.DictReader(io.StringIO(text, newline=""))
    try:
        return list(reader)
    except csv.Error as e:
        raise error(
            f"{path}: line {reader.line_num}: not valid CSV: {short_text(str(e))}"
        ) from None


# --- key checks ----------------------------------------------------------------------------


def schema_fields(schema) -> dict | None:
    """Field name -> type of a dataclass or a pydrake config struct, else None."""
    if dc.is_dataclass(schema):
        hints = typing.get_type_hints(schema)
        return {f.name: hints[f.name] for f in dc.fields(schema)}
    if hasattr(schema, "__fields__"):  # pydrake-bound C++ structs (SimulatorConfig, ...)
        return {f.name: f.type for f in schema.__fields__}
    return None


def _key_text(key, limit: int = 40) -> str:
    """A mapping key as a message's path names it, cut to ``limit`` characters."""
    try:
        text = str(key) if isinstance(key, (str, numbers.Number)) else short_repr(key, limit)
    except ValueError:  # an int too long to print
        text = short_repr(key, limit)
    return text if len(text) <= limit else text[: limit - 3] + "..."


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
        raise ScenarioError(f"{path}: expected a {_type_name(tp)}, got {short_repr(value)}")


def check_keys(data, schema, path: str = "scenario") -> None:
    """Walks ``data`` against the schema; raises ScenarioError naming the first bad key.

    Unknown keys (typos) and values of the wrong type are reported with their full
    path, e.g. ``scenario.initial_pose.xyzz``.
    """
    origin = typing.get_origin(schema)
    if origin is dict:
        key_type, value_type = typing.get_args(schema)
        if not isinstance(data, dict):
            raise ScenarioError(f"{path}: expected a mapping, got {short_repr(data)}")
        for key, value in data.items():
            check_keys(key, key_type, f"{path} key")
            check_keys(value, value_type, f"{path}.{_key_text(key)}")
        return
    if origin is list:
        (item_type,) = typing.get_args(schema) or (None,)
        if not isinstance(data, list):
            raise ScenarioError(f"{path}: expected a list, got {short_repr(data)}")
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
        raise ScenarioError(
            f"{path}: expected a mapping with keys {sorted(fields)}, got {short_repr(data)}"
        )
    for key, value in data.items():
        if key not in fields:
            raise ScenarioError(
                f"{path}.{_key_text(key)}: unknown key (a typo?); allowed keys: "
                f"{', '.join(sorted(fields))}"
            )
        check_keys(value, fields[key], f"{path}.{key}")


# --- value checks --------------------------------------------------------------------------
#
# The one set of value checks of the package: scenarios, data files, Systems' constructors,
# sweep, calibration and optimisation specs and the commands' options. Each raises ``error``
# (a ScenarioError by default; a file kind's own subclass, e.g. ``SweepError``), one line
# naming the field or option, the value and the allowed range.


def check_number(field: str, value, error=ScenarioError) -> None:
    """A finite real number (int, float or a numpy scalar; not a bool)."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise error(f"{field}: {short_repr(value)} is not a number")
    if not math.isfinite(value):
        raise error(f"{field}: {short_repr(value)} is not finite")


def check_in_range(
    field, value, lo, hi, text, open_low=False, open_high=False, error=ScenarioError
) -> None:
    """A finite number in [lo, hi] (or open at either end); ``text`` states the range."""
    check_number(field, value, error)
    above = value > lo if open_low else value >= lo
    below = value < hi if open_high else value <= hi
    if not (above and below):
        raise error(f"{field}: {short_repr(value)} is outside the allowed range {text}")


def field_name(where: str, name: str) -> str:
    """The dotted name of field ``name`` in the section ``where`` (``name`` alone when
    ``where`` is empty: a System's own parameters)."""
    return f"{where}.{name}" if where else name


@dc.dataclass(frozen=True)
class Range:
    """An allowed range of a number, declared once in the module that owns the concept (a
    System's module) and checked by everything that takes such a number: the System's
    constructor (naming its argument) and the scenario (naming its dotted field).

    ``Range(0.0, 10.0, "m", open_low=True).text()`` is ``(0, 10] m``; ``check`` raises
    ScenarioError (one line: the field, the value, the range and an optional note).
    """

    lo: float
    hi: float
    unit: str = ""
    open_low: bool = False
    open_high: bool = False

    def text(self, note: str = "") -> str:
        """The range as the messages state it, e.g. ``(0, 5] Hz`` (``note`` in parentheses
        after it)."""
        left, right = "(" if self.open_low else "[", ")" if self.open_high else "]"
        text = f"{left}{self.lo:g}, {self.hi:g}{right}" + (f" {self.unit}" if self.unit else "")
        return f"{text} ({note})" if note else text

    def check(self, field: str, value, note: str = "") -> None:
        """ScenarioError naming ``field`` unless ``value`` is a finite number in the range."""
        check_in_range(
            field, value, self.lo, self.hi, self.text(note), self.open_low, self.open_high
        )


def check_integer(field: str, value, lo: int, hi: int, error=ScenarioError) -> None:
    """An int (or a numpy integer; not a bool, not 1.7) in [lo, hi]."""
    if isinstance(value, bool) or not isinstance(value, numbers.Integral):
        raise error(f"{field}: {short_repr(value)} is not an integer (allowed: {lo} to {hi})")
    if not lo <= int(value) <= hi:
        raise error(f"{field}: {short_repr(value)} is outside the allowed range [{lo}, {hi}]")


def check_boolean(field: str, value, error=ScenarioError) -> None:
    if not isinstance(value, bool):
        raise error(f"{field}: {short_repr(value)} is not true or false")


def check_text(field: str, value, allow_empty: bool = False, error=ScenarioError) -> None:
    if not isinstance(value, str) or (not allow_empty and not value.strip()):
        raise error(
            f"{field}: {short_repr(value)} is not a {'' if allow_empty else 'non-empty '}string"
        )


def check_one_of(field: str, value, allowed, error=ScenarioError) -> None:
    if not isinstance(value, str) or value not in allowed:
        raise error(f"{field}: {short_repr(value)} is not one of {', '.join(map(str, allowed))}")


def check_vector(
    field: str, value, n: int, bound: float = math.inf, unit: str = "", error=ScenarioError
) -> None:
    """``n`` finite numbers whose Euclidean norm is at most ``bound`` (a list, a tuple or a
    numpy array, which a caller's dataclass may hold after ``dc.replace``)."""
    if hasattr(value, "tolist"):
        value = value.tolist()
    if not isinstance(value, (list, tuple)) or len(value) != n:
        raise error(f"{field}: expected {n} finite numbers, got {short_repr(value)}")
    for i, v in enumerate(value):
        check_number(f"{field}[{i}]", v, error)
    if math.isfinite(bound) and math.sqrt(sum(v * v for v in value)) > bound:
        raise error(f"{field}: {short_repr(value)} has magnitude above the allowed {bound}{unit}")


# --- output folders --------------------------------------------------------------------------


def check_writable_folder(
    out_dir,
    option: str = "--out",
    example: str = "out/run",
    error=ScenarioError,
    create: bool = False,
) -> pathlib.Path:
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
            raise error(f"{option} {out_dir}: cannot be created ({e.strerror or e})") from None
        existing = out_dir

    def refuse(reason: str):
        if existing == out_dir:
            return error(f"{option} {out_dir}: cannot be written ({reason})")
        return error(
            f"{option} {out_dir}: cannot be created ({existing} is not writable: {reason})"
        )

    if not os.access(existing, os.W_OK | os.X_OK):
        raise refuse("no write permission")
    try:  # the permission bits do not tell everything (read-only mounts, root)
        with tempfile.TemporaryFile(dir=existing, prefix=".write-check-"):
            pass
    except OSError as e:
        raise refuse(e.strerror or str(e)) from None
    return out_dir
