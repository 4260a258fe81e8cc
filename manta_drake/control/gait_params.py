"""One gait's CPG targets (Eqs. 6-8) and the left-right mirror rule.

A gait is four 4x4 matrices (rows: leg-fins fl, fr, rl, rr; columns: joints yaw, roll1,
pitch, roll2), as the paper prints them:

* ``R``: oscillation amplitude of each joint [rad];
* ``X``: bias (offset) angle of each joint [rad];
* ``Phi``: layer 1 (SCS) phase bias from joint j to joint j+1 of the same leg-fin,
  ``phi[j+1] - phi[j] -> Phi[k, j]`` (column 4 unused, zero in every gait);
* ``Phi_prime``: layer 2 (FCS) phase bias between the base (yaw) oscillators of
  leg-fins k and l, ``phi_base[l] - phi_base[k] -> Phi_prime[k, l]``.

The 64-vector form (``to_vector``) is R, X, Phi, Phi_prime, each row-major; it is what
flows on the ``cpg_params`` ports.
"""

from __future__ import annotations

import dataclasses as dc

import numpy as np

from manta_drake.model.robot_params import GAIT_SHAPE, NUM_CPG_PARAMS, NUM_JOINTS

SHAPE = GAIT_SHAPE  # (legs, joints per leg)
FIELDS = ("R", "X", "Phi", "Phi_prime")


@dc.dataclass(frozen=True)
class GaitParams:
    """CPG targets of one gait (Eqs. 6-8). Arrays are 4x4, float, finite, read-only."""

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
    def from_vector(cls, v) -> GaitParams:
        """Inverse of ``to_vector``."""
        v = np.asarray(v, dtype=float)
        if v.shape != (NUM_CPG_PARAMS,):
            raise ValueError(
                f"GaitParams.from_vector: expected {NUM_CPG_PARAMS} values, got shape {v.shape}"
            )
        n = NUM_JOINTS
        return cls(*(v[n * i : n * (i + 1)].reshape(SHAPE) for i in range(len(FIELDS))))


# A right fin's joint command that mirrors its left partner's: yaw and pitch change sign
# (joint order yaw, roll1, pitch, roll2; one DH chain for every leg-fin).
MIRROR_SIGNS = np.array([-1.0, 1.0, -1.0, 1.0])
RIGHT_LEGS = (1, 3)  # fr, rr
LEFT_PARTNERS = (0, 2)  # fl, rl


def mirror_right_fins(matrix) -> np.ndarray:
    """``matrix`` (4x4, rows fl fr rl rr) with each right fin's row replaced by the mirror of
    its left partner's (``MIRROR_SIGNS`` times it)."""
    out = np.array(matrix, dtype=float)
    out[list(RIGHT_LEGS)] = MIRROR_SIGNS * out[list(LEFT_PARTNERS)]
    return out
