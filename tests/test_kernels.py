"""The compiled kernels against the numpy reference, the compiled paths of the systems
against the reference paths, constructor checks, and the camera's own scene."""

import copy

import numpy as np
import pytest
from pydrake.multibody.tree import BodyIndex, JacobianWrtVariable
from pydrake.systems.framework import DiagramBuilder
from scipy.spatial.transform import Rotation

from manta_drake.control import cpg as C
from manta_drake.control import cpg_kernels as CK
from manta_drake.model.coefficients import load_coefficients
from manta_drake.model.plant import add_plant, body_pose, set_initial_state
from manta_drake.station import water_kernels as WK
from manta_drake.station.hydro import HydrodynamicForces
from manta_drake.station.water import hydro_body_names

COEFFS = load_coefficients()
NB = len(hydro_body_names())


@pytest.fixture(scope="module")
def water_plant():
    """(diagram, PlantHandles, HydrodynamicForces with the state ports) in one diagram."""
    builder = DiagramBuilder()
    h = add_plant(builder, hydro=COEFFS)
    hydro = HydrodynamicForces.AddToBuilder(
        builder,
        h.plant,
        h.robot,
        COEFFS,
        1e-3,
        added_mass_iso=h.added_mass_iso,
        current=(0.1, -0.05, 0.02),
        inputs="plant_state",
    )
    return builder.Build(), h, hydro


def random_kinematics(rng, nb=NB):
    """Attitudes anywhere, origins straddling the surface (partial submersion), fast motion."""
    R = Rotation.random(nb, random_state=int(rng.integers(1 << 30))).as_matrix()
    p = np.column_stack(
        [rng.uniform(-1, 1, nb), rng.uniform(-1, 1, nb), rng.uniform(-0.25, 0.25, nb)]
    )
    return R, p, rng.normal(scale=2.0, size=(nb, 3)), rng.normal(scale=0.5, size=(nb, 3))


def random_state(h, context, rng):
    plant = h.plant
    plant_context = plant.GetMyMutableContextFromRoot(context)
    set_initial_state(
        h,
        plant_context,
        body_pose(
            [rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(-0.2, 0.1)],
            rng.uniform(-180, 180, 3),
        ),
        rng.uniform(-1.5, 1.5, 16),
    )
    plant.SetVelocities(plant_context, rng.normal(scale=0.7, size=plant.num_velocities()))
    return plant_context


# --- water: kernels vs the numpy reference ------------------------------------------------------


def test_water_kernel_equals_the_numpy_reference_on_random_states(water_plant, rng):
    _, _, hydro = water_plant
    for k in range(40):
        R, p, w, v = random_kinematics(rng)
        balloon = (0.0, 1e-10, 1.5e-3, 2.6e-3)[k % 4]  # empty (skipped), tiny, half, full
        accel = (rng.normal(size=3), rng.normal(size=3)) if k % 3 else (None, None)
        got = hydro.compute_compiled(R, p, w, v, balloon, *accel)
        expected = hydro.compute_reference(R, p, w, v, balloon, *accel)
        assert np.abs(expected).max() > 1.0  # the terms are active
        np.testing.assert_allclose(got, expected, rtol=1e-12, atol=1e-12)


def test_water_kernel_with_rigid_plates_and_changed_parameters(water_plant, rng):
    """Other constructor arguments reach the kernel's packed arrays: rigid plates (the
    other branch of passive pitching), a pitch residual of added inertia, a current."""
    _, h, _ = water_plant
    coeffs = copy.deepcopy(COEFFS)
    coeffs.fins.passive_pitch_max_deg.value = 0.0
    roll, _, yaw = coeffs.body.added_inertia.value
    coeffs.body.added_inertia.value = [roll, roll + yaw + 0.01, yaw]  # 0.01 above the implicit
    default = HydrodynamicForces(h.plant, h.robot, COEFFS, 1e-3, added_mass_iso=h.added_mass_iso)
    hydro = HydrodynamicForces(
        h.plant, h.robot, coeffs, 1e-3, added_mass_iso=h.added_mass_iso, current=(0.3, 0.0, 0.0)
    )
    assert hydro.pitch_max == 0.0
    np.testing.assert_allclose(hydro.residual_added_inertia, [0.0, 0.01, 0.0], atol=1e-15)
    R, p, w, v = random_kinematics(rng)
    a, alpha = rng.normal(size=3), rng.normal(size=3)
    before = default.compute_compiled(R, p, w, v, 1e-3, a, alpha)
    got = hydro.compute_compiled(R, p, w, v, 1e-3, a, alpha)
    assert np.abs(got - before).max() > 1e-3
    np.testing.assert_allclose(
        got, hydro.compute_reference(R, p, w, v, 1e-3, a, alpha), rtol=1e-12, atol=1e-12
    )


def test_hydro_parameters_are_fixed_at_construction(water_plant):
    """Assigning or changing a parameter in place fails: the kernels were packed from them
    once, so a changed copy would leave the compiled backend behind the numpy one."""
    _, _, hydro = water_plant
    for name in ("current", "pitch_max", "residual_added_inertia", "inputs", "backend"):
        with pytest.raises(AttributeError):
            setattr(hydro, name, getattr(hydro, name))
    with pytest.raises(ValueError, match="read-only"):
        hydro.current[0] = 0.5
    with pytest.raises(ValueError, match="read-only"):
        hydro.el["strip_area"][0] = 1.0
    with pytest.raises(TypeError):
        hydro.el["strip_area"] = np.zeros(3)
    np.testing.assert_array_equal(hydro.current, [0.1, -0.05, 0.02])


def test_kinematics_kernel_equals_the_plant(water_plant, rng):
    diagram, h, hydro = water_plant
    context = diagram.CreateDefaultContext()
    for _ in range(10):
        plant_context = random_state(h, context, rng)
        R, p, w, v = hydro._kinematics(hydro.GetMyContextFromRoot(context))
        poses = h.plant.get_body_poses_output_port().Eval(plant_context)
        velocities = h.plant.get_body_spatial_velocities_output_port().Eval(plant_context)
        X = np.array([poses[i].GetAsMatrix34() for i in hydro.body_indices])
        V = np.array([velocities[i].get_coeffs() for i in hydro.body_indices])
        np.testing.assert_allclose(R, X[:, :, :3], rtol=0, atol=1e-12)
        np.testing.assert_allclose(p, X[:, :, 3], rtol=0, atol=1e-12)
        np.testing.assert_allclose(w, V[:, :3], rtol=0, atol=1e-12)
        np.testing.assert_allclose(v, V[:, 3:], rtol=0, atol=1e-12)


def test_generalized_forces_are_the_plant_jacobians_transposed(water_plant, rng):
    diagram, h, hydro = water_plant
    plant = h.plant
    context = diagram.CreateDefaultContext()
    for _ in range(5):
        plant_context = random_state(h, context, rng)
        F = rng.normal(scale=20.0, size=(NB, 6))
        expected = np.zeros(plant.num_velocities())
        for row, index in zip(F, hydro.body_indices):
            frame = plant.get_body(BodyIndex(index)).body_frame()
            J = plant.CalcJacobianSpatialVelocity(
                plant_context,
                JacobianWrtVariable.kV,
                frame,
                np.zeros(3),
                plant.world_frame(),
                plant.world_frame(),
            )
            expected += J.T @ row
        got = hydro.generalized_forces(plant.get_state_output_port().Eval(plant_context), F)
        np.testing.assert_allclose(got, expected, rtol=1e-12, atol=1e-12)


# Every (inputs, backend) pair; the first is the station's.
VARIANTS = [
    ("plant_state", "compiled"),
    ("plant_state", "numpy"),
    ("contract", "compiled"),
    ("contract", "numpy"),
]


def _hydro_diagram(inputs: str, backend: str, update_period: float, apply_as=None):
    builder = DiagramBuilder()
    h = add_plant(builder, hydro=COEFFS)
    hydro = HydrodynamicForces.AddToBuilder(
        builder,
        h.plant,
        h.robot,
        COEFFS,
        1e-3,
        added_mass_iso=h.added_mass_iso,
        current=(0.05, 0.02, 0.0),
        update_period=update_period,
        inputs=inputs,
        backend=backend,
        apply_as=apply_as,
    )
    return builder.Build(), h, hydro


@pytest.mark.slow
def test_every_port_set_and_backend_gives_the_same_forces(rng):
    """The output ports of the four (inputs, backend) variants on the same random plant
    states, with the hull's velocity samples set so the residual added mass is active."""
    systems = [_hydro_diagram(inputs, backend, 0.0) for inputs, backend in VARIANTS]
    contexts = [diagram.CreateDefaultContext() for diagram, _, _ in systems]
    for k in range(8):
        seed = int(rng.integers(1 << 30))
        v_prev = np.r_[rng.normal(size=6), 0.0, np.zeros(6), -1.0]
        spatial, generalized = [], []
        for (_diagram, h, hydro), context in zip(systems, contexts):
            random_state(h, context, np.random.default_rng(seed))
            context.SetTime(1e-3)
            hydro_context = hydro.GetMyMutableContextFromRoot(context)
            hydro_context.SetDiscreteState(0, v_prev)
            hydro.GetInputPort("balloon_volume").FixValue(hydro_context, [(k % 3) * 1e-3])
            spatial.append(
                np.array(
                    [
                        np.r_[f.F_Bq_W.rotational(), f.F_Bq_W.translational()]
                        for f in hydro.GetOutputPort("spatial_forces").Eval(hydro_context)
                    ]
                )
            )
            if hydro.inputs == "plant_state":
                generalized.append(hydro.GetOutputPort("generalized_forces").Eval(hydro_context))
        assert np.abs(spatial[0]).max() > 1.0  # the terms are active
        for got in spatial[1:]:
            np.testing.assert_allclose(got, spatial[0], rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(generalized[1], generalized[0], rtol=1e-12, atol=1e-12)
        # The residual added mass acts: the same forces without the samples differ.
        hydro_context.SetDiscreteState(0, np.tile(np.r_[np.zeros(6), -1.0], 2))
        without = hydro.compute_reference(*hydro._kinematics(hydro_context), (k % 3) * 1e-3)
        assert np.abs(without - spatial[-1]).max() > 1e-6


@pytest.mark.slow
@pytest.mark.parametrize("update_period", [0.0, 0.004])
@pytest.mark.parametrize("inputs, backend", VARIANTS[1:])
def test_every_variant_moves_the_plant_as_the_stations(inputs, backend, update_period):
    """The robot released flapping in the water, forces applied as AddToBuilder connects
    them (with the state input: generalized forces, held too): the same motion as the
    station's variant (state input, compiled maths)."""
    from pydrake.systems.analysis import Simulator

    x0 = None
    finals = []
    for inputs_, backend_ in (VARIANTS[0], (inputs, backend)):
        apply_as = "generalized_forces" if inputs_ == "plant_state" else None
        diagram, h, hydro = _hydro_diagram(inputs_, backend_, update_period, apply_as)
        simulator = Simulator(diagram)
        context = simulator.get_mutable_context()
        plant_context = h.plant.GetMyMutableContextFromRoot(context)
        if x0 is None:
            random_state(h, context, np.random.default_rng(7))
            h.plant.SetVelocities(plant_context, 0.3 * h.plant.GetVelocities(plant_context))
            # In the middle of the pool, clear of its walls and floor: in contact, SAP's
            # iterative solve would amplify the paths' 1e-12 differences.
            X = h.plant.GetFreeBodyPose(plant_context, h.body)
            X.set_translation([0.0, 0.0, -0.05])
            h.plant.SetFreeBodyPose(plant_context, h.body, X)
            x0 = h.plant.GetPositionsAndVelocities(plant_context)
        h.plant.SetPositionsAndVelocities(plant_context, x0)
        hydro.GetInputPort("balloon_volume").FixValue(hydro.GetMyContextFromRoot(context), [1.0e-3])
        simulator.Initialize()
        simulator.AdvanceTo(0.1)
        finals.append(h.plant.GetPositionsAndVelocities(plant_context))
    assert np.abs(finals[0] - x0).max() > 1e-3  # it moved
    np.testing.assert_allclose(finals[0], finals[1], rtol=0, atol=1e-10)


# --- CPG: kernels vs the numpy reference --------------------------------------------------------


def test_cpg_kernels_equal_the_numpy_reference(rng):
    weights = C.pair_weights(3.0, 5.0)
    omega = 2.0 * np.pi * 0.7
    xdot, desired, angles = np.empty(80), np.empty(32), np.empty(16)
    for _ in range(50):
        x, params = rng.uniform(-3, 3, 80), rng.uniform(-3, 3, 64)
        CK.derivatives(x, params, omega, C.PAIRS, weights, 17.0, 23.0, 16, xdot)
        np.testing.assert_allclose(
            xdot, C.cpg_derivatives(x, params, 0.7, weights, 17.0, 23.0), rtol=1e-12, atol=1e-12
        )
        phi_dot = C.phase_rates(x[:16], params, 0.7, weights)
        CK.desired_state(x, params, omega, C.PAIRS, weights, 16, desired)
        np.testing.assert_allclose(
            desired,
            np.concatenate([C.joint_angles(x), C.joint_rates(x, phi_dot)]),
            rtol=1e-12,
            atol=1e-12,
        )
        CK.angles(x, 16, angles)
        np.testing.assert_allclose(angles, C.joint_angles(x), rtol=1e-12, atol=1e-12)


def test_cpg_system_compiled_equals_reference(rng, monkeypatch):
    kw = dict(frequency_hz=0.7, chain_weight=3.0, fcs_weight=5.0, a=17.0, b=23.0)
    systems = [C.CpgOscillators(**kw), C.CpgOscillators(**kw, compiled=False)]
    calls = []  # the reference system really runs the numpy functions

    def counted(*args, _reference=C.cpg_derivatives):
        calls.append(1)
        return _reference(*args)

    monkeypatch.setattr(C, "cpg_derivatives", counted)
    x, params = rng.uniform(-3, 3, 80), rng.uniform(-3, 3, 64)
    results = []
    for cpg in systems:
        context = cpg.CreateDefaultContext()
        context.SetContinuousState(x)
        cpg.GetInputPort("cpg_params").FixValue(context, params)
        results.append(
            np.concatenate(
                [
                    cpg.EvalTimeDerivatives(context).CopyToVector(),
                    cpg.GetOutputPort("desired_state").Eval(context),
                    cpg.GetOutputPort("joint_angles").Eval(context),
                ]
            )
        )
    assert len(calls) == 1
    np.testing.assert_allclose(results[0], results[1], rtol=1e-12, atol=1e-12)


# --- constructor checks ----------------------------------------------------------------------


@pytest.mark.parametrize(
    "kwargs, match",
    [
        (dict(time_step=0.0), "time_step: 0.0 must be a finite number > 0"),
        (dict(time_step=-1e-3), "time_step"),
        (dict(time_step=float("nan")), "time_step"),
        (dict(time_step=float("inf")), "time_step"),
        (dict(time_step="1e-3"), "time_step"),
        (dict(update_period=-0.004), "update_period: -0.004 must be a finite number >= 0"),
        (dict(update_period=float("nan")), "update_period"),
        (dict(current=(0.0, float("nan"), 0.0)), "current: .* must be 3 finite numbers"),
        (dict(current=(0.1, 0.0)), "current: .* must be 3 finite numbers"),
        (dict(current="east"), "current: .* must be 3 finite numbers"),
        (
            dict(current=(1.5, 1.5, 0.0)),
            r"current: .* 2.12 m/s is outside the allowed range \[0, 2",
        ),
        (dict(inputs="state"), "inputs: 'state' must be one of 'contract', 'plant_state'"),
        (dict(inputs=True), "inputs: True must be one of"),
        (dict(backend="numba"), "backend: 'numba' must be one of 'compiled', 'numpy'"),
    ],
)
def test_hydro_constructor_rejects_bad_arguments(water_plant, kwargs, match):
    _, h, _ = water_plant
    args = dict(time_step=1e-3)
    args.update(kwargs)
    time_step = args.pop("time_step")
    with pytest.raises(ValueError, match="HydrodynamicForces." + match):
        HydrodynamicForces(h.plant, h.robot, COEFFS, time_step, **args)


@pytest.mark.parametrize("backend", ["compiled", "numpy"])
def test_hydro_constructor_accepts_the_edges(water_plant, backend):
    """The largest current (2 m/s) and forces at every step (update_period 0) are taken
    and reach the forces: the hull at rest deep under water in that current feels the
    surge drag law of Eq. (2), (d_lin + d_quad |u|) u with u = 2 m/s, and no held state."""
    _, h, _ = water_plant
    hydro = HydrodynamicForces(
        h.plant, h.robot, COEFFS, 1e-3, current=(2.0, 0.0, 0.0), update_period=0.0, backend=backend
    )
    assert hydro.num_discrete_state_groups() == 1  # the velocity samples only: nothing held
    nb = len(hydro_body_names())
    R, p = np.tile(np.eye(3), (nb, 1, 1)), np.tile([0.0, 0.0, -1.0], (nb, 1))
    F = hydro.compute(R, p, np.zeros((nb, 3)), np.zeros((nb, 3)), 0.0)
    d_lin, d_quad = COEFFS.body.linear_damping.value[0], COEFFS.body.quadratic_damping.value[0]
    assert F[0, 3] == pytest.approx((d_lin + d_quad * 2.0) * 2.0, rel=1e-12)
    assert F[0, 3] > 0  # downstream
    np.testing.assert_allclose(F[0, 4], 0.0, atol=1e-12)


@pytest.mark.parametrize(
    "kwargs, match",
    [
        (dict(apply_as="joint_torques"), "apply_as: 'joint_torques' must be None or one of"),
        (
            dict(apply_as="generalized_forces"),
            "apply_as: 'generalized_forces' needs inputs='plant_state', got inputs='contract'",
        ),
    ],
)
def test_add_to_builder_rejects_bad_arguments(kwargs, match):
    builder = DiagramBuilder()
    h = add_plant(builder, hydro=COEFFS)
    with pytest.raises(ValueError, match="HydrodynamicForces.AddToBuilder." + match):
        HydrodynamicForces.AddToBuilder(builder, h.plant, h.robot, COEFFS, 1e-3, **kwargs)


@pytest.mark.parametrize(
    "inputs, update_period, force_port",
    [
        ("plant_state", 0.0, "applied_generalized_force"),
        ("plant_state", 0.004, "applied_spatial_force"),
        ("contract", 0.0, "applied_spatial_force"),
    ],
)
def test_add_to_builder_connects_the_plant(inputs, update_period, force_port):
    """Its inputs come from the plant, its forces go into the plant's input that the
    default ``apply_as`` names; only ``balloon_volume`` is left to the caller."""
    builder = DiagramBuilder()
    h = add_plant(builder, hydro=COEFFS)
    hydro = HydrodynamicForces.AddToBuilder(
        builder,
        h.plant,
        h.robot,
        COEFFS,
        1e-3,
        added_mass_iso=h.added_mass_iso,
        update_period=update_period,
        inputs=inputs,
        name="water",
    )
    assert hydro.get_name() == "water"
    unconnected = [
        hydro.get_input_port(i).get_name()
        for i in range(hydro.num_input_ports())
        if not builder.IsConnectedOrExported(hydro.get_input_port(i))
    ]
    assert unconnected == ["balloon_volume"]
    ports = {
        "applied_generalized_force": h.plant.get_applied_generalized_force_input_port(),
        "applied_spatial_force": h.plant.get_applied_spatial_force_input_port(),
    }
    for name, port in ports.items():
        assert builder.IsConnectedOrExported(port) == (name == force_port), name


@pytest.mark.parametrize(
    "initial_state, match",
    [
        (np.zeros(79), r"expected 80 finite values .* got shape \(79,\)"),
        (np.zeros((5, 16)), r"got shape \(5, 16\)"),
        (np.r_[np.zeros(79), np.nan], "non-finite"),
        (["a"] * 80, "not numbers"),
    ],
)
def test_cpg_constructor_rejects_a_bad_initial_state(initial_state, match):
    with pytest.raises(ValueError, match="CpgOscillators.initial_state: .*" + match):
        C.CpgOscillators(initial_state=initial_state)


@pytest.mark.parametrize(
    "kwargs, name",
    [
        (dict(frequency_hz="1"), "frequency_hz"),
        (dict(a=0.0), "a"),
        (dict(b=-1.0), "b"),
        (dict(fcs_weight=float("inf")), "fcs_weight"),
        (dict(chain_weight=True), "chain_weight"),
    ],
)
def test_cpg_constructor_names_the_bad_argument(kwargs, name):
    with pytest.raises(ValueError, match=f"CpgOscillators.{name}: "):
        C.CpgOscillators(**kwargs)


# --- compile cache ---------------------------------------------------------------------------


def test_kernels_are_cached_on_disk():
    """Every kernel is compiled with cache=True and has written its index file."""
    import pathlib

    for module in (WK, CK):
        for name in dir(module):
            kernel = getattr(module, name)
            if hasattr(kernel, "py_func") and not name.startswith("_"):
                assert kernel._cache is not None and kernel.stats.cache_misses is not None
                kernel_cache = kernel._cache._cache_file
                assert pathlib.Path(kernel._cache._cache_path).is_dir(), name
                assert kernel_cache._index_path.endswith(".nbi")


# --- camera in its own scene -----------------------------------------------------------------


def test_camera_scene_renders_what_the_plant_scene_renders():
    """The same depth image from the camera's own SceneGraph as from a renderer in the
    plant's SceneGraph, the robot standing 0.6 m from the end wall, fins posed."""
    from pydrake.geometry import (
        ClippingRange,
        DepthRange,
        DepthRenderCamera,
        MakeRenderEngineVtk,
        RenderCameraCore,
        RenderEngineVtkParams,
    )
    from pydrake.math import RigidTransform
    from pydrake.systems.sensors import RgbdSensor

    from manta_drake.model.camera import camera_info
    from manta_drake.scenario import CameraConfig
    from manta_drake.station.render_poses import add_camera_scene

    cam = CameraConfig()
    builder = DiagramBuilder()
    h = add_plant(builder)
    plant = h.plant
    scene, _, frames = add_camera_scene(builder, h)
    h.scene_graph.AddRenderer("vtk", MakeRenderEngineVtk(RenderEngineVtkParams()))
    core = RenderCameraCore(
        "vtk",
        camera_info(cam.width, cam.height, cam.fov_y_deg),
        ClippingRange(0.05, 1.6),
        RigidTransform(),
    )
    depth_camera = DepthRenderCamera(core, DepthRange(cam.min_range, cam.max_range))
    X_BC = plant.GetFrameByName("camera", h.robot).GetFixedPoseInBodyFrame()
    own = builder.AddSystem(RgbdSensor(frames[int(h.body.index())], X_BC, depth_camera, False))
    builder.Connect(scene.get_query_output_port(), own.query_object_input_port())
    shared = builder.AddSystem(
        RgbdSensor(plant.GetBodyFrameIdOrThrow(h.body.index()), X_BC, depth_camera, False)
    )
    builder.Connect(h.scene_graph.get_query_output_port(), shared.query_object_input_port())
    diagram = builder.Build()
    context = diagram.CreateDefaultContext()
    set_initial_state(
        h,
        plant.GetMyMutableContextFromRoot(context),
        body_pose([7.5 - 0.6 - 0.19, 0.3, -0.25], [0, 8, 12]),
        np.tile([0.3, -0.6, 0.4, 0.8], 4),
    )
    images = [
        np.array(s.depth_image_32F_output_port().Eval(s.GetMyContextFromRoot(context)).data)
        for s in (own, shared)
    ]
    finite = np.isfinite(images[1])
    assert finite.mean() > 0.3  # the wall and the floor are in view
    np.testing.assert_array_equal(np.isfinite(images[0]), finite)
    np.testing.assert_allclose(images[0][finite], images[1][finite], rtol=0, atol=1e-6)
    poses = [
        s.body_pose_in_world_output_port().Eval(s.GetMyContextFromRoot(context))
        for s in (own, shared)
    ]
    np.testing.assert_allclose(poses[0].GetAsMatrix4(), poses[1].GetAsMatrix4(), atol=1e-12)


# --- whole diagrams: the compiled paths against the reference paths ---------------------------


def _simulated_log(s, **build):
    """The log of scenario ``s`` simulated to its end in the diagram ``build_diagram(s,
    **build)`` builds (from the scenario's start, as ``run`` does)."""
    from manta_drake.simulate import extract_log, make_simulator
    from manta_drake.wiring.diagram import build_diagram

    diagram, handles = build_diagram(s, **build)
    simulator = make_simulator(diagram, s)
    simulator.AdvanceTo(s.duration)
    return extract_log(handles, simulator.get_context())


def _locomotion_velocity(name, duration, **build):
    from manta_drake.scenario import load_scenario
    from manta_drake.simulate import compute_metrics

    s = load_scenario(name)
    s.visualization.meshcat = False
    s.duration, s.steady_after = duration, 1.0
    s = s.validate()
    return np.array(compute_metrics(s, _simulated_log(s, **build), 0.0)["mean_velocity_body"])


@pytest.mark.slow
@pytest.mark.parametrize("name", ["locomotion_swim", "locomotion_trot"])
def test_locomotion_metrics_unchanged_by_the_compiled_paths(name):
    """3 s of the gait: the mean velocity with the compiled paths (the water's state input,
    the CPG's kernels) within 1 % of the reference paths (the contract's per-body ports,
    the CPG's numpy functions)."""
    fast = _locomotion_velocity(name, 3.0)
    reference = _locomotion_velocity(name, 3.0, hydro_plant_state=False, compiled_cpg=False)
    speed = np.linalg.norm(reference)
    assert speed > 0.005
    np.testing.assert_allclose(fast, reference, rtol=0, atol=0.01 * speed)


@pytest.mark.slow
def test_kernels_cache_in_the_user_cache_when_the_package_folder_is_not_used(tmp_path):
    """A non-editable install whose package folder is not writable: numba falls back to its
    user-wide cache (forced here with NUMBA_CACHE_LOCATOR_CLASSES, as root can write
    anywhere). The first process compiles into $XDG_CACHE_HOME/numba, the second loads."""
    import os
    import subprocess
    import sys

    code = (
        "from manta_drake.station import water_kernels as K; "
        "from manta_drake.control import cpg_kernels as C; import numpy as np; "
        "x = np.zeros(80); C.angles(x, 16, np.empty(16)); "
        "print(C.angles.stats.cache_hits.get(C.angles.signatures[0], 0), "
        "C.angles._cache._cache_path)"
    )
    env = {
        **os.environ,
        "XDG_CACHE_HOME": str(tmp_path),
        "NUMBA_CACHE_LOCATOR_CLASSES": "UserWideCacheLocator",
    }
    env.pop("NUMBA_CACHE_DIR", None)
    runs = [
        subprocess.run(
            [sys.executable, "-c", code], capture_output=True, text=True, env=env, check=True
        ).stdout.split()
        for _ in range(2)
    ]
    assert runs[0][1].startswith(str(tmp_path / "numba"))
    assert int(runs[0][0]) == 0 and int(runs[1][0]) == 1  # compiled, then loaded


@pytest.mark.slow
def test_closed_loop_s_hat_same_with_the_camera_in_its_own_scene():
    """The wall in view while trotting toward it: the logged s_hat series with the camera in
    its own SceneGraph against the camera in the plant's SceneGraph (camera_own_scene=False)."""
    from manta_drake.scenario import load_scenario

    def s_hat_series(own_scene: bool):
        s = load_scenario("three_behaviors")
        s.visualization.meshcat = False
        s.duration = 2.1
        s.initial_pose.xyz = [7.5 - 0.19 - 0.7, 0.0, -0.25]  # camera 0.7 m from the wall
        s.initial_stance = s.controller.gait = "trot"
        s.balloon.initial_fill, s.balloon.schedule = 0.0, []
        return _simulated_log(s.validate(), camera_own_scene=own_scene)["s_hat"][:, 0]

    own, shared = s_hat_series(True), s_hat_series(False)
    assert own.max() > 0.5  # the wall is seen
    np.testing.assert_allclose(own, shared, rtol=0, atol=0.02)


def test_kernels_with_the_hull_welded_to_the_world(rng):
    """The tree packing also takes a welded root (the tests' robot held in the air)."""
    from pydrake.math import RigidTransform, RollPitchYaw

    builder = DiagramBuilder()
    X_WB = RigidTransform(RollPitchYaw(0.2, -0.1, 0.4), [0.3, -0.2, -0.05])
    h = add_plant(builder, with_pool=False, weld_body=X_WB, hydro=COEFFS)
    hydro = HydrodynamicForces.AddToBuilder(
        builder,
        h.plant,
        h.robot,
        COEFFS,
        1e-3,
        added_mass_iso=h.added_mass_iso,
        inputs="plant_state",
    )
    diagram = builder.Build()
    context = diagram.CreateDefaultContext()
    plant_context = h.plant.GetMyMutableContextFromRoot(context)
    h.plant.SetPositions(plant_context, rng.uniform(-1, 1, h.plant.num_positions()))
    h.plant.SetVelocities(plant_context, rng.normal(size=h.plant.num_velocities()))
    R, p, w, v = hydro._kinematics(hydro.GetMyContextFromRoot(context))
    poses = h.plant.get_body_poses_output_port().Eval(plant_context)
    velocities = h.plant.get_body_spatial_velocities_output_port().Eval(plant_context)
    X = np.array([poses[i].GetAsMatrix34() for i in hydro.body_indices])
    V = np.array([velocities[i].get_coeffs() for i in hydro.body_indices])
    np.testing.assert_allclose(
        np.concatenate([R.ravel(), p.ravel(), w.ravel(), v.ravel()]),
        np.concatenate(
            [X[:, :, :3].ravel(), X[:, :, 3].ravel(), V[:, :3].ravel(), V[:, 3:].ravel()]
        ),
        rtol=0,
        atol=1e-12,
    )
    F = rng.normal(size=(NB, 6))
    tau = hydro.generalized_forces(h.plant.get_state_output_port().Eval(plant_context), F)
    expected = sum(
        h.plant.CalcJacobianSpatialVelocity(
            plant_context,
            JacobianWrtVariable.kV,
            h.plant.get_body(BodyIndex(i)).body_frame(),
            np.zeros(3),
            h.plant.world_frame(),
            h.plant.world_frame(),
        ).T
        @ row
        for row, i in zip(F, hydro.body_indices)
    )
    np.testing.assert_allclose(tau, expected, rtol=1e-12, atol=1e-12)


def test_kinematics_and_jacobians_with_planar_joints_equal_the_plant(rng):
    """The fins' added-mass bodies ride planar joints: the packed tree's forward
    kinematics and J^T F of every body (the robot's and theirs) against the plant's."""
    from manta_drake.model.plant import FIN_ADDED_MASS_INSTANCE

    coeffs = copy.deepcopy(COEFFS)
    coeffs.fins.added_mass_factor.value = [0.68, 0.64]
    h = add_plant(DiagramBuilder(), hydro=coeffs, fin_added_mass="bodies")
    plant = h.plant
    bodies = [plant.GetBodyByName(n, h.robot).index() for n in hydro_body_names()]
    bodies += list(plant.GetBodyIndices(plant.GetModelInstanceByName(FIN_ADDED_MASS_INSTANCE)))
    tree_i, tree_f = WK.pack_tree(plant, bodies)
    assert (tree_i[:, 1] == WK.PLANAR).sum() == 9  # 8 plates and the hull's heave body
    context = plant.CreateDefaultContext()
    for _ in range(5):
        plant.SetPositions(context, rng.normal(size=plant.num_positions()))
        plant.SetVelocities(context, rng.normal(size=plant.num_velocities()))
        x = plant.GetPositionsAndVelocities(context)
        R, p, w, v, axis_W, origin_W = WK.body_kinematics(x, plant.num_positions(), tree_i, tree_f)
        F = rng.normal(scale=20.0, size=(len(bodies), 6))
        expected = np.zeros(plant.num_velocities())
        for k, index in enumerate(bodies):
            body = plant.get_body(index)
            X, V = body.EvalPoseInWorld(context), body.EvalSpatialVelocityInWorld(context)
            np.testing.assert_allclose(R[k], X.rotation().matrix(), rtol=0, atol=1e-12)
            np.testing.assert_allclose(p[k], X.translation(), rtol=0, atol=1e-12)
            np.testing.assert_allclose(w[k], V.rotational(), rtol=0, atol=1e-12)
            np.testing.assert_allclose(v[k], V.translational(), rtol=0, atol=1e-12)
            J = plant.CalcJacobianSpatialVelocity(
                context,
                JacobianWrtVariable.kV,
                body.body_frame(),
                np.zeros(3),
                plant.world_frame(),
                plant.world_frame(),
            )
            expected += J.T @ F[k]
        got = WK.generalized_forces(F, p, axis_W, origin_W, tree_i, plant.num_velocities())
        np.testing.assert_allclose(got, expected, rtol=1e-12, atol=1e-11)


def test_foil_model_gives_the_same_forces_on_every_port_set_and_backend():
    """The foil model (strips with Wagner states, the added-mass bodies with their velocity
    sample) on one random state with its discrete state set: the four (inputs, backend)
    variants' spatial forces agree to 1e-12 of the largest."""
    rng = np.random.default_rng(5)
    q, v = rng.uniform(-1, 1, 16), None
    forces = []
    for inputs, backend in VARIANTS:
        builder = DiagramBuilder()
        h = add_plant(builder, hydro=COEFFS, fin_added_mass="bodies")
        hydro = HydrodynamicForces.AddToBuilder(
            builder,
            h.plant,
            h.robot,
            COEFFS,
            1e-3,
            added_mass_iso=h.added_mass_iso,
            current=(0.05, 0.02, 0.0),
            inputs=inputs,
            backend=backend,
            fin_model="foil",
            apply_as="spatial_forces",
        )
        diagram = builder.Build()
        context = diagram.CreateDefaultContext()
        plant_context = h.plant.GetMyMutableContextFromRoot(context)
        set_initial_state(h, plant_context, body_pose([0.1, 0.2, -0.05], [10, 20, 30]), q)
        if v is None:
            v = rng.normal(scale=0.5, size=h.plant.num_velocities())
            lag = rng.normal(
                scale=0.05,
                size=hydro.GetMyContextFromRoot(context).get_discrete_state(hydro._lag).size(),
            )
            prev = np.r_[rng.normal(scale=0.1, size=9), 0.0]  # 8 plates, the hull's heave body
        h.plant.SetVelocities(plant_context, v)
        hydro_context = hydro.GetMyMutableContextFromRoot(context)
        hydro_context.get_mutable_discrete_state(hydro._lag).SetFromVector(lag)
        hydro_context.get_mutable_discrete_state(hydro._am_prev).SetFromVector(prev)
        context.SetTime(0.001)
        hydro.GetInputPort("balloon_volume").FixValue(hydro_context, [1e-3])
        out = hydro.GetOutputPort("spatial_forces").Eval(hydro_context)
        forces.append(np.array([f.F_Bq_W.get_coeffs() for f in out]))
    assert forces[0].shape == (NB + 9, 6)
    for F in forces[1:]:
        np.testing.assert_allclose(F, forces[0], rtol=0, atol=1e-12 * np.abs(forces[0]).max())


def test_foil_model_needs_the_added_mass_bodies():
    builder = DiagramBuilder()
    h = add_plant(builder, hydro=COEFFS)
    with pytest.raises(ValueError, match="fin_model: 'foil' needs the fins' added-mass bodies"):
        HydrodynamicForces(h.plant, h.robot, COEFFS, 1e-3, fin_model="foil")
    with pytest.raises(ValueError, match="fin_model: 'wing' must be one of"):
        HydrodynamicForces(h.plant, h.robot, COEFFS, 1e-3, fin_model="wing")
