"""What an optimisation spec holds (``OptimizeSpec`` and its parts) and ``OptimizeError``,
the one-line error of every check. ``loading.load_spec`` reads and checks a file; the
meaning of each field is in the package docstring and docs/optimize.md."""

from __future__ import annotations

import dataclasses as dc
import math
import pathlib
from typing import Any

from manta_drake.sweep.config import SweepError


class OptimizeError(SweepError):
    """The optimisation spec, an option or the output folder is invalid; one line names the
    field (``optimize.free[0].low``) or the option."""


@dc.dataclass
class FreeEntry:
    """One free parameter: a gait entry (``R_deg[fr, pitch]``) searched in [low, high] deg.

    ``tie`` lists entries set to the same value (times ``tie_signs``, each +1 or -1; default
    all +1). A free or tied entry of ``Phi_prime_deg[k, l]`` sets ``[l, k]`` to its negative
    as well (the layer-2 phase biases are antisymmetric).
    """

    entry: str = ""
    low: float = math.nan
    high: float = math.nan
    tie: list[str] = dc.field(default_factory=list)
    tie_signs: list[float] = dc.field(default_factory=list)
    name: str = ""  # the history's column; default the entry as R_deg.fr.pitch


@dc.dataclass
class Term:
    """``weight * metric`` in the cost (minimised; a negative weight maximises)."""

    metric: str = ""
    weight: float = 1.0


@dc.dataclass
class Constraint:
    """``min <= metric <= max`` (either or both); with ``relative_to`` the bounds are
    factors of that metric (``{metric: abs_v, min: 2, relative_to: abs_u}``: |v| >= 2 |u|).

    Violated by d, it adds ``penalty_weight * (d / scale)^2``; ``scale`` defaults to the
    bound's magnitude (1 where that is 0, or with ``relative_to``)."""

    metric: str = ""
    min: float | None = None
    max: float | None = None
    relative_to: str = ""
    scale: float | None = None


@dc.dataclass
class Objective:
    """The cost of one simulation: the terms' weighted sum plus the constraints' penalties;
    a failed run costs ``failed_cost``, a run whose hull touched a wall adds ``wall_cost``."""

    terms: list[Term] = dc.field(default_factory=list)
    constraints: list[Constraint] = dc.field(default_factory=list)
    penalty_weight: float = 100.0
    wall_cost: float = 1000.0
    failed_cost: float = 1.0e6


@dc.dataclass
class Robustness:
    """Every candidate is simulated at each point (dotted scenario overrides, or the derived
    ``net_weight_kg``) and each seed (``random_seed``); its cost is the ``mean`` or the
    ``worst`` (largest) of those simulations' costs. No points: the scenario as it is."""

    points: list[dict[str, Any]] = dc.field(default_factory=list)
    seeds: list[int] = dc.field(default_factory=lambda: [0])
    aggregate: str = "mean"


@dc.dataclass
class HeldOut:
    """Points the best gait is checked at after the search, never used in it; ``seeds``
    default to the robustness seeds."""

    points: list[dict[str, Any]] = dc.field(default_factory=list)
    seeds: list[int] | None = None


@dc.dataclass
class Budget:
    """How much to search. ``sigma0``: CMA-ES's initial step, a fraction of each bound's
    width; ``duration``/``steady_after`` [s]: of every simulation (None: the scenario's);
    ``min_window`` [s]: the shortest steady window a simulation is scored on (a window a wall
    cuts shorter leaves it unscored; None: ``simulate.MIN_STEADY_WINDOW``)."""

    generations: int = 10
    population: int = 8
    sigma0: float = 0.2
    duration: float | None = None
    steady_after: float | None = None
    min_window: float | None = None


@dc.dataclass
class Front:
    """A front instead of one optimum: for each of ``levels`` a search that minimises
    ``minimise`` with ``maximise`` at least that level (and the objective's constraints),
    the epsilon-constraint method; the front is the non-dominated set of every candidate
    of every level that meets the objective's constraints. No levels: no front."""

    maximise: str = "u"
    minimise: str = "cot_net_of_hotel"
    levels: list[float] = dc.field(default_factory=list)

    def __bool__(self) -> bool:
        return bool(self.levels)


@dc.dataclass
class OptimizeSpec:
    """An optimisation spec file (docs/optimize.md)."""

    name: str = ""  # the result gait's name (default the file's stem)
    description: str = ""
    scenario: str = ""  # a shipped name, or a path relative to the spec file
    gait: str = ""  # the starting gait, a gait of the scenario's library
    overrides: dict[str, Any] = dc.field(default_factory=dict)  # set on the scenario
    free: list[FreeEntry] = dc.field(default_factory=list)
    objective: Objective = dc.field(default_factory=Objective)
    robustness: Robustness = dc.field(default_factory=Robustness)
    held_out: HeldOut = dc.field(default_factory=HeldOut)
    budget: Budget = dc.field(default_factory=Budget)
    front: Front = dc.field(default_factory=Front)
    seed: int = 0  # CMA-ES's random numbers
    # Not in the file: where it is and what it says (the provenance and restarts use them).
    folder: pathlib.Path = dc.field(default=pathlib.Path("."), repr=False)
    path: pathlib.Path | None = dc.field(default=None, repr=False)
    text_sha256: str = dc.field(default="", repr=False)

    def held_out_seeds(self) -> list[int]:
        return list(self.robustness.seeds if self.held_out.seeds is None else self.held_out.seeds)

    def points(self) -> list[dict]:
        """The robustness points (one empty point, the scenario as it is, if none)."""
        return [dict(p) for p in self.robustness.points] or [{}]
