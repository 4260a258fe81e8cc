"""The CPG's maths (Eq. 5) compiled with numba: the same as ``manta_drake.control.cpg``.

``cpg.py``'s numpy functions (``cpg_derivatives``, ``phase_rates``, ``joint_angles``,
``joint_rates``) stay the reference; ``CpgOscillators`` calls these kernels, which the
tests hold equal to the reference to 1e-12. The Simulator integrates the 80 continuous
states with RK2 on either path: only the arithmetic inside each derivative evaluation
differs, a dozen numpy calls on 16-element arrays (~1 us each whatever the size) against one
compiled loop.

The coupled pairs are packed once (``pack_pairs``) as rows [receiving oscillator i,
sending oscillator j, index of its bias in the 64 CPG parameters, sign of the bias],
with the weights alongside, so the kernels need no globals. Compiled with
``@njit(cache=True)``: see ``manta_drake.station.water_kernels`` for where numba keeps
the cache.
"""

from __future__ import annotations

import numpy as np

from manta_drake.jit import njit


def pack_pairs(pair_i, pair_j, bias_index, bias_sign) -> np.ndarray:
    """(n_pairs, 4) int64 rows [i, j, bias index into the 64 params, bias sign (+-1)]."""
    return np.ascontiguousarray(
        np.column_stack([pair_i, pair_j, bias_index, bias_sign]), dtype=np.int64
    )


@njit(cache=True)
def phase_rates(x, params, omega, pairs, weights, n_osc):
    """dphi/dt of Eq. (5): omega + sum over pairs (i <- j) of w sin(phi_j - phi_i - b_ij),
    summed in pair order (as ``np.bincount`` does in the reference)."""
    coupling = np.zeros(n_osc)
    for k in range(pairs.shape[0]):
        i, j = pairs[k, 0], pairs[k, 1]
        bias = params[pairs[k, 2]] if pairs[k, 3] > 0 else -params[pairs[k, 2]]
        coupling[i] += weights[k] * np.sin(x[j] - x[i] - bias)
    for i in range(n_osc):
        coupling[i] = omega + coupling[i]
    return coupling


@njit(cache=True)
def derivatives(x, params, omega, pairs, weights, a, b, n_osc, out):
    """``cpg.cpg_derivatives`` into ``out`` (5 n_osc): d/dt of x = [phi, r, dr, chi, dchi].

    The callers own ``out`` (one buffer per system): a kernel that returns a new array
    costs ~0.7 us more per call to box it, and these run three times per plant step."""
    n = n_osc
    out[:n] = phase_rates(x, params, omega, pairs, weights, n)
    for i in range(n):
        out[n + i] = x[2 * n + i]
        out[2 * n + i] = a * (a / 4.0 * (params[i] - x[n + i]) - x[2 * n + i])
        out[3 * n + i] = x[4 * n + i]
        out[4 * n + i] = b * (b / 4.0 * (params[n + i] - x[3 * n + i]) - x[4 * n + i])


@njit(cache=True)
def desired_state(x, params, omega, pairs, weights, n_osc, out):
    """[theta, dtheta/dt] into ``out`` (2 n_osc): ``cpg.joint_angles``, ``cpg.joint_rates``."""
    n = n_osc
    phi_dot = phase_rates(x, params, omega, pairs, weights, n)
    for i in range(n):
        s, c = np.sin(x[i]), np.cos(x[i])
        out[i] = x[3 * n + i] + x[n + i] * s
        out[n + i] = x[4 * n + i] + x[2 * n + i] * s + x[n + i] * c * phi_dot[i]


@njit(cache=True)
def angles(x, n_osc, out):
    """``cpg.joint_angles`` into ``out`` (n_osc): theta = chi + r sin(phi)."""
    n = n_osc
    for i in range(n):
        out[i] = x[3 * n + i] + x[n + i] * np.sin(x[i])
