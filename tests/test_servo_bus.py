"""The servo bus (manta_drake.station.servo_bus): commands one period late, readings in the
servos' units, a start from the first command."""

import math

import numpy as np
import pytest
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import ConstantVectorSource, Sine

from manta_drake.station.servo_bus import VELOCITY_UNIT, ServoBus, quantize_joint_state

PULSE = 2 * math.pi / 4096


def test_quantize_rounds_to_pulses_and_velocity_units():
    x = np.array(
        [
            0.4 * PULSE,
            0.6 * PULSE,
            -2.5001 * PULSE,
            0.49 * VELOCITY_UNIT,
            1.51 * VELOCITY_UNIT,
            -3.2 * VELOCITY_UNIT,
        ]
    )
    np.testing.assert_allclose(
        quantize_joint_state(x, 4096),
        [0.0, PULSE, -3 * PULSE, 0.0, 2 * VELOCITY_UNIT, -3 * VELOCITY_UNIT],
        rtol=0,
        atol=1e-15,
    )
    assert VELOCITY_UNIT == pytest.approx(0.02398, abs=1e-5)  # 0.229 rev/min


def _bus(period=0.01):
    """A ServoBus fed a 1 Hz sine command and a constant joint state, in a simulator."""
    builder = DiagramBuilder()
    command = builder.AddSystem(Sine(1.0, 2 * math.pi, 0.0, 2))
    bus = builder.AddSystem(ServoBus(1, period, 4096, start=[0.7, 0.0]))
    joints = builder.AddSystem(ConstantVectorSource([10.3 * PULSE, -1.6 * VELOCITY_UNIT]))
    builder.Connect(command.get_output_port(0), bus.GetInputPort("command"))
    builder.Connect(joints.get_output_port(), bus.GetInputPort("joint_state"))
    diagram = builder.Build()
    return diagram, bus, Simulator(diagram)


def test_commands_apply_one_period_after_they_were_written():
    diagram, bus, sim = _bus(0.01)
    context = sim.get_mutable_context()
    sim.Initialize()
    applied = bus.GetOutputPort("applied_command")
    ctx = bus.GetMyContextFromRoot(context)
    assert applied.Eval(ctx)[0] == 0.7  # the pose the servos were switched on in
    sim.AdvanceTo(0.0051)
    assert applied.Eval(ctx)[0] == 0.7  # the command of t = 0 is taken up at T
    for t in (0.0149, 0.0349, 0.2549):
        sim.AdvanceTo(t)
        k = math.floor(t / 0.01 + 1e-9)  # the cycle in force at t
        assert applied.Eval(ctx)[0] == pytest.approx(
            math.sin(2 * math.pi * (k - 1) * 0.01), abs=1e-12
        )


def test_readings_are_sampled_and_quantized():
    diagram, bus, sim = _bus(0.01)
    sim.AdvanceTo(0.05)
    reading = bus.GetOutputPort("measured_joint_state").Eval(
        bus.GetMyContextFromRoot(sim.get_context())
    )
    np.testing.assert_allclose(reading, [10 * PULSE, -2 * VELOCITY_UNIT], atol=1e-15)


def test_bad_arguments_are_refused():
    with pytest.raises(ValueError, match="ServoBus.period"):
        ServoBus(16, 0.0, 4096)
    with pytest.raises(ValueError, match="ServoBus.start"):
        ServoBus(2, 0.01, 4096, start=[0.0, 0.0])
