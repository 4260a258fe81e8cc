"""A downward echo sounder (altimeter) on the hull: the range to the pool's floor.

The part modelled is a small single-beam sonar altimeter of the Blue Robotics Ping class:
a transducer on the hull's underside sends a cone of sound of half-angle beta along the
body's -z axis and reports the range of the first echo. Over a flat floor at distance d
from the transducer, whose nearest point lies at angle theta from the beam's axis, the
first echo comes from the cone's ray closest to the floor's normal::

    range = d                        if theta <= beta
            d / cos(theta - beta)    if beta < theta < beta + 90 deg
            no echo                  otherwise

so the reading is the true height while the hull tilts by less than beta, and grows slowly
beyond (a 20 deg pitch with beta = 15 deg reads 0.4 % long). d and the direction of the
floor's nearest point come from the scene's geometry (SceneGraph's signed distance from
the transducer to the pool's floor geometries), so any floor the pool model has is what
the sensor sees. A reading is Gaussian noise added to the range, NaN (no reading) outside
[min_range, max_range] or without an echo, and NaN on a dropout (probability
``dropout_rate`` per reading). Walls are not modelled as echo targets: the beam looks down.

``echo_range`` and ``altimeter_sample`` are the pure maths; ``Altimeter`` the Drake system
that feeds them SceneGraph's distances; ``add_altimeter`` adds it and its noise sources.
"""

import dataclasses as dc
import math

import numpy as np
from pydrake.common import RandomDistribution
from pydrake.common.value import AbstractValue
from pydrake.geometry import QueryObject
from pydrake.systems.framework import LeafSystem
from pydrake.systems.primitives import Multiplexer, RandomSource

from manta_drake.config_io import check_boolean, check_in_range, check_vector
from manta_drake.model.plant import floor_geometries
from manta_drake.model.robot_params import HULL_SENSOR_REACH


@dc.dataclass
class AltimeterParams:
    """The altimeter's mounting, beam, range, rate and noise. Defaults: a Ping-class
    echo sounder (30 deg beam; its 0.5 % of range resolution at the pool's depths is
    ~1-3 mm, taken as 5 mm of noise with the hull's vibration), a 10 Hz ping rate and a
    short-range transducer's 0.05 m blanking distance."""

    enabled: bool = False
    rate_hz: float = 10.0  # Hz, pings per second
    # The transducer on the hull's underside, in the hull's (body) frame [m].
    position: list[float] = dc.field(default_factory=lambda: [0.0, 0.0, -0.08])
    beam_half_angle_deg: float = 15.0  # half the beam's width
    min_range: float = 0.05  # m, nearer echoes return during the transducer's ring-down
    max_range: float = 5.0  # m, farther echoes are too weak
    noise_std: float = 0.005  # m, white noise on the range
    dropout_rate: float = 0.0  # probability that a reading is missing (NaN)

    MAX_RANGE_M = 100.0  # the largest max_range taken (a long-range part's)

    def validate(self, prefix: str = "altimeter") -> "AltimeterParams":
        """Checks every field; ValueError, one line naming ``<prefix>.<field>``, the value
        and the allowed range. Returns self."""
        check_boolean(f"{prefix}.enabled", self.enabled)
        check_in_range(f"{prefix}.rate_hz", self.rate_hz, 0.0, 100.0, "(0, 100] Hz", open_low=True)
        check_in_range(
            f"{prefix}.beam_half_angle_deg", self.beam_half_angle_deg, 0.0, 60.0, "[0, 60] deg"
        )
        check_in_range(
            f"{prefix}.max_range",
            self.max_range,
            0.0,
            self.MAX_RANGE_M,
            f"(0, {self.MAX_RANGE_M:g}] m",
            open_low=True,
        )
        check_in_range(
            f"{prefix}.min_range",
            self.min_range,
            0.0,
            self.max_range,
            f"[0, max_range = {self.max_range:g}) m",
            open_high=True,
        )
        check_in_range(f"{prefix}.noise_std", self.noise_std, 0.0, 0.5, "[0, 0.5] m")
        check_in_range(f"{prefix}.dropout_rate", self.dropout_rate, 0.0, 1.0, "[0, 1]")
        check_vector(f"{prefix}.position", self.position, 3, HULL_SENSOR_REACH, " m")
        return self


def echo_range(distance: float, off_axis: float, half_angle: float) -> float:
    """The first echo's range [m] from a plane at ``distance`` [m] whose nearest point lies
    ``off_axis`` [rad] from the beam's axis, for a beam of ``half_angle`` [rad]: d within
    the beam, d / cos(off_axis - half_angle) beyond it, inf when no ray of the beam meets
    the plane (off_axis - half_angle >= pi / 2)."""
    if off_axis <= half_angle:
        return float(distance)
    if off_axis - half_angle >= 0.5 * math.pi:
        return math.inf
    return float(distance) / math.cos(off_axis - half_angle)


def altimeter_sample(
    true_range: float, params: AltimeterParams, normal_sample: float, uniform_sample: float
) -> float:
    """One reading: NaN on a dropout (``uniform_sample < dropout_rate``) or with the true
    range outside [min_range, max_range]; else the range plus ``noise_std`` times the
    normal sample."""
    if uniform_sample < params.dropout_rate:
        return math.nan
    if not params.min_range <= true_range <= params.max_range:
        return math.nan
    return true_range + params.noise_std * normal_sample


class Altimeter(LeafSystem):
    """The range from a hull-fixed echo sounder to the floor, sampled with noise.

    .. pydrake_system::

        name: Altimeter
        input_ports:
        - geometry_query
        - noise (optional)
        output_ports:
        - altitude
        - altitude_true

    * ``geometry_query``: the plant's SceneGraph's query object (the floor and the hull's
      pose in it).
    * ``noise`` (2, optional): [standard normal sample, uniform [0, 1) sample] per ping,
      from Drake ``RandomSource`` systems. Unconnected: no noise, no dropouts.
    * ``altitude`` (1) [m]: ``altimeter_sample`` of ``echo_range`` to the nearest floor
      geometry (NaN: no reading).
    * ``altitude_true`` (1) [m]: ``echo_range`` without noise or dropouts (inf: no echo),
      for logs and tests; a controller must not read it.

    Both outputs are discrete state sampled every 1 / ``rate_hz`` seconds from t = 0 and
    set at initialization to the initial state's noiseless reading: no direct feedthrough.

    Args:
        frame_id: the SceneGraph frame of the body the transducer is fixed to.
        floor_ids: the floor's geometry ids (the echo targets).
        params: AltimeterParams (checked; ``enabled`` is the caller's switch).

    Raises:
        ValueError: a parameter outside its range, or no floor geometry.
    """

    def __init__(self, frame_id, floor_ids, params: AltimeterParams | None = None):
        super().__init__()
        params = (AltimeterParams() if params is None else params).validate()
        if not floor_ids:
            raise ValueError("Altimeter.floor_ids: needs at least one floor geometry")
        self.params = dc.replace(params, position=list(params.position))
        self.frame_id = frame_id
        self.floor_ids = frozenset(floor_ids)
        self.p_BS = np.asarray(params.position, dtype=float).reshape(3)
        self.period = 1.0 / float(params.rate_hz)
        self._half_angle = math.radians(params.beam_half_angle_deg)
        self._query = self.DeclareAbstractInputPort(
            "geometry_query", AbstractValue.Make(QueryObject())
        )
        self._noise = self.DeclareVectorInputPort("noise", 2)
        self._reading = self.DeclareDiscreteState([math.nan])
        self._true = self.DeclareDiscreteState([math.inf])
        self.DeclareStateOutputPort("altitude", self._reading)
        self.DeclareStateOutputPort("altitude_true", self._true)
        self.DeclarePeriodicDiscreteUpdateEvent(self.period, 0.0, self._sample)
        self.DeclareInitializationDiscreteUpdateEvent(self._initialize)

    def true_range(self, context) -> float:
        """The noiseless first-echo range [m] (inf: no echo within max_range)."""
        query = self._query.Eval(context)
        X_WB = query.GetPoseInWorld(self.frame_id)
        p_WS = X_WB @ self.p_BS
        axis_W = -X_WB.rotation().matrix()[:, 2]  # the beam looks along body -z
        best = math.inf
        for hit in query.ComputeSignedDistanceToPoint(p_WS, self.params.max_range):
            if hit.id_G not in self.floor_ids or hit.distance <= 0.0:
                continue
            toward = -np.asarray(hit.grad_W, dtype=float)  # from the transducer to the floor
            off_axis = math.acos(min(1.0, max(-1.0, float(axis_W @ toward))))
            best = min(best, echo_range(hit.distance, off_axis, self._half_angle))
        return best

    def _initialize(self, context, discrete_state):
        true = self.true_range(context)
        discrete_state.get_mutable_vector(self._true).SetAtIndex(0, true)
        discrete_state.get_mutable_vector(self._reading).SetAtIndex(
            0, altimeter_sample(true, dc.replace(self.params, dropout_rate=0.0), 0.0, 1.0)
        )

    def _sample(self, context, discrete_state):
        n, u = self._noise.Eval(context) if self._noise.HasValue(context) else (0.0, 1.0)
        true = self.true_range(context)
        discrete_state.get_mutable_vector(self._true).SetAtIndex(0, true)
        discrete_state.get_mutable_vector(self._reading).SetAtIndex(
            0, altimeter_sample(true, self.params, n, u)
        )


def add_altimeter(
    builder, plant_handles, params: AltimeterParams | None = None, name: str = "altimeter"
) -> Altimeter:
    """Adds an Altimeter on the robot's hull (``plant_handles.body``), looking at the pool's
    floor, and its noise to ``builder``.

    Adds the sensor (named ``name``), a Gaussian and a uniform ``RandomSource`` of 1
    sample per ping (``<name>_noise_normal``, ``<name>_noise_uniform``) muxed into its
    ``noise`` input, and connects the plant's SceneGraph query output to its
    ``geometry_query``. The output ``altitude`` is left to the caller.

    Returns:
        The sensor, owned by the builder.
    """
    plant = plant_handles.plant
    frame_id = plant.GetBodyFrameIdOrThrow(plant_handles.body.index())
    sensor = builder.AddNamedSystem(
        name, Altimeter(frame_id, floor_geometries(plant_handles), params)
    )
    builder.Connect(
        plant_handles.scene_graph.get_query_output_port(), sensor.GetInputPort("geometry_query")
    )
    mux = builder.AddNamedSystem(f"{name}_noise", Multiplexer([1, 1]))
    for k, distribution in enumerate((RandomDistribution.kGaussian, RandomDistribution.kUniform)):
        kind = ("normal", "uniform")[k]
        source = builder.AddNamedSystem(
            f"{name}_noise_{kind}", RandomSource(distribution, 1, sensor.period)
        )
        builder.Connect(source.get_output_port(), mux.get_input_port(k))
    builder.Connect(mux.get_output_port(), sensor.GetInputPort("noise"))
    return sensor
