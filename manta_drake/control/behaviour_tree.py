r"""Behaviours as a tree: the transition system's target psi_d, generalising Eq. (12).

A tree is a ``dict[str, BlendNode]`` whose top node is named ``root``. Each node reads one
modality m (a 0-1 estimate by its name, e.g. depth ``z_hat`` or wall ``s_hat``; the
package's modalities are ``manta_drake.modalities.ESTIMATES``) and blends its children,
each either another node or a gait (a leaf, a 64-vector R, X, Phi, Phi' in rad). The node's
coordinate is

.. math::  x = \min(\mathrm{clip}(m, 0, 1) / \mathrm{full\_at}, 1)

(a non-finite m counts as 0), so the blend is complete at m = ``full_at``. Two children
c0, c1 are blended by weights (w0, w1) of x:

* ``potential`` (Eq. 12's depth pair): a = pi/2 (x - 1), w0 = -sin(a), w1 = cos(a);
* ``cosine`` (Eq. 12's vision weight): w = (1 - cos(pi x)) / 2, (w0, w1) = (1 - w, w);
* ``linear`` (Eq. 11): (w0, w1) = (1 - x, x);
* ``normalised``: the potential's weights divided by their sum, -sin(a) / (cos(a) - sin(a))
  and cos(a) / (cos(a) - sin(a));
* ``switch``: (1, 0) or (0, 1): child 1 from x >= threshold + hysteresis / 2, child 0 below
  threshold - hysteresis / 2, and in between the child chosen before (hysteresis 0: no
  memory, child 1 exactly from x >= threshold).

Every weight reads ``full_at``; only ``switch`` reads ``threshold`` and ``hysteresis`` (unset:
0.5 and 0), and a node of another weight that sets either is refused.

The target is w0 c0 + w1 c1 (for ``linear`` computed as (c1 - c0) x + c0, for ``switch``
the chosen child), the way ``transition.target_params`` computes Eqs. (11)-(12): the
default trees (``default_tree``) give its targets bit for bit.

Why ``normalised`` exists: Eq. (12) as printed weights swim and the gait by -sin(a) and
cos(a), which sum to sqrt(2) at x = 1/2. The blend is then not convex, and a parameter
leaves the range between the two gaits (a fin keeps most of the swimming amplitude while
its bias moves toward the trot's). The normalised weights are a convex combination (each in
[0, 1], summing to 1) with the potential's shape, so every target lies entrywise between
its leaves' gait vectors.

A node with N > 2 children places child k at x_k = k / (N - 1); between x_k and x_{k+1}
children k and k+1 blend by the node's weight function of the local coordinate
u = (x - x_k) / (x_{k+1} - x_k) (for N = 2, u = x: the two-child formulas exactly). A
switch node with N children steps through them with the same rule on each interval; its
state is the index of the child it holds (0 or 1 for two children: off or on).

A node may be the child of several nodes (a shared subtree); the leaf weights sum over
every path. Cycles are refused.
"""

# No "from __future__ import annotations": yaml_load_typed reads BlendNode's field types.
import bisect
import dataclasses
import types
from collections.abc import Mapping

import numpy as np

from manta_drake.config_io import ScenarioError, short_repr
from manta_drake.model.robot_params import NUM_CPG_PARAMS

WEIGHT_FUNCTIONS = ("potential", "cosine", "linear", "normalised", "switch")
ROOT = "root"
# The most nodes on a path from the root to a gait: the shipped trees are 3 deep.
MAX_TREE_DEPTH = 32
# The fields only a switch reads, and their values when a switch leaves them unset.
SWITCH_DEFAULTS = {"threshold": 0.5, "hysteresis": 0.0}
# The gait names Eq. (12) blends: the surface gait, the floor gait, the floor gait at a wall.
DEFAULT_BEHAVIOURS = ("swim", "trot", "turning")


@dataclasses.dataclass
class BlendNode:
    """One node of a behaviour tree (a scenario's ``transition.tree`` entry).

    Attributes:
        modality: the estimate this node reads (its port's name).
        weight: its weight function, one of ``WEIGHT_FUNCTIONS``.
        children: names of other nodes or of gaits (leaves), at least 2.
        full_at: the modality value at which the blend is complete, in (0, 1]
            (for ``potential`` Eq. 12's z_t).
        threshold: ``switch`` only: child 1 from x >= threshold, in [0, 1]; None (unset):
            0.5.
        hysteresis: ``switch`` only: child 1 from x >= threshold + hysteresis / 2, child 0
            below threshold - hysteresis / 2, in [0, 1) (0: no memory); None (unset): 0.
    """

    modality: str = "z_hat"
    weight: str = "potential"
    children: list[str] = dataclasses.field(default_factory=list)
    full_at: float = 1.0
    threshold: float | None = None
    hysteresis: float | None = None


def switch_parameters(node: BlendNode) -> tuple[float, float]:
    """(threshold, hysteresis) of a switch node, the defaults where unset."""
    threshold = SWITCH_DEFAULTS["threshold"] if node.threshold is None else node.threshold
    hysteresis = SWITCH_DEFAULTS["hysteresis"] if node.hysteresis is None else node.hysteresis
    return threshold, hysteresis


def potential_weights(x: float) -> tuple[float, float]:
    """Eq. (12)'s depth pair: (-sin(a), cos(a)), a = pi/2 (x - 1)."""
    a = 0.5 * np.pi * (x - 1.0)  # the operations of transition.target_params, in its order
    return -np.sin(a), np.cos(a)


def pair_weights(weight: str, x: float) -> tuple[float, float]:
    """(w0, w1) of the continuous weight functions at x in [0, 1] (``switch`` has a state:
    see ``BehaviourTree``)."""
    if weight == "potential":
        return potential_weights(x)
    if weight == "normalised":
        w0, w1 = potential_weights(x)
        total = w0 + w1  # in [1, sqrt(2)]
        return w0 / total, w1 / total
    if weight == "cosine":
        w = 0.5 * (1.0 - np.cos(np.pi * x))  # transition.vision_weight's operations
        return 1.0 - w, w
    if weight == "linear":
        return 1.0 - x, x
    raise ValueError(
        f"weight: {weight!r} is not one of "
        f"{', '.join(w for w in WEIGHT_FUNCTIONS if w != 'switch')}"
    )


def default_tree(
    blend: str = "potential", z_t: float = 1.0, *, behaviours=DEFAULT_BEHAVIOURS
) -> dict[str, BlendNode]:
    """The tree whose target is ``transition.target_params(..., z_t, blend)``.

    Args:
        blend: ``transition.BLENDS``: potential (Eq. 12), normalised, linear (Eq. 11, which
            ignores z_t), switch (the gait from z_hat >= z_t / 2, the wall gait from
            s_hat >= 1/2).
        z_t: depth at which the change is complete, in (0, 1].
        behaviours: the surface, floor and wall gaits' names.
    """
    surface, floor, wall = behaviours
    gait = BlendNode("s_hat", "cosine", [floor, wall])
    if blend in ("potential", "normalised"):
        root = BlendNode("z_hat", blend, [surface, "gait"], full_at=z_t)
    elif blend == "linear":
        root = BlendNode("z_hat", "linear", [surface, "gait"], full_at=1.0)
    elif blend == "switch":
        root = BlendNode("z_hat", "switch", [surface, "gait"], full_at=1.0, threshold=0.5 * z_t)
        gait = BlendNode("s_hat", "switch", [floor, wall], threshold=0.5)
    else:
        raise ValueError(f"blend: {blend!r} is not one of potential, normalised, linear, switch")
    return {ROOT: root, "gait": gait}


def default_tree_parameters(nodes: Mapping[str, BlendNode]) -> tuple[str, float] | None:
    """``(blend, z_t)`` if ``nodes`` is ``default_tree(blend, z_t)`` (Eq. 12's family:
    swim, trot and turning; ``linear`` gives z_t 1, which it ignores), else None."""
    root = nodes.get(ROOT) if isinstance(nodes, Mapping) else None
    if not isinstance(root, BlendNode) or not isinstance(root.weight, str):
        return None
    if root.weight == "switch":
        z_t = 2.0 * root.threshold if isinstance(root.threshold, (int, float)) else None
    else:
        z_t = 1.0 if root.weight == "linear" else root.full_at
    if root.weight not in ("potential", "normalised", "linear", "switch") or not (
        isinstance(z_t, (int, float)) and 0.0 < z_t <= 1.0
    ):
        return None
    if dict(nodes) != default_tree(root.weight, z_t):
        return None
    return root.weight, float(z_t)


@dataclasses.dataclass(frozen=True)
class _Node:
    name: str
    modality: str
    weight: str
    full_at: float
    threshold: float
    hysteresis: float
    children: tuple  # of (is_node, node index or gait name)
    knots: tuple  # x_k = k / (N - 1)
    switch: int  # index into the switch state, -1 if not a switch


def _number(
    where: str,
    value,
    lo: float,
    hi: float,
    interval: str,
    open_hi: bool = False,
    open_lo: bool = False,
) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError):
        v = float("nan")
    ok = (
        np.isfinite(v)
        and (v > lo if open_lo else v >= lo)
        and (v < hi if open_hi else v <= hi)
        and not isinstance(value, bool)
    )
    if not ok:
        raise ScenarioError(f"{where}: {short_repr(value)} is not a finite number in {interval}")
    return v


def _check_node(
    name: str, node, nodes: Mapping, gaits: Mapping, modalities, tree: str = "tree"
) -> None:
    where = f"{tree}.{name}"
    if not isinstance(node, BlendNode):
        raise ScenarioError(f"{where}: expected a BlendNode, got {type(node).__name__}")
    if modalities is not None and node.modality not in modalities:
        raise ScenarioError(
            f"{where}.modality: {short_repr(node.modality)} is not one of {', '.join(modalities)}"
        )
    if not (isinstance(node.modality, str) and node.modality.isidentifier()):
        raise ScenarioError(
            f"{where}.modality: {short_repr(node.modality)} is not an "
            "estimate's name (an identifier, e.g. z_hat)"
        )
    if node.weight not in WEIGHT_FUNCTIONS:
        raise ScenarioError(
            f"{where}.weight: {short_repr(node.weight)} is not one of {', '.join(WEIGHT_FUNCTIONS)}"
        )
    if not isinstance(node.children, (list, tuple)):
        raise ScenarioError(
            f"{where}.children: expected a list of node or gait names, got "
            f"{type(node.children).__name__}"
        )
    if len(node.children) < 2:
        raise ScenarioError(f"{where}.children: needs at least 2, got {len(node.children)}")
    for k, child in enumerate(node.children):
        at = f"{where}.children[{k}]"
        if not isinstance(child, str):
            raise ScenarioError(f"{at}: {short_repr(child)} is not a name (of a node or a gait)")
        if child in nodes and child in gaits:
            raise ScenarioError(f"{at}: {short_repr(child)} is both a node and a gait; rename one")
        if child not in nodes and child not in gaits:
            raise ScenarioError(
                f"{at}: {short_repr(child)} is neither a node nor a gait "
                f"(gaits: {', '.join(gaits)})"
            )
    _number(f"{where}.full_at", node.full_at, 0.0, 1.0, "(0, 1]", open_lo=True)
    if node.weight != "switch":
        for field in SWITCH_DEFAULTS:
            if getattr(node, field) is not None:
                raise ScenarioError(
                    f"{where}.{field}: {short_repr(getattr(node, field))} is set on "
                    f"a {node.weight} node, which ignores it (only switch reads "
                    f"{' and '.join(SWITCH_DEFAULTS)}): leave it out"
                )
        return
    threshold, h = switch_parameters(node)
    threshold = _number(f"{where}.threshold", threshold, 0.0, 1.0, "[0, 1]")
    h = _number(f"{where}.hysteresis", h, 0.0, 1.0, "[0, 1)", open_hi=True)
    lo, hi = threshold - 0.5 * h, threshold + 0.5 * h
    if lo < 0.0 or hi > 1.0:
        raise ScenarioError(
            f"{where}.hysteresis: threshold {threshold:g} +- hysteresis/2 = "
            f"[{lo:g}, {hi:g}] is not inside [0, 1]"
        )


def _depth_first(nodes: Mapping[str, BlendNode], tree: str = "tree") -> list[str]:
    """Node names in first-seen depth-first order from the root; refuses a cycle and a tree
    more than ``MAX_TREE_DEPTH`` nodes deep (its longest path from the root, shared subtrees
    included). Iterative: a tree of any depth is refused without recursion, and every
    recursive walk of a compiled tree is at most ``MAX_TREE_DEPTH`` deep."""
    order, path = [ROOT], [ROOT]
    height: dict[str, int] = {}  # nodes on the longest path below
    pending = [iter(nodes[ROOT].children)]
    while pending:
        child = next(pending[-1], None)
        if child is None:  # every child of path[-1] done
            pending.pop()
            name = path.pop()
            height[name] = 1 + max(
                (height[c] for c in nodes[name].children if c in nodes), default=0
            )
            if len(path) + height[name] > MAX_TREE_DEPTH:
                _refuse_depth(nodes, path + [name], height, tree)
            continue
        if child not in nodes or child in height:
            continue
        if child in path:
            cycle = path[path.index(child) :] + [child]
            raise ScenarioError(f"{tree}.{' -> '.join(cycle)}: a cycle")
        if len(path) == MAX_TREE_DEPTH:
            _refuse_depth(nodes, path + [child], height, tree)
        order.append(child)
        path.append(child)
        pending.append(iter(nodes[child].children))
    return order


def _refuse_depth(
    nodes: Mapping[str, BlendNode], path: list, height: dict, tree: str = "tree"
) -> None:
    """Raises the depth error naming the node at level ``MAX_TREE_DEPTH + 1`` of a longest
    path through ``path`` (followed down by ``height``)."""
    while len(path) <= MAX_TREE_DEPTH:
        below = [c for c in nodes[path[-1]].children if c in height]
        path.append(max(below, key=height.__getitem__))
    raise ScenarioError(
        f"{tree}.{path[MAX_TREE_DEPTH]}: {MAX_TREE_DEPTH + 1} nodes deep from "
        f"root ({' -> '.join(path[:3])} -> ...); a tree may be at most "
        f"{MAX_TREE_DEPTH} nodes deep"
    )


def compile_tree(
    nodes: Mapping[str, BlendNode],
    gaits: Mapping[str, np.ndarray],
    modalities=None,
    where: str = "tree",
) -> "BehaviourTree":
    """Checks a tree and returns it compiled (immutable).

    Args:
        nodes: the tree, node name -> BlendNode; the top node is ``root``.
        gaits: gait name -> its 64-vector (R, X, Phi, Phi' in rad, ``GaitParams.to_vector()``).
        modalities: the estimates a node may read, in the order ``modalities`` lists them
            (a scenario passes ``manta_drake.modalities.ESTIMATES``); None: any name, in
            the order the tree first reads them.

        where: the tree's name in the messages (a scenario's ``transition.tree``).

    Raises:
        ScenarioError: one line naming the node and the field (``<where>.<node>.<field>``)
            or the gait (``gaits.<name>``).
    """
    if not isinstance(nodes, Mapping):
        raise ScenarioError(
            f"{where}: expected a mapping of node name -> BlendNode, got {type(nodes).__name__}"
        )
    if not isinstance(gaits, Mapping):
        raise ScenarioError(
            f"gaits: expected a mapping of gait name -> 64-vector, got {type(gaits).__name__}"
        )
    vectors = {}
    for name, vector in gaits.items():
        v = np.array(vector, dtype=float)
        if v.shape != (NUM_CPG_PARAMS,) or not np.all(np.isfinite(v)):
            raise ScenarioError(
                f"gaits.{name}: expected {NUM_CPG_PARAMS} finite values "
                f"(R, X, Phi, Phi' in rad), got shape {v.shape}"
            )
        v.flags.writeable = False
        vectors[name] = v
    if ROOT not in nodes:
        raise ScenarioError(f"{where}.root: missing (the tree's top node is named root)")
    for name, node in nodes.items():
        _check_node(name, node, nodes, vectors, modalities, where)
    order = _depth_first(nodes, where)
    for name in nodes:
        if name not in order:
            raise ScenarioError(f"{where}.{name}: not reachable from root")
    read = [nodes[n].modality for n in order]
    ordered = tuple(m for m in (modalities if modalities is not None else read) if m in read)
    return BehaviourTree(
        _PRIVATE, {n: nodes[n] for n in order}, vectors, tuple(dict.fromkeys(ordered))
    )


_PRIVATE = object()  # BehaviourTree is made by compile_tree only


class BehaviourTree:
    """A checked behaviour tree (``compile_tree``); immutable.

    ``target`` and ``leaf_weights`` take the estimates (modality -> value) and the switches'
    state and return the new state with the result: a switch with hysteresis remembers the
    child it holds, so a caller stepping in time passes the state back at the next step.
    """

    __slots__ = ("_blend_nodes", "_leaves", "_modalities", "_nodes", "_switch_nodes", "_vectors")
    _blend_nodes: Mapping[str, BlendNode]
    _leaves: tuple[str, ...]
    _modalities: tuple[str, ...]
    _nodes: tuple[_Node, ...]
    _switch_nodes: tuple[str, ...]
    _vectors: Mapping[str, np.ndarray]

    def __init__(
        self,
        key,
        nodes: dict[str, BlendNode],
        vectors: dict[str, np.ndarray],
        modalities: tuple[str, ...],
    ):
        if key is not _PRIVATE:
            raise TypeError("BehaviourTree: build one with compile_tree(nodes, gaits)")
        index = {name: i for i, name in enumerate(nodes)}  # depth-first: the root is 0
        compiled: list[_Node] = []
        switches: list[str] = []
        for name, node in nodes.items():
            children = tuple((c in index, index.get(c, c)) for c in node.children)
            n = len(children)
            threshold, hysteresis = switch_parameters(node)
            compiled.append(
                _Node(
                    name,
                    node.modality,
                    node.weight,
                    float(node.full_at),
                    float(threshold),
                    float(hysteresis),
                    children,
                    tuple(k / (n - 1) for k in range(n)),
                    len(switches) if node.weight == "switch" else -1,
                )
            )
            if node.weight == "switch":
                switches.append(name)
        leaves, visited = [], set()

        def visit(name):  # the gaits in first-seen depth-first order
            visited.add(name)  # a shared subtree once: its gaits are in leaves already
            for child in nodes[name].children:
                if child in index:
                    if child not in visited:
                        visit(child)
                elif child not in leaves:
                    leaves.append(child)

        visit(ROOT)
        set_ = object.__setattr__
        set_(self, "_nodes", tuple(compiled))
        set_(self, "_vectors", types.MappingProxyType({g: vectors[g] for g in leaves}))
        set_(self, "_leaves", tuple(leaves))
        set_(self, "_modalities", modalities)
        set_(self, "_switch_nodes", tuple(switches))
        set_(
            self,
            "_blend_nodes",
            types.MappingProxyType(
                {
                    name: dataclasses.replace(node, children=list(node.children))
                    for name, node in nodes.items()
                }
            ),
        )

    def __setattr__(self, name, value):
        raise AttributeError("BehaviourTree is immutable")

    @property
    def modalities(self) -> tuple[str, ...]:
        """The modalities the tree reads, in the order ``compile_tree`` was given."""
        return self._modalities

    @property
    def leaves(self) -> tuple[str, ...]:
        """The distinct gait names, in first-seen depth-first order."""
        return self._leaves

    @property
    def gait_vectors(self) -> dict[str, np.ndarray]:
        """Gait name -> its 64-vector (read-only), for every leaf."""
        return dict(self._vectors)

    @property
    def num_switches(self) -> int:
        """The number of switch nodes (the length of a switch state)."""
        return len(self._switch_nodes)

    @property
    def switch_nodes(self) -> tuple[str, ...]:
        """The switch nodes' names, depth first: switch_state[i] is the index of
        the child ``switch_nodes[i]`` holds."""
        return self._switch_nodes

    @property
    def nodes(self) -> dict[str, BlendNode]:
        """A copy of the tree it was compiled from (nodes in depth-first order)."""
        return {
            name: dataclasses.replace(node, children=list(node.children))
            for name, node in self._blend_nodes.items()
        }

    # -- evaluation -------------------------------------------------------------------------

    def _coordinates(self, values: Mapping[str, float]) -> list[float]:
        clipped = {}
        for m in self._modalities:
            try:
                v = values[m]
            except KeyError:
                raise ValueError(
                    f"values: missing {m!r} (the tree reads {', '.join(self._modalities)})"
                ) from None
            v = float(v)
            # target_params' operations in its order: clip, then min(z / z_t, 1).
            clipped[m] = float(np.clip(v, 0.0, 1.0)) if np.isfinite(v) else 0.0
        return [min(clipped[n.modality] / n.full_at, 1.0) for n in self._nodes]

    @staticmethod
    def _segment(node: _Node, x: float) -> tuple[int, float]:
        """The interval [x_k, x_k+1] holding x and the local coordinate u in [0, 1]."""
        knots = node.knots
        k = min(max(bisect.bisect_right(knots, x) - 1, 0), len(knots) - 2)
        u = (x - knots[k]) / (knots[k + 1] - knots[k])  # for N = 2: (x - 0) / 1 = x
        return k, min(max(u, 0.0), 1.0)

    @staticmethod
    def _switch(node: _Node, x: float, held: int, h: float) -> int:
        """The child a switch holds at x after holding ``held`` (h: its hysteresis)."""
        knots, n = node.knots, len(node.knots)

        def boundary(k, offset):  # between child k and k + 1
            return knots[k] + (node.threshold + offset) * (knots[k + 1] - knots[k])

        while held < n - 1 and x >= boundary(held, 0.5 * h):
            held += 1
        while held > 0 and x < boundary(held - 1, -0.5 * h):
            held -= 1
        return held

    def _switch_states(self, xs: list[float], switch_state) -> np.ndarray:
        switches = [n for n in self._nodes if n.switch >= 0]
        if switch_state is None:
            return np.array(
                [
                    self._switch(n, xs[i], 0, 0.0)
                    for i, n in enumerate(self._nodes)
                    if n.switch >= 0
                ],
                dtype=float,
            )
        held = np.asarray(switch_state, dtype=float).reshape(-1)
        if held.shape != (len(switches),):
            raise ValueError(
                f"switch_state: expected {len(switches)} values (one per switch "
                f"node), got shape {np.shape(switch_state)}"
            )
        out = np.empty(len(switches))
        for i, n in enumerate(self._nodes):
            if n.switch < 0:
                continue
            j = held[n.switch]
            if not (np.isfinite(j) and j == round(j) and 0 <= j < len(n.children)):
                raise ValueError(
                    f"switch_state[{n.switch}] ({n.name}): {float(j)!r} is not a "
                    f"child index in 0..{len(n.children) - 1}"
                )
            out[n.switch] = self._switch(n, xs[i], int(j), n.hysteresis)
        return out

    def _child_weights(self, node: _Node, x: float, state: np.ndarray) -> list[tuple[int, float]]:
        """(child position, weight) of the children the node's target uses."""
        if node.switch >= 0:
            return [(int(state[node.switch]), 1.0)]
        k, u = self._segment(node, x)
        w0, w1 = pair_weights(node.weight, u)
        return [(k, w0), (k + 1, w1)]

    def evaluate(self, values: Mapping[str, float], switch_state=None):
        """The target, the leaf weights and the new switch state in one pass.

        Args:
            values: modality -> estimate (at least ``modalities``); non-finite counts as 0,
                values are clipped to [0, 1].
            switch_state: the switch nodes' held children (``num_switches``); None: the
                threshold rule without memory (``initial_switch_state``).

        Returns:
            (psi_d (64,), leaf weights (len(leaves),), new switch state (num_switches,)).
        """
        xs = self._coordinates(values)
        state = self._switch_states(xs, switch_state)
        weights = [self._child_weights(n, x, state) for n, x in zip(self._nodes, xs)]
        vectors: dict[int, np.ndarray] = {}

        def child_vector(node, k):
            is_node, ref = node.children[k]
            return node_vector(ref) if is_node else self._vectors[ref]

        def node_vector(i):
            if i not in vectors:
                node, x = self._nodes[i], xs[i]
                (k0, w0), *rest = weights[i]
                if not rest:  # switch: the chosen child
                    vectors[i] = np.array(child_vector(node, k0), dtype=float)
                elif node.weight == "linear":  # Eq. (11) as target_params computes it
                    c0, c1 = child_vector(node, k0), child_vector(node, k0 + 1)
                    vectors[i] = (c1 - c0) * self._segment(node, x)[1] + c0
                else:
                    ((k1, w1),) = rest
                    vectors[i] = w0 * child_vector(node, k0) + w1 * child_vector(node, k1)
            return vectors[i]

        psi_d = node_vector(0)
        # Leaf weights: products along the paths, summed; nodes are in depth-first order,
        # so propagate in an order where every parent precedes its children.
        node_weight = np.zeros(len(self._nodes))
        node_weight[0] = 1.0
        leaf_weight = dict.fromkeys(self._leaves, 0.0)
        for i in self._topological():
            node = self._nodes[i]
            for k, w in weights[i]:
                is_node, ref = node.children[k]
                if is_node:
                    node_weight[ref] += node_weight[i] * w
                else:
                    leaf_weight[ref] += node_weight[i] * w
        return psi_d, np.array([leaf_weight[g] for g in self._leaves]), state

    def _topological(self) -> list[int]:
        """Node indices with every parent before its children (reverse post-order)."""
        done, post = set(), []

        def visit(i):
            done.add(i)
            for is_node, ref in self._nodes[i].children:
                if is_node and ref not in done:
                    visit(ref)
            post.append(i)

        visit(0)
        return post[::-1]

    def target(
        self, values: Mapping[str, float], switch_state: np.ndarray | None = None
    ) -> tuple[np.ndarray, np.ndarray]:
        """(psi_d (64,), new switch state): the tree's target for these values."""
        psi_d, _, state = self.evaluate(values, switch_state)
        return psi_d, state

    def leaf_weights(
        self, values: Mapping[str, float], switch_state: np.ndarray | None = None
    ) -> tuple[np.ndarray, np.ndarray]:
        """(weights (len(leaves),), new switch state): each gait's share of the target, the
        product of the node weights along its paths summed over its paths."""
        _, weights, state = self.evaluate(values, switch_state)
        return weights, state

    def initial_switch_state(self, values: Mapping[str, float]) -> np.ndarray:
        """The switches' held children for these values without memory (threshold rule)."""
        return self._switch_states(self._coordinates(values), None)

    def __repr__(self):
        return (
            f"BehaviourTree(nodes={list(self._blend_nodes)}, leaves={list(self._leaves)}, "
            f"modalities={list(self._modalities)})"
        )
