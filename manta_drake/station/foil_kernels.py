"""The fin strips' flapping-foil forces compiled with numba: ``manta_drake.station.foil``'s
maths in one pass over the strips (the tests hold the two to 1e-12 on random states).

``strip_wrenches`` evaluates every strip of the robot from its body's pose and spatial
velocity and its two Wagner lag states, and sums the forces per body as [tau_W, f_W]
about the body origin. It also returns each strip's three-quarter-chord normal velocity
and in-plane speed, the inputs of ``lag_step``, which advances the lag states by one
period (``foil.wagner_step``).

Packed strips (``pack_strips``), one row each:
[body, element, p_B (3), normal_B (3), chord_B (3), span_B (3), area, chord]
(``chord_B`` the unit chord direction to the geometric leading edge; ``element`` the
strip's volume element, whose submerged fraction scales its force).
"""

from __future__ import annotations

import numpy as np

from manta_drake.jit import njit
from manta_drake.station.foil import WAGNER_A, WAGNER_B

# Layout of the packed strip parameters (``pack_foil_params``).
F_RHO, F_SLOPE, F_SUCTION, F_CDCF, F_CF, F_STALL, F_WIDTH = range(7)
F_CURRENT = 7
NUM_FOIL_PARAMS = 10
_A1, _A2 = WAGNER_A
_B1, _B2 = WAGNER_B


def pack_strips(body, element, p, normal, chord_dir, span_dir, area, chord) -> np.ndarray:
    """The strips as one float table (rows: see the module docstring)."""
    table = np.column_stack([body, element, p, normal, chord_dir, span_dir, area, chord])
    return np.ascontiguousarray(table, dtype=float)


def pack_foil_params(rho, lift_slope, suction_efficiency, cross_flow_coefficient,
                     friction_coefficient, stall_angle, stall_width, current) -> np.ndarray:
    """The strip model's parameters as one float vector (layout: the F_* indices)."""
    prm = np.empty(NUM_FOIL_PARAMS)
    prm[:7] = (rho, lift_slope, suction_efficiency, cross_flow_coefficient,
               friction_coefficient, stall_angle, stall_width)
    prm[F_CURRENT:F_CURRENT + 3] = current
    return prm


@njit(cache=True)
def _rot(Rb, x0, x1, x2):
    return (Rb[0, 0] * x0 + Rb[0, 1] * x1 + Rb[0, 2] * x2,
            Rb[1, 0] * x0 + Rb[1, 1] * x1 + Rb[1, 2] * x2,
            Rb[2, 0] * x0 + Rb[2, 1] * x1 + Rb[2, 2] * x2)


@njit(cache=True)
def strip_wrenches(R, w, v, strips, frac, lag, prm):
    """Every strip's ``foil.strip_forces`` with ``foil.strip_kinematics``, the lagged
    normal velocity from the states ``lag`` (ns, 2), scaled by its element's submerged
    fraction ``frac`` and summed per body.

    Args:
        R, w, v: (nb, 3, 3), (nb, 3), (nb, 3) body orientations, angular and origin
            velocities in the world.

    Returns:
        (S (nb, 6) [tau_W, f_W] about each body origin, w34 (ns,), speed (ns,)).
    """
    nb, ns = R.shape[0], strips.shape[0]
    rho, slope, eta = prm[F_RHO], prm[F_SLOPE], prm[F_SUCTION]
    c_dcf, c_f, stall, width = prm[F_CDCF], prm[F_CF], prm[F_STALL], prm[F_WIDTH]
    cur0, cur1, cur2 = prm[F_CURRENT], prm[F_CURRENT + 1], prm[F_CURRENT + 2]
    S = np.zeros((nb, 6))
    w34 = np.empty(ns)
    speed = np.empty(ns)
    for k in range(ns):
        b = int(strips[k, 0])
        Rb = R[b]
        r0, r1, r2 = _rot(Rb, strips[k, 2], strips[k, 3], strips[k, 4])
        n0, n1, n2 = _rot(Rb, strips[k, 5], strips[k, 6], strips[k, 7])
        c0, c1, c2 = _rot(Rb, strips[k, 8], strips[k, 9], strips[k, 10])
        area, chord = strips[k, 14], strips[k, 15]
        o0, o1, o2 = w[b, 0], w[b, 1], w[b, 2]
        # Mid-chord velocity relative to the water.
        m0 = v[b, 0] + (o1 * r2 - o2 * r1) - cur0
        m1 = v[b, 1] + (o2 * r0 - o0 * r2) - cur1
        m2 = v[b, 2] + (o0 * r1 - o1 * r0) - cur2
        u_mid = m0 * c0 + m1 * c1 + m2 * c2
        sgn = -1.0 if u_mid < 0.0 else 1.0
        l0, l1, l2 = sgn * c0, sgn * c1, sgn * c2  # the edge facing the flow
        # The 3/4-chord point, a quarter chord behind the mid-chord: v + omega x d.
        d0, d1, d2 = -0.25 * chord * l0, -0.25 * chord * l1, -0.25 * chord * l2
        q0 = m0 + (o1 * d2 - o2 * d1)
        q1 = m1 + (o2 * d0 - o0 * d2)
        q2 = m2 + (o0 * d1 - o1 * d0)
        wn = q0 * n0 + q1 * n1 + q2 * n2
        uc = q0 * c0 + q1 * c1 + q2 * c2
        spd = np.sqrt(wn * wn + uc * uc)
        w34[k], speed[k] = wn, spd
        alpha = np.arctan2(abs(wn), abs(uc))
        f_att = 1.0 / (1.0 + np.exp((alpha - stall) / width))
        w_eff = (1.0 - _A1 - _A2) * wn + lag[k, 0] + lag[k, 1]
        half_rho_a = 0.5 * rho * area
        fn = (f_att * (-half_rho_a * slope * spd * w_eff)
              + (1.0 - f_att) * (-half_rho_a * c_dcf * abs(wn) * wn))
        fs = f_att * half_rho_a * slope * eta * w_eff * w_eff
        mn = m0 * n0 + m1 * n1 + m2 * n2
        t0, t1, t2 = m0 - mn * n0, m1 - mn * n1, m2 - mn * n2
        ft = -(half_rho_a * c_f * np.sqrt(t0 * t0 + t1 * t1 + t2 * t2))
        scale = frac[int(strips[k, 1])]
        f0 = (fn * n0 + fs * l0 + ft * t0) * scale
        f1 = (fn * n1 + fs * l1 + ft * t1) * scale
        f2 = (fn * n2 + fs * l2 + ft * t2) * scale
        S[b, 0] += r1 * f2 - r2 * f1
        S[b, 1] += r2 * f0 - r0 * f2
        S[b, 2] += r0 * f1 - r1 * f0
        S[b, 3] += f0
        S[b, 4] += f1
        S[b, 5] += f2
    return S, w34, speed


@njit(cache=True)
def lag_step(lag, w34, speed, strips, dt):
    """``foil.wagner_step`` for every strip, in place-free form: the states after ``dt``."""
    out = np.empty_like(lag)
    for k in range(lag.shape[0]):
        rate = 2.0 * speed[k] / strips[k, 15]
        e1, e2 = np.exp(-_B1 * rate * dt), np.exp(-_B2 * rate * dt)
        out[k, 0] = lag[k, 0] * e1 + _A1 * w34[k] * (1.0 - e1)
        out[k, 1] = lag[k, 1] * e2 + _A2 * w34[k] * (1.0 - e2)
    return out
