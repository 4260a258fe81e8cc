"""The gait library: the CPG targets of Eqs. (6)-(8), read from ``models/gaits.yaml``.

A gait (``GaitParams``, ``control.gait_params``) is four 4x4 matrices R, X, Phi, Phi_prime;
the library is data: the shipped file holds the paper's gaits and our readings of them,
and a scenario adds its own files (``controller.gait_files``; ``control.gait_files`` has
the format). ``GAITS`` (the paper reading) and ``MIRRORED`` are read-only views of the
shipped library; ``gait_library(files, reading)`` is a scenario's.

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
the right fins' pitch column; the matrix exactly as printed is the gait
``swim_printed`` (and every gait exactly as printed is ``<gait>_printed``, in both readings).
The legged gaits stay as printed: their matrices already mirror R's yaw
and X's pitch columns, the crab needs the left-right antisymmetric pitch to walk sideways
(a mirror-symmetric command with the trot's phases cannot make a net side force), and with
the mirror rule applied to every column the trot and the walk of this model stop (measured:
docs/design.md) unless the fins' rest sweep is changed for that stance. ``MIRRORED`` is
that reading, one rule for every gait (its exceptions, such as the crab's antisymmetric
pitch, are the file's ``mirror_keep``), selected by ``controller.gait_reading: mirrored``;
its stance balances with the fins swept back 30 deg at rest (``robot.fin_sweep_deg``, whose
default follows the reading: ``BALANCED_FIN_SWEEP_DEG``; docs/stance.md compares the two).
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from manta_drake.control.gait_files import gait_library
from manta_drake.control.gait_params import (  # noqa: F401 (the library's API)
    FIELDS,
    MIRROR_SIGNS,
    RIGHT_LEGS,
    SHAPE,
    GaitParams,
    mirror_right_fins,
)

PI = np.pi

# Oscillator frequency f_i of Eq. (5), shared by all oscillators and gaits (the
# transition system blends R, X, Phi, Phi' but not f). 0.5 Hz is the order of the
# paper's Fig. 9/10 joint traces and inside the servos' bandwidth at these amplitudes.
DEFAULT_FREQUENCY_HZ = 0.5

# The shipped library (models/gaits.yaml), read-only, by reading (``controller.gait_reading``).
GAITS: Mapping[str, GaitParams] = gait_library((), "paper")
MIRRORED: Mapping[str, GaitParams] = gait_library((), "mirrored")
READINGS: Mapping[str, Mapping[str, GaitParams]] = {"paper": GAITS, "mirrored": MIRRORED}
# Every matrix exactly as printed, by name, in both readings: ``<gait>_printed``.
PRINTED_NAMES = tuple(name for name in GAITS if name.endswith("_printed"))
# The fins' rest sweep [deg] (``robot.fin_sweep_deg``) at which each reading's trot stance has
# both support diagonals within 1.5 cm of the CG (tests/test_kinematics.py; docs/stance.md):
# the scenario's default for that reading.
BALANCED_FIN_SWEEP_DEG: dict[str, float] = {"paper": 10.0, "mirrored": 30.0}


def get_gait(name: str, reading: str = "paper", files=()) -> GaitParams:
    """The gait called ``name`` under ``reading``, from the shipped library and ``files``
    (a scenario's ``controller.gait_files``); a clear error lists the known ones."""
    if reading not in READINGS:
        raise KeyError(
            f"unknown gait reading '{reading}'; known readings: {', '.join(READINGS)}"
        ) from None
    library = gait_library(tuple(files), reading) if files else READINGS[reading]
    try:
        return library[name]
    except KeyError:
        raise KeyError(f"unknown gait '{name}'; known gaits: {', '.join(library)}") from None


def phase_lock_targets(Phi_prime) -> np.ndarray:
    """Base-oscillator phases (relative to leg 1) that the all-to-all FCS locks to.

    With equal symmetric weights and antisymmetric biases the FCS is a gradient flow
    of ``V = sum_{i<j} (1 - cos(phi_j - phi_i - Phi_prime[i, j]))``; its lock is V's
    global minimum, found here by multistart minimisation (independent of the CPG's
    integration). Equal to the biases (mod 2 pi) when they are consistent, the
    compromise when not (Phi'_swim, see the module docstring).

    Returns:
        the four phases, ``[0, phi_2, phi_3, phi_4]`` wrapped to (-pi, pi].
    """
    from scipy.optimize import minimize

    B = np.asarray(Phi_prime, dtype=float)
    n = len(B)
    i, j = np.triu_indices(n, 1)

    def potential(x):
        phi = np.concatenate([[0.0], x])
        e = phi[j] - phi[i] - B[i, j]
        grad_pairs = np.sin(e)
        g = np.zeros(n)
        np.add.at(g, j, grad_pairs)
        np.add.at(g, i, -grad_pairs)
        return np.sum(1.0 - np.cos(e)), g[1:]

    starts = np.stack(np.meshgrid(*[np.linspace(-PI, PI, 5)[:-1]] * (n - 1)), -1).reshape(-1, n - 1)
    best = min(
        (minimize(potential, x0, jac=True, method="BFGS") for x0 in starts), key=lambda r: r.fun
    )
    return np.angle(np.exp(1j * np.concatenate([[0.0], best.x])))
