"""The one strict YAML reader and the value checks every file kind goes through."""

import math

import numpy as np
import pytest

from manta_drake.config_io import (
    ScenarioError,
    check_in_range,
    check_integer,
    check_number,
    check_vector,
    load_yaml_mapping,
    parse_yaml,
)


def test_yaml_1_2_floats_are_numbers_and_other_scalars_keep_their_types():
    data = parse_yaml("a: 1e-3\nb: 1.0e9\nc: -2.5E+1\nd: 12\ne: 1e\nf: v1e3\ng: .5e2\n")
    assert data == {"a": 1e-3, "b": 1e9, "c": -25.0, "d": 12, "e": "1e", "f": "v1e3", "g": 50.0}
    assert isinstance(data["d"], int)


@pytest.mark.parametrize("text", ["a: 1\na: 2\n", "x: {a: 1, a: 2}\n", "- {k: 1, k: 1}\n"])
def test_a_key_given_twice_is_refused_with_its_line(text):
    with pytest.raises(ScenarioError, match=r"where: not valid YAML: .*duplicate key"):
        parse_yaml(text, "where")


def test_files_are_named_in_every_refusal(tmp_path):
    with pytest.raises(ScenarioError, match=r"sweep file not found: .*nope.yaml"):
        load_yaml_mapping(tmp_path / "nope.yaml", "sweep")
    listy = tmp_path / "l.yaml"
    listy.write_text("- 1\n")
    with pytest.raises(ScenarioError, match=r"l.yaml: the sweep file's root must be a mapping"):
        load_yaml_mapping(listy, "sweep")
    binary = tmp_path / "b.yaml"
    binary.write_bytes(b"\xff\xfe\x81")
    with pytest.raises(ScenarioError, match=r"b.yaml: not a UTF-8 text"):
        load_yaml_mapping(binary, "sweep")
    empty = tmp_path / "e.yaml"
    empty.write_text("")
    assert load_yaml_mapping(empty)[0] == {}


@pytest.mark.parametrize(
    "check, words",
    [
        (lambda: check_number("f", True), "f: True is not a number"),
        (lambda: check_number("f", math.inf), "f: inf is not finite"),
        (lambda: check_number("f", "1"), "f: '1' is not a number"),
        (
            lambda: check_in_range("f", 0.0, 0.0, 1.0, "(0, 1]", open_low=True),
            "outside the allowed range (0, 1]",
        ),
        (
            lambda: check_in_range("f", 1.0, 0.0, 1.0, "[0, 1)", open_high=True),
            "outside the allowed range [0, 1)",
        ),
        (lambda: check_integer("n", 1.7, 0, 5), "n: 1.7 is not an integer (allowed: 0 to 5)"),
        (lambda: check_integer("n", 6, 0, 5), "n: 6 is outside the allowed range [0, 5]"),
        (
            lambda: check_vector("v", [3.0, 4.0, 0.0], 3, bound=4.9),
            "magnitude above the allowed 4.9",
        ),
        (lambda: check_vector("v", [1.0, math.nan, 0.0], 3), "v[1]: nan is not finite"),
    ],
)
def test_value_checks_are_one_line_naming_the_field(check, words):
    with pytest.raises(ScenarioError) as info:
        check()
    assert words in str(info.value) and "\n" not in str(info.value)


def test_value_checks_accept_the_edges_and_numpy_scalars():
    check_in_range("f", 1.0, 0.0, 1.0, "(0, 1]", open_low=True)
    check_in_range("f", np.float32(0.5), 0.0, 1.0, "[0, 1]")
    check_integer("n", np.int64(5), 0, 5)
    check_vector("v", [3.0, 4.0, 0.0], 3, bound=5.0)


def test_closed_ends_take_their_edge_and_refuse_beyond_it():
    check_in_range("f", 0.0, 0.0, 1.0, "[0, 1]")
    with pytest.raises(ScenarioError, match=r"outside the allowed range \[0, 1\]"):
        check_in_range("f", -1e-12, 0.0, 1.0, "[0, 1]")
    with pytest.raises(ScenarioError, match=r"outside the allowed range \[0, 1\]"):
        check_in_range("f", 1.0 + 1e-12, 0.0, 1.0, "[0, 1]")


def test_optional_fields_take_none_or_their_type_and_a_true_union_is_not_narrowed():
    import dataclasses as dc

    from manta_drake.config_io import check_keys

    @dc.dataclass
    class Schema:
        sweep: float | None = None
        either: int | str = 0

    check_keys({"sweep": None, "either": "x"}, Schema)
    check_keys({"sweep": 12.5, "either": 3}, Schema)
    with pytest.raises(ScenarioError, match=r"scenario\.sweep: expected a float, got 'ten'"):
        check_keys({"sweep": "ten"}, Schema)


class _FileKindError(ScenarioError):
    """A file kind's own error type (as sweep's SweepError is)."""


@pytest.mark.parametrize(
    "check, words",
    [
        (lambda e: check_number("f", "x", error=e), "f: 'x' is not a number"),
        (
            lambda e: check_in_range("f", 2.0, 0.0, 1.0, "[0, 1]", error=e),
            "f: 2.0 is outside the allowed range [0, 1]",
        ),
        (lambda e: check_in_range("f", math.nan, 0, 1, "[0, 1]", error=e), "f: nan is not finite"),
        (lambda e: check_integer("n", True, 0, 5, error=e), "n: True is not an integer"),
        (lambda e: check_vector("v", [1.0, "a"], 2, error=e), "v[1]: 'a' is not a number"),
    ],
)
def test_value_checks_raise_the_callers_error_type(check, words):
    """A sweep, calibration or optimisation spec checks its values with these same functions
    and gets its own error type (a subclass of ScenarioError), with the same message."""
    with pytest.raises(_FileKindError) as info:
        check(_FileKindError)
    assert str(info.value).startswith(words)
