"""Flapping-foil physics of a fin strip, as pure maths (modified strip theory).

A strip is a 2-D section of a thin plate: chord ``c``, area ``A``, unit normal ``n``, unit
chord direction ``c_hat`` (to the geometric leading edge), pitching about its mid-chord.
The terms follow DeLaurier's modified strip theory of flapping wings (DeLaurier 1993,
"An aerodynamic model for flapping-wing flight", Aeronaut. J. 97:125-130), which keeps
the terms a quasi-steady cross-flow model lacks:

* **circulatory normal force** of attached flow, N = -1/2 rho A a U w_eff, from the
  normal velocity ``w`` of the three-quarter-chord point (Pistolesi's point: evaluating
  the downwash there gives the pitching plate's *rotational circulation*, Sane &
  Dickinson 2002's C_rot = pi (3/4 - x0_hat) with x0_hat = 1/2 for a mid-chord axis);
  ``a`` is the lift slope, 2 pi in 2-D (``helmbold_lift_slope`` for a finite plate);
* **leading-edge suction** of attached flow, S = +1/2 rho A a eta_s w_eff^2 along the
  leading edge that faces the flow: the force that makes a plunging plate's thrust
  (Garrick 1936); eta_s the suction efficiency (1 for a sharp-edged plate in theory);
* **Wagner's lag** of the circulation behind the downwash, in R. T. Jones's two-pole
  approximation of Wagner's function, Phi(s) = 1 - 0.165 e^(-0.0455 s) - 0.335 e^(-0.3 s)
  with s = 2 U t / c (``wagner_step``); its harmonic response is Jones's approximation
  of Theodorsen's C(k) (``jones_theodorsen``, ``theodorsen``);
* **separated cross-flow normal force** past stall, -1/2 rho A C_dcf |w| w, blended
  with the attached terms by the attached share f of the flow: f follows
  ``attached_fraction`` of the angle the lagged circulation sees, atan(|w_eff| / |u|),
  with the boundary layer's lag of T_f semichords (``separation_step``; Leishman &
  Beddoes 1989's separation-point lag, T_f = 3 for NACA0012), which delays stall in a
  fast stroke (dynamic stall); T_f = 0 gives the instantaneous geometric switch;
* **skin friction** on the in-plane velocity, -1/2 rho A C_f |v_t| v_t.

The strips' added mass (the reactive force of the water the plate accelerates, rho pi
c^2 / 4 per span) is not a force here: it acts through the mass matrix (added-mass
bodies), with the velocity-dependent part of Kirchhoff's equations from
``kirchhoff_plate_correction``.

Every function takes (N, 3) arrays of world-frame vectors (one row a strip) or scalars,
and none needs a plant; the tests check each against its closed form.
"""

import numpy as np

# The fins' models of HydrodynamicForces (``water.fin_model``): the quasi-steady cross-flow
# normal force of ``manta_drake.station.water``, or this module's flapping-foil strips with
# the fins' added mass as bodies.
FIN_MODELS = ("cross_flow", "foil")

# R. T. Jones's approximation of Wagner's indicial function (NACA Report 681, 1940):
# Phi(s) = 1 - sum A_i exp(-b_i s), s = 2 U t / c (distance travelled in half-chords).
WAGNER_A = (0.165, 0.335)
WAGNER_B = (0.0455, 0.3)


def theodorsen(k):
    """Theodorsen's function C(k) = H1(k) / (H1(k) + i H0(k)) (Hankel functions of the
    second kind), k = omega b / U the reduced frequency on the half-chord b
    (Theodorsen 1935, NACA Report 496). C(0) = 1, C(inf) = 1/2."""
    from scipy.special import hankel2

    k = np.asarray(k, dtype=float)
    h1, h0 = hankel2(1, k), hankel2(0, k)
    return h1 / (h1 + 1j * h0)


def jones_theodorsen(k):
    """The harmonic response of Jones's two-pole Wagner function: the C(k) the strip
    model's lag reproduces, 1 - sum A_i i k / (i k + b_i)."""
    k = np.asarray(k, dtype=float)
    return 1.0 - sum(a * 1j * k / (1j * k + b) for a, b in zip(WAGNER_A, WAGNER_B))


def garrick_plunge_thrust(rho, half_chord, omega, heave_amplitude, speed):
    """Mean thrust per span of a flat plate plunging h = h0 sin(omega t) in a stream U,
    inviscid and small-amplitude (Garrick 1936, NACA Report 567):
    T' = pi rho b omega^2 h0^2 (F^2 + G^2), with C(k) = F + i G at k = omega b / U."""
    k = omega * half_chord / speed
    c = theodorsen(k)
    return np.pi * rho * half_chord * omega**2 * heave_amplitude**2 * abs(c) ** 2


def helmbold_lift_slope(aspect_ratio):
    """Lift slope [1/rad] of a thin plate of aspect ratio AR in attached flow, Helmbold's
    formula a = 2 pi AR / (2 + sqrt(AR^2 + 4)) (Helmbold 1942; within a few % of lifting-
    surface theory for AR 1-6); 2 pi as AR -> inf."""
    ar = np.asarray(aspect_ratio, dtype=float)
    return 2.0 * np.pi * ar / (2.0 + np.sqrt(ar * ar + 4.0))


def wagner_step(x, w, speed, chord, dt):
    """One step of the circulation lag: the states x (N, 2) after ``dt`` with the normal
    velocity w (N,) and the strip speed U (N,) held over the step (exact for that).

    x_i' = -lambda_i x_i + A_i lambda_i w, lambda_i = 2 b_i U / c, so
    x_i(t + dt) = x_i e^(-lambda_i dt) + A_i w (1 - e^(-lambda_i dt)): stable for any dt.
    """
    lam = 2.0 * np.asarray(WAGNER_B)[None, :] * (np.asarray(speed) / np.asarray(chord))[:, None]
    decay = np.exp(-lam * dt)
    return x * decay + np.asarray(WAGNER_A)[None, :] * np.asarray(w)[:, None] * (1.0 - decay)


def effective_normal_velocity(x, w):
    """The lagged normal velocity the circulation sees, w_eff = (1 - A1 - A2) w + x1 + x2
    (half of a step at once, Wagner's Phi(0) = 1/2; all of it in steady flow)."""
    return (1.0 - sum(WAGNER_A)) * np.asarray(w) + np.asarray(x).sum(axis=1)


def attached_fraction(alpha, stall_angle, width):
    """Share of attached flow at the geometric angle of attack alpha in [0, pi/2]:
    1 / (1 + exp((alpha - alpha_stall) / width)), a smooth switch from the attached
    terms to the separated cross-flow force."""
    return 1.0 / (1.0 + np.exp((np.asarray(alpha) - stall_angle) / width))


def lagged_angle(w_eff, u):
    """The angle of attack the lagged circulation sees, atan(|w_eff| / |u|) in [0, pi/2]."""
    return np.arctan2(np.abs(w_eff), np.abs(u))


def separation_step(attached, alpha, speed, chord, dt, stall_angle, stall_width, lag_semichords):
    """The attached share of each strip's flow after ``dt``: first-order towards
    ``attached_fraction(alpha)`` with the time constant T_f c / (2 U) (T_f semichords of
    travel), exact for alpha and U held over the step; T_f = 0: at once."""
    target = attached_fraction(alpha, stall_angle, stall_width)
    if lag_semichords <= 0.0:
        return target
    rate = 2.0 * np.asarray(speed) / (np.asarray(chord) * lag_semichords)
    return target + (np.asarray(attached) - target) * np.exp(-rate * dt)


def strip_kinematics(v_mid, omega, normal, chord_dir, span_dir, chord):
    """The 2-D flow of each strip: the velocity of its three-quarter-chord point relative
    to the water in the chord-normal plane and its parts.

    Args:
        v_mid: (N, 3) mid-chord velocity relative to the water; omega: (N, 3) angular
            velocity of the plate; normal, chord_dir, span_dir: (N, 3) unit vectors;
            chord: (N,) chord lengths.

    Returns:
        dict with ``w`` (N,) normal velocity at 3/4 chord, ``u`` (N,) chordwise velocity
        (positive towards the geometric leading edge), ``speed`` (N,) in-plane speed,
        ``alpha`` (N,) geometric angle of attack in [0, pi/2], ``lead`` (N, 3) the unit
        chord direction of the edge facing the flow, ``v_t`` (N, 3) the velocity along the
        plate (chordwise and spanwise) for skin friction.
    """
    u_mid = (v_mid * chord_dir).sum(axis=1)
    lead = np.where(u_mid[:, None] < 0.0, -chord_dir, chord_dir)
    # The 3/4-chord point lies a quarter chord behind the mid-chord, away from the flow.
    r = -0.25 * np.asarray(chord)[:, None] * lead
    v34 = v_mid + np.cross(omega, r)
    w = (v34 * normal).sum(axis=1)
    u = (v34 * chord_dir).sum(axis=1)
    speed = np.hypot(w, u)
    alpha = np.arctan2(np.abs(w), np.abs(u))
    v_t = v_mid - (v_mid * normal).sum(axis=1)[:, None] * normal
    return {"w": w, "u": u, "speed": speed, "alpha": alpha, "lead": lead, "v_t": v_t}


def strip_forces(
    kin,
    w_eff,
    normal,
    area,
    rho,
    lift_slope,
    suction_efficiency,
    cross_flow_coefficient,
    friction_coefficient,
    stall_angle,
    stall_width,
    attached=None,
):
    """Circulatory, suction, separated and friction forces (N, 3) on strips.

    F = f [-1/2 rho A a U w_eff n + 1/2 rho A a eta_s w_eff^2 l]
        + (1 - f) [-1/2 rho A C_dcf |w| w n] - 1/2 rho A C_f |v_t| v_t,
    with f the ``attached`` share (a state: ``separation_step``), or, when None,
    ``attached_fraction`` of the geometric angle at once; l the leading edge facing the flow
    and U the in-plane speed of the three-quarter-chord point (``strip_kinematics``).
    """
    half_rho_a = 0.5 * rho * np.asarray(area)
    f = (
        attached_fraction(kin["alpha"], stall_angle, stall_width)
        if attached is None
        else np.asarray(attached)
    )
    w = kin["w"]
    normal_force = f * (-half_rho_a * lift_slope * kin["speed"] * w_eff) + (1.0 - f) * (
        -half_rho_a * cross_flow_coefficient * np.abs(w) * w
    )
    suction = f * half_rho_a * lift_slope * suction_efficiency * w_eff * w_eff
    v_t = kin["v_t"]
    friction = -(half_rho_a * friction_coefficient * np.linalg.norm(v_t, axis=1))[:, None] * v_t
    return normal_force[:, None] * normal + suction[:, None] * kin["lead"] + friction


def kirchhoff_plate_force(mass, normal, v_rel, a_rel, omega):
    """Kirchhoff's force and moment on a thin plate whose only added mass is ``mass`` along
    its normal (potential flow; Lamb 1932, art. 124; Fossen 2011 eq. 6.50), about the
    point whose velocity relative to the water is v_rel and acceleration a_rel:

        F = -m (d/dt q) n - m q (omega x n),  T = -m q (v_rel x n),  q = v_rel . n,

    with d/dt q = a_rel . n + v_rel . (omega x n). World-frame (N, 3) rows. The reference
    the mass-matrix part plus ``kirchhoff_plate_correction`` must add up to."""
    n_dot = np.cross(omega, normal)
    q = (v_rel * normal).sum(axis=1)
    q_dot = (a_rel * normal).sum(axis=1) + (v_rel * n_dot).sum(axis=1)
    force = -(mass * q_dot)[:, None] * normal - (mass * q)[:, None] * n_dot
    torque = -(mass * q)[:, None] * np.cross(v_rel, normal)
    return force, torque


def kirchhoff_plate_correction(mass, normal, v_rel, v_slider_rel, omega):
    """The velocity-dependent part of Kirchhoff's plate force that a mass ``mass`` riding
    the plate on a joint free in the plate's plane does not give (``kirchhoff_plate_force``
    minus the slider's reaction -m (a_slider . n) n), as a force and moment (N, 3) on the
    plate at the slider's point:

        F = -m (v_slider_rel . n_dot) n - m q n_dot,  T = -m q (v_rel x n),

    with n_dot = omega x n, q = v_rel . n. It holds velocities only (no acceleration), so
    an explicit step of it stays stable where an explicit -m a does not."""
    n_dot = np.cross(omega, normal)
    q = (v_rel * normal).sum(axis=1)
    s = (v_slider_rel * n_dot).sum(axis=1)
    force = -(mass * s)[:, None] * normal - (mass * q)[:, None] * n_dot
    torque = -(mass * q)[:, None] * np.cross(v_rel, normal)
    return force, torque


def strip_wrenches(R, w, v, current, strips: dict, frac, lag, params: dict, attached=None):
    """Every strip's force from its body's pose and velocity, summed per body: the numpy
    reference of ``foil_kernels.strip_wrenches``.

    Args:
        R, w, v: (nb, 3, 3), (nb, 3), (nb, 3) body orientations, angular and origin
            velocities in the world; current: (3,) the water's velocity.
        strips: ``body``, ``element`` (ns,) ints, ``p``, ``normal``, ``chord_dir``,
            ``span_dir`` (ns, 3) in the body frame, ``area``, ``chord`` (ns,).
        frac: (ne,) submerged fraction of each volume element (scales its strip).
        lag: (ns, 2) Wagner states.
        params: ``rho``, ``lift_slope``, ``suction_efficiency``, ``cross_flow_coefficient``,
            ``friction_coefficient``, ``stall_angle``, ``stall_width`` (and
            ``separation_lag``, read by the state's step).
        attached: (ns,) the attached shares (a state), or None: the geometric switch.

    Returns:
        (S (nb, 6) [tau_W, f_W] about each body origin, w34 (ns,), speed (ns,), the lagged
        angle (ns,)).
    """
    b = strips["body"]
    Rs = R[b]
    rot = lambda x: np.matmul(Rs, x[:, :, None])[:, :, 0]  # noqa: E731
    r = rot(strips["p"])
    n = rot(strips["normal"])
    v_mid = v[b] + np.cross(w[b], r) - current
    kin = strip_kinematics(
        v_mid, w[b], n, rot(strips["chord_dir"]), rot(strips["span_dir"]), strips["chord"]
    )
    w_eff = effective_normal_velocity(lag, kin["w"])
    f = strip_forces(
        kin,
        w_eff,
        n,
        strips["area"],
        params["rho"],
        params["lift_slope"],
        params["suction_efficiency"],
        params["cross_flow_coefficient"],
        params["friction_coefficient"],
        params["stall_angle"],
        params["stall_width"],
        attached,
    )
    f = f * np.asarray(frac)[strips["element"]][:, None]
    to_body = np.eye(len(R))[:, b]
    return (
        to_body @ np.concatenate([np.cross(r, f), f], axis=1),
        kin["w"],
        kin["speed"],
        lagged_angle(w_eff, kin["u"]),
    )


def prescribed_motion_forces(
    dt, v_mid, omega, normal, chord_dir, span_dir, area, chord, params: dict
):
    """The strip model driven by a prescribed motion (no plant): the forces on each strip
    at each time step, the Wagner lag integrated along (the same terms and order as a
    simulation step: forces from the states, then ``wagner_step`` over ``dt``).

    Args:
        dt: the time step [s] of the series.
        v_mid, omega, normal, chord_dir, span_dir: (nt, ns, 3) each strip's mid-chord
            velocity relative to the water, angular velocity and unit axes, per step.
        area, chord: (ns,).
        params: as ``strip_wrenches``'s; with ``separation_lag`` (T_f semichords) the
            attached share is a state (from 1, ``separation_step``), else the geometric
            switch at once.

    Returns:
        (nt, ns, 3) forces [N] in the world.
    """
    nt, ns = v_mid.shape[:2]
    lag = np.zeros((ns, 2))
    lagged = "separation_lag" in params
    attached = np.ones(ns) if lagged else None
    out = np.empty((nt, ns, 3))
    for i in range(nt):
        kin = strip_kinematics(v_mid[i], omega[i], normal[i], chord_dir[i], span_dir[i], chord)
        w_eff = effective_normal_velocity(lag, kin["w"])
        out[i] = strip_forces(
            kin,
            w_eff,
            normal[i],
            area,
            params["rho"],
            params["lift_slope"],
            params["suction_efficiency"],
            params["cross_flow_coefficient"],
            params["friction_coefficient"],
            params["stall_angle"],
            params["stall_width"],
            attached,
        )
        if lagged:
            attached = separation_step(
                attached,
                lagged_angle(w_eff, kin["u"]),
                kin["speed"],
                chord,
                dt,
                params["stall_angle"],
                params["stall_width"],
                params["separation_lag"],
            )
        lag = wagner_step(lag, kin["w"], kin["speed"], chord, dt)
    return out


def added_mass_body_wrenches(
    R,
    p,
    w,
    v,
    current,
    bodies: dict,
    plate_fraction,
    a_normal,
    centring_frequency: float,
    centring_damping: float,
):
    """The forces that complete the fins' added-mass bodies (``model.plant``'s planar-joint
    bodies, one per plate), as wrench rows to add, and each body's normal velocity.

    * On each body alone, a spring-damper that keeps it at its plate's centre and its
      frame aligned, k = m omega_c^2, c = 2 zeta m omega_c (and I_n for the rotation
      about the normal): the planar joint passes none of it to the plate.
    * On each plate at the body's point, Kirchhoff's velocity terms
      (``kirchhoff_plate_correction``), scaled by the plate's submerged fraction s.
    * On each plate, the emerged share of the body's reaction given back,
      +(1 - s) m (a . n) n, from the body's normal acceleration ``a_normal`` estimated
      over the last step (NaN: not yet known, nothing applied): a plate in air moves no
      water. Explicit, so stable while (1 - s) m stays below the plate's effective mass
      with the body (m + the plate's own): always, as s >= 0.

    Args:
        R, p, w, v: (nb, 3, 3), (nb, 3) x 3 poses and velocities of all bodies (world).
        current: (3,) the water's velocity.
        bodies: ``body``, ``plate`` (nm,) rows of each added-mass body and its plate,
            ``mass``, ``inertia_normal`` (nm,), ``R_PF`` (nm, 3, 3) and ``p_PF`` (nm, 3)
            the joint frame on the plate.
        plate_fraction: (nm,) the plate's submerged fraction.
        a_normal: (nm,) a . n of each body [m/s^2] or NaN.
        centring_frequency: omega_c [rad/s]; centring_damping: zeta.

    Returns:
        (F (nb, 6) rows [tau_W, f_W] about each body origin, q (nm,) v_body . n).
    """
    plate, body = bodies["plate"], bodies["body"]
    m, i_n = bodies["mass"], bodies["inertia_normal"]
    R_WF = np.matmul(R[plate], bodies["R_PF"])
    origin = p[plate] + np.matmul(R[plate], bodies["p_PF"][:, :, None])[:, :, 0]
    n = R_WF[:, :, 2]
    p_s, v_s = p[body], v[body]
    r_plate = p_s - p[plate]
    v_point = v[plate] + np.cross(w[plate], r_plate)
    to_F = lambda x: np.matmul(np.swapaxes(R_WF, 1, 2), x[:, :, None])[:, :, 0]  # noqa: E731
    offset, drift = to_F(p_s - origin), to_F(v_s - v_point)
    M = np.matmul(np.swapaxes(R_WF, 1, 2), R[body])
    theta = np.arctan2(M[:, 1, 0], M[:, 0, 0])
    theta_rate = ((w[body] - w[plate]) * n).sum(axis=1)
    k, c = centring_frequency**2, 2.0 * centring_damping * centring_frequency
    f_F = np.zeros_like(offset)
    f_F[:, :2] = -(m[:, None] * (k * offset[:, :2] + c * drift[:, :2]))
    tau = -(i_n * (k * theta + c * theta_rate))[:, None] * n
    F = np.zeros((len(R), 6))
    np.add.at(F, body, np.concatenate([tau, np.matmul(R_WF, f_F[:, :, None])[:, :, 0]], axis=1))
    s = np.asarray(plate_fraction, dtype=float)
    f_c, t_c = kirchhoff_plate_correction(m, n, v_point - current, v_s - current, w[plate])
    emerged = np.where(np.isnan(a_normal), 0.0, (1.0 - s) * m * np.nan_to_num(a_normal))
    f_plate = s[:, None] * f_c + emerged[:, None] * n
    t_plate = s[:, None] * t_c + np.cross(r_plate, f_plate)
    np.add.at(F, plate, np.concatenate([t_plate, f_plate], axis=1))
    return F, (v_s * n).sum(axis=1)


def added_mass_normal_acceleration(R, w, v, bodies: dict, q_prev, t_prev: float, t: float):
    """Each added-mass body's normal acceleration a . n = d/dt (v . n) - v . (omega x n)
    over the last step, from its normal velocity ``q_prev`` at ``t_prev`` (the plate's
    angular velocity turns n); NaN where no earlier sample exists (t_prev < 0 or not
    before t)."""
    body, plate = bodies["body"], bodies["plate"]
    n = R[body][:, :, 2]
    q = (v[body] * n).sum(axis=1)
    if not 0.0 <= t_prev < t - 1e-12:
        return np.full(len(body), np.nan)
    n_dot = np.cross(w[plate], n)
    return (q - q_prev) / (t - t_prev) - (v[body] * n_dot).sum(axis=1)
