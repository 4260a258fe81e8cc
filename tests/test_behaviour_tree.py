"""Behaviour trees (control/behaviour_tree.py): the default trees are Eqs. (11)-(12) bit for
bit, the weight functions' closed forms, N-child nodes, switches with hysteresis, leaf
weights of a deeper tree, and every validation message."""

import dataclasses
import re

import numpy as np
import pytest

from manta_drake.control.behaviour_tree import (
    WEIGHT_FUNCTIONS,
    BlendNode,
    compile_tree,
    default_tree,
    pair_weights,
)
from manta_drake.control.gaits import GAITS
from manta_drake.control.transition import BLENDS, target_params
from manta_drake.modalities import ESTIMATES

NAMES = ("swim", "trot", "turning")
SWIM, TROT, TURN = (GAITS[n].to_vector() for n in NAMES)
GAIT3 = dict(zip(NAMES, (SWIM, TROT, TURN)))
# Random 64-vectors: leaves whose entries are all different (the pure maths does not care).
RNG = np.random.default_rng(7)
RANDOM = {name: RNG.uniform(-np.pi, np.pi, 64) for name in "ABCDE"}
GRID = [
    np.nan,
    np.inf,
    -np.inf,
    -0.5,
    0.0,
    1e-9,
    0.1,
    0.25,
    0.3,
    0.4,
    0.45,
    0.5,
    0.55,
    0.6,
    0.75,
    0.8,
    0.9,
    0.999,
    1.0,
    1.5,
]


def values(z=0.0, s=0.0, **more):
    return {"z_hat": z, "s_hat": s, **more}


# -- the default trees are target_params -------------------------------------------------


@pytest.mark.parametrize("blend", BLENDS)
@pytest.mark.parametrize("z_t", [1.0, 0.8, 0.5, 0.3])
def test_default_trees_are_target_params_bit_for_bit(blend, z_t):
    tree = compile_tree(default_tree(blend, z_t), GAIT3)
    assert tree.modalities == ("z_hat", "s_hat") and tree.leaves == NAMES
    for z in GRID + [0.5 * z_t, z_t, np.nextafter(0.5 * z_t, 0.0)]:
        for s in GRID:
            got, _ = tree.target(values(z, s))
            np.testing.assert_array_equal(
                got, target_params(z, s, SWIM, TROT, TURN, z_t, blend), err_msg=f"z={z} s={s}"
            )


def test_default_tree_equals_the_printed_eq12_and_its_leaf_weights():
    """Against Eq. (12) written out here (cos(pi z/2) = -sin(a), sin(pi z/2) = cos(a))."""
    tree = compile_tree(default_tree("potential", 1.0), GAIT3)
    for z in np.linspace(0.0, 1.0, 11):
        for s in np.linspace(0.0, 1.0, 5):
            w = (1.0 - np.cos(np.pi * s)) / 2
            expected = np.cos(np.pi * z / 2) * SWIM + np.sin(np.pi * z / 2) * (
                w * TURN + (1 - w) * TROT
            )
            np.testing.assert_allclose(tree.target(values(z, s))[0], expected, atol=1e-12)
            weights, _ = tree.leaf_weights(values(z, s))
            np.testing.assert_allclose(
                weights,
                [np.cos(np.pi * z / 2), np.sin(np.pi * z / 2) * (1 - w), np.sin(np.pi * z / 2) * w],
                atol=1e-15,
            )


def test_default_tree_names_other_gaits():
    tree = compile_tree(
        default_tree("linear", behaviours=("swim", "walk", "crab")),
        {n: GAITS[n].to_vector() for n in ("swim", "walk", "crab")},
    )
    assert tree.leaves == ("swim", "walk", "crab")
    np.testing.assert_allclose(
        tree.target(values(1.0, 1.0))[0], GAITS["crab"].to_vector(), atol=1e-12
    )


def test_a_tree_loads_with_yaml_load_typed():
    from pydrake.common.yaml import yaml_load_typed

    @dataclasses.dataclass
    class Config:
        tree: dict[str, BlendNode] = dataclasses.field(default_factory=dict)

    config = yaml_load_typed(
        schema=Config,
        data="""
tree:
  root: {modality: z_hat, weight: potential, children: [swim, gait], full_at: 0.8}
  gait: {modality: s_hat, weight: cosine, children: [trot, turning]}
""",
    )
    tree = compile_tree(config.tree, GAIT3)
    for z, s in [(0.3, 0.2), (0.7, 0.9), (1.0, 0.5)]:
        np.testing.assert_array_equal(
            tree.target(values(z, s))[0], target_params(z, s, SWIM, TROT, TURN, 0.8)
        )


# -- weight functions --------------------------------------------------------------------

X = np.linspace(0.0, 1.0, 201)


def test_weight_closed_forms():
    for x in X:
        np.testing.assert_allclose(
            pair_weights("cosine", x),
            ((1 + np.cos(np.pi * x)) / 2, (1 - np.cos(np.pi * x)) / 2),
            atol=1e-15,
        )
        assert pair_weights("linear", x) == (1 - x, x)
        np.testing.assert_allclose(
            pair_weights("potential", x), (np.cos(np.pi * x / 2), np.sin(np.pi * x / 2)), atol=1e-15
        )
    assert sum(pair_weights("potential", 0.5)) == pytest.approx(np.sqrt(2))


def test_normalised_weights_are_convex_with_the_potentials_ratio():
    for x in X:
        w0, w1 = pair_weights("normalised", x)
        assert abs(w0 + w1 - 1.0) <= 4.5e-16 and 0.0 <= w0 <= 1.0 and 0.0 <= w1 <= 1.0
        p0, p1 = np.cos(np.pi * x / 2), np.sin(np.pi * x / 2)
        np.testing.assert_allclose((w0, w1), (p0 / (p0 + p1), p1 / (p0 + p1)), atol=1e-15)


def test_normalised_target_stays_between_the_gaits_and_the_potential_does_not():
    lo, hi = np.minimum.reduce([SWIM, TROT, TURN]), np.maximum.reduce([SWIM, TROT, TURN])
    excess = {}
    for blend in ("normalised", "potential"):
        tree = compile_tree(default_tree(blend), GAIT3)
        excess[blend] = max(
            max(
                (tree.target(values(z, s))[0] - hi).max(), (lo - tree.target(values(z, s))[0]).max()
            )
            for z in X
            for s in (0.0, 0.3, 0.5, 1.0)
        )
    assert excess["normalised"] <= 1e-12
    assert excess["potential"] > 1.0  # rad: Eq. (12) as printed leaves the gaits' range


def test_n_children_at_their_points_and_between():
    for n in (3, 4, 5):
        leaves = list("ABCDE")[:n]
        for weight in ("cosine", "linear", "potential", "normalised"):
            tree = compile_tree({"root": BlendNode("z_hat", weight, leaves)}, RANDOM)
            for k in range(n):
                got = tree.target(values(k / (n - 1)))[0]
                if weight == "cosine" or (weight == "linear" and k < n - 1):
                    np.testing.assert_array_equal(got, RANDOM[leaves[k]])
                else:  # cos(pi/2) and (c1 - c0) + c0 are exact only to rounding
                    np.testing.assert_allclose(got, RANDOM[leaves[k]], atol=1e-14)
                assert tree.leaf_weights(values(k / (n - 1)))[0][k] == pytest.approx(1.0)
            for k in range(n - 1):
                for u in (0.2, 0.5, 0.9):
                    w0, w1 = pair_weights(weight, u)
                    c0, c1 = RANDOM[leaves[k]], RANDOM[leaves[k + 1]]
                    expected = w0 * c0 + w1 * c1
                    got = tree.target(values((k + u) / (n - 1)))[0]
                    np.testing.assert_allclose(got, expected, atol=1e-12)
                    weights = np.zeros(n)
                    weights[[k, k + 1]] = w0, w1
                    np.testing.assert_allclose(
                        tree.leaf_weights(values((k + u) / (n - 1)))[0], weights, atol=1e-12
                    )


def test_two_children_are_the_pair_formulas_and_full_at_scales_x():
    for weight in ("cosine", "linear", "potential", "normalised"):
        tree = compile_tree(
            {"root": BlendNode("flow_hat", weight, ["A", "B"], full_at=0.5)}, RANDOM
        )
        assert tree.modalities == ("flow_hat",)
        for m in (0.0, 0.1, 0.2, 0.35, 0.5, 0.8):
            x = min(m / 0.5, 1.0)
            w0, w1 = pair_weights(weight, x)
            np.testing.assert_allclose(
                tree.target({"flow_hat": m})[0], w0 * RANDOM["A"] + w1 * RANDOM["B"], atol=1e-12
            )


# -- switches ----------------------------------------------------------------------------


def _sweep(tree, xs, modality="z_hat"):
    held, out = tree.initial_switch_state({modality: xs[0]}), []
    for x in xs:
        weights, held = tree.leaf_weights({modality: x}, held)
        out.append(int(held[0]))
        assert weights[int(held[0])] == 1.0 and weights.sum() == 1.0
    return np.array(out)


def test_switch_hysteresis_turns_on_and_off_at_threshold_plus_minus_half():
    tree = compile_tree(
        {"root": BlendNode("z_hat", "switch", ["A", "B"], threshold=0.5, hysteresis=0.25)}, RANDOM
    )
    assert tree.num_switches == 1 and tree.switch_nodes == ("root",)
    up = np.arange(65) / 64  # exact binary fractions: 0.625 and 0.375 are grid points
    on = _sweep(tree, up)
    assert up[np.argmax(on == 1)] == 0.625 and np.all(on[up < 0.625] == 0)
    down = up[::-1]
    held = _sweep(tree, down)
    assert down[np.argmax(held == 0)] == 0.375 - 1 / 64 and np.all(held[down >= 0.375] == 1)
    # without memory the threshold rule
    assert tree.initial_switch_state({"z_hat": 0.5})[0] == 1.0
    assert tree.initial_switch_state({"z_hat": 0.49})[0] == 0.0
    np.testing.assert_array_equal(tree.target({"z_hat": 0.45}, [1.0])[0], RANDOM["B"])
    np.testing.assert_array_equal(tree.target({"z_hat": 0.45}, [0.0])[0], RANDOM["A"])


def test_switch_without_hysteresis_has_no_memory():
    tree = compile_tree({"root": BlendNode("z_hat", "switch", ["A", "B"], threshold=0.3)}, RANDOM)
    for x in GRID:
        for held in (0.0, 1.0):
            z = float(np.clip(x, 0, 1)) if np.isfinite(x) else 0.0
            assert tree.target({"z_hat": x}, [held])[1][0] == float(z >= 0.3), (x, held)


def test_three_child_switch_steps_through_with_hysteresis():
    tree = compile_tree(
        {"root": BlendNode("z_hat", "switch", ["A", "B", "C"], threshold=0.5, hysteresis=0.25)},
        RANDOM,
    )
    # knots 0, 1/2, 1: up at 0 + 0.625/2 and 1/2 + 0.625/2, down below 0.375/2 and 1/2 + 0.375/2
    up = np.arange(129) / 128
    held = _sweep(tree, up)
    assert up[np.argmax(held >= 1)] == 0.3125 and up[np.argmax(held == 2)] == 0.8125
    down = up[::-1]
    held = _sweep(tree, down)
    assert down[np.argmax(held <= 1)] == 0.6875 - 1 / 128
    assert down[np.argmax(held == 0)] == 0.1875 - 1 / 128


def test_switch_state_is_checked():
    tree = compile_tree(default_tree("switch"), GAIT3)
    assert tree.num_switches == 2 and tree.switch_nodes == ("root", "gait")
    with pytest.raises(ValueError, match=r"switch_state: expected 2 values"):
        tree.target(values(), [0.0])
    with pytest.raises(ValueError, match=r"switch_state\[1\] \(gait\): 2.0 is not a child index"):
        tree.target(values(), [0.0, 2.0])


# -- deeper trees ------------------------------------------------------------------------


def test_three_levels_four_leaves_weights_are_products_of_the_node_weights():
    nodes = {
        "root": BlendNode("z_hat", "cosine", ["A", "mid"]),
        "mid": BlendNode("s_hat", "linear", ["B", "low"]),
        "low": BlendNode("energy_hat", "cosine", ["C", "D"]),
    }
    tree = compile_tree(nodes, RANDOM)
    assert tree.modalities == ("z_hat", "s_hat", "energy_hat")
    assert tree.leaves == ("A", "B", "C", "D") and tree.num_switches == 0
    assert set(tree.gait_vectors) == {"A", "B", "C", "D"}
    v = values(0.5, 0.25, energy_hat=1 / 3)
    # by hand: root cosine at 1/2 -> (1/2, 1/2); mid linear at 1/4 -> (3/4, 1/4);
    # low cosine at 1/3 -> ((1 + cos(pi/3))/2, (1 - cos(pi/3))/2) = (3/4, 1/4)
    expected = [0.5, 0.5 * 0.75, 0.5 * 0.25 * 0.75, 0.5 * 0.25 * 0.25]
    weights, _ = tree.leaf_weights(v)
    np.testing.assert_allclose(weights, expected, atol=1e-15)
    assert weights.sum() == pytest.approx(1.0)
    np.testing.assert_allclose(
        tree.target(v)[0], sum(w * RANDOM[g] for w, g in zip(expected, "ABCD")), atol=1e-12
    )
    # convex nodes: the weights sum to 1 everywhere
    for z, s, e in RNG.uniform(0, 1, (50, 3)):
        assert tree.leaf_weights(values(z, s, energy_hat=e))[0].sum() == pytest.approx(1.0)
    # leaves in first-seen depth-first order: a subtree's gaits before a later sibling gait
    nested_first = compile_tree(
        {
            "root": BlendNode("z_hat", "linear", ["mid", "A"]),
            "mid": BlendNode("s_hat", "linear", ["B", "C"]),
        },
        RANDOM,
    )
    assert nested_first.leaves == ("B", "C", "A")
    with pytest.raises(ValueError, match=r"values: missing 'energy_hat'"):
        tree.target(values(0.5, 0.5))


def test_a_gait_on_several_leaves_and_a_shared_node_sum_their_paths():
    nodes = {
        "root": BlendNode("z_hat", "linear", ["A", "left", "right"]),
        "left": BlendNode("s_hat", "linear", ["shared", "A"]),
        "right": BlendNode("s_hat", "linear", ["shared", "C"]),
        "shared": BlendNode("flow_hat", "linear", ["B", "C"]),
    }
    tree = compile_tree(nodes, RANDOM)
    assert tree.leaves == ("A", "B", "C")
    z, s, f = 0.75, 0.4, 0.1  # root between left (k=1) and right (k=2): u = 0.5
    weights, _ = tree.leaf_weights(values(z, s, flow_hat=f))
    left, right = 0.5, 0.5
    shared = left * (1 - s) + right * (1 - s)
    np.testing.assert_allclose(
        weights, [left * s, shared * (1 - f), shared * f + right * s], atol=1e-15
    )


def test_potential_leaf_weights_exceed_one():
    tree = compile_tree(default_tree("potential"), GAIT3)
    assert tree.leaf_weights(values(0.5, 0.0))[0].sum() == pytest.approx(np.sqrt(2))
    tree = compile_tree(default_tree("normalised"), GAIT3)
    assert tree.leaf_weights(values(0.5, 0.7))[0].sum() == pytest.approx(1.0)


def test_the_compiled_tree_is_immutable():
    nodes = default_tree()
    tree = compile_tree(nodes, GAIT3)
    before = tree.target(values(0.5, 0.5))[0]
    nodes["gait"].children[1] = "swim"  # editing the source does not reach the compiled tree
    nodes["root"].full_at = 0.1
    np.testing.assert_array_equal(tree.target(values(0.5, 0.5))[0], before)
    with pytest.raises(AttributeError):
        tree.leaves = ()
    with pytest.raises(ValueError):
        tree.gait_vectors["swim"][0] = 1.0  # read-only
    tree.gait_vectors.clear()  # a copy
    assert set(tree.gait_vectors) == set(NAMES)


# -- validation --------------------------------------------------------------------------


def _tree(**changes):
    """The default tree with node fields changed: changes = {node: {field: value}}."""
    nodes = default_tree()
    for name, fields in changes.items():
        nodes[name] = dataclasses.replace(nodes[name], **fields)
    return nodes


def _switch(**fields):
    """The default tree with its gait node a switch with these fields."""
    return _tree(gait={"weight": "switch", **fields})


ERRORS = [
    (
        _tree(gait={"weight": "cubic"}),
        "tree.gait.weight: 'cubic' is not one of potential, cosine, linear, normalised, switch",
    ),
    (
        {"top": BlendNode(children=["swim", "trot"])},
        "tree.root: missing (the tree's top node is named root)",
    ),
    (
        {
            "root": BlendNode(children=["swim", "floor"]),
            "floor": BlendNode(children=["trot", "wlak"]),
        },
        "tree.floor.children[1]: 'wlak' is neither a node nor a gait (gaits: swim, trot, turning)",
    ),
    (_tree(gait={"children": ["trot"]}), "tree.gait.children: needs at least 2, got 1"),
    (_tree(gait={"children": "trot"}), "tree.gait.children: expected a list of node or gait"),
    (_tree(gait={"children": ["trot", 3]}), "tree.gait.children[1]: 3 is not a name"),
    (
        {
            "root": BlendNode(children=["swim", "trot"]),
            "trot": BlendNode(children=["swim", "trot"]),
        },
        "tree.root.children[1]: 'trot' is both a node and a gait",
    ),
    (
        {
            "root": BlendNode(children=["swim", "a"]),
            "a": BlendNode(children=["trot", "b"]),
            "b": BlendNode(children=["a", "turning"]),
        },
        "tree.a -> b -> a: a cycle",
    ),
    ({"root": BlendNode(children=["swim", "root"])}, "tree.root -> root: a cycle"),
    (
        {**default_tree(), "spare": BlendNode(children=["swim", "trot"])},
        "tree.spare: not reachable from root",
    ),
    (
        _tree(root={"modality": "depth"}),
        "tree.root.modality: 'depth' is not one of " + ", ".join(ESTIMATES),
    ),
    (_tree(root={"modality": 3}), "tree.root.modality: 3 is not one of"),
    (_tree(root={"full_at": 0.0}), "tree.root.full_at: 0.0 is not a finite number in (0, 1]"),
    (_tree(root={"full_at": 1.5}), "tree.root.full_at: 1.5 is not a finite number in (0, 1]"),
    (_tree(root={"full_at": np.nan}), "tree.root.full_at: nan is not a finite number"),
    (_switch(threshold=-0.1), "tree.gait.threshold: -0.1 is not a finite number in [0, 1]"),
    (_switch(threshold=1.1), "tree.gait.threshold: 1.1 is not a finite number in [0, 1]"),
    (_switch(threshold=np.inf), "tree.gait.threshold: inf is not a finite number"),
    (_switch(hysteresis=1.0), "tree.gait.hysteresis: 1.0 is not a finite number in [0, 1)"),
    (_switch(hysteresis=-0.1), "tree.gait.hysteresis: -0.1 is not a finite number"),
    (
        _switch(threshold=0.9, hysteresis=0.4),
        "tree.gait.hysteresis: threshold 0.9 +- hysteresis/2 = [0.7, 1.1] is not inside [0, 1]",
    ),
    (
        _switch(threshold=0.1, hysteresis=0.4),
        "tree.gait.hysteresis: threshold 0.1 +- hysteresis/2 = [-0.1, 0.3] is not inside [0, 1]",
    ),
    # only a switch reads threshold and hysteresis: set on another weight, refused
    (
        _tree(gait={"threshold": 0.5}),
        "tree.gait.threshold: 0.5 is set on a cosine node, which "
        "ignores it (only switch reads threshold and hysteresis): leave it out",
    ),
    (_tree(root={"hysteresis": 0.0}), "tree.root.hysteresis: 0.0 is set on a potential node"),
    (
        _tree(root={"weight": "linear", "threshold": 0.3}),
        "tree.root.threshold: 0.3 is set on a linear node",
    ),
    (
        _tree(root={"weight": "normalised", "threshold": 0.3}),
        "tree.root.threshold: 0.3 is set on a normalised node",
    ),
    ({"root": {"modality": "z_hat"}}, "tree.root: expected a BlendNode, got dict"),
]


@pytest.mark.parametrize("nodes, message", ERRORS, ids=[m[:40] for _, m in ERRORS])
def test_validation_messages(nodes, message):
    with pytest.raises(ValueError, match=re.escape(message)) as error:
        compile_tree(nodes, GAIT3, ESTIMATES)
    assert "\n" not in str(error.value)
    assert str(error.value).startswith("tree.")


def test_without_a_list_any_name_is_read_in_the_order_first_read():
    """compile_tree without modalities takes any estimate's name (a library user's own
    sensor) in depth-first order; a name that cannot be a port is refused."""
    nodes = {
        "root": BlendNode("my_sonar_hat", "linear", ["A", "gait"]),
        "gait": BlendNode("z_hat", "linear", ["B", "C"]),
    }
    tree = compile_tree(nodes, RANDOM)
    assert tree.modalities == ("my_sonar_hat", "z_hat")
    assert compile_tree(nodes, RANDOM, ("z_hat", "s_hat", "my_sonar_hat")).modalities == (
        "z_hat",
        "my_sonar_hat",
    )
    with pytest.raises(
        ValueError, match=re.escape("tree.root.modality: 'a b' is not an estimate's name")
    ):
        compile_tree({"root": BlendNode("a b", "linear", ["A", "B"])}, RANDOM)


def test_gait_vectors_are_checked():
    with pytest.raises(ValueError, match=re.escape("gaits.trot: expected 64 finite values")):
        compile_tree(default_tree(), {**GAIT3, "trot": np.zeros(10)})
    with pytest.raises(ValueError, match=re.escape("gaits.swim: expected 64 finite values")):
        compile_tree(default_tree(), {**GAIT3, "swim": np.full(64, np.nan)})


def test_every_weight_function_compiles():
    for weight in WEIGHT_FUNCTIONS:
        tree = compile_tree({"root": BlendNode("posture_hat", weight, ["A", "B"])}, RANDOM)
        assert tree.leaf_weights({"posture_hat": 1.0})[0] == pytest.approx([0.0, 1.0])
        assert tree.leaf_weights({"posture_hat": 0.0})[0] == pytest.approx([1.0, 0.0])


def test_hysteresis_band_may_touch_0_and_1():
    """threshold +- hysteresis/2 = [0, 0.5] and [0.5, 1] are inside [0, 1]: accepted. With the
    off edge at 0 a switch once on never turns off (x < 0 cannot happen); with the on edge
    at 1 it turns on only at full x."""
    low = compile_tree(
        {"root": BlendNode("z_hat", "switch", ["A", "B"], threshold=0.25, hysteresis=0.5)}, RANDOM
    )
    held = low.initial_switch_state({"z_hat": 0.5})
    assert held[0] == 1.0
    for z in (0.3, 0.1, 0.0, -1.0, np.nan):
        _, held = low.target({"z_hat": z}, held)
        assert held[0] == 1.0, z
    high = compile_tree(
        {"root": BlendNode("z_hat", "switch", ["A", "B"], threshold=0.75, hysteresis=0.5)}, RANDOM
    )
    held = np.zeros(1)
    for z, expected in (
        (0.9, 0.0),
        (np.nextafter(1.0, 0.0), 0.0),
        (1.0, 1.0),
        (0.6, 1.0),
        (0.49, 0.0),
    ):
        _, held = high.target({"z_hat": z}, held)
        assert held[0] == expected, z
