"""From free gait entries to gaits: ``parse_entry`` reads ``R_deg[fr, pitch]``,
``build_parameters`` turns the spec's ``free`` list into parameters (each setting its entry,
its ties and, for ``Phi_prime_deg``, the antisymmetric partners), and ``ParameterSpace``
maps CMA-ES's unit cube to degrees and degrees to gaits.

CMA-ES searches x in [0, 1]^n; parameter i is ``low_i + x_i (high_i - low_i)`` degrees, so
one ``sigma0`` is the same fraction of every bound's width."""

from __future__ import annotations

import dataclasses as dc
import math
import re

import numpy as np

from manta_drake.config_io import check_in_range
from manta_drake.control.gait_files import (
    FIELD_OF_MATRIX,
    JOINT_COLUMNS,
    LEG_ROWS,
    MATRICES,
    MAX_DEGREES,
    degrees_to_radians,
    gait_file_data,
    gait_file_text,
    radians_to_degrees,
)
from manta_drake.control.gait_params import GaitParams
from manta_drake.optimize.spec import FreeEntry, OptimizeError

_ENTRY = re.compile(r"\s*([A-Za-z_]+)\s*\[\s*([A-Za-z0-9_]+)\s*,\s*([A-Za-z0-9_]+)\s*\]\s*\Z")
# Phi_deg's last column is no phase bias (joint j to j + 1 has three links): unused.
UNUSED = {("Phi_deg", c) for c in range(4) if JOINT_COLUMNS[c] == "roll2"}


@dc.dataclass(frozen=True)
class Target:
    """One matrix entry a parameter sets: ``sign * value`` degrees at (row, col)."""

    matrix: str
    row: int
    col: int
    sign: float
    field: str = "entry"  # what in the spec's free entry sets it: entry or tie[j]

    def label(self) -> str:
        cols = LEG_ROWS if self.matrix == "Phi_prime_deg" else JOINT_COLUMNS
        return f"{self.matrix}[{LEG_ROWS[self.row]}, {cols[self.col]}]"


@dc.dataclass(frozen=True)
class Parameter:
    """A free parameter: its name, bounds [deg] and the entries it sets (the first is the
    spec's ``entry`` with sign +1)."""

    name: str
    low: float
    high: float
    targets: tuple

    @property
    def entry(self) -> str:
        return self.targets[0].label()


def parse_entry(text, where: str) -> tuple[str, int, int]:
    """``MATRIX[row, column]`` as (matrix, row index, column index).

    The matrix is one of R_deg, X_deg, Phi_deg, Phi_prime_deg; the row a leg-fin (fl, fr,
    rl, rr); the column a joint (yaw, roll1, pitch, roll2), for Phi_prime_deg a leg-fin.

    Raises:
        OptimizeError: one line naming ``where`` and what is wrong.
    """
    m = _ENTRY.match(text) if isinstance(text, str) else None
    if m is None:
        raise OptimizeError(
            f"{where}: {text!r} is not an entry; expected MATRIX[row, column], "
            "e.g. R_deg[fr, pitch] or Phi_prime_deg[fl, fr]"
        )
    matrix, row, col = m.groups()
    if matrix not in MATRICES:
        raise OptimizeError(
            f"{where}: {text!r}: matrix {matrix!r} is not one of {', '.join(MATRICES)}"
        )
    if row not in LEG_ROWS:
        raise OptimizeError(f"{where}: {text!r}: row {row!r} is not one of {', '.join(LEG_ROWS)}")
    cols = LEG_ROWS if matrix == "Phi_prime_deg" else JOINT_COLUMNS
    if col not in cols:
        what = "a leg-fin" if matrix == "Phi_prime_deg" else "a joint"
        raise OptimizeError(f"{where}: {text!r}: column {col!r} is not {what} ({', '.join(cols)})")
    r, c = LEG_ROWS.index(row), cols.index(col)
    if matrix == "Phi_prime_deg" and r == c:
        raise OptimizeError(
            f"{where}: {text!r}: a fin's phase bias to itself is 0 by "
            "definition; choose two different leg-fins"
        )
    if (matrix, c) in UNUSED:
        raise OptimizeError(
            f"{where}: {text!r}: Phi_deg's roll2 column is unused (no joint "
            "after roll2); choose yaw, roll1 or pitch"
        )
    return matrix, r, c


def default_name(matrix: str, row: int, col: int) -> str:
    cols = LEG_ROWS if matrix == "Phi_prime_deg" else JOINT_COLUMNS
    return f"{matrix}.{LEG_ROWS[row]}.{cols[col]}"


def build_parameters(free: list[FreeEntry], root: str = "optimize.free") -> list[Parameter]:
    """The spec's free entries as parameters, checked.

    Raises:
        OptimizeError: no entries; a bad entry (syntax, matrix, row, column, a fin to
            itself, Phi_deg's unused column); bounds not finite, beyond +-720 deg, or
            low >= high; a tie to the entry itself or of the wrong length of signs, a sign
            other than +1 or -1; an entry set by two parameters (directly, tied or as the
            antisymmetric partner of a Phi_prime_deg entry); a name used twice.
    """
    if not free:
        raise OptimizeError(
            f"{root}: name at least one free entry, e.g. "
            "{entry: 'R_deg[fr, pitch]', low: -45, high: 45}"
        )
    out: list[Parameter] = []
    owner: dict[tuple, str] = {}  # (matrix, row, col) -> where it is set
    names: set[str] = set()
    for i, f in enumerate(free):
        where = f"{root}[{i}]"
        matrix, r, c = parse_entry(f.entry, f"{where}.entry")
        low, high = _bounds(f, where)
        targets = _with_partners(_entry_and_ties(f, where, matrix, r, c), where)
        _claim(targets, owner, where)
        name = f.name or default_name(matrix, r, c)
        if not re.fullmatch(r"[A-Za-z_][A-Za-z0-9_.]*", name) or name in names:
            raise OptimizeError(
                f"{where}.name: {name!r} is used twice or is not a name (letters, digits, _ and .)"
            )
        names.add(name)
        out.append(Parameter(name, low, high, tuple(targets)))
    return out


def _bounds(f: FreeEntry, where: str) -> tuple[float, float]:
    """(low, high) of a free entry, checked: finite, within +-MAX_DEGREES, low < high."""
    for key in ("low", "high"):
        check_in_range(
            f"{where}.{key}",
            getattr(f, key),
            -MAX_DEGREES,
            MAX_DEGREES,
            f"[-{MAX_DEGREES:g}, {MAX_DEGREES:g}] deg",
            error=OptimizeError,
        )
    low, high = float(f.low), float(f.high)
    if not low < high:
        raise OptimizeError(f"{where}.low: {low!r} must be below high ({high!r})")
    return low, high


def _entry_and_ties(f: FreeEntry, where: str, matrix: str, r: int, c: int) -> list[Target]:
    """The entry (sign +1) and each entry of its ``tie`` with its sign, checked."""
    if not isinstance(f.tie, list):
        raise OptimizeError(f"{where}.tie: expected a list of entries")
    signs = list(f.tie_signs) if f.tie_signs else [1.0] * len(f.tie)
    if len(signs) != len(f.tie):
        raise OptimizeError(
            f"{where}.tie_signs: {len(signs)} signs for {len(f.tie)} tied "
            "entries; give one sign (+1 or -1) per entry of tie, or none"
        )
    targets = [Target(matrix, r, c, 1.0)]
    for j, (text, sign) in enumerate(zip(f.tie, signs)):
        if isinstance(sign, bool) or sign not in (1, -1):
            raise OptimizeError(f"{where}.tie_signs[{j}]: {sign!r} is not +1 or -1")
        tm, tr, tc = parse_entry(text, f"{where}.tie[{j}]")
        if (tm, tr, tc) == (matrix, r, c):
            raise OptimizeError(
                f"{where}.tie[{j}]: {text!r} is the entry itself; a tie names another entry"
            )
        targets.append(Target(tm, tr, tc, float(sign), f"tie[{j}]"))
    return targets


def _with_partners(targets: list[Target], where: str) -> list[Target]:
    """``targets`` and, after them, the antisymmetric partner of each Phi_prime_deg one
    ([l, k] = -[k, l]); naming both of a pair is an error."""
    for t in list(targets):
        if t.matrix == "Phi_prime_deg":
            partner = Target(t.matrix, t.col, t.row, -t.sign, t.field)
            if any(
                (p.matrix, p.row, p.col) == (partner.matrix, partner.row, partner.col)
                for p in targets
            ):
                raise OptimizeError(
                    f"{where}.tie: {partner.label()} follows {t.label()} as "
                    "its negative automatically; do not name both"
                )
            targets.append(partner)
    return targets


def _claim(targets: list[Target], owner: dict[tuple, str], where: str) -> None:
    """Records ``where`` as the setter of each target's entry in ``owner``; an entry
    already there is an error."""
    for j, t in enumerate(targets):
        spot = (t.matrix, t.row, t.col)
        field = f"{where}.entry" if j == 0 else f"{where}.tie"
        if spot in owner:
            raise OptimizeError(
                f"{field}: {t.label()} is already set by {owner[spot]}; "
                "each entry may follow one parameter"
            )
        owner[spot] = f"{where}"


class ParameterSpace:
    """The free parameters around a start gait: unit cube <-> degrees -> gait.

    Args:
        parameters: from ``build_parameters``.
        start: the start gait (GaitParams, radians), as the scenario's reading gives it.
    """

    def __init__(self, parameters: list[Parameter], start: GaitParams):
        self.parameters = list(parameters)
        self.start = start
        self.low = np.array([p.low for p in parameters])
        self.high = np.array([p.high for p in parameters])
        # As a gait file writes them: whole degrees exactly (45, not 45.00000000000001).
        self.start_degrees = {
            m: np.array(radians_to_degrees(getattr(start, FIELD_OF_MATRIX[m])), dtype=float)
            for m in MATRICES
        }

    @property
    def names(self) -> list[str]:
        return [p.name for p in self.parameters]

    def start_vector(self) -> np.ndarray:
        """The start gait's value of each parameter's entry [deg]."""
        return np.array(
            [
                self.start_degrees[p.targets[0].matrix][p.targets[0].row, p.targets[0].col]
                for p in self.parameters
            ]
        )

    def to_degrees(self, unit) -> np.ndarray:
        """Degrees of a point of the unit cube (clipped into it)."""
        unit = np.clip(np.asarray(unit, dtype=float), 0.0, 1.0)
        return self.low + unit * (self.high - self.low)

    def to_unit(self, degrees) -> np.ndarray:
        return (np.asarray(degrees, dtype=float) - self.low) / (self.high - self.low)

    def matrices_degrees(self, degrees) -> dict[str, np.ndarray]:
        """The four matrices [deg] with every parameter's targets set."""
        out = {m: v.copy() for m, v in self.start_degrees.items()}
        for p, value in zip(self.parameters, np.asarray(degrees, dtype=float)):
            for t in p.targets:
                out[t.matrix][t.row, t.col] = t.sign * value
        return out

    def gait(self, degrees) -> GaitParams:
        """The start gait with the parameters at ``degrees``. Entries the parameters do not
        set keep the start gait's radians to the bit."""
        fields = {
            FIELD_OF_MATRIX[m]: np.array(getattr(self.start, FIELD_OF_MATRIX[m])) for m in MATRICES
        }
        for p, value in zip(self.parameters, np.asarray(degrees, dtype=float)):
            for t in p.targets:
                fields[FIELD_OF_MATRIX[t.matrix]][t.row, t.col] = degrees_to_radians(t.sign * value)
        return GaitParams(**fields)

    def changed_entries(self, degrees) -> list[tuple[str, float, float]]:
        """Every entry the parameters set: (label, start deg, value deg)."""
        new = self.matrices_degrees(degrees)
        return [
            (
                t.label(),
                float(self.start_degrees[t.matrix][t.row, t.col]),
                float(new[t.matrix][t.row, t.col]),
            )
            for p in self.parameters
            for t in p.targets
        ]

    def distance_from_start(self, degrees) -> float:
        """RMS change [deg] of every entry the parameters set (entries, ties and partners)
        from the start gait."""
        changes = [value - start for _, start, value in self.changed_entries(degrees)]
        return float(math.sqrt(np.mean(np.square(changes))))

    def outside_bounds(self) -> list[tuple[int, str, str]]:
        """Parameters whose start value is outside their bounds (the search starts there):
        (index, the bound it passes: low or high, a text)."""
        out = []
        for i, (p, v) in enumerate(zip(self.parameters, self.start_vector())):
            if not p.low <= v <= p.high:
                text = (
                    f"the start gait has {p.entry} = {v:g} deg, outside [low, high] = "
                    f"[{p.low:g}, {p.high:g}]"
                )
                out.append((i, "low" if v < p.low else "high", text))
        return out

    def off_ties(self) -> list[tuple[int, str, str]]:
        """Entries the start gait does not give as their parameter sets them (a tied entry
        not ``sign`` times the entry, a Phi_prime partner not its negative): the search
        could not start at the start gait. (parameter index, the spec's field, text)."""
        out = []
        for i, p in enumerate(self.parameters):
            first = p.targets[0]
            value = self.start_degrees[first.matrix][first.row, first.col]
            for t in p.targets[1:]:
                have = self.start_degrees[t.matrix][t.row, t.col]
                if abs(have - t.sign * value) > 1e-9:
                    text = (
                        f"the start gait has {t.label()} = {have:g} deg, not "
                        f"{t.sign:+g} x {first.label()} = {t.sign * value:g} deg; the "
                        "search could not start at the start gait"
                    )
                    out.append((i, t.field, text))
        return out


def candidate_gait_text(
    name: str,
    gait: GaitParams,
    description: str = "",
    provenance: dict | None = None,
    header: str = "",
) -> str:
    """A gait file holding ``gait`` as ``name``: all four matrices, ``mirror_keep: [R_deg,
    X_deg]`` so that it runs as written under either ``controller.gait_reading``."""
    data = gait_file_data(
        {name: gait}, description, provenance, mirror_keep={name: ["R_deg", "X_deg"]}
    )
    return gait_file_text(data, header)
