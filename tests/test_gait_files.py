"""Gait files: the shipped library is the paper's matrices to the last digit, user files
join it through the scenario, and every mistake in a file is one line naming it."""

import math
import types

import numpy as np
import pytest

from manta_drake.control import gait_files as GF
from manta_drake.control.gait_params import GaitParams
from manta_drake.control.gaits import GAITS, MIRRORED, get_gait
from manta_drake.scenario import ScenarioError, load_scenario

PI = np.pi


def rows(row):
    return np.tile(np.asarray(row, dtype=float), (4, 1))


# The paper's matrices written as the package's Python constants once were (Eqs. 6-8).
R_SWIM_PRINTED = rows([0, PI / 4, PI / 4, PI / 4])
PHI_PRIME_SWIM = np.array(
    [[0, -PI / 18, 0, 0], [PI / 18, 0, 0, 0], [0, 0, 0, -PI / 18], [0, 0, PI / 18, 0]]
)
R_GAIT = np.array(
    [
        [PI / 9, PI / 18, PI / 12, 0],
        [-PI / 9, PI / 18, PI / 12, 0],
        [PI / 9, PI / 18, PI / 12, 0],
        [-PI / 9, PI / 18, PI / 12, 0],
    ]
)
X_GAIT = np.array(
    [
        [PI / 9, -PI / 6, -PI / 6, -5 * PI / 18],
        [PI / 9, -PI / 6, PI / 6, -5 * PI / 18],
        [PI / 9, -PI / 6, -PI / 6, -5 * PI / 18],
        [PI / 9, -PI / 6, PI / 6, -5 * PI / 18],
    ]
)
PHI_GAIT = rows([2 * PI / 3, -PI, PI, 0])
PHI_PRIME_GAIT = np.array([[0, PI, PI, 0], [-PI, 0, 0, -PI], [-PI, 0, 0, -PI], [0, PI, PI, 0]])
PHI_PRIME_WALK = np.array(
    [
        [0, 3 * PI / 2, PI, PI / 2],
        [-3 * PI / 2, 0, -PI / 2, -PI],
        [-PI, PI / 2, 0, -PI / 2],
        [-PI / 2, PI, PI / 2, 0],
    ]
)
PHI_PRIME_TURNING = np.array(
    [
        [0, -3 * PI / 2, -PI / 2, -PI],
        [3 * PI / 2, 0, PI, PI / 2],
        [PI / 2, -PI, 0, -PI / 2],
        [PI, -PI / 2, PI / 2, 0],
    ]
)
R_CRAB = rows([0, PI / 18, PI / 9, PI / 9])
PHI_CRAB = np.array([[0, 0, -PI, 0], [0, 0, -PI, 0], [0, 0, PI, 0], [0, 0, PI, 0]])
SIGNS = np.array([-1.0, 1.0, -1.0, 1.0])


def mirror(m):
    out = np.array(m, dtype=float)
    out[[1, 3]] = SIGNS * out[[0, 2]]
    return out


R_SWIM = R_SWIM_PRINTED.copy()
R_SWIM[[1, 3], 2] *= -1
PAPER = {
    "swim": (R_SWIM, np.zeros((4, 4)), rows([0, -PI, 0, 0]), PHI_PRIME_SWIM),
    "swim_printed": (R_SWIM_PRINTED, np.zeros((4, 4)), rows([0, -PI, 0, 0]), PHI_PRIME_SWIM),
    "trot": (R_GAIT, X_GAIT, PHI_GAIT, PHI_PRIME_GAIT),
    "walk": (R_GAIT, X_GAIT, PHI_GAIT, PHI_PRIME_WALK),
    "turning": (R_GAIT, X_GAIT, PHI_GAIT, PHI_PRIME_TURNING),
    "crab": (R_CRAB, X_GAIT, PHI_CRAB, PHI_PRIME_GAIT),
}
for _name in ("trot", "walk", "turning", "crab"):
    PAPER[f"{_name}_printed"] = PAPER[_name]


def same_bits(a, b):
    """Equal to the last bit (a signed zero and an unsigned one count as equal)."""
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    return np.array_equal(np.abs(a).view(np.int64), np.abs(b).view(np.int64)) and np.array_equal(
        np.signbit(a) & (a != 0), np.signbit(b) & (b != 0)
    )


@pytest.mark.parametrize("name", sorted(PAPER))
def test_shipped_file_is_the_paper_to_the_last_bit(name):
    for field, expected in zip(("R", "X", "Phi", "Phi_prime"), PAPER[name]):
        assert same_bits(getattr(GAITS[name], field), expected), (name, field)


def test_mirrored_reading_applies_one_rule_with_the_files_exceptions():
    assert set(MIRRORED) == set(GAITS) == set(PAPER)
    for name in ("trot", "walk", "turning"):
        assert same_bits(MIRRORED[name].R, mirror(R_GAIT))
        assert same_bits(MIRRORED[name].X, mirror(X_GAIT))
        assert same_bits(MIRRORED[name].Phi_prime, GAITS[name].Phi_prime)
    # The crab keeps its antisymmetric pitch amplitudes (mirror_keep: R_deg.pitch), its X is
    # mirrored; the printed forms keep everything; the swim already obeys the rule.
    expected_crab_r = mirror(R_CRAB)
    expected_crab_r[:, 2] = R_CRAB[:, 2]
    assert same_bits(MIRRORED["crab"].R, expected_crab_r)
    assert same_bits(MIRRORED["crab"].X, mirror(X_GAIT))
    for name in GAITS:
        if name.endswith("_printed"):
            assert same_bits(MIRRORED[name].to_vector(), GAITS[name].to_vector())
    assert same_bits(MIRRORED["swim"].R, R_SWIM)


def test_the_library_views_are_read_only():
    assert isinstance(GAITS, types.MappingProxyType)
    with pytest.raises(TypeError):
        GAITS["mine"] = GAITS["trot"]
    with pytest.raises(ValueError):
        GAITS["trot"].R[0, 0] = 1.0


@pytest.mark.parametrize(
    "degrees, radians",
    [
        (10, PI / 18),
        (-10, -PI / 18),
        (50, 5 * PI / 18),
        (120, 2 * PI / 3),
        (270, 3 * PI / 2),
        (-180, -PI),
        (45, PI / 4),
        (15, PI / 12),
    ],
)
def test_whole_degrees_convert_to_the_constants_double(degrees, radians):
    assert GF.degrees_to_radians([degrees])[0] == radians


def test_other_degrees_convert_by_the_formula():
    x = 12.3456789012
    assert GF.degrees_to_radians([x])[0] == pytest.approx(math.radians(x), rel=1e-15)


def test_written_file_reads_back(tmp_path):
    odd = GaitParams(
        GAITS["trot"].R * 0.8137, GAITS["trot"].X, GAITS["trot"].Phi, GAITS["walk"].Phi_prime
    )
    path = GF.write_gait_file(
        tmp_path / "g.yaml",
        {"my_trot": odd, "my_swim": GAITS["swim"]},
        provenance={"made_by": "test"},
    )
    entries = GF.load_gait_file(path)
    np.testing.assert_allclose(
        GaitParams(**entries["my_trot"].matrices).to_vector(),
        odd.to_vector(),
        rtol=0,
        atol=1e-9 * PI / 180,
    )
    assert same_bits(
        GaitParams(**entries["my_swim"].matrices).to_vector(), GAITS["swim"].to_vector()
    )


def _file(tmp_path, text, name="gaits.yaml"):
    path = tmp_path / name
    path.write_text(text)
    return path


TROT_TEXT = """
gaits:
  slow_trot:
    base: trot
    R_deg: [[10, 5, 7.5, 0], [-10, 5, 7.5, 0], [10, 5, 7.5, 0], [-10, 5, 7.5, 0]]
"""


def test_base_takes_the_missing_matrices(tmp_path):
    entries = GF.gait_entries([_file(tmp_path, TROT_TEXT)])
    slow = GaitParams(**entries["slow_trot"].matrices)
    np.testing.assert_array_equal(slow.R, GAITS["trot"].R / 2)
    np.testing.assert_array_equal(slow.Phi_prime, GAITS["trot"].Phi_prime)


@pytest.mark.parametrize(
    "text, match",
    [
        (
            "gaits:\n  g: {base: trot, R_deg: [[1, 2, 3, 4], [1, 2, 3, 4], [1, 2, 3, 4]]}\n",
            r"gaits\.g\.R_deg: expected 4 rows .* got 3 rows",
        ),
        (
            "gaits:\n  g: {base: trot, X_deg: [[1, 2, 3], [1, 2, 3, 4], [1, 2, 3, 4], [1, 2, "
            "3, 4]]}\n",
            r"gaits\.g\.X_deg\[fl\]: expected 4 rows .* got 3 numbers",
        ),
        (
            "gaits:\n  g: {base: trot, Phi_deg: [[1, 2, a, 4], [1, 2, 3, 4], [1, 2, 3, 4], "
            "[1, 2, 3, 4]]}\n",
            r"gaits\.g\.Phi_deg\[fl, pitch\]: 'a' is not a number",
        ),
        (
            "gaits:\n  g: {base: trot, Phi_deg: [[1, 2, 3, 4], [1, .nan, 3, 4], [1, 2, 3, 4], "
            "[1, 2, 3, 4]]}\n",
            r"gaits\.g\.Phi_deg\[fr, roll1\]: nan is outside \[-720, 720\] deg",
        ),
        ("gaits:\n  g: {base: trot, R_dg: []}\n", r"gaits\.g: unknown key 'R_dg'; allowed: R_deg"),
        (
            "gaits:\n  g: {R_deg: [[0, 0, 0, 0], [0, 0, 0, 0], [0, 0, 0, 0], [0, 0, 0, 0]]}\n",
            r"gaits\.g: X_deg missing",
        ),
        (
            "gaits:\n  g: {base: trott}\n",
            r"gaits\.g\.base: 'trott' is not a gait defined before it",
        ),
        ("gaits:\n  g: {base: trot, mirror_keep: [R_deg.tilt]}\n", r"gaits\.g\.mirror_keep: "),
        ("gaits:\n  zero: {base: trot}\n", r"'zero' is not a gait name"),
        ("gaitz: {}\n", r"unknown key 'gaitz'"),
    ],
)
def test_file_mistakes_are_one_line_naming_the_gait_and_field(tmp_path, text, match):
    path = _file(tmp_path, text)
    with pytest.raises(ScenarioError, match=match) as e:
        GF.gait_entries([path])
    assert "\n" not in str(e.value) and str(path) in str(e.value)


def test_a_name_clash_names_both_files(tmp_path):
    clash = _file(tmp_path, "gaits:\n  trot: {base: walk}\n")
    with pytest.raises(
        ScenarioError,
        match=rf"{clash}: gaits\.trot: the name is already "
        rf"defined in .*models/gaits\.yaml",
    ):
        GF.gait_entries([clash])
    first = _file(tmp_path, TROT_TEXT, "a.yaml")
    second = _file(tmp_path, TROT_TEXT, "b.yaml")
    with pytest.raises(ScenarioError, match=rf"{second}: gaits\.slow_trot: .* defined in {first}"):
        GF.gait_entries([first, second])


def test_scenario_gait_files_relative_to_the_scenario_and_by_set(tmp_path, monkeypatch):
    (tmp_path / "sub").mkdir()
    _file(tmp_path / "sub", TROT_TEXT, "mine.yaml")
    scenario_path = tmp_path / "sub" / "run.yaml"
    scenario_path.write_text(
        "controller: {mode: gait, gait: slow_trot, gait_files: [mine.yaml]}\n"
        "initial_stance: slow_trot\n"
    )
    monkeypatch.chdir(tmp_path)  # the scenario's folder, not the working directory, anchors it
    s = load_scenario(scenario_path)
    assert s.controller.gait_files == [str((tmp_path / "sub" / "mine.yaml").resolve())]
    np.testing.assert_array_equal(s.gait("slow_trot").R, GAITS["trot"].R / 2)
    # --set is relative to the working directory.
    s2 = load_scenario(
        "locomotion_trot",
        overrides={"controller.gait_files": ["sub/mine.yaml"], "controller.gait": "slow_trot"},
    )
    assert s2.controller.gait_files == [str((tmp_path / "sub" / "mine.yaml").resolve())]
    assert get_gait("slow_trot", "paper", s2.controller.gait_files).R[0, 0] == PI / 18
    # The mirrored reading applies its rule to the user's gait too.
    s3 = load_scenario(defaults=s2, overrides={"controller.gait_reading": "mirrored"})
    np.testing.assert_array_equal(s3.gait("slow_trot").R, mirror(GAITS["trot"].R / 2))


def test_scenario_refuses_a_missing_or_unknown_gait(tmp_path):
    with pytest.raises(ScenarioError, match=r"controller\.gait_files\[0\]: gait file not found"):
        load_scenario(
            "locomotion_trot", overrides={"controller.gait_files": [str(tmp_path / "x.yaml")]}
        )
    with pytest.raises(ScenarioError, match=r"controller\.gait: 'slow_trot' is not one of"):
        load_scenario("locomotion_trot", overrides={"controller.gait": "slow_trot"})


def test_the_finest_simple_fraction_still_converts_to_the_constants_double():
    # 0.55 deg = pi * 11 / 3600, the largest denominator the rule takes; the plain formula
    # d * pi / 180 gives a different last bit there.
    assert GF.degrees_to_radians([0.55])[0] == PI * 11 / 3600
    assert 0.55 * PI / 180 != PI * 11 / 3600


def test_written_degrees_snap_to_whole_only_within_1e9():
    # 7e-10 deg from a whole number is written as the whole number; 1.2e-9 deg away it is
    # not, or the file would no longer read back to within 1e-9 deg.
    degrees = np.array([[10 + 7e-10, 10 + 1.2e-9, 0, 0]] * 4)
    near, far = GF.radians_to_degrees(np.radians(degrees))[0][:2]
    assert near == 10 and isinstance(near, int)
    assert abs(far - (10 + 1.2e-9)) <= 1e-9 and far != 10


def test_entries_up_to_720_degrees_are_accepted(tmp_path):
    text = (
        "gaits:\n  g: {base: trot, Phi_deg: [[720, -720, 0, 0], [0, 0, 0, 0], [0, 0, 0, 0], "
        "[0, 0, 0, 0]]}\n"
    )
    g = GF.gait_entries([_file(tmp_path, text)])["g"]
    assert g.matrices["Phi"][0, 0] == 4 * PI and g.matrices["Phi"][0, 1] == -4 * PI
    with pytest.raises(ScenarioError, match=r"720\.5 is outside"):
        GF.gait_entries([_file(tmp_path, text.replace("720,", "720.5,"), "b.yaml")])


def test_a_missing_gait_file_is_one_line(tmp_path):
    with pytest.raises(ScenarioError, match=rf"gait file not found: {tmp_path / 'x.yaml'}"):
        GF.gait_entries([tmp_path / "x.yaml"])
