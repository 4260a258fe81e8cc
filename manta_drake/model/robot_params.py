"""The robot's numbers: one source of truth for the SDFormat model and the kinematics.

Table 2 of the paper gives the DH chain of a leg-fin but leaves a_0, d_3, d_E,
theta_init and theta_offset without numbers. They are chosen here so that
Table 1 holds (8.4 kg; 0.38 m x 0.85 m x 0.14 m at the zero pose):

* The leg-fin bases sit on the body's sides, 0.10 m ahead of / behind the centre of
  gravity (CG) and 0.10 m to each side, in the CG's horizontal plane (Table 2 has
  d_0 = 0). Hence a_0 = |(0.10, 0.10)| = 0.1414 m and theta_init = +-45 deg, +-135 deg.
* theta_offset = +-(90 + 10) deg - theta_init turns each leg-fin sideways and swept
  back by 10 deg at theta_1 = 0 (a manta's pectoral fins sweep back), so the roll axes
  are nearly parallel to the body's x axis (roll1/roll2 flap the fin up and down) and
  the pitch axis runs along the span. Why the sweep: X_gait's pitch column bends every
  distal link forward (by ~0.38 d_E) and its yaw column turns all four fins the same
  way (a pinwheel, since one DH chain serves every leg); without a sweep both trot
  support diagonals pass 7-9 cm ahead of the CG and the robot tips over in the trot.
* d_3 = 0.20 m (proximal plate, roll1 -> roll2) and d_E = 0.125 m (distal plate,
  roll2 -> tip): a short distal link keeps that forward bend small. With the sweep
  both trot diagonals pass within 1.5 cm of the CG. d_3 + d_E = 0.325 m puts the tips
  0.84 m apart at the zero pose (Table 1: 0.85 m).
* The sweep is the scenario's ``robot.fin_sweep_deg`` (``RobotParams.with_fin_sweep``): the
  mirrored reading of the gait matrices (``controller.gait_reading: mirrored``) turns all four
  fins forward at the stance and balances at 30 deg (docs/stance.md).

Frames: the paper's body frame is NED (x forward, y starboard, z down). Drake's world
is z-up, so the robot's Drake body frame is x forward, y port (left), z up; the two
differ by a rotation of pi about x, applied once, in `X_BodyDrake_BodyNed`.

Leg order (rows of R, X, Phi, Phi' in Eqs. 6-8): 1 = front-left, 2 = front-right,
3 = rear-left, 4 = rear-right. Joint order within a leg-fin (columns): yaw, roll1,
pitch, roll2. The plant's joint (and actuator) order is leg-major in that order,
so a 4x4 matrix flattened row-major is in the plant's order.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

LEGS = ("fl", "fr", "rl", "rr")
JOINTS = ("yaw", "roll1", "pitch", "roll2")
JOINT_NAMES = tuple(f"{leg}_{joint}" for leg in LEGS for joint in JOINTS)
NUM_LEGS = len(LEGS)  # 4
JOINTS_PER_LEG = len(JOINTS)  # 4
NUM_JOINTS = len(JOINT_NAMES)  # 16 = legs x joints, the plant's actuated joints
# A sensor on the hull (IMU, flow probe, altimeter) sits within this of the body's origin [m];
# a position farther out is off the robot (the hull is 0.65 m long).
HULL_SENSOR_REACH = 1.0
GAIT_SHAPE = (NUM_LEGS, JOINTS_PER_LEG)  # rows: leg-fins, columns: joints (Eqs. 6-8)
NUM_CPG_PARAMS = 4 * NUM_JOINTS  # R, X, Phi, Phi' (each legs x joints), 64


@dataclass(frozen=True)
class LegMount:
    """Where a leg-fin's base sits in the body frame (paper NED: x fwd, y right, z down)."""

    name: str
    x: float
    y: float
    sweep: float = math.radians(10.0)  # fin swept back by this at theta_1 = 0

    @property
    def a0(self) -> float:
        """Table 2, link 0: distance CG -> leg base [m]."""
        return math.hypot(self.x, self.y)

    @property
    def theta_init(self) -> float:
        """Table 2, link 0: direction of the leg base seen from the CG [rad]."""
        return math.atan2(self.y, self.x)

    @property
    def theta_offset(self) -> float:
        """Table 2, link 1: yaw-servo zero: at theta_1 = 0 the fin points sideways, swept
        back by ``sweep`` (NED yaw: left fins rotate negative, right fins positive)."""
        lateral = math.copysign(math.pi / 2, self.y)
        return lateral + math.copysign(1.0, self.y) * self.sweep - self.theta_init


@dataclass(frozen=True)
class RobotParams:
    """All numbers of the robot model. Lengths in m, masses in kg, angles in rad."""

    # Leg-fin bases (NED body frame). Left is y < 0 in NED.
    mounts: tuple = (
        LegMount("fl", 0.10, -0.10),
        LegMount("fr", 0.10, 0.10),
        LegMount("rl", -0.10, -0.10),
        LegMount("rr", -0.10, 0.10),
    )
    d3: float = 0.20  # Table 2, link 3: roll1/pitch axes -> roll2 axis, along the span
    dE: float = 0.125  # Table 2, link E: roll2 axis -> fin tip, along the span

    # Body: a flat ellipsoid (NACA0022-like section), semi-axes along x, y, z.
    body_semi_axes: tuple = (0.19, 0.12, 0.07)
    # Masses from models/bill_of_materials.yaml (model.bill_of_materials) when None: the
    # hull body's (hull, what it holds, the yaw servos, the residual) and per leg-fin link
    # 1-4's (link 1: the roll1 servo; link 2: the pitch servo; link 3: the proximal plate
    # and the roll2 servo; link 4: the distal plate), and one servo's mass and case size.
    body_mass: float | None = None
    link_masses: tuple | None = None
    servo_mass: float | None = None
    servo_size: tuple | None = None
    # The hull's residual (its ballast among it) and where its centre sits (body frame).
    residual_mass: float | None = None
    residual_position: tuple | None = None
    proximal_chord: float = 0.14
    distal_chord: float = 0.10
    fin_thickness: float = 0.012  # NACA0012 at ~0.1 m chord

    # Joint limits [rad] per joint type (yaw, roll1, pitch, roll2) and servo class.
    position_limits: tuple = (
        (-math.radians(60), math.radians(60)),
        (-math.radians(90), math.radians(90)),
        (-math.radians(90), math.radians(90)),
        (-math.radians(100), math.radians(100)),
    )
    effort_limit: float = 6.0  # N m; waterproof servo class (stall ~10 N m)
    velocity_limit: float = 8.0  # rad/s
    kp: float = 60.0  # N m / rad, implicit PD (drake:controller_gains)
    kd: float = 0.6  # N m s / rad
    joint_damping: float = 0.02  # N m s / rad, gear-train viscous friction

    # Camera on the head (Drake body frame: x fwd, y left, z up).
    camera_position: tuple = (0.19, 0.0, 0.03)
    camera_pitch_down: float = math.radians(10.0)

    # Contact (wet, point contact with SAP). 0.8: rubber-tipped fins on the rough painted
    # concrete of an outdoor pool, the top of the wet range 0.5-0.8. The gait speeds are
    # sensitive to it (walk vs trot: walk ahead at 0.5 and 0.8, trot ahead at 0.6).
    friction: float = 0.8
    # Hydroelastic contact (model_sdf._contact_props): the robot's geometry is rigid, the
    # pool's compliant (PoolParams.hydroelastic_modulus). The resolution of the hull
    # ellipsoid's surface mesh (the plates' boxes are exact).
    hydroelastic_resolution: float = 0.02  # m

    def __post_init__(self):
        if None in (
            self.body_mass,
            self.link_masses,
            self.servo_mass,
            self.servo_size,
            self.residual_mass,
            self.residual_position,
        ):
            from manta_drake.model import bill_of_materials as bom

            shipped = bom.shipped_bill_of_materials()
            rows = bom.parts(shipped, self.geometry())
            body, links = bom.carried_masses(rows)
            derived = {
                "body_mass": body,
                "link_masses": links,
                "servo_mass": shipped.servo.mass.value,
                "servo_size": tuple(shipped.servo.size.value),
                "residual_mass": rows[-1].mass,
                "residual_position": rows[-1].position,
            }
            for name, value in derived.items():
                if getattr(self, name) is None:
                    object.__setattr__(self, name, value)

    def geometry(self):
        """The dimensions the bill of materials' masses and volumes follow."""
        from manta_drake.model.bill_of_materials import Geometry

        return Geometry(
            tuple(self.body_semi_axes),
            self.fin_thickness,
            self.proximal_chord,
            self.d3,
            self.distal_chord,
            self.dE,
        )

    @property
    def servo_volume(self) -> float:
        """The water one servo's case displaces [m^3]: its envelope."""
        assert self.servo_size is not None  # set by __post_init__
        return math.prod(self.servo_size)

    @property
    def plate_volumes(self) -> tuple[float, float]:
        """The water the proximal and the distal plate displace [m^3]: a NACA0012 section
        (model.bill_of_materials.naca_section_area) times the span."""
        from manta_drake.model.bill_of_materials import naca_section_area

        t = self.fin_thickness
        return (
            naca_section_area(t, self.proximal_chord) * self.d3,
            naca_section_area(t, self.distal_chord) * self.dE,
        )

    def with_fin_sweep(self, sweep: float) -> RobotParams:
        """These parameters with every leg-fin swept back by ``sweep`` [rad] at theta_1 = 0
        (negative: swept forward)."""
        return replace(self, mounts=tuple(replace(m, sweep=sweep) for m in self.mounts))

    @property
    def total_mass(self) -> float:
        assert self.body_mass is not None and self.link_masses is not None  # __post_init__
        return self.body_mass + len(self.mounts) * sum(self.link_masses)

    def mount(self, leg: str) -> LegMount:
        for m in self.mounts:
            if m.name == leg:
                return m
        raise KeyError(f"unknown leg '{leg}', expected one of {LEGS}")


DEFAULT_ROBOT = RobotParams()


def robot_with_fin_sweep_deg(fin_sweep_deg: float) -> RobotParams:
    """DEFAULT_ROBOT with every fin swept back by ``fin_sweep_deg`` at theta_1 = 0
    (DEFAULT_ROBOT itself at its own sweep, so the shipped manta.sdf is used)."""
    sweep = math.radians(fin_sweep_deg)
    if all(m.sweep == sweep for m in DEFAULT_ROBOT.mounts):
        return DEFAULT_ROBOT
    return DEFAULT_ROBOT.with_fin_sweep(sweep)


@dataclass(frozen=True)
class PoolParams:
    """The paper's outdoor pool (section 4.1): 15 m x 2 m, 0.5 m deep; water surface at z = 0."""

    length: float = 15.0
    width: float = 2.0
    depth: float = 0.5
    wall_height_above_water: float = 0.2
    wall_thickness: float = 0.1
    floor_thickness: float = 0.1
    friction: float = 0.8
    # Hydroelastic contact: what touches the floor is a fin plate's edge, which point
    # contact resolves as one corner that chatters under friction (1 ms contacts every ~10
    # ms, 100-550 N spikes); a pressure field over the edge holds it. The compliance sits in
    # the pool's floor and walls, the thick bodies (a thin compliant plate's pressure field
    # stays soft at its corners whatever its modulus), and the robot is rigid. The modulus
    # is chosen where the gaits have converged to the stiff limit (painted concrete and a
    # PLA tip are far stiffer than a 1 ms step resolves): 1e9 Pa, 0.5-0.7 mm penetration;
    # over 1e8-1e10 Pa the walk makes 0.022-0.031 m/s, the trot 0.036-0.042 (docs/design.md,
    # section 4).
    hydroelastic_modulus: float = 1.0e9  # Pa


DEFAULT_POOL = PoolParams()
