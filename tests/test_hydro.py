"""The water: each term's pure function against closed forms (no plant), and
HydrodynamicForces in the plant against hydrostatics and drag laws by hand."""

import numpy as np
import pytest
from scipy.optimize import brentq
from scipy.spatial.transform import Rotation

from manta_drake.model import MODELS_DIR
from manta_drake.model.coefficients import load_coefficients
from manta_drake.model.robot_params import DEFAULT_ROBOT as P
from manta_drake.scenario import (
    BalloonConfig,
    ControllerConfig,
    InitialPose,
    Scenario,
    VisualizationConfig,
)
from manta_drake.simulate import run
from manta_drake.station.water import (
    BOX_TO_ELLIPSOID,
    balloon_wrench,
    buoyancy_wrenches,
    check_explicit_added_mass,
    damping_wrenches,
    ellipsoid_submersion,
    passive_pitch,
    plate_forces,
    residual_added_mass_wrench,
    split_added_inertia,
    split_added_mass,
)

COEFFS = load_coefficients()
RHO, G = COEFFS.water_density.value, COEFFS.gravity.value


# --- pure maths ------------------------------------------------------------------------------


def test_ellipsoid_submersion_matches_monte_carlo(rng):
    """Submerged fraction and centroid of tilted ellipsoids vs. random sampling."""
    n_mc = 400_000
    u = rng.normal(size=(n_mc, 3))
    u *= (rng.uniform(size=n_mc) ** (1 / 3) / np.linalg.norm(u, axis=1))[:, None]  # unit ball
    for _ in range(6):
        axes = rng.uniform(0.05, 0.3, 3)
        R = Rotation.random(random_state=rng.integers(1 << 30)).as_matrix()
        p = np.array([0.1, -0.2, rng.uniform(-0.25, 0.25)])
        x = p + (R @ (axes * u).T).T
        below = x[:, 2] < 0
        frac, centroid = ellipsoid_submersion(p[None], R[None], axes[None])
        assert frac[0] == pytest.approx(below.mean(), abs=0.003)
        if below.mean() > 0.05:
            np.testing.assert_allclose(centroid[0], x[below].mean(axis=0), atol=2e-3)


def test_half_submerged_body_gets_half_its_buoyancy_continuously():
    axes = np.array([[0.19, 0.12, 0.07]])
    R = np.eye(3)[None]
    z = np.linspace(-0.1, 0.1, 401)
    fracs = np.array([ellipsoid_submersion(np.array([[0, 0, zz]]), R, axes)[0][0] for zz in z])
    assert fracs[200] == pytest.approx(0.5)
    assert np.all(np.diff(fracs) <= 1e-12)  # monotone
    assert np.abs(np.diff(fracs)).max() < 0.02  # continuous: no jumps on a 0.5 mm grid
    assert fracs[0] == 1.0 and fracs[-1] == 0.0


def test_plate_moving_normal_to_itself_feels_the_drag_law():
    n = np.array([[0.0, 0.0, 1.0]])
    for v in (0.3, -0.7):
        f = plate_forces(v * n, n, np.array([0.02]), RHO, 1.17, 0.015)
        np.testing.assert_allclose(f[0], [0, 0, -0.5 * RHO * 1.17 * 0.02 * v * abs(v)])
        assert np.dot(f[0], n[0]) * v < 0  # opposite to the motion


def test_plate_moving_edgewise_feels_skin_friction_only():
    n = np.array([[0.0, 0.0, 1.0]])
    f = plate_forces(np.array([[0.5, 0.0, 0.0]]), n, np.array([0.02]), RHO, 1.17, 0.015)
    np.testing.assert_allclose(f[0], [-0.5 * RHO * 0.015 * 0.02 * 0.25, 0, 0])


def test_passive_pitch_makes_thrust_on_both_strokes():
    n = np.array([[0.0, 0.0, 1.0]])
    lead = np.array([[1.0, 0.0, 0.0]])
    for w in (0.5, -0.5):
        v = np.array([[0.0, 0.0, w]])
        n_eff = passive_pitch(v, n, lead, RHO, 1.17, np.radians(25), 150.0)
        f = plate_forces(v, n_eff, np.array([0.02]), RHO, 1.17, 0.0)
        assert f[0, 0] > 0.05 * abs(f[0, 2])  # forward, whichever way the plate moves
    rigid = passive_pitch(np.array([[0, 0, 0.5]]), n, lead, RHO, 1.17, 0.0, 150.0)
    np.testing.assert_array_equal(rigid, n)


def test_strip_theory_added_mass_equals_numerical_integration():
    from scipy.integrate import quad

    from manta_drake.model.coefficients import body_added_mass_strip_theory

    a, b, c = P.body_semi_axes
    am = body_added_mass_strip_theory((a, b, c), RHO)
    heave = quad(lambda x: RHO * np.pi * (b * np.sqrt(1 - x * x / a / a)) ** 2, -a, a)[0]
    sway = quad(lambda x: RHO * np.pi * (c * np.sqrt(1 - x * x / a / a)) ** 2, -a, a)[0]
    surge = quad(lambda y: RHO * np.pi * (c * np.sqrt(1 - y * y / b / b)) ** 2, -b, b)[0]
    pitch = quad(lambda x: x * x * RHO * np.pi * b * b * (1 - x * x / a / a), -a, a)[0]
    np.testing.assert_allclose(am["mass"], [surge, sway, heave], rtol=1e-9)
    assert am["inertia"][1] == pytest.approx(pitch, rel=1e-9)


def test_the_yaml_hull_added_mass_is_lambs_ellipsoid():
    from manta_drake.model.potential_flow import ellipsoid_added_mass

    mass, inertia = ellipsoid_added_mass(P.body_semi_axes, RHO)
    np.testing.assert_allclose(COEFFS.body.added_mass.value, mass, rtol=1e-5)
    np.testing.assert_allclose(COEFFS.body.added_inertia.value, inertia, rtol=1e-5)


def test_every_yaml_coefficient_names_its_source():
    entries = COEFFS.entries()
    assert len(entries) > 20
    for name, entry in entries:
        assert len(entry.source) > 10, name


def test_added_mass_split_and_build_time_check():
    iso, res = split_added_mass([2.46, 3.90, 11.46], rigid_mass=5.2)
    assert iso == pytest.approx((2.46 + 11.46) / 2)
    assert np.all(np.abs(res) < 5.2 + iso)
    with pytest.raises(ValueError, match="heave axis"):
        check_explicit_added_mass([0.1, 0.2, 9.0], 5.0)
    # The midpoint split always passes (|residual| = (max - min)/2 < rigid + (max + min)/2).
    # The system checks the explicit residual per axis against the whole robot's effective
    # inertia on that axis (rigid + implicit added); a pitch residual above it is refused:
    import copy

    from pydrake.systems.framework import DiagramBuilder

    from manta_drake.model.plant import add_plant
    from manta_drake.station.hydro import HydrodynamicForces

    coeffs = copy.deepcopy(COEFFS)
    coeffs.body.added_inertia.value = [0.01, 0.5, 0.01]  # implicit pitch 0.02, residual 0.48
    h = add_plant(DiagramBuilder(), hydro=coeffs)
    with pytest.raises(ValueError, match="pitch axis .* not below the robot.s effective kg m\\^2"):
        HydrodynamicForces(h.plant, h.robot, coeffs, 1e-3, added_mass_iso=h.added_mass_iso)
    h = add_plant(DiagramBuilder(), hydro=COEFFS)
    hydro = HydrodynamicForces(h.plant, h.robot, COEFFS, 1e-3, added_mass_iso=h.added_mass_iso)
    # the effective mass is the robot's 8.4 kg plus the isotropic added mass
    assert hydro.effective_mass == pytest.approx(P.total_mass + h.added_mass_iso, rel=1e-9)
    implicit, residual = split_added_inertia([0.052, 0.083, 0.028])
    assert implicit[1] <= implicit[0] + implicit[2] + 1e-15  # a rigid body can carry it
    np.testing.assert_allclose(implicit + residual, [0.052, 0.083, 0.028])


def test_identification_recovers_known_coefficients(rng):
    from manta_drake.model.coefficients import fit_damping

    for lin, quad_, (lo, hi) in (
        (1.7, 4.4, (0.4, 1.2)),
        (4.7, 37.0, (0.1, 0.6)),
        (0.05, 0.013, (0.5, 6.0)),
    ):
        u = np.concatenate([-np.linspace(lo, hi, 40), np.linspace(lo, hi, 40)])
        force = (lin + quad_ * np.abs(u)) * u * (1 + 0.01 * rng.standard_normal(u.size))
        (got_lin, got_quad), residual = fit_damping(u, force)
        assert got_lin == pytest.approx(lin, rel=0.02, abs=0.02 * quad_)
        assert got_quad == pytest.approx(quad_, rel=0.02)
        assert np.sqrt(np.mean(residual**2)) < 0.02 * np.abs(force).max()


@pytest.mark.slow
def test_identify_damping_script_reads_csv_and_writes_yaml(tmp_path):
    import shutil
    import subprocess
    import sys

    import yaml

    root = __import__("pathlib").Path(__file__).resolve().parent.parent
    csv = tmp_path / "s.csv"
    lines = ["# test", "# source: a closed-form test table"] + [
        f"{a},{u},{(1.0 + i + 2.0 * (i + 1) * abs(u)) * u}"
        for i, a in enumerate(("surge", "sway", "heave", "roll", "pitch", "yaw"))
        for u in (-1.0, -0.5, 0.5, 1.0, 1.5)
    ]
    csv.write_text("\n".join(lines) + "\n")
    target = tmp_path / "h.yaml"
    shutil.copy(MODELS_DIR / "hydrodynamics.yaml", target)
    out = subprocess.run(
        [
            sys.executable,
            "scripts/identify_damping.py",
            "--csv",
            str(csv),
            "--yaml",
            str(target),
            "--write",
        ],
        cwd=root,
        capture_output=True,
        text=True,
    )
    assert out.returncode == 0, out.stderr
    data = yaml.safe_load(target.read_text())
    np.testing.assert_allclose(
        data["body"]["linear_damping"]["value"], [1, 2, 3, 4, 5, 6], atol=1e-6
    )
    np.testing.assert_allclose(
        data["body"]["quadratic_damping"]["value"], [2, 4, 6, 8, 10, 12], atol=1e-6
    )
    assert "surge" in out.stdout and "rms" in out.stdout
    # The fit's source names the table and what the table says it is.
    assert "s.csv (a closed-form test table)" in data["body"]["linear_damping"]["source"]


def _one_element(p_B, axes, body=0):
    """The arrays of build_elements for a single ellipsoid volume element."""
    axes = np.asarray([axes], dtype=float)
    return {
        "body": np.array([body]),
        "p": np.asarray([p_B], dtype=float),
        "axes": axes,
        "volume": 4.0 / 3.0 * np.pi * np.prod(axes, axis=1),
    }


def test_buoyancy_wrench_of_a_submerged_and_a_floating_ellipsoid():
    a, b, c = 0.2, 0.1, 0.05
    V = 4 / 3 * np.pi * a * b * c
    el = _one_element([0.1, 0.0, 0.0], (a, b, c))  # element 0.1 m ahead of the body origin
    R, p = np.eye(3)[None], np.array([[0.0, 0.0, -1.0]])
    F, frac, body_frac = buoyancy_wrenches(R, p, el, RHO, G)
    lift = RHO * G * V
    # Archimedes at the centroid: f = (0, 0, rho g V), torque = r x f = (0, -0.1 lift, 0).
    np.testing.assert_allclose(F[0], [0, -0.1 * lift, 0, 0, 0, lift], rtol=1e-12, atol=1e-12)
    assert frac[0] == 1.0 and body_frac[0] == 1.0
    # Level, centre at depth d < c: the cap below z = 0 of height h = c + d has volume
    # pi a b h^2 (3c - h) / (3 c^2) (closed form of the ellipsoid cap).
    d = 0.02
    F, frac, _ = buoyancy_wrenches(R, np.array([[0.0, 0.0, -d]]), el, RHO, G)
    h = c + d
    assert F[0, 5] == pytest.approx(
        RHO * G * np.pi * a * b * h * h * (3 * c - h) / (3 * c * c), rel=1e-12
    )
    assert frac[0] == pytest.approx(F[0, 5] / lift)


def test_balloon_wrench_is_its_sphere_buoyancy_at_the_mount():
    R, p = np.eye(3), np.array([0.0, 0.0, -1.0])
    V, mount = 2.5e-3, np.array([-0.05, 0.0, 0.07])
    F = balloon_wrench(R, p, mount, V, RHO, G)
    lift = RHO * G * V
    np.testing.assert_allclose(F, [0, 0.05 * lift, 0, 0, 0, lift], rtol=1e-12, atol=1e-12)
    np.testing.assert_array_equal(balloon_wrench(R, p, mount, 0.0, RHO, G), np.zeros(6))
    # Out of the water: nothing. Half out (centre on the surface): half.
    assert balloon_wrench(R, np.array([0, 0, 1.0]), mount, V, RHO, G)[5] == 0.0
    half = balloon_wrench(R, np.array([0, 0, -0.07]), mount, V, RHO, G)[5]
    assert half == pytest.approx(0.5 * lift, rel=1e-12)


def test_damping_wrench_is_the_per_axis_drag_law_in_the_body_frame():
    yaw = np.radians(30)
    R = np.array([[[np.cos(yaw), -np.sin(yaw), 0], [np.sin(yaw), np.cos(yaw), 0], [0, 0, 1]]])
    u = 0.4  # surge speed along the body's x axis
    v = (R[0] @ [u, 0, 0])[None]
    w = np.array([[0.0, 0.0, 0.5]])  # yaw rate
    d_lin = np.array([[1.0, 2, 3, 4, 5, 6]])
    d_quad = np.array([[10.0, 20, 30, 40, 50, 60]])
    F = damping_wrenches(R, w, v, np.zeros(3), d_lin, d_quad, np.array([0.5]))
    surge = -0.5 * (1.0 + 10.0 * u) * u
    yaw_torque = -0.5 * (6.0 + 60.0 * 0.5) * 0.5
    np.testing.assert_allclose(F[0, 3:], R[0] @ [surge, 0, 0], atol=1e-15)
    np.testing.assert_allclose(F[0, :3], [0, 0, yaw_torque], atol=1e-15)
    # moving with a current: no relative velocity, no force
    F = damping_wrenches(R, np.zeros((1, 3)), v, v[0], d_lin, d_quad, np.array([1.0]))
    np.testing.assert_allclose(F, 0.0, atol=1e-15)


def test_residual_added_mass_opposes_the_acceleration_per_body_axis():
    R = np.array([[0.0, 1.0, 0.0], [-1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])  # yaw by -90 deg
    a_W, alpha_W = np.array([0.2, -0.1, 0.3]), np.array([0.0, 1.0, 0.0])
    m_res, i_res = np.array([-4.5, -3.0, 4.5]), np.array([0.0, 0.0027, 0.0])
    F = residual_added_mass_wrench(R, a_W, alpha_W, m_res, i_res, 0.5)
    np.testing.assert_allclose(F[3:], 0.5 * R @ (-m_res * (R.T @ a_W)), atol=1e-15)
    np.testing.assert_allclose(F[:3], 0.5 * R @ (-i_res * (R.T @ alpha_W)), atol=1e-15)
    # along a body axis it is exactly -m a on that axis
    F = residual_added_mass_wrench(np.eye(3), np.array([0, 0, 2.0]), np.zeros(3), m_res, i_res, 1)
    np.testing.assert_allclose(F[3:], [0, 0, -4.5 * 2.0])


# --- hydrostatics by hand ----------------------------------------------------------------------


def _ellipsoid_cap(a, b, c, depth_of_centre):
    """Volume of a level ellipsoid below z = 0 with its centre at -depth (closed form)."""
    if c <= 0:
        return 0.0
    h = np.clip(c + depth_of_centre, 0.0, 2 * c)  # submerged height from the bottom
    return np.pi * a * b * h * h * (3 * c - h) / (3 * c * c)


def robot_displacement(z_body, balloon_volume):
    """Displaced volume of the level robot at the zero pose, body origin at z_body."""
    b = COEFFS.body
    a_, b_, c_ = b.sealed_semi_axes.value
    v = _ellipsoid_cap(a_, b_, c_, -(z_body + b.center_of_buoyancy.value[2]))
    # Fin plates and servo cases lie in the body's mid-plane at the zero pose; thin
    # next to the hull: treat them as fully in or out at their plane.
    plates = 4 * 0.68508 * P.fin_thickness * (P.proximal_chord * P.d3 + P.distal_chord * P.dE)
    servos = 16 * 0.0335 * 0.0585 * 0.0459  # the XW540 cases, all at z = 0 at the zero pose
    fin_frac = np.clip(0.5 - z_body / (BOX_TO_ELLIPSOID * 0.68508 * P.fin_thickness), 0, 1)
    v += (plates + servos) * fin_frac
    r = (3 * balloon_volume / (4 * np.pi)) ** (1 / 3)
    v += _ellipsoid_cap(r, r, r, -(z_body + COEFFS.balloon.mount_point.value[2]))
    return v


def _water_scenario(**kw) -> Scenario:
    s = Scenario(
        name="test",
        initial_stance="zero",
        controller=ControllerConfig(mode="hold", gait="swim"),
        visualization=VisualizationConfig(meshcat=False),
        steady_after=0.0,
    )
    for k, v in kw.items():
        setattr(s, k, v)
    return s.validate()


@pytest.mark.slow
def test_inflated_robot_floats_at_the_hydrostatic_draft(tmp_path):
    full = COEFFS.balloon.max_volume.value
    mass = P.total_mass
    z_eq = brentq(lambda z: RHO * robot_displacement(z, full) - mass, -0.2, 0.1)
    # 14 s: with the fins' and the hull's added mass (foil fins) the heave settles slowly
    # (about 38 kg of effective heave mass on the waterplane's stiffness).
    s = _water_scenario(
        duration=14.0,
        initial_pose=InitialPose(xyz=[0, 0, z_eq + 0.005]),
        balloon=BalloonConfig(initial_fill=1.0),
    )
    result = run(s, tmp_path, progress=False, write_outputs=False)
    z = result.log["body_xyz"][:, 2]
    t = result.log["t"]
    # The heave rings about the draft: nothing in the model radiates waves (a floating body's
    # main heave damping at small amplitude), and the hull's CFD-identified heave drag is
    # quadratic, so the 5 mm release decays slowly; it decays, about the draft.
    late, early = z[t > 12.0], z[(t > 0.5) & (t < 2.5)]
    assert np.ptp(late) < 0.8 * np.ptp(early)
    assert np.mean(late) == pytest.approx(z_eq, abs=0.002)
    # Back out of the water: the hull's top is above the surface.
    assert z[-1] + P.body_semi_axes[2] > 0.01
    R = Rotation.from_quat(result.log["body_quat_wxyz"][-1][[1, 2, 3, 0]]).as_matrix()
    # Near level: the ballast trims the deflated robot level under water; afloat with the
    # balloon full (its buoyancy and the waterplane's on another vertical) it sits 1.1 deg off.
    assert np.degrees(np.arccos(R[2, 2])) < 1.5
    # The system's own output at rest: the vertical hydro force on the robot, less the
    # cancellation of the added-mass body's weight (that body is in the plant, not in
    # the robot's 8.4 kg), carries the robot's weight.
    hydro = result.handles.systems["hydro"]
    forces = hydro.GetOutputPort("spatial_forces").Eval(hydro.GetMyContextFromRoot(result.context))
    lift = sum(f.F_Bq_W.translational()[2] for f in forces) - hydro.added_mass_iso * G
    assert hydro.added_mass_iso > 0
    assert lift == pytest.approx(mass * G, rel=0.01)


@pytest.mark.slow
def test_deflated_robot_sinks_at_terminal_velocity_and_rests_on_floor(tmp_path):
    """With the cross-flow fins, whose heave drag is one quadratic law, the sink reaches the
    closed-form terminal velocity in the pool's half metre; with the foil fins (38 kg of
    effective heave mass, the plates' drag building up over a few chords of travel) it does
    not in that depth: ``test_deflated_robot_with_foil_fins_sinks_and_rests``."""
    s = _water_scenario(
        duration=7.0,
        initial_pose=InitialPose(xyz=[0, 0, -0.12]),
        balloon=BalloonConfig(initial_fill=0.0),
    )
    s.water.fin_model = "cross_flow"
    result = run(s, tmp_path, progress=False, write_outputs=False)
    z, w = result.log["body_xyz"][:, 2], result.log["body_v_world"][:, 2]
    # Closed form: net weight = (sum of heave drag laws) at terminal velocity, fully submerged.
    fins_area = 4 * (P.proximal_chord * P.d3 + P.distal_chord * P.dE)
    b, links, fins = COEFFS.body, COEFFS.links, COEFFS.fins
    lin = b.linear_damping.value[2] + 16 * links.linear_damping.value[2]
    quad_ = (
        b.quadratic_damping.value[2]
        + 16 * links.quadratic_damping.value[2]
        + 0.5 * RHO * fins.normal_force_coefficient.value * fins_area
    )
    volume = robot_displacement(-1.0, 0.0)
    net = (P.total_mass - RHO * volume) * G
    assert net > 0  # deflated, heavier than neutral
    w_term = (-lin + np.sqrt(lin * lin + 4 * quad_ * net)) / (2 * quad_)
    mid = (z < -0.2) & (z > -0.3)  # well below the surface, above the floor
    assert mid.sum() > 10
    assert -w[mid].mean() == pytest.approx(w_term, rel=0.10)
    # comes to rest on the floor (hull bottom within a few mm of z = -0.5): a rocking of a
    # few mm/s on its held legs is left against the sink's 0.2 m/s
    t = result.log["t"]
    assert np.sqrt(np.mean(w[t > 5.0] ** 2)) < 0.05 * np.max(np.abs(w))
    assert z[-1] - P.body_semi_axes[2] == pytest.approx(-0.5, abs=0.01)


@pytest.mark.slow
def test_deflated_robot_with_foil_fins_sinks_and_rests(tmp_path):
    """The default fins: released at rest, the deflated robot starts down at net weight over
    the plant's own heave mass (M_zz of the mass matrix with the joints held: rigid, hull and
    plates' added mass) and comes to rest on the floor."""
    s = _water_scenario(
        duration=7.0,
        initial_pose=InitialPose(xyz=[0, 0, -0.12]),
        balloon=BalloonConfig(initial_fill=0.0),
    )
    assert s.water.fin_model == "foil"
    result = run(s, tmp_path, progress=False, write_outputs=False)
    t, z, w = result.log["t"], result.log["body_xyz"][:, 2], result.log["body_v_world"][:, 2]
    h = result.handles
    plant = h.plant
    # At the end the robot lies level on the floor in the same held pose it started in.
    M = plant.CalcMassMatrix(plant.GetMyContextFromRoot(result.context))
    iz = h.plant_handles.body.floating_velocities_start_in_v() + 5
    volume = robot_displacement(-1.0, 0.0)
    net = (P.total_mass - RHO * volume) * G
    # Over the first 0.3 s the drag is a few % of the net weight; the fins' lag behind the
    # hull on their servos (the hull starts at ~net / 24 kg) averages out: 2 dz / T^2.
    i = np.searchsorted(t, 0.3)
    accel = 2.0 * (z[0] - z[i]) / t[i] ** 2
    assert accel == pytest.approx(net / M[iz, iz], rel=0.05)
    assert M[iz, iz] > 3.0 * P.total_mass  # the water's mass dominates the heave
    # At rest on its held legs: a rocking of a few mm/s is left (the servos' PD and the
    # contact dissipate it slowly) against the 0.2 m/s of the sink.
    assert np.sqrt(np.mean(w[t > 5.0] ** 2)) < 0.05 * np.max(np.abs(w))
    assert z[-1] - P.body_semi_axes[2] == pytest.approx(-0.5, abs=0.01)


def test_surge_step_force_accelerates_with_added_mass():
    from manta_drake.simulate import make_simulator
    from manta_drake.wiring.diagram import build_diagram

    s = _water_scenario(
        duration=0.1,
        initial_pose=InitialPose(xyz=[0, 0, -0.25]),
        balloon=BalloonConfig(initial_fill=0.25),
    )
    diagram, h = build_diagram(s)
    plant = h.plant
    simulator = make_simulator(diagram, s)  # the default context is the scenario's start
    context = simulator.get_mutable_context()
    plant_context = plant.GetMyMutableContextFromRoot(context)
    F = 10.0
    # The push enters through the plant's spatial-force input (the water's forces take its
    # generalized-force input): F along world x (= surge) at the hull's origin.
    from pydrake.multibody.math import SpatialForce
    from pydrake.multibody.plant import ExternallyAppliedSpatialForce

    push = ExternallyAppliedSpatialForce()
    push.body_index = h.plant_handles.body.index()
    push.p_BoBq_B = np.zeros(3)
    push.F_Bq_W = SpatialForce(np.zeros(3), np.array([F, 0.0, 0.0]))
    plant.get_applied_spatial_force_input_port().FixValue(plant_context, [push])
    times = np.arange(0.0, 0.06, 0.002)
    vx = []
    for t in times:
        simulator.AdvanceTo(t)
        v_start = h.plant_handles.body.floating_velocities_start_in_v()
        vx.append(plant.GetVelocities(plant_context)[v_start + 3])
    slope = np.polyfit(times[5:], np.array(vx)[5:], 1)[0]
    expected = F / (P.total_mass + COEFFS.body.added_mass.value[0])
    assert slope == pytest.approx(expected, rel=0.05)


@pytest.mark.slow
@pytest.mark.parametrize("dt", [0.5e-3, 1e-3, 2e-3])
def test_swim_flapping_at_the_surface_moves_forward_stably(dt, tmp_path):
    s = _water_scenario(
        duration=6.0,
        time_step=dt,
        initial_pose=InitialPose(xyz=[0, 0, -0.04]),
        balloon=BalloonConfig(initial_fill=1.0),
        controller=ControllerConfig(mode="gait", gait="swim"),
        initial_stance="swim",
        log_period=dt,
        steady_after=2.0,
    )
    s.simulator.max_step_size = dt
    result = run(s, tmp_path, progress=False, write_outputs=False)
    log = result.log
    assert result.metrics["status"] == "ok"
    assert np.all(np.isfinite(log["body_xyz"])) and np.all(np.isfinite(log["joint_angles"]))
    assert result.metrics["mean_velocity_body"][0] > 0.01  # forward, m/s
    assert log["body_xyz"][-1, 0] - log["body_xyz"][0, 0] > 0.05
    # Stays at the surface: the balloon's buoyancy holds it up against the fins' mean
    # downward force (the hull's centre ~0.16 m down with the foil fins, ~0.06 m with the
    # cross-flow fins), nowhere near the 0.5 m floor.
    assert np.abs(log["body_xyz"][:, 2]).max() < 0.25


@pytest.mark.slow
def test_held_forces_agree_with_exact_forces(tmp_path):
    """water.update_period trades a small delay for speed; the swim speed barely moves."""
    speeds = []
    for period in (0.0, 0.004):
        s = _water_scenario(
            duration=6.0,
            initial_pose=InitialPose(xyz=[0, 0, -0.04]),
            balloon=BalloonConfig(initial_fill=1.0),
            controller=ControllerConfig(mode="gait", gait="swim"),
            initial_stance="swim",
            steady_after=2.0,
        )
        s.water.update_period = period
        result = run(s, tmp_path / str(period), progress=False, write_outputs=False)
        speeds.append(result.metrics["mean_velocity_body"][0])
    assert speeds[0] > 0.01
    assert speeds[1] == pytest.approx(speeds[0], rel=0.05)


def test_spinning_plate_gets_torque_and_no_net_force():
    """Strips see their own point velocities: a plate spinning about its centre line."""
    import copy

    from pydrake.systems.framework import DiagramBuilder

    from manta_drake.model.plant import add_plant
    from manta_drake.station.hydro import HydrodynamicForces
    from manta_drake.station.water import hydro_body_names

    coeffs = copy.deepcopy(COEFFS)
    coeffs.links.linear_damping.value = [0.0] * 6  # isolate the blade elements
    coeffs.links.quadratic_damping.value = [0.0] * 6
    coeffs.fins.passive_pitch_max_deg.value = 0.0  # rigid plates for the closed form
    h = add_plant(DiagramBuilder(), hydro=coeffs)
    hydro = HydrodynamicForces(h.plant, h.robot, coeffs, 1e-3)
    nb = len(hydro_body_names())
    R = np.tile(np.eye(3), (nb, 1, 1))
    p = np.tile([0.0, 0.0, -1.0], (nb, 1))  # deep under water
    w, v = np.zeros((nb, 3)), np.zeros((nb, 3))
    rest = hydro.compute(R, p, w, v, 0.0)
    link = hydro_body_names().index("fl_link4")
    omega = 3.0
    centre = np.array([0.0, -P.dE / 2, 0.0])  # distal plate centre in its link frame
    w[link] = [0.0, 0.0, omega]  # spin about the plate's chord axis through its centre
    v[link] = np.cross(w[link], -centre)  # so the centre itself is at rest
    spin = hydro.compute(R, p, w, v, 0.0) - rest
    np.testing.assert_allclose(spin[link, 3:], 0.0, atol=1e-12)  # no net force
    n = int(coeffs.fins.strips_per_plate.value)
    ds = P.dE / n
    y = (np.arange(n) + 0.5) * ds - P.dE / 2  # strip offsets from the centre
    area = P.distal_chord * ds
    c_n = coeffs.fins.normal_force_coefficient.value
    expected = -np.sum(0.5 * RHO * c_n * area * omega**2 * y**2 * np.abs(y))
    assert spin[link, 2] == pytest.approx(expected, rel=1e-9)  # torque opposes the spin
    assert expected < 0
    others = np.delete(np.arange(nb), link)
    np.testing.assert_allclose(spin[others], 0.0, atol=1e-12)


def test_held_forces_start_from_the_initial_state():
    """With update_period > 0 the first held forces are those of the initial state."""
    from manta_drake.simulate import make_simulator
    from manta_drake.wiring.diagram import build_diagram

    s = _water_scenario(
        duration=0.1,
        initial_pose=InitialPose(xyz=[0, 0, -0.04]),
        balloon=BalloonConfig(initial_fill=1.0),
    )
    s.water.update_period = 0.004
    diagram, h = build_diagram(s)
    simulator = make_simulator(diagram, s)
    context = simulator.get_mutable_context()
    simulator.Initialize()
    hydro = h.systems["hydro"]
    hydro_context = hydro.GetMyContextFromRoot(context)
    held = hydro.GetOutputPort("spatial_forces").Eval(hydro_context)
    exact = hydro._forces_now(hydro_context)
    lift = sum(f.F_Bq_W.translational()[2] for f in held)
    assert lift == pytest.approx(exact[:, 5].sum(), rel=1e-9)
    assert lift > 0.9 * P.total_mass * G  # buoyancy from the first step on


@pytest.mark.slow
@pytest.mark.parametrize("dt", [0.5e-3, 1e-3, 2e-3])
def test_explicit_added_inertia_is_stable_below_the_effective_inertia_only(
    dt, tmp_path, monkeypatch
):
    """The build-time criterion |residual| < effective inertia, per axis, is the stability
    bound of the explicit -I_res alpha_prev term (its amplification factor per step is
    -I_res / I_eff): the swim with a pitch residual of 0.9 I_eff stays bounded; at 1.5 I_eff
    it diverges, at every time step (the check is bypassed to show it).

    The residual comes from a coefficient file whose pitch added inertia exceeds the part
    a rigid body can carry (roll + yaw, which stays in the mass matrix, so I_eff does not
    change) by ratio * I_eff."""
    import yaml

    import manta_drake.station.hydro as hydro_module
    from manta_drake.scenario import load_scenario
    from manta_drake.simulate import make_simulator
    from manta_drake.wiring.diagram import build_diagram

    def swim(coefficients=None):
        s = load_scenario("locomotion_swim")
        s.water.fin_model = "cross_flow"  # the model whose hull residual is explicit
        s.visualization.meshcat = False
        s.time_step = s.simulator.max_step_size = dt
        s.water.update_period = 0.0  # forces and the acceleration estimate at every step
        if coefficients is not None:
            s.water.coefficients = str(coefficients)
        return (s, *build_diagram(s))

    i_eff = float(swim()[2].systems["hydro"].effective_inertia[1])
    data = yaml.safe_load((MODELS_DIR / "hydrodynamics.yaml").read_text())
    roll, _, yaw = data["body"]["added_inertia"]["value"]

    def peak_pitch_rate(ratio):
        data["body"]["added_inertia"]["value"] = [roll, roll + yaw + ratio * i_eff, yaw]
        path = tmp_path / f"hydrodynamics_{ratio}.yaml"
        path.write_text(yaml.safe_dump(data))
        s, diagram, h = swim(path)
        hydro = h.systems["hydro"]
        assert hydro.effective_inertia[1] == pytest.approx(i_eff, rel=1e-12)
        np.testing.assert_allclose(
            hydro.residual_added_inertia, [0.0, ratio * i_eff, 0.0], rtol=1e-9, atol=1e-15
        )
        simulator = make_simulator(diagram, s)
        plant_context = h.plant.GetMyContextFromRoot(simulator.get_context())
        peak = 0.0
        try:
            for t in np.arange(0.1, 1.51, 0.1):
                simulator.AdvanceTo(t)
                w = h.plant.GetVelocities(plant_context)[:3]
                peak = max(peak, float(np.abs(w).max())) if np.all(np.isfinite(w)) else np.inf
                if peak > 50.0:
                    break
        except RuntimeError:  # non-finite forces: diverged
            peak = np.inf
        return peak

    stable = peak_pitch_rate(0.9)
    assert stable < 0.5  # rad/s: the swim's own rocking (0.14 measured at every dt)
    with pytest.raises(ValueError, match="pitch axis"):
        peak_pitch_rate(1.5)  # what the check refuses; bypassed below to show why
    monkeypatch.setattr(hydro_module, "check_explicit_added_mass", lambda *args: None)
    # Unstable: 10-29 rad/s within 1.5 s (measured at 2, 1 and 0.5 ms), growing until the
    # quadratic damping holds it; 70-200 times the stable swim's peak.
    assert peak_pitch_rate(1.5) > 20 * max(stable, 0.05)


def test_body_lift_is_the_u_w_and_u_v_law_in_the_body_frame():
    """Y = -Y_uv |u| v, Z = -Z_uw |u| w, M = -M_uw u w, N = -N_uv u v, by hand."""
    from manta_drake.station.water import body_lift

    nu = np.array([[0.4, 0.1, -0.2, 0.3, 0.0, 0.0], [-0.4, 0.1, -0.2, 0.0, 0.0, 0.0]])
    d = np.array([[0.5, 45.0, -4.4, 1.3]] * 2)
    out = body_lift(nu, d)
    np.testing.assert_allclose(out[0], [0, -0.5 * 0.04, -45 * -0.08, 0, 4.4 * -0.08, -1.3 * 0.04])
    # Reversed (a fore-aft reflection): the side and vertical forces stay, the pitch and yaw
    # moments turn over.
    np.testing.assert_allclose(out[1][[1, 2]], out[0][[1, 2]])
    np.testing.assert_allclose(out[1][[4, 5]], -out[0][[4, 5]])
    # Pure heave and sway: no lift, Eq. (2)'s diagonal is the whole force.
    assert not body_lift(np.array([[0.0, 0.3, 0.2, 0, 0, 0]]), d[:1]).any()
    # In damping_wrenches, rotated to the world and scaled by the submerged fraction.
    yaw = np.radians(30)
    R = np.array([[[np.cos(yaw), -np.sin(yaw), 0], [np.sin(yaw), np.cos(yaw), 0], [0, 0, 1]]])
    v = (R[0] @ nu[0, :3])[None]
    zero = np.zeros((1, 6))
    F = damping_wrenches(R, np.zeros((1, 3)), v, np.zeros(3), zero, zero, np.array([0.5]), d[:1])
    np.testing.assert_allclose(F[0, 3:], 0.5 * R[0] @ out[0, :3], atol=1e-15)
    np.testing.assert_allclose(F[0, :3], 0.5 * R[0] @ out[0, 3:], atol=1e-15)
