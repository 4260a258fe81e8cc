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
F_LAG = 10  # the separation lag T_f [semichords]
NUM_FOIL_PARAMS = 11
_A1, _A2 = WAGNER_A
_B1, _B2 = WAGNER_B


def pack_strips(body, element, p, normal, chord_dir, span_dir, area, chord) -> np.ndarray:
    """The strips as one float table (rows: see the module docstring)."""
    table = np.column_stack([body, element, p, normal, chord_dir, span_dir, area, chord])
    return np.ascontiguousarray(table, dtype=float)


def pack_foil_params(
    rho,
    lift_slope,
    suction_efficiency,
    cross_flow_coefficient,
    friction_coefficient,
    stall_angle,
    stall_width,
    current,
    separation_lag=0.0,
) -> np.ndarray:
    """The strip model's parameters as one float vector (layout: the F_* indices)."""
    prm = np.empty(NUM_FOIL_PARAMS)
    prm[:7] = (
        rho,
        lift_slope,
        suction_efficiency,
        cross_flow_coefficient,
        friction_coefficient,
        stall_angle,
        stall_width,
    )
    prm[F_CURRENT : F_CURRENT + 3] = current
    prm[F_LAG] = separation_lag
    return prm


@njit(cache=True)
def _rot(Rb, x0, x1, x2):
    return (
        Rb[0, 0] * x0 + Rb[0, 1] * x1 + Rb[0, 2] * x2,
        Rb[1, 0] * x0 + Rb[1, 1] * x1 + Rb[1, 2] * x2,
        Rb[2, 0] * x0 + Rb[2, 1] * x1 + Rb[2, 2] * x2,
    )


@njit(cache=True)
def strip_wrenches(R, w, v, strips, frac, lag, prm, attached):
    """Every strip's ``foil.strip_forces`` with ``foil.strip_kinematics``, the lagged
    normal velocity from the states ``lag`` (ns, 2) and the attached shares ``attached``
    (ns,), scaled by its element's submerged fraction ``frac`` and summed per body.

    Args:
        R, w, v: (nb, 3, 3), (nb, 3), (nb, 3) body orientations, angular and origin
            velocities in the world.

    Returns:
        (S (nb, 6) [tau_W, f_W] about each body origin, w34 (ns,), speed (ns,), the angle
        the lagged circulation sees (ns,)).
    """
    nb, ns = R.shape[0], strips.shape[0]
    rho, slope, eta = prm[F_RHO], prm[F_SLOPE], prm[F_SUCTION]
    c_dcf, c_f = prm[F_CDCF], prm[F_CF]
    cur0, cur1, cur2 = prm[F_CURRENT], prm[F_CURRENT + 1], prm[F_CURRENT + 2]
    S = np.zeros((nb, 6))
    w34 = np.empty(ns)
    speed = np.empty(ns)
    alpha_lag = np.empty(ns)
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
        w_eff = (1.0 - _A1 - _A2) * wn + lag[k, 0] + lag[k, 1]
        alpha_lag[k] = np.arctan2(abs(w_eff), abs(uc))
        f_att = attached[k]
        half_rho_a = 0.5 * rho * area
        fn = f_att * (-half_rho_a * slope * spd * w_eff) + (1.0 - f_att) * (
            -half_rho_a * c_dcf * abs(wn) * wn
        )
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
    return S, w34, speed, alpha_lag


@njit(cache=True)
def separation_step(attached, alpha, speed, strips, dt, prm):
    """``foil.separation_step`` for every strip: the attached shares after ``dt``."""
    out = np.empty_like(attached)
    stall, width, lag_semichords = prm[F_STALL], prm[F_WIDTH], prm[F_LAG]
    for k in range(attached.shape[0]):
        target = 1.0 / (1.0 + np.exp((alpha[k] - stall) / width))
        if lag_semichords <= 0.0:
            out[k] = target
        else:
            rate = 2.0 * speed[k] / (strips[k, 15] * lag_semichords)
            out[k] = target + (attached[k] - target) * np.exp(-rate * dt)
    return out


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


def pack_added_mass_bodies(body, plate, mass, inertia_normal, R_PF, p_PF) -> np.ndarray:
    """The added-mass bodies as one float table: [body, plate, m, I_n, R_PF (9, row-major),
    p_PF (3)] per row."""
    table = np.column_stack(
        [body, plate, mass, inertia_normal, np.asarray(R_PF).reshape(-1, 9), p_PF]
    )
    return np.ascontiguousarray(table, dtype=float)


@njit(cache=True)
def added_mass_body_wrenches(
    R, p, w, v, current, bodies, plate_fraction, a_normal, centring_frequency, centring_damping
):
    """``foil.added_mass_body_wrenches`` compiled: (F (nb, 6), q (nm,))."""
    nb, nm = R.shape[0], bodies.shape[0]
    F = np.zeros((nb, 6))
    q = np.empty(nm)
    k = centring_frequency * centring_frequency
    c = 2.0 * centring_damping * centring_frequency
    R_WF = np.empty((3, 3))
    for j in range(nm):
        s_row, b = int(bodies[j, 0]), int(bodies[j, 1])
        m, i_n = bodies[j, 2], bodies[j, 3]
        R_PF = bodies[j, 4:13].reshape(3, 3)
        for a in range(3):
            for e in range(3):
                R_WF[a, e] = (
                    R[b, a, 0] * R_PF[0, e] + R[b, a, 1] * R_PF[1, e] + R[b, a, 2] * R_PF[2, e]
                )
        o0, o1, o2 = _rot(R[b], bodies[j, 13], bodies[j, 14], bodies[j, 15])
        o0, o1, o2 = p[b, 0] + o0, p[b, 1] + o1, p[b, 2] + o2
        n0, n1, n2 = R_WF[0, 2], R_WF[1, 2], R_WF[2, 2]
        r0, r1, r2 = p[s_row, 0] - p[b, 0], p[s_row, 1] - p[b, 1], p[s_row, 2] - p[b, 2]
        wb0, wb1, wb2 = w[b, 0], w[b, 1], w[b, 2]
        vp0 = v[b, 0] + (wb1 * r2 - wb2 * r1)
        vp1 = v[b, 1] + (wb2 * r0 - wb0 * r2)
        vp2 = v[b, 2] + (wb0 * r1 - wb1 * r0)
        vs0, vs1, vs2 = v[s_row, 0], v[s_row, 1], v[s_row, 2]
        d0, d1, d2 = p[s_row, 0] - o0, p[s_row, 1] - o1, p[s_row, 2] - o2
        u0, u1, u2 = vs0 - vp0, vs1 - vp1, vs2 - vp2
        # Centring, in F's x and y, on the body alone.
        fx = -m * (
            k * (R_WF[0, 0] * d0 + R_WF[1, 0] * d1 + R_WF[2, 0] * d2)
            + c * (R_WF[0, 0] * u0 + R_WF[1, 0] * u1 + R_WF[2, 0] * u2)
        )
        fy = -m * (
            k * (R_WF[0, 1] * d0 + R_WF[1, 1] * d1 + R_WF[2, 1] * d2)
            + c * (R_WF[0, 1] * u0 + R_WF[1, 1] * u1 + R_WF[2, 1] * u2)
        )
        # The body's rotation about the normal relative to F: M = R_WF^T R_body.
        Rs = R[s_row]
        m00 = R_WF[0, 0] * Rs[0, 0] + R_WF[1, 0] * Rs[1, 0] + R_WF[2, 0] * Rs[2, 0]
        m10 = R_WF[0, 1] * Rs[0, 0] + R_WF[1, 1] * Rs[1, 0] + R_WF[2, 1] * Rs[2, 0]
        theta = np.arctan2(m10, m00)
        rate = (w[s_row, 0] - wb0) * n0 + (w[s_row, 1] - wb1) * n1 + (w[s_row, 2] - wb2) * n2
        tq = -i_n * (k * theta + c * rate)
        F[s_row, 0] += tq * n0
        F[s_row, 1] += tq * n1
        F[s_row, 2] += tq * n2
        F[s_row, 3] += R_WF[0, 0] * fx + R_WF[0, 1] * fy
        F[s_row, 4] += R_WF[1, 0] * fx + R_WF[1, 1] * fy
        F[s_row, 5] += R_WF[2, 0] * fx + R_WF[2, 1] * fy
        # Kirchhoff's velocity terms on the plate (foil.kirchhoff_plate_correction).
        nd0, nd1, nd2 = wb1 * n2 - wb2 * n1, wb2 * n0 - wb0 * n2, wb0 * n1 - wb1 * n0
        e0, e1, e2 = vp0 - current[0], vp1 - current[1], vp2 - current[2]
        qr = e0 * n0 + e1 * n1 + e2 * n2
        sv = (vs0 - current[0]) * nd0 + (vs1 - current[1]) * nd1 + (vs2 - current[2]) * nd2
        frac = plate_fraction[j]
        an = a_normal[j]
        emerged = 0.0 if np.isnan(an) else (1.0 - frac) * m * an
        f0 = frac * (-m * sv * n0 - m * qr * nd0) + emerged * n0
        f1 = frac * (-m * sv * n1 - m * qr * nd1) + emerged * n1
        f2 = frac * (-m * sv * n2 - m * qr * nd2) + emerged * n2
        # -m q (v x n), scaled, plus the moment of the force at the body's point.
        c0, c1, c2 = e1 * n2 - e2 * n1, e2 * n0 - e0 * n2, e0 * n1 - e1 * n0
        F[b, 0] += -frac * m * qr * c0 + (r1 * f2 - r2 * f1)
        F[b, 1] += -frac * m * qr * c1 + (r2 * f0 - r0 * f2)
        F[b, 2] += -frac * m * qr * c2 + (r0 * f1 - r1 * f0)
        F[b, 3] += f0
        F[b, 4] += f1
        F[b, 5] += f2
        q[j] = vs0 * n0 + vs1 * n1 + vs2 * n2
    return F, q


@njit(cache=True)
def added_mass_normal_acceleration(R, w, v, bodies, q_prev, t_prev, t):
    """``foil.added_mass_normal_acceleration`` compiled."""
    nm = bodies.shape[0]
    a = np.empty(nm)
    known = 0.0 <= t_prev < t - 1e-12
    for j in range(nm):
        s, b = int(bodies[j, 0]), int(bodies[j, 1])
        n0, n1, n2 = R[s, 0, 2], R[s, 1, 2], R[s, 2, 2]
        if not known:
            a[j] = np.nan
            continue
        q = v[s, 0] * n0 + v[s, 1] * n1 + v[s, 2] * n2
        wb0, wb1, wb2 = w[b, 0], w[b, 1], w[b, 2]
        nd0, nd1, nd2 = wb1 * n2 - wb2 * n1, wb2 * n0 - wb0 * n2, wb0 * n1 - wb1 * n0
        a[j] = (q - q_prev[j]) / (t - t_prev) - (v[s, 0] * nd0 + v[s, 1] * nd1 + v[s, 2] * nd2)
    return a


@njit(cache=True)
def add_foil_forces(
    F,
    R,
    p,
    w,
    v,
    frac,
    current,
    t,
    strips,
    prm,
    lag,
    attached,
    bodies,
    weights,
    prev,
    centring_frequency,
    centring_damping,
):
    """The foil model's terms added to the water's other forces F (``spatial_wrenches``,
    whose element fractions ``frac`` it filled): the strips' forces, and the added-mass
    bodies' (their plates' submerged fraction the mean of the plate's strips' elements,
    ``weights`` (nm, ne); their normal acceleration from ``prev`` = [q (nm), t])."""
    fp = prm.copy()
    fp[F_CURRENT : F_CURRENT + 3] = current
    S, _, _, _ = strip_wrenches(R, w, v, strips, frac, lag, fp, attached)
    nm = bodies.shape[0]
    a_n = added_mass_normal_acceleration(R, w, v, bodies, prev[:nm], prev[nm], t)
    A, _ = added_mass_body_wrenches(
        R, p, w, v, current, bodies, weights @ frac, a_n, centring_frequency, centring_damping
    )
    return F + S + A


@njit(cache=True)
def foil_state_step(R, w, v, current, strips, prm, lag, attached, bodies, dt):
    """The foil model's discrete state after one period ``dt``: the strips' Wagner states
    (``lag_step``) and attached shares (``separation_step``), and each added-mass body's
    normal velocity v . n (its next ``prev``)."""
    fp = prm.copy()
    fp[F_CURRENT : F_CURRENT + 3] = current
    ones = np.ones(int(strips[:, 1].max()) + 1 if strips.shape[0] else 0)
    _, w34, speed, alpha = strip_wrenches(R, w, v, strips, ones, lag, fp, attached)
    nm = bodies.shape[0]
    q = np.empty(nm)
    for j in range(nm):
        s = int(bodies[j, 0])
        q[j] = v[s, 0] * R[s, 0, 2] + v[s, 1] * R[s, 1, 2] + v[s, 2] * R[s, 2, 2]
    return (
        lag_step(lag, w34, speed, strips, dt),
        separation_step(attached, alpha, speed, strips, dt, fp),
        q,
    )
