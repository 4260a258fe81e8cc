"""The gait library: the CPG targets of Eqs. (6)-(8).

A gait is four 4x4 matrices (rows: leg-fins fl, fr, rl, rr; columns: joints yaw,
roll1, pitch, roll2), exactly as the paper prints them:

* ``R``: oscillation amplitude of each joint [rad];
* ``X``: bias (offset) angle of each joint [rad];
* ``Phi``: layer 1 (SCS) phase bias from joint j to joint j+1 of the same leg-fin,
  ``phi[j+1] - phi[j] -> Phi[k, j]`` (column 4 unused, zero in every gait);
* ``Phi_prime``: layer 2 (FCS) phase bias between the base (yaw) oscillators of
  leg-fins k and l, ``phi_base[l] - phi_base[k] -> Phi_prime[k, l]``.

The 64-vector form (``to_vector``) is R, X, Phi, Phi_prime, each row-major; it is
what flows on the ``cpg_params`` ports.

Known inconsistency of the printed Eq. (6): Phi'_swim asks for a -pi/18 lag from
fl to fr and from rl to rr but 0 between every front and rear fin, including the
diagonals, so no set of phases satisfies all six pair biases (the loop
fl -> fr -> rr -> fl sums to -pi/18). With the all-to-all FCS the oscillators lock
at the least-squares compromise (fr and rr lag by pi/36, 0.087 rad off on four
pairs). We keep the matrix as printed; ``phase_lock_targets`` computes the lock.

Our reading of the signs (docs/design.md, section 6 (c), has the measurements). The robot
has one DH chain for every leg-fin (the modules are rotated about the vertical, not
mirrored), so a joint command q on a right fin gives the mirror image of the left partner's
motion only as ``MIRROR_SIGNS * q``: yaw and pitch flip, the two rolls do not (checked
against the kinematics in tests/test_gaits.py). The printed R_swim gives every fin the same
pitch amplitude, so the left and right fins feather in opposite senses and the printed swim
turns (-11 deg/s). Eq. (6) describes one flapping motion of all fins, so ``swim`` mirrors
the right fins' pitch column (``R_SWIM``); the matrix exactly as printed is the gait
``swim_printed`` (and every gait exactly as printed is ``<gait>_printed``, in both readings).
The legged gaits stay as printed: their matrices already mirror R's yaw
and X's pitch columns, the crab needs the left-right antisymmetric pitch to walk sideways
(a mirror-symmetric command with the trot's phases cannot make a net side force), and with
the mirror rule applied to every column the trot and the walk of this model stop (measured:
docs/design.md) unless the fins' rest sweep is changed for that stance. ``MIRRORED`` below is
that reading, one rule for every gait, selected by ``controller.gait_reading: mirrored``;
its stance balances with the fins swept back 30 deg at rest (``robot.fin_sweep_deg``, whose
default follows the reading: ``BALANCED_FIN_SWEEP_DEG``; docs/stance.md compares the two).
"""

from __future__ import annotations

import dataclasses as dc

import numpy as np

from manta_drake.model.robot_params import (
    GAIT_SHAPE,
    NUM_CPG_PARAMS,
    NUM_JOINTS,
    NUM_LEGS,
)

PI = np.pi
SHAPE = GAIT_SHAPE  # (legs, joints per leg)
FIELDS = ("R", "X", "Phi", "Phi_prime")

# Oscillator frequency f_i of Eq. (5), shared by all oscillators and gaits (the
# transition system blends R, X, Phi, Phi' but not f). 0.5 Hz is the order of the
# paper's Fig. 9/10 joint traces and inside the servos' bandwidth at these amplitudes.
DEFAULT_FREQUENCY_HZ = 0.5


@dc.dataclass(frozen=True)
class GaitParams:
    """CPG targets of one gait (Eqs. 6-8). Arrays are 4x4, float, finite."""

    R: np.ndarray
    X: np.ndarray
    Phi: np.ndarray
    Phi_prime: np.ndarray

    def __post_init__(self):
        for name in FIELDS:
            value = np.array(getattr(self, name), dtype=float)
            if value.shape != SHAPE:
                raise ValueError(f"GaitParams.{name}: shape {value.shape}, expected {SHAPE}")
            if not np.all(np.isfinite(value)):
                raise ValueError(f"GaitParams.{name}: contains non-finite values")
            value.flags.writeable = False
            object.__setattr__(self, name, value)
        # Negative amplitudes are legal: R_gait's yaw column mirrors left and right by sign.

    def to_vector(self) -> np.ndarray:
        """The 64-vector (R, X, Phi, Phi_prime, each row-major)."""
        return np.concatenate([getattr(self, name).ravel() for name in FIELDS])

    @classmethod
    def from_vector(cls, v) -> "GaitParams":
        """Inverse of ``to_vector``."""
        v = np.asarray(v, dtype=float)
        if v.shape != (NUM_CPG_PARAMS,):
            raise ValueError(f"GaitParams.from_vector: expected {NUM_CPG_PARAMS} values, "
                             f"got shape {v.shape}")
        n = NUM_JOINTS
        return cls(*(v[n * i : n * (i + 1)].reshape(SHAPE) for i in range(len(FIELDS))))


def _rows(row) -> np.ndarray:
    return np.tile(np.asarray(row, dtype=float), (NUM_LEGS, 1))


# A right fin's joint command that mirrors its left partner's: yaw and pitch change sign
# (joint order yaw, roll1, pitch, roll2; one DH chain for every leg-fin).
MIRROR_SIGNS = np.array([-1.0, 1.0, -1.0, 1.0])
RIGHT_LEGS = (1, 3)  # fr, rr


def mirror_right_fins(matrix) -> np.ndarray:
    """``matrix`` (4x4, rows fl fr rl rr) with each right fin's row replaced by the mirror of
    its left partner's (``MIRROR_SIGNS`` times it)."""
    out = np.array(matrix, dtype=float)
    out[list(RIGHT_LEGS)] = MIRROR_SIGNS * out[[0, 2]]
    return out


# Eq. (6)
R_SWIM_PRINTED = _rows([0, PI / 4, PI / 4, PI / 4])
R_SWIM = mirror_right_fins(R_SWIM_PRINTED)  # right fins' pitch amplitude -pi/4
X_SWIM = np.zeros(SHAPE)
PHI_SWIM = _rows([0, -PI, 0, 0])
PHI_PRIME_SWIM = np.array(
    [[0, -PI / 18, 0, 0], [PI / 18, 0, 0, 0], [0, 0, 0, -PI / 18], [0, 0, PI / 18, 0]]
)
# Eq. (7)
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
PHI_GAIT = _rows([2 * PI / 3, -PI, PI, 0])
PHI_PRIME_GAIT = np.array([[0, PI, PI, 0], [-PI, 0, 0, -PI], [-PI, 0, 0, -PI], [0, PI, PI, 0]])
# Eq. (8)
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
R_CRAB = _rows([0, PI / 18, PI / 9, PI / 9])
PHI_CRAB = np.array([[0, 0, -PI, 0], [0, 0, -PI, 0], [0, 0, PI, 0], [0, 0, PI, 0]])

GAITS: dict[str, GaitParams] = {
    "swim": GaitParams(R_SWIM, X_SWIM, PHI_SWIM, PHI_PRIME_SWIM),
    "trot": GaitParams(R_GAIT, X_GAIT, PHI_GAIT, PHI_PRIME_GAIT),
    "walk": GaitParams(R_GAIT, X_GAIT, PHI_GAIT, PHI_PRIME_WALK),
    "turning": GaitParams(R_GAIT, X_GAIT, PHI_GAIT, PHI_PRIME_TURNING),
    "crab": GaitParams(R_CRAB, X_GAIT, PHI_CRAB, PHI_PRIME_GAIT),
    # Eq. (6) exactly as printed (its fins feather in opposite senses and it turns).
    "swim_printed": GaitParams(R_SWIM_PRINTED, X_SWIM, PHI_SWIM, PHI_PRIME_SWIM),
}
# Every matrix exactly as printed, by name, in both readings: ``<gait>_printed``. (In this
# reading the legged gaits are the printed ones.)
PRINTED_NAMES = tuple(f"{name}_printed" for name in ("swim", "trot", "walk", "turning", "crab"))
GAITS.update({f"{name}_printed": GAITS[name] for name in ("trot", "walk", "turning", "crab")})


# The second reading (docs/design.md, section 6 (c); docs/stance.md): one rule for every
# gait. The printed left rows are the reference (Fig. 9 checks the left front fin) and each
# right fin's R and X rows are their mirror image, so every motion is mirror-symmetric
# up to its phases. Changed printed entries: R_swim and R_gait [fr, rr; pitch] and
# X_gait [fr, rr; yaw]. One exception, forced by symmetry: the crab keeps R_crab's
# printed pitch column, whose left-right antisymmetry is what walks it sideways (a
# mirror-symmetric command with the trot's half-period left-right phases makes side forces
# that cancel over a cycle). Its all-forward yaw bias balances the stance only with the
# fins swept back ~30 deg at theta_1 = 0 (``robot.fin_sweep_deg``; docs/stance.md).
X_GAIT_MIRRORED = mirror_right_fins(X_GAIT)
R_GAIT_MIRRORED = mirror_right_fins(R_GAIT)
MIRRORED: dict[str, GaitParams] = {
    "swim": GAITS["swim"],  # already the mirror rule
    "trot": GaitParams(R_GAIT_MIRRORED, X_GAIT_MIRRORED, PHI_GAIT, PHI_PRIME_GAIT),
    "walk": GaitParams(R_GAIT_MIRRORED, X_GAIT_MIRRORED, PHI_GAIT, PHI_PRIME_WALK),
    "turning": GaitParams(R_GAIT_MIRRORED, X_GAIT_MIRRORED, PHI_GAIT, PHI_PRIME_TURNING),
    "crab": GaitParams(R_CRAB, X_GAIT_MIRRORED, PHI_CRAB, PHI_PRIME_GAIT),
    **{name: GAITS[name] for name in PRINTED_NAMES},
}

# Gait libraries by reading (the scenario's ``controller.gait_reading``).
READINGS: dict[str, dict[str, GaitParams]] = {"paper": GAITS, "mirrored": MIRRORED}
# The fins' rest sweep [deg] (``robot.fin_sweep_deg``) at which each reading's trot stance has
# both support diagonals within 1.5 cm of the CG (tests/test_kinematics.py; docs/stance.md):
# the scenario's default for that reading.
BALANCED_FIN_SWEEP_DEG: dict[str, float] = {"paper": 10.0, "mirrored": 30.0}


def get_gait(name: str, reading: str = "paper") -> GaitParams:
    """The gait called ``name`` under ``reading``; a clear error lists the known ones."""
    try:
        library = READINGS[reading]
    except KeyError:
        raise KeyError(f"unknown gait reading '{reading}'; known readings: "
                       f"{', '.join(READINGS)}") from None
    try:
        return library[name]
    except KeyError:
        raise KeyError(f"unknown gait '{name}'; known gaits: {', '.join(library)}") from None


def phase_lock_targets(Phi_prime) -> np.ndarray:
    """Base-oscillator phases (relative to leg 1) that the all-to-all FCS locks to.

    With equal symmetric weights and antisymmetric biases the FCS is a gradient flow
    of ``V = sum_{k<l} (1 - cos(phi_l - phi_k - Phi_prime[k, l]))``; its lock is V's
    global minimum, found here by multistart minimisation (independent of the CPG's
    integration). Equal to the biases (mod 2 pi) when they are consistent, the
    compromise when not (Phi'_swim, see the module docstring).

    Returns:
        the four phases, ``[0, phi_2, phi_3, phi_4]`` wrapped to (-pi, pi].
    """
    from scipy.optimize import minimize

    B = np.asarray(Phi_prime, dtype=float)
    n = len(B)
    k, l = np.triu_indices(n, 1)

    def potential(x):
        phi = np.concatenate([[0.0], x])
        e = phi[l] - phi[k] - B[k, l]
        grad_pairs = np.sin(e)
        g = np.zeros(n)
        np.add.at(g, l, grad_pairs)
        np.add.at(g, k, -grad_pairs)
        return np.sum(1.0 - np.cos(e)), g[1:]

    starts = np.stack(np.meshgrid(*[np.linspace(-PI, PI, 5)[:-1]] * (n - 1)), -1).reshape(-1, n - 1)
    best = min((minimize(potential, x0, jac=True, method="BFGS") for x0 in starts),
               key=lambda r: r.fun)
    return np.angle(np.exp(1j * np.concatenate([[0.0], best.x])))
