"""The bill of materials: closed forms of its geometry, the parts summing to Table 1, the
masses the model is built from, and one-line errors for a bad file."""

import math

import numpy as np
import pytest
from pydrake.multibody.tree import RotationalInertia, SpatialInertia, UnitInertia

from manta_drake.config_io import ScenarioError
from manta_drake.model import bill_of_materials as B
from manta_drake.model.model_sdf import body_inertia, composite_inertia, link_inertias
from manta_drake.model.robot_params import DEFAULT_ROBOT, RobotParams

SHIPPED = B.shipped_bill_of_materials()
ROWS = B.parts(SHIPPED, DEFAULT_ROBOT.geometry())


def test_naca_section_area_is_the_integral_of_the_thickness_distribution():
    x = np.linspace(0.0, 1.0, 200001)
    half = 5 * (0.2969 * np.sqrt(x) - 0.1260 * x - 0.3516 * x**2 + 0.2843 * x**3 - 0.1015 * x**4)
    assert B.NACA4_SECTION_AREA == pytest.approx(2 * np.trapezoid(half, x), rel=1e-6)
    assert B.NACA4_SECTION_AREA == pytest.approx(0.68508, abs=5e-6)
    assert B.naca_section_area(0.012, 0.14) == pytest.approx(0.68508 * 0.012 * 0.14, rel=1e-5)


def test_ellipsoid_surface_closed_forms():
    assert B.ellipsoid_surface_area(0.1, 0.1, 0.1) == pytest.approx(4 * math.pi * 0.01)
    # A prolate spheroid: 2 pi b^2 (1 + a / (b e) asin e), e = sqrt(1 - b^2 / a^2).
    a, b = 0.2, 0.1
    e = math.sqrt(1 - b * b / (a * a))
    prolate = 2 * math.pi * b * b * (1 + a / (b * e) * math.asin(e))
    assert B.ellipsoid_surface_area(a, b, b) == pytest.approx(prolate, rel=1e-12)
    # An oblate one: 2 pi a^2 (1 + (1 - e^2) / e atanh e), e = sqrt(1 - c^2 / a^2).
    a, c = 0.2, 0.05
    e = math.sqrt(1 - c * c / (a * a))
    oblate = 2 * math.pi * a * a * (1 + (1 - e * e) / e * math.atanh(e))
    assert B.ellipsoid_surface_area(c, a, a) == pytest.approx(oblate, rel=1e-12)
    # The fairing, against Knud Thomsen's approximation (within 1.061 %).
    a, b, c = DEFAULT_ROBOT.body_semi_axes
    p = 1.6075
    thomsen = 4 * math.pi * (((a * b) ** p + (a * c) ** p + (b * c) ** p) / 3) ** (1 / p)
    assert B.ellipsoid_surface_area(a, b, c) == pytest.approx(thomsen, rel=0.011)


def test_the_parts_sum_to_table_1_and_the_residual_is_what_is_left():
    assert sum(r.total_mass for r in ROWS) == pytest.approx(8.4, abs=1e-12)
    residual = ROWS[-1]
    assert residual.name == "residual" and residual.carrier == "hull"
    listed = sum(r.total_mass for r in ROWS[:-1])
    assert residual.mass == pytest.approx(8.4 - listed) and 0 < residual.mass < 8.4
    servos = [r for r in ROWS if r.name.endswith("servo")]
    assert sum(r.count for r in servos) == 16
    assert sum(r.total_mass for r in servos) == pytest.approx(16 * 0.185)
    assert servos[0].volume == pytest.approx(0.0335 * 0.0585 * 0.0459)  # 90.0 mL
    # Only the servos and the plates displace water of their own (the rest is in the hull).
    wet = {r.name for r in ROWS if r.volume > 0}
    assert wet == {
        "yaw servo",
        "roll1 servo",
        "pitch servo",
        "roll2 servo",
        "proximal fin plate",
        "distal fin plate",
    }
    plate = next(r for r in ROWS if r.name == "proximal fin plate")
    assert plate.volume == pytest.approx(0.68508 * 0.012 * 0.14 * 0.20, rel=1e-5)
    assert plate.mass == pytest.approx(1240.0 * plate.volume)
    shell = next(r for r in ROWS if r.name == "hull shell")
    assert shell.mass == pytest.approx(1240 * 0.003 * B.ellipsoid_surface_area(0.19, 0.12, 0.07))


def test_the_model_carries_each_part_where_the_bill_puts_it():
    p = DEFAULT_ROBOT
    assert p.total_mass == pytest.approx(8.4, abs=1e-12)
    # Links 1 and 2 carry one servo each; link 3 the proximal plate and the roll2 servo.
    assert p.link_masses[0] == p.link_masses[1] == pytest.approx(0.185)
    assert p.link_masses[2] == pytest.approx(0.185 + 1240 * 0.68508 * 0.012 * 0.14 * 0.20, rel=1e-5)
    assert p.link_masses[3] == pytest.approx(1240 * 0.68508 * 0.012 * 0.10 * 0.125, rel=1e-5)
    assert p.body_mass == pytest.approx(8.4 - 4 * sum(p.link_masses))
    assert p.servo_volume == pytest.approx(89.95e-6, rel=1e-3)
    # Explicit masses win over the bill's.
    assert RobotParams(body_mass=5.0).body_mass == 5.0


def test_composite_inertia_agrees_with_drake():
    parts = [
        (0.3, (0.0, 0.0, 0.1), (1e-3, 2e-3, 3e-3)),
        (0.2, (0.05, -0.02, 0.2), (4e-4, 5e-4, 6e-4)),
    ]
    mass, com, inertia = composite_inertia(parts)
    total = SpatialInertia.Zero()
    for m, c, moments in parts:
        # Each part about its own centre, shifted to the frame's origin, then summed.
        unit = UnitInertia(*(np.array(moments) / m), 0.0, 0.0, 0.0)
        total += SpatialInertia(m, np.zeros(3), unit).Shift(-np.array(c))
    assert mass == pytest.approx(total.get_mass())
    np.testing.assert_allclose(com, total.get_com(), atol=1e-15)
    about_com = total.Shift(total.get_com()).CalcRotationalInertia()
    np.testing.assert_allclose(inertia, about_com.CopyToFullMatrix3(), atol=1e-15)
    # Two point masses: the reduced mass times the distance squared about the common axis.
    _, _, i2 = composite_inertia([(1.0, (0, 0, 0), (0, 0, 0)), (3.0, (0, 0, 0.4), (0, 0, 0))])
    assert i2[0, 0] == pytest.approx(3.0 / 4.0 * 0.16) and i2[2, 2] == pytest.approx(0.0)
    assert isinstance(about_com, RotationalInertia)


def test_link_and_body_inertias_put_the_servos_at_their_joints():
    p = DEFAULT_ROBOT
    links = link_inertias("fl", p)
    m3, com3, _ = links[3]
    plate = p.link_masses[2] - p.servo_mass
    # Link 3: the plate's centre at d3 / 2 and the roll2 servo at the roll2 axis, d3.
    assert m3 == pytest.approx(p.link_masses[2])
    assert com3[2] == pytest.approx((plate * p.d3 / 2 + p.servo_mass * p.d3) / m3)
    mass, com, inertia = body_inertia(p)
    assert mass == pytest.approx(p.body_mass)
    # The four yaw servos are symmetric about the origin: only the residual moves the centre.
    xr = p.residual_position[0]
    np.testing.assert_allclose(com, [p.residual_mass * xr / p.body_mass, 0, 0], atol=1e-12)
    # Yaw inertia about that centre: the hull's parts and the residual as solid ellipsoids
    # (at 0 and at x_r), the yaw servos as blocks at (+-0.1, +-0.1).
    c = com[0]
    a, b, _ = p.body_semi_axes
    x, y, _ = p.servo_size
    rest = p.body_mass - 4 * p.servo_mass - p.residual_mass
    expected = (
        (rest + p.residual_mass) / 5 * (a * a + b * b)
        + rest * c * c
        + p.residual_mass * (xr - c) ** 2
        + p.servo_mass
        * sum((sx - c) ** 2 + 0.01 + (x * x + y * y) / 12 for sx in (0.1, 0.1, -0.1, -0.1))
    )
    assert inertia[2, 2] == pytest.approx(expected)


@pytest.mark.parametrize(
    "old, new, match",
    [
        ("value: 0.185  # kg each", "value: -0.185", "servo.mass = -0.185 must be finite and > 0"),
        ("value: 16", "value: 12", "servo.count = 12.0 must be 16"),
        ("    mass: 0.20\n", "    mass: 9.0\n", "the parts weigh .* more than total_mass"),
        ("    count: 2\n", "    count: 2\n    colour: red\n", "battery_packs.colour: unknown key"),
        ("  source: 'Table 1: \"Total Mass 8.4 kg\"'", "  source: ''", "total_mass has no source"),
    ],
)
def test_bad_files_give_one_line_errors(tmp_path, old, new, match):
    text = B.DEFAULT_BILL_OF_MATERIALS_FILE.read_text()
    assert old in text
    path = tmp_path / "bom.yaml"
    path.write_text(text.replace(old, new, 1))
    with pytest.raises(ScenarioError, match=match) as e:
        B.parts(B.load_bill_of_materials(path), DEFAULT_ROBOT.geometry())
    assert "\n" not in str(e.value)


def test_the_residual_trims_the_deflated_robot_level_under_water():
    """The plant's centre of mass (MultibodyPlant, zero pose) lies under the centre of
    buoyancy of the water model's sealed volumes (``build_elements``, fully submerged,
    balloon empty) to 0.5 mm: the ballast's chosen position does what its source says."""
    from pydrake.multibody.parsing import Parser
    from pydrake.multibody.plant import MultibodyPlant

    from manta_drake.model.coefficients import load_coefficients
    from manta_drake.model.kinematics import link_poses_at_zero
    from manta_drake.model.model_sdf import robot_sdf
    from manta_drake.station.water import build_elements

    plant = MultibodyPlant(0.0)
    Parser(plant).AddModelsFromString(robot_sdf(DEFAULT_ROBOT), "sdf")
    plant.Finalize()
    context = plant.CreateDefaultContext()
    com = plant.CalcCenterOfMassPositionInWorld(context)
    assert plant.CalcTotalMass(context) == pytest.approx(8.4)
    frames = {0: np.eye(4)}  # each hydro body's pose in the body frame at the zero pose
    for k, leg in enumerate(("fl", "fr", "rl", "rr")):
        poses = link_poses_at_zero(leg, DEFAULT_ROBOT)
        X = poses["X_Body_L1"]
        for i, X_next in enumerate([None] + poses["X_Lprev_L"]):
            X = X if X_next is None else X @ X_next
            frames[1 + 4 * k + i] = X
    el = build_elements(load_coefficients(), DEFAULT_ROBOT)
    centres = np.array(
        [frames[int(b)][:3, :3] @ p + frames[int(b)][:3, 3] for b, p in zip(el["body"], el["p"])]
    )
    cob = el["volume"] @ centres / el["volume"].sum()
    assert abs(com[0] - cob[0]) < 5e-4 and abs(com[1] - cob[1]) < 1e-9
    assert cob[2] - com[2] > 0.01  # and above it: stable
