"""A value and where it comes from: the entries of the data files.

Every number of ``models/hydrodynamics.yaml``, ``models/actuators.yaml`` and
``models/bill_of_materials.yaml`` is written with its source::

    water_density: {value: 997.0, source: "fresh water at 25 C (CRC Handbook)"}

and read into one of the types below, one per kind of value, which the three files'
dataclasses share: ``Number`` (one number), ``Numbers`` (a list of numbers), ``Text`` (a name
or a choice), ``Flag`` (yes or no) and ``Table`` (named numbers). :func:`sourced_entries`
walks a file's dataclasses and gives each entry with its dotted name, the name the checks'
messages and the scales (``water.coefficient_scales``, ``actuators.scales``) use.
"""

# No ``from __future__ import annotations``: Drake's ``yaml_load_typed`` reads the fields'
# types from ``dataclasses.fields``, which would then be strings.
import dataclasses as dc
from collections.abc import Iterator


@dc.dataclass
class Number:
    """A number and where it comes from."""

    value: float = 0.0
    source: str = ""


@dc.dataclass
class Numbers:
    """A list of numbers and where they come from."""

    value: list[float] = dc.field(default_factory=list)
    source: str = ""


@dc.dataclass
class Text:
    """A name or a choice and where it comes from."""

    value: str = ""
    source: str = ""


@dc.dataclass
class Flag:
    """A yes/no choice and where it comes from."""

    value: bool = False
    source: str = ""


@dc.dataclass
class Table:
    """Named numbers (e.g. a power per operating mode) and where they come from."""

    value: dict[str, float] = dc.field(default_factory=dict)
    source: str = ""


Sourced = Number | Numbers | Text | Flag | Table
SOURCED = (Number, Numbers, Text, Flag, Table)


def sourced_entries(node, prefix: str = "") -> Iterator[tuple[str, Sourced]]:
    """(dotted name, entry) of every sourced entry of the dataclass ``node`` and of the
    dataclasses it holds, in field order (``body.linear_damping``); fields of other types
    (a dict of parts, a plain number) are not entries and are skipped."""
    for f in dc.fields(node):
        value = getattr(node, f.name)
        name = f"{prefix}{f.name}"
        if isinstance(value, SOURCED):
            yield name, value
        elif dc.is_dataclass(value) and not isinstance(value, type):
            yield from sourced_entries(value, name + ".")
