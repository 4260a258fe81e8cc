"""Keys the scenario no longer has, still read from files, data and dotted overrides, each
translated to the one way that replaced it (deprecated; CHANGELOG.md says when they go):

* ``water.current: V``, a constant current [m/s]: the constant is the schedule's one-key
  case, ``water.current_schedule: [{time: 0, velocity: V}]`` (V zero: no key, still water).
  As before, a non-zero ``current`` beside a schedule of several keys (in the same layer,
  or one it layers onto) is refused: they are exclusive; a zero one beside it is ignored.
* ``transition.blend`` and ``transition.z_t``, which shaped the default behaviour tree:
  the tree itself, ``control.behaviour_tree.default_tree(blend, z_t)`` as
  ``transition.tree`` (``potential`` and 1, Eq. 12: the default tree, no tree given). A
  layer naming one of them starts from the blend and z_t of the tree it layers onto; beside
  another tree they are refused unless they say Eq. (12), as before.

``translate`` rewrites one layer's data before its keys are checked; the messages name the
old keys, as they did.
"""

import copy

from manta_drake.config_io import ScenarioError, check_keys, check_number, check_vector
from manta_drake.control.behaviour_tree import default_tree, default_tree_parameters
from manta_drake.control.transition import BLENDS
from manta_drake.station.current import MAX_SPEED

# dotted key -> (attribute path, type): settable as overrides (``--set water.current=...``).
LEGACY_KEYS = {
    "water.current": (["water", "current"], list[float]),
    "transition.blend": (["transition", "blend"], str),
    "transition.z_t": (["transition", "z_t"], float),
}
EQ12 = ("potential", 1.0)


def translate(data: dict, base) -> tuple[dict, dict | None]:
    """One layer's ``data`` (a scenario mapping) with the legacy keys rewritten for the
    ``base`` scenario it layers onto.

    Returns:
        (data, tree): the data without legacy keys (a copy when it had any), and the
        behaviour tree to set whole after the layer (None: the layer sets none).

    Raises:
        ScenarioError: a legacy value of the wrong type or out of range, or one that
            contradicts the schedule or the tree beside it (naming the legacy key).
    """
    water, transition = data.get("water"), data.get("transition")
    has_current = isinstance(water, dict) and "current" in water
    has_tree_keys = isinstance(transition, dict) and ("blend" in transition or "z_t" in transition)
    if not (has_current or has_tree_keys):
        return data, None
    data = copy.copy(data)
    if isinstance(water, dict) and has_current:
        data["water"] = _current(dict(water), base)
    tree = None
    if isinstance(transition, dict) and has_tree_keys:
        data["transition"], tree = _tree(dict(transition), base)
    return data, tree


def _current(water: dict, base) -> dict:
    value = water.pop("current")
    check_keys(value, list[float], "scenario.water.current")
    if isinstance(value, list):
        value = [float(v) if isinstance(v, int) and not isinstance(v, bool) else v for v in value]
    check_vector("water.current", value, 3, bound=MAX_SPEED, unit=" m/s")
    given = "current_schedule" in water
    keys = water["current_schedule"] if given else base.water.current_schedule
    if not given and len(keys) <= 1:
        keys = []  # the base's current is a constant (or none): this one replaces it
        water["current_schedule"] = keys
    if all(v == 0.0 for v in value):
        return water  # a zero current beside a schedule is no constant
    if keys:
        raise ScenarioError(
            f"water.current: {value!r} is set beside water.current_schedule; they are "
            "exclusive (the schedule replaces the constant: make it a key of the schedule, "
            "or clear the schedule with water.current_schedule: [])"
        )
    water["current_schedule"] = [{"time": 0.0, "velocity": value}]
    return water


def _tree(transition: dict, base) -> tuple[dict, dict | None]:
    given = {k: transition.pop(k) for k in ("blend", "z_t") if k in transition}
    if "blend" in given:
        check_keys(given["blend"], str, "scenario.transition.blend")
        if given["blend"] not in BLENDS:
            raise ScenarioError(
                f"transition.blend: {given['blend']!r} is not one of {', '.join(BLENDS)}"
            )
    if "z_t" in given:
        check_keys(given["z_t"], float, "scenario.transition.z_t")
        check_number("transition.z_t", given["z_t"])
        given["z_t"] = float(given["z_t"])
        if not 0.0 < given["z_t"] <= 1.0:
            raise ScenarioError(f"transition.z_t: {given['z_t']} is outside (0, 1]")
    beside = transition.get("tree") or None
    shaped = default_tree_parameters(base.behaviour_nodes()) if beside is None else None
    if shaped is None:  # another tree: here, or the one the layer goes onto
        for field, default in zip(("blend", "z_t"), EQ12):
            if field in given and given[field] != default:
                raise ScenarioError(
                    f"transition.{field}: {given[field]!r} is set beside transition.tree; "
                    "a tree gives each node's weight and full_at itself (blend and z_t "
                    "shape the default tree only)"
                )
        return transition, None
    blend, z_t = given.get("blend", shaped[0]), given.get("z_t", shaped[1])
    return transition, {} if (blend, z_t) == EQ12 else default_tree(blend, z_t)
