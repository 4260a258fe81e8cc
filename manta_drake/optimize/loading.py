"""Reading an optimisation spec: ``load_problem`` checks every field of the file and the
command line's overrides, resolves the scenario, the start gait and every robustness and
held-out point, and returns the ``Problem`` the run works on. Nothing is simulated; every
refusal is one line naming the spec file and the field (``spec.yaml: optimize.free[1].tie[0]:
...``) or the option."""

from __future__ import annotations

import copy
import dataclasses as dc
import hashlib
import json
import pathlib
import re
import tempfile

from manta_drake.config_io import (
    ScenarioError,
    check_in_range,
    check_integer,
    load_yaml_mapping,
    short_repr,
)
from manta_drake.control.gait_files import RESERVED_NAMES
from manta_drake.optimize.evaluate import candidate_overrides
from manta_drake.optimize.objective import METRICS, STEADY_METRICS, needed_metrics
from manta_drake.optimize.parameters import (
    ParameterSpace,
    build_parameters,
    candidate_gait_text,
)
from manta_drake.optimize.spec import (
    Budget,
    Constraint,
    FreeEntry,
    Front,
    HeldOut,
    Objective,
    OptimizeError,
    OptimizeSpec,
    Robustness,
    Term,
)
from manta_drake.scenario import (
    Scenario,
    anchored_gait_files,
    find_scenario,
    load_scenario,
    scenario_yaml,
)
from manta_drake.simulate import MIN_STEADY_WINDOW
from manta_drake.sweep.config import check_config_keys, check_parameter_name
from manta_drake.sweep.plan import apply_overrides

ROOT = "optimize"
# Fields of OptimizeSpec the loader sets, never the file.
NOT_IN_FILE = ("folder", "path", "text_sha256")
# Scenario keys the optimiser sets itself: refused in overrides and points.
RESERVED_KEYS = {
    "controller.gait": "the optimiser runs the candidate gait (the start gait is `gait`)",
    "random_seed": "the seeds are robustness.seeds",
    "duration": "use budget.duration (or --duration)",
    "steady_after": "use budget.steady_after",
}
AGGREGATES = ("mean", "worst")
MAX_GENERATIONS = 100_000
MAX_POPULATION = 10_000
_NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_]*\Z")


@dc.dataclass
class Problem:
    """A checked spec with what every evaluation starts from.

    Attributes:
        spec: the spec, command-line overrides applied.
        base: the resolved base scenario (overrides, budget's duration and steady_after,
            no Meshcat); every evaluation layers its candidate and point on it.
        base_yaml: ``base`` as the text a worker loads.
        space: the free parameters around the start gait.
        set_stance: the X matrix is free, so each run starts in its candidate's stance.
        sets: the ``--set`` overrides (also in ``base``).
    """

    spec: OptimizeSpec
    base: Scenario
    base_yaml: str
    space: ParameterSpace
    set_stance: bool
    sets: dict = dc.field(default_factory=dict)

    def identity(self) -> dict:
        """What an output folder's evaluations depend on: a restart must match it. The
        spec's content (not ``budget.generations``, which a restart may raise), the
        resolved scenario, the population and the seed."""
        content = spec_content(self.spec)
        for key in ("generations", "population"):  # generations may change; population
            content["budget"].pop(key)  # and seed are compared apart
        content.pop("seed")
        return {
            "spec": _sha(json.dumps(content, sort_keys=True, default=str)),
            "scenario": _sha(self._portable_yaml()),
            "population": self.spec.budget.population,
            "seed": self.spec.seed,
            "parameters": self.space.names,
        }

    def _portable_yaml(self) -> str:
        """``base_yaml`` with each gait file named by its content's SHA-256 instead of its
        absolute path: a checkout moved elsewhere restarts its searches, an edited gait file
        does not."""
        files = self.base.controller.gait_files
        if not any(pathlib.Path(f).is_absolute() for f in files):
            return self.base_yaml
        base = copy.deepcopy(self.base)
        base.controller.gait_files = [
            f"sha256:{_sha(pathlib.Path(f).read_text())}" if pathlib.Path(f).is_absolute() else f
            for f in files
        ]
        return scenario_yaml(base)


def _sha(text: str) -> str:
    return hashlib.sha256(text.encode()).hexdigest()


def spec_content(spec: OptimizeSpec) -> dict:
    """The spec's fields as plain data (not where it is)."""
    data = dc.asdict(spec)
    for key in NOT_IN_FILE:
        data.pop(key)
    return data


def _build(data: dict, path: pathlib.Path, text: str) -> OptimizeSpec:
    check_config_keys(data, OptimizeSpec, ROOT, NOT_IN_FILE, OptimizeError)
    obj = data.get("objective") or {}
    return OptimizeSpec(
        name=data.get("name") or path.stem,
        description=data.get("description", ""),
        scenario=data.get("scenario", ""),
        gait=data.get("gait", ""),
        overrides=dict(data.get("overrides") or {}),
        free=[FreeEntry(**f) for f in data.get("free") or []],
        objective=Objective(
            terms=[Term(**t) for t in obj.get("terms") or []],
            constraints=[Constraint(**c) for c in obj.get("constraints") or []],
            **{k: v for k, v in obj.items() if k not in ("terms", "constraints")},
        ),
        robustness=Robustness(**(data.get("robustness") or {})),
        held_out=HeldOut(**(data.get("held_out") or {})),
        budget=Budget(**(data.get("budget") or {})),
        front=Front(**(data.get("front") or {})),
        seed=data.get("seed", 0),
        folder=path.resolve().parent,
        path=path.resolve(),
        text_sha256=_sha(text),
    )


def load_problem(
    path,
    sets: dict | None = None,
    generations: int | None = None,
    population: int | None = None,
    duration: float | None = None,
    seed: int | None = None,
    steady_after: float | None = None,
) -> Problem:
    """Loads and checks an optimisation spec; simulates nothing.

    Args:
        path: the spec file.
        sets: ``--set`` overrides (dotted scenario keys), layered over the spec's
            ``overrides``.
        generations, population, duration, steady_after: replace the spec's ``budget``
            entries.
        seed: replaces the spec's ``seed``.

    Raises:
        OptimizeError: one line naming the spec file and the field, or the option (module
            docstring).
    """
    path = pathlib.Path(path)
    data, text = load_yaml_mapping(path, "optimisation spec", OptimizeError)
    try:
        return _load(path, data, text, sets, generations, population, duration, seed, steady_after)
    except OptimizeError as e:
        if str(e).startswith(f"{ROOT}."):  # a field of the file: name the file
            raise OptimizeError(f"{path}: {e}") from None
        raise


def _load(
    path: pathlib.Path,
    data: dict,
    text: str,
    sets,
    generations,
    population,
    duration,
    seed,
    steady_after=None,
) -> Problem:
    spec = _build(data, path, text)
    budget = spec.budget
    for option, field, value in (
        ("--generations", "generations", generations),
        ("--population", "population", population),
        ("--duration", "duration", duration),
        ("--steady-after", "steady_after", steady_after),
    ):
        if value is not None:
            _check_budget_value(option, field, value)
            setattr(budget, field, value)
    if seed is not None:
        check_integer("--seed", seed, 0, 2**32 - 1, error=OptimizeError)
        spec.seed = seed
    return validate(spec, dict(sets or {}))


def _check_budget_value(where: str, field: str, value) -> None:
    if field == "generations":
        check_integer(where, value, 1, MAX_GENERATIONS, error=OptimizeError)
    elif field == "population":
        check_integer(where, value, 2, MAX_POPULATION, error=OptimizeError)
    elif field == "sigma0":
        check_in_range(
            where,
            value,
            0.0,
            1.0,
            "(0, 1] (a fraction of each bound's width)",
            open_low=True,
            error=OptimizeError,
        )
    elif field == "duration":
        if value is not None:
            check_in_range(
                where, value, 0.0, 3600.0, "(0, 3600] s", open_low=True, error=OptimizeError
            )
    elif field in ("steady_after", "min_window") and value is not None:
        check_in_range(where, value, 0.0, 3600.0, "[0, 3600] s", error=OptimizeError)


def _check_keys_of(point, where: str, setup: bool = False) -> None:
    """The keys of overrides (``setup``: the scenario's own gait files and visualisation
    may be set) or of a robustness or held-out point."""
    if not isinstance(point, dict):
        raise OptimizeError(f"{where}: expected a mapping of dotted scenario keys to values")
    for key in point:
        try:
            check_parameter_name(key, {}, f"{where}.{key}")
        except ScenarioError as e:
            raise OptimizeError(str(e)) from None
        if key in RESERVED_KEYS:
            raise OptimizeError(f"{where}.{key}: set by the optimiser ({RESERVED_KEYS[key]})")
        if not setup and (key == "controller.gait_files" or key.startswith("visualization.")):
            raise OptimizeError(f"{where}.{key}: not a robustness parameter (set it in overrides)")


def _seeds(seeds, where: str) -> None:
    if not isinstance(seeds, list) or not seeds:
        raise OptimizeError(f"{where}: expected a list of one or more seeds")
    for i, s in enumerate(seeds):
        check_integer(f"{where}[{i}]", s, 0, 2**32 - 1, error=OptimizeError)
    if len(set(seeds)) != len(seeds):
        raise OptimizeError(f"{where}: {seeds} names a seed twice")


def _metric(name, where: str) -> None:
    if name not in METRICS:
        raise OptimizeError(f"{where}: {name!r} is not a metric; allowed: {', '.join(METRICS)}")


def _scenario_path(spec: OptimizeSpec) -> pathlib.Path:
    """The scenario file the spec names (relative to the spec's folder, or shipped)."""
    where = f"{ROOT}.scenario"
    if not isinstance(spec.scenario, str) or not spec.scenario.strip():
        raise OptimizeError(
            f"{where}: name a scenario (a shipped name such as "
            "locomotion_walk, or a path relative to the spec file)"
        )
    candidate = spec.folder / spec.scenario
    try:
        if candidate.is_file():
            return candidate
        return find_scenario(spec.scenario)
    except ScenarioError as e:
        raise OptimizeError(
            f"{where}: {short_repr(spec.scenario)} is neither a file "
            f"(relative to {spec.folder}) nor a shipped scenario; "
            f"{_after_path(str(e), spec.scenario)}"
        ) from None
    except (OSError, ValueError) as e:  # a name too long for a path, a NUL byte
        raise OptimizeError(
            f"{where}: {short_repr(spec.scenario)} is not a path "
            f"({short_repr(' '.join(str(e).split()), 60)})"
        ) from None


def _after_path(message: str, path) -> str:
    """A scenario message without its leading path (the caller names the file)."""
    message = " ".join(message.split())
    for prefix in (f"{path}: ", f"scenario file not found: {path} "):
        if message.startswith(prefix):
            return message[len(prefix) :].strip("() ")
    return message


def _anchored(overrides: dict, folder: pathlib.Path) -> dict:
    """``overrides`` with the gait files it names relative to ``folder`` (the spec's), as a
    scenario file's are relative to its own folder."""
    files = overrides.get("controller.gait_files")
    if not isinstance(files, list):
        return dict(overrides)
    return {**overrides, "controller.gait_files": anchored_gait_files(files, folder)}


def _load_scenario_file(spec: OptimizeSpec, path: pathlib.Path) -> Scenario:
    """The scenario the spec names, alone; the file and then its content checked, each
    refusal naming ``scenario``, what the spec says and the file it resolved to."""
    named = f"{ROOT}.scenario: {short_repr(spec.scenario)} ({path.resolve()})"
    try:
        load_yaml_mapping(path, "scenario")
    except ScenarioError as e:
        raise OptimizeError(
            f"{named} is not a scenario file: {_after_path(str(e), path)}"
        ) from None
    try:
        return load_scenario(path)
    except ScenarioError as e:
        raise OptimizeError(f"{named}: {_after_path(str(e), path)}") from None


def _check_steady_window(spec: OptimizeSpec, base: Scenario) -> None:
    """When the objective needs a steady-window metric: the runs' window (``simulate.run``'s:
    from steady_after, at most half the run, to its end) must start at steady_after (a run
    shorter than twice steady_after would start it at half the run, before the settling the
    spec assumes: refused, not halved silently) and last at least ``MIN_STEADY_WINDOW``
    (else every simulation would be unscored)."""
    front = [spec.front.maximise, spec.front.minimise] if spec.front else []
    steady = [m for m in needed_metrics(spec.objective) + front if m in STEADY_METRICS]
    duration, after = base.duration, base.steady_after
    window = duration - min(after, 0.5 * duration)
    if not steady or (after <= 0.5 * duration and window >= MIN_STEADY_WINDOW):
        return
    source = [
        "" if getattr(spec.budget, f) is not None else " (the scenario's)"
        for f in ("duration", "steady_after")
    ]
    need = max(2.0 * after, after + MIN_STEADY_WINDOW, 2 * MIN_STEADY_WINDOW)
    given = (
        f"{ROOT}.budget: duration {duration:g} s{source[0]} and steady_after {after:g} s{source[1]}"
    )
    if after > 0.5 * duration:
        raise OptimizeError(
            f"{given}: the run is under twice steady_after, so the objective's {steady[0]} "
            f"would be averaged from half the run, {0.5 * duration:g} s, before the settling "
            f"steady_after assumes; set duration to at least {need:g} s (or lower "
            f"steady_after)"
        )
    raise OptimizeError(
        f"{given} leave a steady window of {window:g} s, under the {MIN_STEADY_WINDOW:g} s "
        f"the objective's {steady[0]} needs: every simulation would be unscored; set "
        f"duration to at least {need:g} s"
    )


def _check_min_window(spec: OptimizeSpec, base: Scenario) -> None:
    """``budget.min_window`` within what a run that meets no wall gives: from the shortest
    window a mean is reported over to the whole window, duration - steady_after."""
    wanted = spec.budget.min_window
    if wanted is None:
        return
    after = min(base.steady_after, 0.5 * base.duration)  # where simulate.run starts it
    window = base.duration - after
    check_in_range(
        f"{ROOT}.budget.min_window",
        wanted,
        MIN_STEADY_WINDOW,
        window,
        f"[{MIN_STEADY_WINDOW:g}, {window:g}] s (at most the runs' steady window, duration "
        f"{base.duration:g} s from steady_after {after:g} s)",
        error=OptimizeError,
    )


def validate(spec: OptimizeSpec, sets: dict | None = None) -> Problem:
    """Checks a spec (every field, in file order) and resolves its scenario and points."""
    sets = dict(sets or {})
    if not isinstance(spec.name, str) or not _NAME.match(spec.name) or spec.name in RESERVED_NAMES:
        raise OptimizeError(
            f"{ROOT}.name: {spec.name!r} is not a gait name (letters, digits "
            "and _, not starting with a digit; not 'zero')"
        )
    scenario_path = _scenario_path(spec)
    _check_keys_of(spec.overrides, f"{ROOT}.overrides", setup=True)
    _check_keys_of(sets, "--set", setup=True)
    for field in ("generations", "population", "sigma0", "duration", "steady_after", "min_window"):
        _check_budget_value(f"{ROOT}.budget.{field}", field, getattr(spec.budget, field))
    check_integer(f"{ROOT}.seed", spec.seed, 0, 2**32 - 1, error=OptimizeError)
    # The base scenario: the file, the spec's overrides, --set, the budget's times.
    extra = {**_anchored(spec.overrides, spec.folder), **sets}
    if spec.budget.duration is not None:
        extra["duration"] = spec.budget.duration
    if spec.budget.steady_after is not None:
        extra["steady_after"] = spec.budget.steady_after
    scenario = _load_scenario_file(spec, scenario_path)
    try:
        base = apply_overrides(scenario, extra)
    except ScenarioError as e:
        raise OptimizeError(
            f"{ROOT}.overrides, --set or budget: {' '.join(str(e).split())}"
        ) from None
    base.visualization.meshcat = False
    if base.controller.mode != "gait":
        raise OptimizeError(
            f"{ROOT}.scenario: {scenario_path.name} has controller.mode "
            f"{base.controller.mode!r}; a gait is optimised with the CPG "
            "running it (set overrides: {controller.mode: gait})"
        )
    library = base.gaits()
    if spec.gait not in library:
        raise OptimizeError(
            f"{ROOT}.gait: {spec.gait!r} is not a gait of the scenario's "
            f"library; known gaits: {', '.join(library)}"
        )
    if spec.name in library:
        raise OptimizeError(
            f"{ROOT}.name: {spec.name!r} is already a gait of the scenario's "
            "library; the result needs a name of its own"
        )
    parameters = build_parameters(spec.free, f"{ROOT}.free")
    space = ParameterSpace(parameters, base.gait(spec.gait))
    outside = space.outside_bounds()
    if outside:
        i, bound, text = outside[0]
        raise OptimizeError(f"{ROOT}.free[{i}].{bound}: {text}; widen the bounds")
    off = space.off_ties()
    if off:
        i, field, text = off[0]
        raise OptimizeError(f"{ROOT}.free[{i}].{field}: {text}")
    _validate_front(spec)
    _validate_objective(spec.objective, front=bool(spec.front))
    _check_steady_window(spec, base)
    _check_min_window(spec, base)
    r = spec.robustness
    if not isinstance(r.points, list):
        raise OptimizeError(f"{ROOT}.robustness.points: expected a list of mappings")
    _seeds(r.seeds, f"{ROOT}.robustness.seeds")
    if r.aggregate not in AGGREGATES:
        raise OptimizeError(
            f"{ROOT}.robustness.aggregate: {r.aggregate!r} is not one of {', '.join(AGGREGATES)}"
        )
    if spec.held_out.seeds is not None:
        _seeds(spec.held_out.seeds, f"{ROOT}.held_out.seeds")
    set_stance = any(t.matrix == "X_deg" for p in parameters for t in p.targets)
    problem = Problem(spec, base, scenario_yaml(base), space, set_stance, sets)
    for group, points in (("robustness", r.points), ("held_out", spec.held_out.points)):
        seen = set()
        for i, point in enumerate(points):
            where = f"{ROOT}.{group}.points[{i}]"
            _check_keys_of(point, where)
            text = json.dumps(point, sort_keys=True, default=str)
            if text in seen:
                raise OptimizeError(f"{where}: the same point twice")
            seen.add(text)
            _check_point(problem, point, where)
    if not r.points:
        _check_point(problem, {}, f"{ROOT}.gait")
    return problem


def _check_point(problem: Problem, point: dict, where: str) -> None:
    """The start gait, as a candidate, resolves at ``point`` (values in range, the
    candidate's stance accepted)."""
    space = problem.space
    text = candidate_gait_text(problem.spec.name, space.gait(space.start_vector()))
    with tempfile.TemporaryDirectory(prefix="manta_opt_check_") as tmp:
        gait_path = pathlib.Path(tmp) / "gait.yaml"
        gait_path.write_text(text)
        task = {
            "overrides": point,
            "gait_name": problem.spec.name,
            "seed": 0,
            "set_stance": problem.set_stance,
        }
        try:
            apply_overrides(
                problem.base,
                candidate_overrides(task, gait_path, problem.base.controller.gait_files),
            )
        except ScenarioError as e:
            raise OptimizeError(f"{where}: {' '.join(str(e).split())}") from None


def _validate_front(spec: OptimizeSpec) -> None:
    """A front's metrics are metrics, its levels finite and increasing, and the objective
    leaves the terms to it."""
    f, where = spec.front, f"{ROOT}.front"
    if not isinstance(f.levels, list):
        raise OptimizeError(f"{where}.levels: expected a list of numbers")
    if not f.levels:
        return
    _metric(f.maximise, f"{where}.maximise")
    _metric(f.minimise, f"{where}.minimise")
    for i, level in enumerate(f.levels):
        check_in_range(f"{where}.levels[{i}]", level, -1e9, 1e9, "[-1e9, 1e9]", error=OptimizeError)
        if i and not level > f.levels[i - 1]:
            raise OptimizeError(
                f"{where}.levels[{i}]: {level!r} is not above the level "
                f"before it ({f.levels[i - 1]!r}); give them increasing"
            )
    if spec.objective.terms:
        raise OptimizeError(
            f"{ROOT}.objective.terms: a front minimises {f.minimise} at each "
            f"level of {f.maximise}; leave the terms out (keep constraints)"
        )


def _validate_objective(o: Objective, front: bool = False) -> None:
    where = f"{ROOT}.objective"
    if not o.terms and not front:
        raise OptimizeError(
            f"{where}.terms: name at least one term, e.g. {{metric: u, weight: -1.0}}"
        )
    for i, t in enumerate(o.terms):
        _metric(t.metric, f"{where}.terms[{i}].metric")
        check_in_range(
            f"{where}.terms[{i}].weight", t.weight, -1e9, 1e9, "[-1e9, 1e9]", error=OptimizeError
        )
        if t.weight == 0:
            raise OptimizeError(f"{where}.terms[{i}].weight: 0 makes the term do nothing")
    for i, c in enumerate(o.constraints):
        w = f"{where}.constraints[{i}]"
        _metric(c.metric, f"{w}.metric")
        if c.min is None and c.max is None:
            raise OptimizeError(f"{w}: give min, max or both")
        for key in ("min", "max"):
            value = getattr(c, key)
            if value is not None:
                check_in_range(f"{w}.{key}", value, -1e9, 1e9, "[-1e9, 1e9]", error=OptimizeError)
        if c.min is not None and c.max is not None and c.min > c.max:
            raise OptimizeError(f"{w}.min: {c.min!r} is above max ({c.max!r})")
        if c.relative_to:
            _metric(c.relative_to, f"{w}.relative_to")
            if c.relative_to == c.metric:
                raise OptimizeError(f"{w}.relative_to: {c.relative_to!r} is the metric itself")
        if c.scale is not None:
            check_in_range(
                f"{w}.scale", c.scale, 0.0, 1e9, "(0, 1e9]", open_low=True, error=OptimizeError
            )
    check_in_range(
        f"{where}.penalty_weight",
        o.penalty_weight,
        0.0,
        1e12,
        "(0, 1e12]",
        open_low=True,
        error=OptimizeError,
    )
    check_in_range(f"{where}.wall_cost", o.wall_cost, 0.0, 1e12, "[0, 1e12]", error=OptimizeError)
    check_in_range(
        f"{where}.failed_cost",
        o.failed_cost,
        0.0,
        1e15,
        "(0, 1e15]",
        open_low=True,
        error=OptimizeError,
    )
