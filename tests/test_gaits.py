"""The gait library against Eqs. (6)-(8), typed here again in degrees."""

import numpy as np
import pytest

from manta_drake.control.gaits import GAITS, GaitParams, get_gait, phase_lock_targets

D = np.radians


def rows(*r):
    return D(np.tile(r, (4, 1)))


EQ6_SWIM = dict(
    R=rows(0, 45, 45, 45),
    X=np.zeros((4, 4)),
    Phi=rows(0, -180, 0, 0),
    Phi_prime=D([[0, -10, 0, 0], [10, 0, 0, 0], [0, 0, 0, -10], [0, 0, 10, 0]]),
)
R_GAIT = D([[20, 10, 15, 0], [-20, 10, 15, 0], [20, 10, 15, 0], [-20, 10, 15, 0]])
X_GAIT = D([[20, -30, -30, -50], [20, -30, 30, -50], [20, -30, -30, -50], [20, -30, 30, -50]])
PHI_GAIT = rows(120, -180, 180, 0)
PHIP_GAIT = D([[0, 180, 180, 0], [-180, 0, 0, -180], [-180, 0, 0, -180], [0, 180, 180, 0]])
PHIP_WALK = D([[0, 270, 180, 90], [-270, 0, -90, -180], [-180, 90, 0, -90], [-90, 180, 90, 0]])
PHIP_TURN = D([[0, -270, -90, -180], [270, 0, 180, 90], [90, -180, 0, -90], [180, -90, 90, 0]])
# Our reading of Eq. (6): the right fins' pitch amplitude mirrored (module docstring).
SWIM = dict(EQ6_SWIM, R=D([[0, 45, 45, 45], [0, 45, -45, 45], [0, 45, 45, 45], [0, 45, -45, 45]]))
EXPECTED = {
    "swim_printed": EQ6_SWIM,
    "swim": SWIM,
    "trot": dict(R=R_GAIT, X=X_GAIT, Phi=PHI_GAIT, Phi_prime=PHIP_GAIT),
    "walk": dict(R=R_GAIT, X=X_GAIT, Phi=PHI_GAIT, Phi_prime=PHIP_WALK),
    "turning": dict(R=R_GAIT, X=X_GAIT, Phi=PHI_GAIT, Phi_prime=PHIP_TURN),
    "crab": dict(
        R=rows(0, 10, 20, 20),
        X=X_GAIT,
        Phi=D([[0, 0, -180, 0], [0, 0, -180, 0], [0, 0, 180, 0], [0, 0, 180, 0]]),
        Phi_prime=PHIP_GAIT,
    ),
}


EXPECTED.update(
    {f"{name}_printed": EXPECTED[name] for name in ("trot", "walk", "turning", "crab")}
)  # the paper reading's


@pytest.mark.parametrize("name", sorted(EXPECTED))
def test_gait_matrices_equal_the_paper(name):
    gait = GAITS[name]
    for field, expected in EXPECTED[name].items():
        np.testing.assert_allclose(getattr(gait, field), expected, atol=1e-12, err_msg=field)


@pytest.mark.parametrize("name", [n for n in sorted(EXPECTED) if n.endswith("_printed")])
def test_every_printed_matrix_is_a_named_gait_in_both_readings(name):
    from manta_drake.control.gaits import READINGS

    for reading in READINGS:
        gait = get_gait(name, reading)
        for field, expected in EXPECTED[name].items():
            np.testing.assert_allclose(
                getattr(gait, field), expected, atol=1e-12, err_msg=f"{reading} {field}"
            )


def test_library_has_exactly_the_contract_gaits():
    gaits = {"swim", "trot", "walk", "turning", "crab"}
    assert set(GAITS) == gaits | {f"{name}_printed" for name in gaits}


def test_mirror_signs_mirror_the_leg_geometry():
    """A right fin at MIRROR_SIGNS * q is the mirror image (y -> -y) of its left partner at
    q: every DH frame origin of the leg-fin, for random joint angles; no other sign vector
    does it."""
    from itertools import product

    from manta_drake.control.gaits import MIRROR_SIGNS
    from manta_drake.model.kinematics import leg_frames_ned

    reflect = np.diag([1.0, -1.0, 1.0])
    qs = np.random.default_rng(3).uniform(-0.8, 0.8, (6, 4))

    def mirror_error(signs):
        err = 0.0
        for q in qs:
            for left, right in (("fl", "fr"), ("rl", "rr")):
                for a, b in zip(leg_frames_ned(left, q), leg_frames_ned(right, signs * q)):
                    err = max(err, np.abs(reflect @ a[:3, 3] - b[:3, 3]).max())
        return err

    assert mirror_error(MIRROR_SIGNS) < 1e-12
    others = [
        np.array(s) for s in product((1.0, -1.0), repeat=4) if not np.array_equal(s, MIRROR_SIGNS)
    ]
    assert min(mirror_error(s) for s in others) > 1e-3


def test_swim_fins_mirror_each_other_and_the_legged_gaits_keep_the_print():
    """swim: each right fin's R, X row is the mirror of its left partner's; the printed
    swim is not (its pitch column is equal on both sides)."""
    from manta_drake.control.gaits import MIRROR_SIGNS

    for name, mirrored in (("swim", True), ("swim_printed", False)):
        g = GAITS[name]
        same = all(
            np.allclose(M[right], MIRROR_SIGNS * M[left])
            for M in (g.R, g.X)
            for left, right in ((0, 1), (2, 3))
        )
        assert same is mirrored, name


@pytest.mark.parametrize("name", sorted(EXPECTED))
def test_vector_round_trip_and_layout(name):
    gait = GAITS[name]
    v = gait.to_vector()
    assert v.shape == (64,)
    np.testing.assert_array_equal(v[16:32].reshape(4, 4), gait.X)  # R, X, Phi, Phi' row-major
    back = GaitParams.from_vector(v)
    for field in ("R", "X", "Phi", "Phi_prime"):
        np.testing.assert_array_equal(getattr(back, field), getattr(gait, field))


@pytest.mark.parametrize("name", sorted(EXPECTED))
def test_fcs_biases_are_antisymmetric(name):
    P = GAITS[name].Phi_prime
    np.testing.assert_allclose(P, -P.T, atol=1e-12)


def test_invalid_gaits_are_rejected_with_the_field_named():
    good = GAITS["trot"]
    with pytest.raises(ValueError, match="GaitParams.R: shape"):
        GaitParams(np.zeros((3, 4)), good.X, good.Phi, good.Phi_prime)
    bad = good.X.copy()
    bad[1, 2] = np.nan
    with pytest.raises(ValueError, match="GaitParams.X: contains non-finite"):
        GaitParams(good.R, bad, good.Phi, good.Phi_prime)
    with pytest.raises(ValueError, match="expected 64"):
        GaitParams.from_vector(np.zeros(60))
    with pytest.raises(KeyError, match="known gaits: swim"):
        get_gait("gallop")


def test_gait_arrays_are_read_only():
    with pytest.raises(ValueError):
        GAITS["trot"].R[0, 0] = 1.0


@pytest.mark.parametrize("name", ["trot", "walk", "turning", "crab"])
def test_consistent_fcs_lock_equals_the_biases(name):
    phi = phase_lock_targets(GAITS[name].Phi_prime)
    P = GAITS[name].Phi_prime
    for k in range(4):
        for m in range(4):
            err = np.angle(np.exp(1j * (phi[m] - phi[k] - P[k, m])))
            assert abs(err) < 1e-6


def test_swim_fcs_is_inconsistent_and_locks_at_the_compromise():
    # Eq. (6): fl->fr and rl->rr lag pi/18, every front-rear pair 0: no exact solution.
    phi = phase_lock_targets(GAITS["swim"].Phi_prime)
    np.testing.assert_allclose(phi, [0, -np.pi / 36, 0, -np.pi / 36], atol=1e-6)


def test_mirrored_reading_is_one_mirror_rule_and_the_crab_keeps_its_pitch():
    """Every right fin's R and X row mirrors its left partner's (MIRROR_SIGNS); the left rows
    are the printed ones; the only exception is R_crab's pitch column (antisymmetric, as
    printed), without which the crab cannot walk sideways."""
    from manta_drake.control.gaits import MIRROR_SIGNS, READINGS

    lib, paper = READINGS["mirrored"], READINGS["paper"]
    for name in ("swim", "trot", "walk", "turning", "crab"):
        g, p = lib[name], paper[name]
        for M, P in ((g.R, p.R), (g.X, p.X)):
            np.testing.assert_array_equal(M[[0, 2]], P[[0, 2]])  # left rows as printed
        np.testing.assert_array_equal(g.X[[1, 3]], MIRROR_SIGNS * g.X[[0, 2]])
        np.testing.assert_array_equal(g.Phi, p.Phi)
        np.testing.assert_array_equal(g.Phi_prime, p.Phi_prime)
        if name == "crab":
            np.testing.assert_array_equal(g.R, p.R)
            assert np.all(g.R[[1, 3], 2] == g.R[[0, 2], 2])  # pitch: not mirrored
        else:
            np.testing.assert_array_equal(g.R[[1, 3]], MIRROR_SIGNS * g.R[[0, 2]])
    # The entries the rule changes in the printed legged matrices: X yaw and R pitch of fr, rr.
    changed = np.argwhere(lib["trot"].R != paper["trot"].R).tolist()
    changed += np.argwhere(lib["trot"].X != paper["trot"].X).tolist()
    assert changed == [[1, 2], [3, 2], [1, 0], [3, 0]]


def test_get_gait_names_the_unknown_reading_and_gait():
    from manta_drake.control.gaits import get_gait

    with pytest.raises(KeyError, match="unknown gait reading 'mirror'.*paper, mirrored"):
        get_gait("trot", "mirror")
    with pytest.raises(KeyError, match="unknown gait 'trott'.*trot"):
        get_gait("trott", "mirrored")
