"""CpgOscillators: Eq. (5), settling, phase locks, rates, and closed-loop tracking."""

import numpy as np
import pytest
from pydrake.math import RigidTransform
from pydrake.systems.analysis import ApplySimulatorConfig, Simulator, SimulatorConfig
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import ConstantVectorSource, LogVectorOutput

from manta_drake.control.cpg import CpgOscillators, locked_phases
from manta_drake.control.gaits import GAITS, phase_lock_targets
from manta_drake.model.plant import add_plant

RK2 = SimulatorConfig(
    integration_scheme="runge_kutta2", max_step_size=1e-3, use_error_control=False
)


def hand_eq5(x, params, f, w_chain, w_fcs, a, b):
    """Eq. (5) written out with loops, from the coupling's definition."""
    phi, r, dr, chi, dchi = np.split(x, 5)
    R, X = params[:16], params[16:32]
    Phi, Phip = params[32:48].reshape(4, 4), params[48:].reshape(4, 4)
    W = np.zeros((16, 16))
    B = np.zeros((16, 16))
    for k in range(4):
        for j in range(3):  # SCS chain: phi_{j+1} - phi_j -> Phi[k, j]
            i = 4 * k + j
            W[i, i + 1] = W[i + 1, i] = w_chain
            B[i, i + 1], B[i + 1, i] = Phi[k, j], -Phi[k, j]
        for m in range(4):  # FCS among bases: phi_4m - phi_4k -> Phi'[k, m]
            if m != k:
                W[4 * k, 4 * m] = w_fcs
                B[4 * k, 4 * m] = Phip[k, m]
    dphi = np.array(
        [
            2 * np.pi * f + sum(W[i, j] * np.sin(phi[j] - phi[i] - B[i, j]) for j in range(16))
            for i in range(16)
        ]
    )
    ddr = a * (a / 4 * (R - r) - dr)
    ddchi = b * (b / 4 * (X - chi) - dchi)
    return np.concatenate([dphi, dr, ddr, dchi, ddchi])


def cpg_diagram(params, **kw):
    builder = DiagramBuilder()
    cpg = builder.AddSystem(CpgOscillators(**kw))
    src = builder.AddSystem(ConstantVectorSource(np.asarray(params, dtype=float)))
    builder.Connect(src.get_output_port(), cpg.GetInputPort("cpg_params"))
    angles = LogVectorOutput(cpg.GetOutputPort("joint_angles"), builder, 1e-3)
    desired = LogVectorOutput(cpg.GetOutputPort("desired_state"), builder, 1e-3)
    diagram = builder.Build()
    sim = Simulator(diagram)
    ApplySimulatorConfig(RK2, sim)
    return sim, cpg, angles, desired


@pytest.mark.slow
def test_derivatives_equal_eq5_by_hand(rng):
    kw = dict(frequency_hz=0.7, chain_weight=3.0, fcs_weight=5.0, a=17.0, b=23.0)
    cpg = CpgOscillators(**kw)
    context = cpg.CreateDefaultContext()
    for _ in range(20):
        x = rng.uniform(-3, 3, 80)
        params = rng.uniform(-3, 3, 64)
        context.SetContinuousState(x)
        cpg.GetInputPort("cpg_params").FixValue(context, params)
        got = cpg.EvalTimeDerivatives(context).CopyToVector()
        expected = hand_eq5(x, params, 0.7, 3.0, 5.0, 17.0, 23.0)
        np.testing.assert_allclose(got, expected, rtol=1e-12, atol=1e-12)


def test_outputs_are_theta_and_its_exact_rate(rng):
    cpg = CpgOscillators()
    context = cpg.CreateDefaultContext()
    x = rng.uniform(-2, 2, 80)
    params = GAITS["trot"].to_vector()
    context.SetContinuousState(x)
    cpg.GetInputPort("cpg_params").FixValue(context, params)
    phi, r, dr, chi, dchi = np.split(x, 5)
    theta = cpg.GetOutputPort("joint_angles").Eval(context)
    np.testing.assert_allclose(theta, chi + r * np.sin(phi), atol=1e-14)
    xdot = cpg.EvalTimeDerivatives(context).CopyToVector()
    # d/dt (chi + r sin phi) by the chain rule on the state derivative.
    rate = xdot[48:64] + xdot[16:32] * np.sin(phi) + r * np.cos(phi) * xdot[:16]
    desired = cpg.GetOutputPort("desired_state").Eval(context)
    np.testing.assert_allclose(desired[:16], theta, atol=1e-14)
    np.testing.assert_allclose(desired[16:], rate, atol=1e-12)


def test_joint_angles_depend_on_state_only():
    cpg = CpgOscillators()
    context = cpg.CreateDefaultContext()
    cpg.GetInputPort("cpg_params").FixValue(context, GAITS["swim"].to_vector())
    assert not cpg.HasDirectFeedthrough(0, 0)  # cpg_params -> joint_angles
    assert cpg.HasDirectFeedthrough(0, 1)  # desired_state's rate uses the biases


def test_amplitude_and_bias_settle_without_overshoot_in_closed_form_time(rng):
    a = b = 20.0
    R = rng.uniform(0.1, 0.8, 16) * rng.choice([-1, 1], 16)
    X = rng.uniform(-0.8, 0.8, 16)
    params = np.concatenate([R, X, np.zeros(32)])
    sim, cpg, _, _ = cpg_diagram(params, a=a, b=b)
    context = sim.get_mutable_context()
    cpg.set_state(
        cpg.GetMyMutableContextFromRoot(context), phi=0.0, r=0.0, dr=0.0, chi=0.0, dchi=0.0
    )
    omega = a / 2  # critically damped double pole
    # 2 % settling time of 1 - (1 + w t) e^{-w t}: (1 + w t) e^{-w t} = 0.02.
    from scipy.optimize import brentq

    t_settle = brentq(lambda t: (1 + omega * t) * np.exp(-omega * t) - 0.02, 0.01, 5.0)
    times = np.arange(0.0, 1.5, 0.01)
    rs, chis = [], []
    for t in times:
        sim.AdvanceTo(t)
        x = cpg.GetMyContextFromRoot(context).get_continuous_state_vector().CopyToVector()
        rs.append(x[16:32].copy())
        chis.append(x[48:64].copy())
    rs, chis = np.array(rs), np.array(chis)
    closed = 1 - (1 + omega * times) * np.exp(-omega * times)
    np.testing.assert_allclose(rs, np.outer(closed, R), atol=2e-3)
    np.testing.assert_allclose(chis, np.outer(closed, X), atol=2e-3)
    assert np.all(rs / R <= 1 + 1e-9) and np.all(chis / X <= 1 + 1e-9)  # no overshoot
    after = times >= t_settle + 0.01
    assert np.all(np.abs(rs[after] / R - 1) <= 0.02)
    assert np.all(np.abs(chis[after] / X - 1) <= 0.02)
    before = times < t_settle - 0.05
    assert np.all(np.abs(rs[before] / R - 1) > 0.02)  # and not faster: the time is tight
    assert t_settle == pytest.approx(0.583, abs=0.002)


def _wrap(x):
    return np.angle(np.exp(1j * np.asarray(x)))


# The distinct gaits (trot_printed and the like are the same matrices as trot in this reading).
@pytest.mark.parametrize(
    "name", sorted(n for n in GAITS if not n.endswith("_printed")) + ["swim_printed"]
)
def test_phase_lock_after_settling(name, rng):
    gait = GAITS[name]
    sim, cpg, _, _ = cpg_diagram(gait.to_vector())
    context = sim.get_mutable_context()
    cpg.set_state(cpg.GetMyMutableContextFromRoot(context), phi=rng.uniform(-np.pi, np.pi, 16))
    sim.AdvanceTo(12.0)
    phi = cpg.GetMyContextFromRoot(context).get_continuous_state_vector().CopyToVector()[:16]
    # Layer 1: each chain pair at its bias.
    for k in range(4):
        for j in range(3):
            err = _wrap(phi[4 * k + j + 1] - phi[4 * k + j] - gait.Phi[k, j])
            assert abs(err) < 0.05, (name, "SCS", k, j, err)
    # Layer 2: every base pair at the lock, which is the bias itself where the
    # biases are consistent (all but swim, see gaits.py).
    target = phase_lock_targets(gait.Phi_prime)
    for k in range(4):
        for m in range(4):
            err = _wrap(phi[4 * m] - phi[4 * k] - (target[m] - target[k]))
            assert abs(err) < 0.05, (name, "FCS", k, m, err)
            if not name.startswith("swim"):
                assert abs(_wrap(phi[4 * m] - phi[4 * k] - gait.Phi_prime[k, m])) < 0.05


def test_desired_rates_equal_finite_difference_of_angles():
    sim, cpg, angles, desired = cpg_diagram(GAITS["walk"].to_vector())
    context = sim.get_mutable_context()
    cpg.set_state(
        cpg.GetMyMutableContextFromRoot(context),
        phi=locked_phases(GAITS["walk"].to_vector()),
        r=0.0,
        chi=0.0,
    )
    sim.AdvanceTo(3.0)
    t = angles.FindLog(context).sample_times()
    theta = angles.FindLog(context).data().T
    rate = desired.FindLog(context).data().T[:, 16:]
    fd = np.gradient(theta, t, axis=0)
    inner = slice(5, -5)
    scale = np.abs(rate[inner]).max()
    assert scale > 0.5  # the joints really move
    np.testing.assert_allclose(fd[inner], rate[inner], atol=2e-3 * scale)


def test_constructor_rejects_bad_parameters():
    with pytest.raises(ValueError, match="frequency_hz"):
        CpgOscillators(frequency_hz=0.0)
    with pytest.raises(ValueError, match="chain_weight"):
        CpgOscillators(chain_weight=-1.0)
    with pytest.raises(ValueError, match="a:"):
        CpgOscillators(a=np.nan)


@pytest.mark.slow
@pytest.mark.parametrize("name", ["trot", "swim"])
def test_plant_tracks_cpg_with_body_welded_in_air(name):
    """Closed loop: the plant's implicit PD follows the CPG's desired state."""
    builder = DiagramBuilder()
    h = add_plant(builder, with_pool=False, weld_body=RigidTransform([0, 0, 1.0]))
    cpg = builder.AddSystem(CpgOscillators())
    src = builder.AddSystem(ConstantVectorSource(GAITS[name].to_vector()))
    builder.Connect(src.get_output_port(), cpg.GetInputPort("cpg_params"))
    builder.Connect(
        cpg.GetOutputPort("desired_state"), h.plant.get_desired_state_input_port(h.robot)
    )
    cmd = LogVectorOutput(cpg.GetOutputPort("joint_angles"), builder, 1e-3)
    state = LogVectorOutput(h.plant.get_state_output_port(h.robot), builder, 1e-3)
    diagram = builder.Build()
    sim = Simulator(diagram)
    ApplySimulatorConfig(RK2, sim)
    context = sim.get_mutable_context()
    cpg.set_state(
        cpg.GetMyMutableContextFromRoot(context), phi=locked_phases(GAITS[name].to_vector())
    )
    sim.AdvanceTo(5.0)
    t = cmd.FindLog(context).sample_times()
    q_cmd = cmd.FindLog(context).data().T
    q = state.FindLog(context).data().T[:, :16]
    after = t >= 2.0
    rms = np.sqrt(np.mean((q[after] - q_cmd[after]) ** 2, axis=0))
    assert rms.max() < 0.05, rms.round(3)
    assert np.ptp(q[after], axis=0).max() > 0.5  # and the joints really oscillate
