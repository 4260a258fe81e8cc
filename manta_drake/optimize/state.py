"""An optimisation's restart state, ``state.json``: plain JSON numbers and lists, never code.

It holds what the search told CMA-ES, not CMA-ES itself: each told generation's candidates
(the points in the unit cube CMA-ES asked) and costs, the candidates of a generation asked
and not yet told, the state of CMA-ES's normal generator after the last ask
(``numpy``'s ``bit_generator.state``: a dict of integers), the wall times and the
generations' timings. A restart builds the ``cma.CMAEvolutionStrategy`` from the spec (the
options and seed of the first run, the start gait injected) and replays every ask and tell:
each replayed ask must give the saved candidates bit for bit and the generator must end in
the saved state, else the state is refused (another build of cma or numpy may round
differently). CMA-ES thus continues exactly where it was, and a search interrupted and
restarted asks the candidates of one that ran through.

The file is read with a bound on its size and checked field by field before anything is
replayed; a malformed file, one of another spec or options, or one that does not replay is
refused with one line naming it. ``state.pkl``, the pickle an earlier version wrote, is
refused and never opened: unpickling runs whatever code the file names.
"""

from __future__ import annotations

import dataclasses as dc
import json
import math
import os
import pathlib
from typing import Any

import numpy as np

from manta_drake.config_io import short_repr
from manta_drake.optimize.history import read_bounded
from manta_drake.optimize.spec import OptimizeError

STATE = "state.json"
LEGACY_STATE = "state.pkl"
KIND = "manta-drake optimize state"
STATE_FORMAT = 2
KEYS = (
    "kind",
    "format",
    "identity",
    "versions",
    "generations",
    "pending",
    "generator",
    "wall_time_s",
    "timings",
)
TIMING_KEYS = {
    "generation": int,
    "wall_s": float,
    "simulated": int,
    "reused": int,
    "longest_simulation_s": float,
    "sum_simulation_s": float,
    "resumed": bool,
}
# The size bound of a state file: this much, plus a generation's candidates and costs (each
# number at most 32 characters) and timing for every generation a state of this spec may
# hold (at least FLOOR_GENERATIONS).
SLACK_BYTES = 1 << 20
GENERATION_BYTES = 1024
FLOOR_GENERATIONS = 1000


class Normal:
    """CMA-ES's normal samples from a generator of its own (its ``randn`` option), seeded
    by the spec: its state after the last ask is saved and checked by the replay."""

    def __init__(self, seed: int):
        self.rng = np.random.default_rng(seed)

    def __call__(self, *shape):
        return self.rng.standard_normal(shape)


@dc.dataclass
class SearchState:
    """CMA-ES and what it was told. ``generation``: the generations asked (the last one
    pending until it is told)."""

    es: Any  # a cma.CMAEvolutionStrategy (cma ships no type information)
    normal: Normal
    told: list = dc.field(default_factory=list)  # (candidates, costs) per generation
    pending: list | None = None  # the asked candidates (float arrays), not yet told
    best: dict | None = None
    wall_time_s: float = 0.0
    timings: list = dc.field(default_factory=list)

    @property
    def generation(self) -> int:
        return len(self.told) + (self.pending is not None)

    def stop(self) -> dict:
        """CMA-ES's termination criteria met (empty: go on)."""
        return self.es.stop()

    def ask(self) -> None:
        self.pending = [np.asarray(x, dtype=float) for x in self.es.ask()]

    def tell(self, costs) -> None:
        self.es.tell(self.pending, list(costs))
        self.told.append((self.pending, [float(c) for c in costs]))
        self.pending = None


def new_search(problem) -> SearchState:
    """CMA-ES as the spec starts it: on the unit cube, the spec's population, step and seed,
    generation 1's first candidate the start gait itself (its cost is the one to beat)."""
    import cma

    space, spec = problem.space, problem.spec
    normal = Normal(spec.seed)
    start = list(space.to_unit(space.start_vector()))
    es = cma.CMAEvolutionStrategy(
        start,
        spec.budget.sigma0,
        {
            "bounds": [0.0, 1.0],
            "popsize": spec.budget.population,
            "seed": spec.seed + 1,
            "randn": normal,
            "verbose": -9,
            "verb_log": 0,
            "verb_disp": 0,
        },
    )
    # CMA-ES works on a genotype the bound handler maps into [0, 1]; the inverse map gives
    # the genotype of the start (a start on a bound too).
    es.inject([es.boundary_handler.inverse(start)], force=True)
    return SearchState(es, normal)


def _versions() -> dict:
    import cma

    return {"cma": str(cma.__version__), "numpy": str(np.__version__)}


def state_data(state: SearchState, identity: dict) -> dict:
    """What ``state.json`` holds (module docstring)."""
    return {
        "kind": KIND,
        "format": STATE_FORMAT,
        "identity": identity,
        "versions": _versions(),
        "generations": [
            {"candidates": [x.tolist() for x in xs], "costs": list(costs)}
            for xs, costs in state.told
        ],
        "pending": None if state.pending is None else [x.tolist() for x in state.pending],
        "generator": state.normal.rng.bit_generator.state,
        "wall_time_s": float(state.wall_time_s),
        "timings": list(state.timings),
    }


def save_state(out_dir: pathlib.Path, state: SearchState, identity: dict) -> None:
    """Writes ``state.json`` atomically (a kill leaves the old state or the new one)."""
    path = pathlib.Path(out_dir) / STATE
    tmp = path.with_name(f".{path.name}.tmp")
    tmp.write_text(json.dumps(state_data(state, identity), separators=(",", ":")) + "\n")
    os.replace(tmp, path)


def state_limit(problem) -> int:
    """The largest ``state.json`` this spec's search writes in ``FLOOR_GENERATIONS`` or
    ``budget.generations`` generations [bytes]."""
    per_generation = (
        problem.spec.budget.population * (len(problem.space.names) + 1) * 32 + GENERATION_BYTES
    )
    return SLACK_BYTES + per_generation * max(problem.spec.budget.generations, FLOOR_GENERATIONS)


def load_state(out_dir, problem) -> SearchState | None:
    """The search saved in ``out_dir``, CMA-ES rebuilt by replaying it, or None if there is
    none. The best so far is left to the caller (it is recomputed from ``told``).

    Raises:
        OptimizeError: ``state.pkl`` is present (never opened), or ``state.json`` is not a
            regular file, too large, malformed, of another spec or options, or does not
            replay; one line naming the file.
    """
    out_dir = pathlib.Path(out_dir)
    legacy = out_dir / LEGACY_STATE
    if legacy.exists() or legacy.is_symlink():
        raise OptimizeError(
            f"--out {out_dir}: {legacy} is the restart state of an earlier version, a pickle, "
            "and is no longer read (unpickling runs whatever code the file names, so anyone "
            "who could write this folder could run code here); delete it to search again "
            "from the start in this folder (the simulations history.csv holds are reused) or "
            "use another --out"
        )
    path = out_dir / STATE
    data = _read(path, state_limit(problem))
    if data is None:
        return None
    _check_identity(path, data, problem)
    _check_fields(path, data, problem)
    return _replay(path, data, problem)


def _read(path: pathlib.Path, limit: int):
    """The parsed JSON of ``path`` (None if absent), read with at most ``limit`` bytes."""
    raw = read_bounded(path, limit, lambda size: OptimizeError(_too_large(path, size, limit)))
    if raw is None:
        return None
    try:
        return json.loads(raw)
    except (ValueError, RecursionError) as e:
        what = type(e).__name__ if isinstance(e, RecursionError) else _plain(str(e), 120)
        raise OptimizeError(
            f"{path}: not an optimisation state (not JSON: {what}); use "
            "another --out (or delete the folder)"
        ) from None


def _too_large(path, size: int, limit: int) -> str:
    return (
        f"{path}: {size} bytes, more than the {limit} a state of this spec takes in its "
        "generations (raise --generations to those it ran) or not a state; use another "
        "--out"
    )


def _malformed(path, what: str) -> OptimizeError:
    return OptimizeError(
        f"{path}: not an optimisation state this version writes ({what}); "
        "use another --out (or delete the folder)"
    )


def _check_identity(path, data, problem) -> None:
    if not isinstance(data, dict):
        raise _malformed(path, f"its root is a {type(data).__name__}, not an object")
    if data.get("kind") != KIND:
        raise _malformed(path, f"kind {short_repr(data.get('kind'))}, not {KIND!r}")
    if data.get("format") != STATE_FORMAT:
        raise _malformed(
            path, f"format {short_repr(data.get('format'))}; this version writes {STATE_FORMAT}"
        )
    theirs = data.get("identity")
    if not isinstance(theirs, dict):
        raise _malformed(path, "identity is not an object")
    mine = problem.identity()
    different = [k for k in mine if mine[k] != theirs.get(k)]
    if different:
        what = ", ".join(
            f"{k} ({short_repr(theirs.get(k), 24)} there, {mine[k]} now)"
            if k in ("population", "seed")
            else k
            for k in different
        )
        raise OptimizeError(
            f"--out {path.parent}: holds an optimisation of another spec or "
            f"options (different {what}); run with what it was started with "
            "(only --generations may change) or use another --out"
        )


def _check_fields(path, data: dict, problem) -> None:
    """Every field's type and shape: the candidates P lists of n finite numbers, the costs
    P numbers, the timings objects of numbers."""
    extra = sorted(set(data) - set(KEYS))
    missing = [k for k in KEYS if k not in data]
    if extra or missing:
        raise _malformed(
            path, f"unknown key {short_repr(extra[0])}" if extra else f"no {missing[0]}"
        )
    population, n = problem.spec.budget.population, len(problem.space.names)
    generations = data["generations"]
    if not isinstance(generations, list):
        raise _malformed(path, "generations is not a list")
    for g, told in enumerate(generations, start=1):
        where = f"generations[{g - 1}]"
        if not isinstance(told, dict) or sorted(told) != ["candidates", "costs"]:
            raise _malformed(path, f"{where} is not {{candidates, costs}}")
        _check_candidates(path, f"{where}.candidates", told["candidates"], population, n)
        costs = told["costs"]
        if (
            not isinstance(costs, list)
            or len(costs) != population
            or not all(_is_number(c) for c in costs)
        ):
            raise _malformed(path, f"{where}.costs is not a list of {population} numbers")
    if data["pending"] is not None:
        _check_candidates(path, "pending", data["pending"], population, n)
    if not isinstance(data["generator"], dict):
        raise _malformed(path, "generator is not an object")
    wall = data["wall_time_s"]
    if not _is_number(wall) or not math.isfinite(wall) or wall < 0:
        raise _malformed(path, f"wall_time_s {short_repr(wall)} is not a time >= 0")
    timings = data["timings"]
    if not isinstance(timings, list) or len(timings) > len(generations):
        raise _malformed(path, "timings is not a list of one object per told generation")
    for i, t in enumerate(timings):
        if (
            not isinstance(t, dict)
            or set(t) != set(TIMING_KEYS)
            or not all(_of_type(t[k], kind) for k, kind in TIMING_KEYS.items())
        ):
            raise _malformed(path, f"timings[{i}] is not {{{', '.join(TIMING_KEYS)}}} of numbers")


def _is_number(value) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def _of_type(value, kind) -> bool:
    if kind is bool:
        return isinstance(value, bool)
    if kind is int:
        return isinstance(value, int) and not isinstance(value, bool)
    return _is_number(value)


def _check_candidates(path, where: str, candidates, population: int, n: int) -> None:
    ok = (
        isinstance(candidates, list)
        and len(candidates) == population
        and all(
            isinstance(x, list)
            and len(x) == n
            and all(_is_number(v) and math.isfinite(v) for v in x)
            for x in candidates
        )
    )
    if not ok:
        raise _malformed(path, f"{where} is not {population} lists of {n} finite numbers")


def _replay(path, data: dict, problem) -> SearchState:
    """CMA-ES rebuilt from the spec and the saved asks and tells (module docstring)."""
    state = new_search(problem)
    asks = [
        (g, told["candidates"], told["costs"])
        for g, told in enumerate(data["generations"], start=1)
    ]
    if data["pending"] is not None:
        asks.append((len(asks) + 1, data["pending"], None))
    for generation, candidates, costs in asks:
        state.stop()  # as the search does before each ask
        state.ask()
        assert state.pending is not None  # just asked
        if len(state.pending) != len(candidates) or any(
            np.asarray(saved, dtype=float).tobytes() != x.tobytes()
            for saved, x in zip(candidates, state.pending)
        ):
            raise OptimizeError(
                _no_replay(
                    path, data, f"generation {generation}'s candidates differ from the saved ones"
                )
            )
        if costs is not None:
            state.tell(costs)
    if state.normal.rng.bit_generator.state != data["generator"]:
        raise OptimizeError(
            _no_replay(path, data, "the normal generator ends in another state than the saved one")
        )
    state.wall_time_s = float(data["wall_time_s"])
    state.timings = [dict(t) for t in data["timings"]]
    return state


def _plain(value, limit: int) -> str:
    """A text as it is (one line, cut to ``limit``), any other value as ``short_repr``."""
    if not isinstance(value, str):
        return short_repr(value, limit)
    text = " ".join(value[: 4 * limit].split())
    return text if len(text) <= limit else text[: limit - 3] + "..."


def _no_replay(path, data: dict, what: str) -> str:
    theirs = data.get("versions")
    if not isinstance(theirs, dict):
        theirs = {}
    here = _versions()
    made = ", ".join(f"{k} {_plain(theirs.get(k), 24)}" for k in here)
    now = ", ".join(f"{k} {v}" for k, v in here.items())
    return (
        f"{path}: does not replay: {what} (written with {made}; this is {now}); continue "
        "it where it was made or use another --out"
    )
