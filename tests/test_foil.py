"""The fin strip's flapping-foil terms against their closed forms (no plant)."""

import numpy as np
import pytest

from manta_drake.station.foil import (
    WAGNER_A,
    WAGNER_B,
    attached_fraction,
    effective_normal_velocity,
    garrick_plunge_thrust,
    helmbold_lift_slope,
    jones_theodorsen,
    kirchhoff_plate_correction,
    kirchhoff_plate_force,
    prescribed_motion_forces,
    separation_step,
    strip_forces,
    strip_kinematics,
    theodorsen,
    wagner_step,
)

RHO = 1000.0
X, Y, Z = np.eye(3)


def test_theodorsen_against_the_published_table():
    """F and G of Theodorsen (1935, NACA Report 496), as tabulated by Bisplinghoff,
    Ashley & Halfman (1955, table 5-1)."""
    table = {
        0.1: (0.8319, -0.1723),
        0.2: (0.7276, -0.1886),
        0.5: (0.5979, -0.1507),
        1.0: (0.5394, -0.1003),
    }
    for k, (f, g) in table.items():
        c = theodorsen(k)
        assert (c.real, c.imag) == pytest.approx((f, g), abs=1.5e-4), k
    assert theodorsen(1e-6).real == pytest.approx(1.0, abs=1e-4)
    assert abs(theodorsen(1e4) - 0.5) < 1e-4


def test_jones_approximation_is_within_two_percent_of_theodorsen():
    k = np.geomspace(0.02, 10.0, 60)
    assert np.max(np.abs(jones_theodorsen(k) - theodorsen(k))) < 0.02


def test_wagner_step_response_is_jones_indicial_function_for_any_step_size():
    """w steps from 0 to 1 at t = 0: w_eff(t) = Phi(s) = 1 - sum A_i exp(-b_i s),
    s = 2 U t / c, whatever the steps taken to get there."""
    U, c = 0.4, 0.12
    rng = np.random.default_rng(3)
    x, t = np.zeros((1, 2)), 0.0
    for dt in rng.uniform(1e-4, 0.05, 40):
        x = wagner_step(x, np.ones(1), np.full(1, U), np.full(1, c), dt)
        t += dt
        s = 2 * U * t / c
        phi = 1 - sum(a * np.exp(-b * s) for a, b in zip(WAGNER_A, WAGNER_B))
        assert effective_normal_velocity(x, np.ones(1))[0] == pytest.approx(phi, rel=1e-12)
    assert effective_normal_velocity(np.zeros((1, 2)), np.ones(1))[0] == 0.5  # Phi(0)


@pytest.mark.slow
def test_harmonic_response_of_the_lag_is_its_frequency_response():
    """Driven by w = sin(omega t), the lag settles to |C| sin(omega t + arg C) with
    C = jones_theodorsen(k), k = omega c / (2 U): a time-domain run against the
    frequency-domain formula (one strip per k)."""
    k = np.array([0.3, 1.0, 3.0])
    c, dt = np.full(3, 0.12), 1e-3
    omega = np.full(3, 2 * np.pi)  # 1 Hz; U sets k
    U = omega * c / (2 * k)
    t = np.arange(0.0, 80.0, dt)  # the slowest lag (k = 3) decays as exp(-t / 10.5 s)
    x, out = np.zeros((3, 2)), np.empty((len(t), 3))
    for i, ti in enumerate(t):
        out[i] = effective_normal_velocity(x, np.sin(omega * ti))
        x = wagner_step(x, np.sin(omega * (ti + 0.5 * dt)), U, c, dt)  # held over the step
    tail = t > t[-1] - 10.0
    basis = np.column_stack([np.sin(2 * np.pi * t[tail]), np.cos(2 * np.pi * t[tail])])
    fit = np.linalg.lstsq(basis, out[tail], rcond=None)[0]
    np.testing.assert_allclose(fit[0] + 1j * fit[1], jones_theodorsen(k), atol=3e-3)


def _plunge_mean_thrust(k, U=0.3, c=0.12, h0=0.002, cycles=30, steps=400):
    """The strip model of a 2-D plate plunging h0 sin(omega t) at speed U, attached flow,
    inviscid: its mean thrust per span over the last 10 cycles."""
    omega = 2 * U * k / c
    dt = 2 * np.pi / omega / steps
    t = np.arange(cycles * steps) * dt
    nt = len(t)
    v = np.zeros((nt, 1, 3))
    v[:, 0, 0], v[:, 0, 2] = U, h0 * omega * np.cos(omega * t)
    axes = [np.broadcast_to(e, (nt, 1, 3)) for e in (Z, X, Y)]
    params = {
        "rho": RHO,
        "lift_slope": 2 * np.pi,
        "suction_efficiency": 1.0,
        "cross_flow_coefficient": 1.17,
        "friction_coefficient": 0.0,
        "stall_angle": np.pi / 2,
        "stall_width": 1e-3,
    }
    f = prescribed_motion_forces(
        dt, v, np.zeros((nt, 1, 3)), *axes, np.full(1, c), np.full(1, c), params
    )
    return f[-10 * steps :, 0, 0].mean(), omega


@pytest.mark.slow
@pytest.mark.parametrize("k", [0.5, 1.0, 2.0])
def test_plunging_plate_thrust_is_garricks(k):
    """Small-amplitude pure plunge: Garrick's (1936) inviscid thrust pi rho b omega^2 h0^2
    |C(k)|^2. With the C(k) of Jones's lag the time-domain strip model gives it to 0.5 %;
    against Theodorsen's exact C(k) Jones's approximation is 1.5-4.1 % low in |C|^2 over
    these k (4.1 % at k = 1)."""
    U, c, h0 = 0.3, 0.12, 0.002
    mean, omega = _plunge_mean_thrust(k, U, c, h0)
    garrick = garrick_plunge_thrust(RHO, c / 2, omega, h0, U)
    with_jones = garrick / abs(theodorsen(k)) ** 2 * abs(jones_theodorsen(k)) ** 2
    assert mean == pytest.approx(with_jones, rel=0.005)
    assert mean == pytest.approx(garrick, rel=0.045)
    assert mean < np.pi * RHO * c / 2 * omega**2 * h0**2  # the lag always costs thrust


def test_pitching_about_mid_chord_gives_sane_and_dickinsons_rotational_force():
    """Translating at zero incidence and pitching at rate q about the mid-chord: the
    normal force per span is C_rot rho U c^2 q with C_rot = pi (3/4 - 1/2) for a 2-D
    plate (Sane & Dickinson 2002, eq. 5; Fung 1969)."""
    U, c, q = 0.5, 0.1, 0.4
    omega = np.array([[0.0, q, 0.0]])  # nose (+x) down: the 3/4-chord point rises
    kin = strip_kinematics(
        np.array([[U, 0.0, 0.0]]), omega, Z[None], X[None], Y[None], np.full(1, c)
    )
    assert kin["w"][0] == pytest.approx(0.25 * c * q)
    f = strip_forces(
        kin, kin["w"], Z[None], np.full(1, c), RHO, 2 * np.pi, 1.0, 1.17, 0.0, np.pi / 2, 1e-3
    )
    assert abs(f[0, 2]) == pytest.approx(np.pi * 0.25 * RHO * U * c * c * q, rel=1e-3)


def test_broadside_motion_is_the_cross_flow_drag_and_stall_blends_smoothly():
    w, c, cd = 0.4, 0.1, 1.17
    kin = strip_kinematics(
        np.array([[0.0, 0.0, w]]), np.zeros((1, 3)), Z[None], X[None], Y[None], np.full(1, c)
    )
    assert kin["alpha"][0] == pytest.approx(np.pi / 2)
    f = strip_forces(
        kin,
        kin["w"],
        Z[None],
        np.full(1, c),
        RHO,
        2 * np.pi,
        1.0,
        cd,
        0.0,
        np.radians(15),
        np.radians(3),
    )
    np.testing.assert_allclose(f[0], [0.0, 0.0, -0.5 * RHO * c * cd * w * w], rtol=1e-6, atol=1e-8)
    alpha = np.radians([0.0, 15.0, 90.0])
    share = attached_fraction(alpha, np.radians(15), np.radians(3))
    assert share[0] > 0.99 and share[1] == 0.5 and share[2] < 1e-9


def test_skin_friction_opposes_the_in_plane_velocity():
    v = np.array([[0.3, 0.4, 0.0]])
    kin = strip_kinematics(v, np.zeros((1, 3)), Z[None], X[None], Y[None], np.full(1, 0.1))
    f = strip_forces(
        kin,
        kin["w"],
        Z[None],
        np.full(1, 0.05),
        RHO,
        2 * np.pi,
        1.0,
        1.17,
        0.01,
        np.radians(15),
        np.radians(3),
    )
    np.testing.assert_allclose(f[0], -0.5 * RHO * 0.05 * 0.01 * 0.5 * v[0], atol=1e-12)


def test_helmbold_slope_limits():
    """2 pi for an infinite span; pi AR / 2 for a slender plate (R. T. Jones 1946)."""
    assert helmbold_lift_slope(1e6) == pytest.approx(2 * np.pi, rel=1e-5)
    assert helmbold_lift_slope(1e-3) == pytest.approx(np.pi * 1e-3 / 2, rel=1e-3)


def test_kirchhoff_steady_translation_has_no_force_and_munks_moment():
    """A plate gliding at incidence alpha in still water: no force (d'Alembert), and the
    moment m U^2 sin(alpha) cos(alpha) that turns it broadside (Munk)."""
    m, U, alpha = 2.0, 0.5, np.radians(20)
    v = np.array([[U * np.cos(alpha), 0.0, -U * np.sin(alpha)]])
    force, torque = kirchhoff_plate_force(
        np.full(1, m), Z[None], v, np.zeros((1, 3)), np.zeros((1, 3))
    )
    np.testing.assert_allclose(force, 0.0, atol=1e-15)
    assert np.linalg.norm(torque) == pytest.approx(m * U * U * np.sin(alpha) * np.cos(alpha))


def test_slider_reaction_plus_correction_is_kirchhoffs_force():
    """The added-mass body rides the plate free in its plane: its reaction on the plate is
    -m (a_slider . n) n with a_slider . n = d/dt(v . n) - v_slider . n_dot. With the
    correction the sum is Kirchhoff's force, for any slider velocity."""
    rng = np.random.default_rng(7)
    n = rng.normal(size=(20, 3))
    n /= np.linalg.norm(n, axis=1)[:, None]
    v, a, omega, v_slider = (rng.normal(size=(20, 3)) for _ in range(4))
    v_slider -= (v_slider * n).sum(axis=1)[:, None] * n
    v_slider += (v * n).sum(axis=1)[:, None] * n  # same normal velocity as the plate
    m = rng.uniform(0.1, 3.0, 20)
    n_dot = np.cross(omega, n)
    q_dot = (a * n).sum(axis=1) + (v * n_dot).sum(axis=1)
    reaction = -(m * (q_dot - (v_slider * n_dot).sum(axis=1)))[:, None] * n
    f_corr, t_corr = kirchhoff_plate_correction(m, n, v, v_slider, omega)
    f_ref, t_ref = kirchhoff_plate_force(m, n, v, a, omega)
    np.testing.assert_allclose(reaction + f_corr, f_ref, atol=1e-12)
    np.testing.assert_allclose(t_corr, t_ref, atol=1e-12)


def test_compiled_strip_wrenches_and_lag_equal_the_numpy_reference():
    from scipy.spatial.transform import Rotation

    from manta_drake.station import foil
    from manta_drake.station import foil_kernels as FK

    rng = np.random.default_rng(11)
    nb, ns, ne = 5, 12, 15
    R = Rotation.random(nb, random_state=3).as_matrix()
    w, v = rng.normal(size=(nb, 3)), rng.normal(size=(nb, 3)) * 0.5
    normal = np.tile(X, (ns, 1))
    chord_dir = np.where(rng.uniform(size=(ns, 1)) < 0.5, Y, -Y)
    strips = {
        "body": rng.integers(0, nb, ns),
        "element": rng.integers(0, ne, ns),
        "p": rng.normal(size=(ns, 3)) * 0.1,
        "normal": normal,
        "chord_dir": chord_dir,
        "span_dir": np.tile(Z, (ns, 1)),
        "area": rng.uniform(0.001, 0.01, ns),
        "chord": rng.uniform(0.08, 0.15, ns),
    }
    params = {
        "rho": RHO,
        "lift_slope": 3.2,
        "suction_efficiency": 0.8,
        "cross_flow_coefficient": 1.17,
        "friction_coefficient": 0.015,
        "stall_angle": np.radians(15),
        "stall_width": np.radians(3),
    }
    current = np.array([0.1, -0.05, 0.02])
    frac, lag = rng.uniform(size=ne), rng.normal(size=(ns, 2)) * 0.1
    attached = rng.uniform(size=ns)
    S, w34, speed, alpha = foil.strip_wrenches(
        R, w, v, current, strips, frac, lag, params, attached
    )
    packed = FK.pack_strips(
        strips["body"],
        strips["element"],
        strips["p"],
        normal,
        chord_dir,
        strips["span_dir"],
        strips["area"],
        strips["chord"],
    )
    prm = FK.pack_foil_params(**params, current=current, separation_lag=3.0)
    S_k, w34_k, speed_k, alpha_k = FK.strip_wrenches(R, w, v, packed, frac, lag, prm, attached)
    np.testing.assert_allclose(S_k, S, rtol=1e-12, atol=1e-12)
    for got, expected in ((w34_k, w34), (speed_k, speed), (alpha_k, alpha)):
        np.testing.assert_allclose(got, expected, rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose(
        FK.lag_step(lag, w34, speed, packed, 1e-3),
        wagner_step(lag, w34, speed, strips["chord"], 1e-3),
        rtol=1e-12,
        atol=1e-15,
    )
    np.testing.assert_allclose(
        FK.separation_step(attached, alpha, speed, packed, 1e-3, prm),
        separation_step(
            attached,
            alpha,
            speed,
            strips["chord"],
            1e-3,
            params["stall_angle"],
            params["stall_width"],
            3.0,
        ),
        rtol=1e-12,
        atol=1e-15,
    )


def _one_plate(U=0.4, alpha=np.radians(25)):
    """A plate (row 0, normal z) gliding at incidence alpha, its added-mass body (row 1)
    centred and aligned on it, in still water."""
    from manta_drake.station.foil import added_mass_body_wrenches  # noqa: F401

    R = np.stack([np.eye(3), np.eye(3)])
    p = np.array([[0.0, 0.0, 0.0], [0.0, 0.0, 0.0]])
    vel = np.array([U * np.cos(alpha), 0.0, -U * np.sin(alpha)])
    v = np.stack([vel, vel])
    bodies = {
        "body": np.array([1]),
        "plate": np.array([0]),
        "mass": np.array([2.0]),
        "inertia_normal": np.array([0.01]),
        "R_PF": np.eye(3)[None],
        "p_PF": np.zeros((1, 3)),
    }
    return R, p, np.zeros((2, 3)), v, bodies


def test_added_mass_body_adds_munks_moment_and_no_force_in_steady_glide():
    from manta_drake.station.foil import added_mass_body_wrenches

    U, alpha, m = 0.4, np.radians(25), 2.0
    R, p, w, v, bodies = _one_plate(U, alpha)
    F, q = added_mass_body_wrenches(
        R, p, w, v, np.zeros(3), bodies, np.ones(1), np.array([np.nan]), 20.0, 1.0
    )
    np.testing.assert_allclose(F[0, 3:], 0.0, atol=1e-14)
    assert np.linalg.norm(F[0, :3]) == pytest.approx(m * U * U * np.sin(alpha) * np.cos(alpha))
    np.testing.assert_allclose(F[1], 0.0, atol=1e-14)  # centred, aligned: no centring force
    assert q[0] == pytest.approx(-U * np.sin(alpha))


def test_added_mass_body_emerged_share_and_centring():
    from manta_drake.station.foil import added_mass_body_wrenches

    m, s, a_n, omega_c = 2.0, 0.3, 1.5, 20.0
    R, p, w, v, bodies = _one_plate(0.0, 0.0)
    p[1] = [0.01, -0.02, 0.0]  # the body 1 cm, -2 cm off the plate's centre, in its plane
    F, _ = added_mass_body_wrenches(
        R, p, w, v, np.zeros(3), bodies, np.full(1, s), np.array([a_n]), omega_c, 1.0
    )
    np.testing.assert_allclose(F[0, 3:], [0.0, 0.0, (1 - s) * m * a_n], atol=1e-14)
    np.testing.assert_allclose(F[0, :3], np.cross(p[1], [0.0, 0.0, (1 - s) * m * a_n]), atol=1e-14)
    np.testing.assert_allclose(F[1, 3:], -m * omega_c**2 * p[1], atol=1e-12)


def test_compiled_added_mass_body_wrenches_equal_the_numpy_reference():
    from scipy.spatial.transform import Rotation

    from manta_drake.station import foil
    from manta_drake.station import foil_kernels as FK

    rng = np.random.default_rng(5)
    nb, nm = 7, 3
    R = Rotation.random(nb, random_state=8).as_matrix()
    p, w, v = (rng.normal(size=(nb, 3)) for _ in range(3))
    bodies = {
        "body": np.array([4, 5, 6]),
        "plate": np.array([1, 2, 2]),
        "mass": rng.uniform(0.5, 3.0, nm),
        "inertia_normal": rng.uniform(0.001, 0.01, nm),
        "R_PF": Rotation.random(nm, random_state=9).as_matrix(),
        "p_PF": rng.normal(size=(nm, 3)) * 0.1,
    }
    frac, a_n = rng.uniform(size=nm), np.array([0.7, np.nan, -1.2])
    current = np.array([0.1, 0.0, -0.05])
    F, q = foil.added_mass_body_wrenches(R, p, w, v, current, bodies, frac, a_n, 20.0, 0.9)
    packed = FK.pack_added_mass_bodies(*bodies.values())
    F_k, q_k = FK.added_mass_body_wrenches(R, p, w, v, current, packed, frac, a_n, 20.0, 0.9)
    np.testing.assert_allclose(F_k, F, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(q_k, q, rtol=1e-12, atol=1e-14)


def test_separation_lag_is_first_order_in_semichords_travelled():
    """From attached flow, the angle jumps past stall: f(t) = f_inf + (1 - f_inf)
    exp(-2 U t / (c T_f)) (Leishman & Beddoes's first-order lag), for any step sizes; with
    T_f = 0 the share is the switch's at once."""
    U, c, T_f = 0.4, 0.12, 3.0
    stall, width = np.radians(15), np.radians(3)
    alpha = np.full(1, np.radians(40))
    f_inf = attached_fraction(alpha, stall, width)[0]
    f, t = np.ones(1), 0.0
    for dt in np.random.default_rng(2).uniform(1e-4, 0.05, 30):
        f = separation_step(f, alpha, np.full(1, U), np.full(1, c), dt, stall, width, T_f)
        t += dt
        assert f[0] == pytest.approx(
            f_inf + (1 - f_inf) * np.exp(-2 * U * t / (c * T_f)), rel=1e-12
        )
    assert (
        separation_step(np.ones(1), alpha, np.full(1, U), np.full(1, c), 1e-3, stall, width, 0.0)[0]
        == f_inf
    )
