"""What the floor does to each leg-fin: its normal load and how fast its loaded points slide.

Ground truth for analysis (a real robot has no such sensor): the plant's contact results
reduced per carrier, each leg-fin's links (``fl``, ``fr``, ``rl``, ``rr``) and the hull.
With hydroelastic contact a carrier's contact is a pressure patch, reported at its
centroid with its net force; with point contact a point pair. Per carrier c, over its
floor contacts i, with f_i the floor's force on the robot and v_i the velocity of the
robot's material point at the contact (world frame, z up):

    N_c = sum_i max(f_i,z, 0)
    s_c = sum_i max(f_i,z, 0) v_i,xy / N_c     (0 when N_c = 0)

N_c is the leg's normal load [N] and s_c the load-weighted horizontal slip velocity of
its contacts [m/s]: zero when the loaded points hold, the body's velocity relative to
them when they do not. ``carrier_loads`` is the pure maths; ``FootContacts`` the Drake
system that feeds it the plant's contact results and body kinematics.
"""

from __future__ import annotations

import numpy as np
from pydrake.common.value import Value
from pydrake.geometry import QueryObject
from pydrake.multibody.math import SpatialVelocity
from pydrake.multibody.plant import ContactResults
from pydrake.systems.framework import LeafSystem

from manta_drake.model.robot_params import LEGS

CARRIERS = (*LEGS, "hull")
# Per carrier: normal load [N], slip velocity x, y [m/s].
FIELDS = ("normal_force", "slip_x", "slip_y")
SIZE = len(CARRIERS) * len(FIELDS)


def carrier_loads(carriers, forces, velocities, n_carriers: int = len(CARRIERS)) -> np.ndarray:
    """(n_carriers, 3): each carrier's normal load N_c and load-weighted slip velocity
    s_c (x, y) (module docstring) of contacts ``i`` on carrier ``carriers[i]`` with force
    ``forces[i]`` (3,) on the robot and robot-point velocity ``velocities[i]`` (3,)."""
    out = np.zeros((n_carriers, 3))
    for c, f, v in zip(carriers, forces, velocities):
        fn = max(float(f[2]), 0.0)
        out[c] += fn * np.array([1.0, v[0], v[1]])
    loaded = out[:, 0] > 0.0
    out[loaded, 1:] /= out[loaded, :1]
    return out


def floor_contacts(results, floor, geometry_body):
    """(robot body index, the floor's force on the robot (3), where it acts (3)) of every
    contact in ``results`` (ContactResults) between a geometry of ``floor`` and one of
    ``geometry_body`` (robot geometry -> its body index): point pairs at their contact
    point, hydroelastic patches at their centroid with their net force."""
    for i in range(results.num_point_pair_contacts()):
        info = results.point_pair_contact_info(i)
        pair = info.point_pair()
        # contact_force is the force on body B.
        if pair.id_B in floor and pair.id_A in geometry_body:
            yield int(info.bodyA_index()), -info.contact_force(), info.contact_point()
        elif pair.id_A in floor and pair.id_B in geometry_body:
            yield int(info.bodyB_index()), info.contact_force(), info.contact_point()
    for i in range(results.num_hydroelastic_contacts()):
        info = results.hydroelastic_contact_info(i)
        surface = info.contact_surface()
        m, n = surface.id_M(), surface.id_N()
        # F_Ac_W: the force on the body of geometry M, at the patch's centroid.
        if n in floor and m in geometry_body:
            yield geometry_body[m], info.F_Ac_W().translational(), surface.centroid()
        elif m in floor and n in geometry_body:
            yield geometry_body[n], -info.F_Ac_W().translational(), surface.centroid()


def robot_geometry_bodies(plant, robot) -> dict:
    """Each collision geometry of the ``robot`` model instance -> its body's index."""
    return {
        g: int(index)
        for index in plant.GetBodyIndices(robot)
        for g in plant.GetCollisionGeometriesForBody(plant.get_body(index))
    }


class FootContacts(LeafSystem):
    """Each leg-fin's and the hull's floor load and slip (module docstring).

    .. pydrake_system::

        name: FootContacts
        input_ports:
        - contact_results
        - body_poses
        - body_spatial_velocities
        - query_object
        output_ports:
        - foot_contacts

    ``foot_contacts`` is the 15-vector [N, s_x, s_y] for fl, fr, rl, rr, hull. Inputs are
    the plant's ports of the same names and its SceneGraph's query (``AddToBuilder``
    connects them). Reading the plant's contact results solves the step's contact problem
    (~0.4 ms with the servos' PD constraints), so the output reads them only when the
    geometry overlaps something (``QueryObject.HasCollisions``): a swimming robot costs
    nothing. A diagram that logs it should do so on the plant's step grid (the diagram
    logs it every 10 ms, with its other loggers): a publish at a time off that grid splits
    the CPG's continuous integration and changes the run by ~1e-9 over seconds.

    Args:
        plant: the finalized MultibodyPlant.
        robot: the robot's model instance.
        floor_geometries: the GeometryIds of the floor (contacts with anything else are
            left out).
    """

    def __init__(self, plant, robot, floor_geometries):
        super().__init__()
        self._floor = frozenset(floor_geometries)
        self._geometry_body = robot_geometry_bodies(plant, robot)
        self._carrier = {}  # robot body index -> carrier row
        for index in plant.GetBodyIndices(robot):
            leg = plant.get_body(index).name().split("_")[0]
            self._carrier[int(index)] = CARRIERS.index(leg) if leg in LEGS else len(LEGS)
        self.DeclareAbstractInputPort("contact_results", Value(ContactResults()))
        self.DeclareAbstractInputPort("body_poses", plant.get_body_poses_output_port().Allocate())
        self.DeclareAbstractInputPort(
            "body_spatial_velocities", plant.get_body_spatial_velocities_output_port().Allocate()
        )
        self._query = self.DeclareAbstractInputPort("query_object", Value(QueryObject()))
        self.DeclareVectorOutputPort("foot_contacts", SIZE, self._calc)

    @property
    def floor_geometries(self) -> frozenset:
        """The floor's GeometryIds this system counts contacts with."""
        return self._floor

    def _calc(self, context, output):
        if not self._query.Eval(context).HasCollisions():
            output.SetFromVector(np.zeros(SIZE))
            return
        results = self.get_input_port(0).Eval(context)
        poses = self.get_input_port(1).Eval(context)
        velocities = self.get_input_port(2).Eval(context)
        carriers, forces, speeds = [], [], []
        for body, f, p in floor_contacts(results, self._floor, self._geometry_body):
            V: SpatialVelocity = velocities[body]
            carriers.append(self._carrier[body])
            forces.append(np.asarray(f))
            speeds.append(V.Shift(p - poses[body].translation()).translational())
        output.SetFromVector(carrier_loads(carriers, forces, speeds).ravel())

    @staticmethod
    def AddToBuilder(builder, plant, scene_graph, robot, floor_geometries) -> FootContacts:
        """Adds the system and connects it to ``plant``'s and ``scene_graph``'s ports."""
        system = builder.AddNamedSystem(
            "foot_contacts", FootContacts(plant, robot, floor_geometries)
        )
        builder.Connect(scene_graph.get_query_output_port(), system.GetInputPort("query_object"))
        builder.Connect(plant.get_contact_results_output_port(), system.get_input_port(0))
        builder.Connect(plant.get_body_poses_output_port(), system.get_input_port(1))
        builder.Connect(plant.get_body_spatial_velocities_output_port(), system.get_input_port(2))
        return system
