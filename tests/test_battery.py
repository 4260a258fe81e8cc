"""Battery: the Rint pack (V = OCV(SoC) - R I), the current a power draws, coulomb counting
as a discrete update, and the stop at the cut-off."""

import dataclasses as dc

import numpy as np
import pytest
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import ConstantVectorSource, LogVectorOutput

from manta_drake.model.actuators import PackConstants, load_actuators, pack_constants
from manta_drake.station.battery import (
    Battery,
    battery_kernel,
    current_from_power,
    state_of_charge_step,
    terminal_voltage,
)

DT = 1e-3


@pytest.fixture(scope="module")
def pack():
    return pack_constants(load_actuators())


def test_open_circuit_voltage_is_the_cell_table_times_the_cells(pack):
    assert pack.cells_in_series == 4
    for s, v in zip(pack.ocv_soc, pack.ocv_cell_voltage):
        assert pack.open_circuit_voltage(s) == pytest.approx(4 * v, rel=1e-15)
    mid = 0.5 * (pack.ocv_soc[3] + pack.ocv_soc[4])
    assert pack.open_circuit_voltage(mid) == pytest.approx(
        2 * (pack.ocv_cell_voltage[3] + pack.ocv_cell_voltage[4]), rel=1e-12
    )
    # Outside [0, 1] the table's ends hold.
    assert pack.open_circuit_voltage(1.2) == pack.open_circuit_voltage(1.0)
    assert pack.open_circuit_voltage(-0.1) == pack.open_circuit_voltage(0.0)


def test_terminal_voltage():
    assert terminal_voltage(16.0, 4.0, 0.05) == pytest.approx(15.8)
    assert terminal_voltage(16.0, -2.0, 0.05) == pytest.approx(16.1)  # charging raises it


@pytest.mark.parametrize("power", [0.0, 1.0, 60.0, 500.0, 1200.0, -40.0])
def test_current_solves_p_equals_v_i_on_the_physical_root(power):
    ocv, r = 16.4, 0.0508
    i = float(current_from_power(power, ocv, r))
    assert (ocv - r * i) * i == pytest.approx(power, abs=1e-9)
    # The physical root: the terminal voltage stays above the maximum-power point's OCV / 2.
    assert ocv - r * i > ocv / 2
    assert np.sign(i) == np.sign(power)


def test_current_closed_forms():
    assert current_from_power(60.0, 15.0, 0.0) == pytest.approx(4.0, rel=1e-15)  # P / OCV
    ocv, r = 16.0, 0.05
    # The quadratic's smaller root, written out.
    assert current_from_power(100.0, ocv, r) == pytest.approx(
        (ocv - np.sqrt(ocv**2 - 4 * r * 100.0)) / (2 * r), rel=1e-12
    )
    # Above the maximum power OCV^2 / (4 R) = 1280 W: the maximum-power current.
    assert current_from_power(2000.0, ocv, r) == pytest.approx(ocv / (2 * r))
    np.testing.assert_allclose(current_from_power(np.array([0.0, 60.0]), 15.0, 0.0), [0.0, 4.0])


def test_compiled_battery_maths_equals_the_reference(pack, rng):
    grid = np.asarray(pack.ocv_soc)
    table = pack.cells_in_series * np.asarray(pack.ocv_cell_voltage)
    for soc, power in zip(rng.uniform(-0.1, 1.1, 300), rng.uniform(-100, 1500, 300)):
        ocv, current = battery_kernel(soc, power, grid, table, pack.internal_resistance)
        assert ocv == pytest.approx(pack.open_circuit_voltage(soc), rel=1e-14)
        assert current == pytest.approx(
            float(
                current_from_power(power, pack.open_circuit_voltage(soc), pack.internal_resistance)
            ),
            rel=1e-12,
        )
    assert battery_kernel(0.5, 2e5, grid, table, pack.internal_resistance)[1] == pytest.approx(
        pack.open_circuit_voltage(0.5) / (2 * pack.internal_resistance)
    )


def test_state_of_charge_step():
    # One hour at 1 A from 10 Ah is 10 %.
    assert state_of_charge_step(0.9, 1.0, 3600.0, 10.0) == pytest.approx(0.8, rel=1e-12)
    assert state_of_charge_step(0.05, 10.0, 3600.0, 5.0) == 0.0  # held at empty
    assert state_of_charge_step(0.99, -10.0, 3600.0, 5.0) == 1.0  # and at full


def _run(pack, power, duration, initial_soc=1.0, stop=True):
    builder = DiagramBuilder()
    source = builder.AddSystem(ConstantVectorSource([power]))
    battery = builder.AddSystem(Battery(pack, DT, initial_soc, stop_at_cutoff=stop))
    builder.Connect(source.get_output_port(), battery.GetInputPort("electrical_power"))
    logger = LogVectorOutput(battery.GetOutputPort("battery"), builder, DT)
    diagram = builder.Build()
    simulator = Simulator(diagram)
    simulator.Initialize()
    status = simulator.AdvanceTo(duration)
    return simulator, status, logger.FindLog(simulator.get_context()), battery


def test_state_of_charge_falls_by_exactly_the_integrated_current(pack):
    power = 60.0
    simulator, status, log, battery = _run(pack, power, 2.0)
    soc, volts, amps = log.data()
    n = len(soc)
    assert n == 2001
    # Each step charges the current the output shows at its end, no more, no less.
    expected = np.empty(n)
    expected[0] = 1.0
    for k in range(1, n):
        expected[k] = expected[k - 1] - amps[k] * (DT / (3600.0 * pack.capacity_ah))
    np.testing.assert_array_equal(soc, expected)
    # And the closed form: about P / V amperes for 2 s out of 5 Ah.
    assert 1.0 - soc[-1] == pytest.approx(amps[1:].sum() * DT / (3600 * 5.0), rel=1e-12)
    assert 1.0 - soc[-1] == pytest.approx(2.0 * power / volts[1:].mean() / (3600 * 5.0), rel=1e-3)
    # The output is consistent: the step's V = OCV(SoC at its start) - R I, and V I = P;
    # at the start the open-circuit voltage and no current.
    np.testing.assert_allclose(
        volts[1:],
        pack.open_circuit_voltage(soc[:-1]) - pack.internal_resistance * amps[1:],
        rtol=1e-14,
    )
    np.testing.assert_allclose(volts[1:] * amps[1:], power, rtol=1e-12)
    assert (volts[0], amps[0]) == (pack.open_circuit_voltage(1.0), 0.0)
    # The last sample is published at the end of the last step, before the next update.
    context = battery.GetMyContextFromRoot(simulator.get_context())
    assert battery.state_of_charge(context) == soc[-1]


def test_the_run_stops_at_the_cutoff_at_the_end_of_a_whole_step(pack):
    small = dc.replace(pack, capacity_ah=0.002)  # 7.2 C: ~0.16 s at 60 W from SoC 0.3
    simulator, status, log, battery = _run(small, 60.0, 10.0, initial_soc=0.3)
    assert status.reason() == status.ReturnReason.kReachedTerminationCondition
    assert "battery empty" in status.FormatMessage()
    soc = log.data()[0]
    t = log.sample_times()
    stop = simulator.get_context().get_time()
    # It stops at the first sample at the cut-off, and not before.
    first = np.flatnonzero(soc <= small.cutoff_soc)[0]
    assert stop == pytest.approx(t[first])
    assert soc[first - 1] > small.cutoff_soc
    # Another AdvanceTo takes one ordinary step (time moves on: no update is re-applied
    # at the same time) and stops again.
    again = simulator.AdvanceTo(10.0)
    assert again.reason() == again.ReturnReason.kReachedTerminationCondition
    assert simulator.get_context().get_time() == pytest.approx(stop + DT)


def test_without_the_stop_it_runs_on_and_holds_at_empty(pack):
    small = dc.replace(pack, capacity_ah=0.002)
    simulator, status, log, _ = _run(small, 60.0, 1.0, initial_soc=0.3, stop=False)
    assert status.reason() == status.ReturnReason.kReachedBoundaryTime
    soc = log.data()[0]
    assert soc.min() == 0.0 and np.all(np.diff(soc) <= 0)


def test_set_state_of_charge_and_bad_parameters(pack):
    battery = Battery(pack, DT)
    context = battery.CreateDefaultContext()
    assert battery.state_of_charge(context) == 1.0
    battery.set_state_of_charge(context, 0.6)
    battery.GetInputPort("electrical_power").FixValue(context, [60.0])
    soc, volts, amps = battery.GetOutputPort("battery").Eval(context)
    assert (soc, amps) == (0.6, 0.0) and volts == pytest.approx(pack.open_circuit_voltage(0.6))
    # One update: the charge falls by the current 60 W draws at 0.6, V I = 60 W.
    context.SetDiscreteState(battery.EvalUniquePeriodicDiscreteUpdate(context))
    soc, volts, amps = battery.GetOutputPort("battery").Eval(context)
    assert volts * amps == pytest.approx(60.0, rel=1e-12)
    assert soc == pytest.approx(0.6 - amps * DT / (3600 * pack.capacity_ah), rel=1e-15)
    with pytest.raises(ValueError, match="set_state_of_charge"):
        battery.set_state_of_charge(context, 1.5)
    with pytest.raises(ValueError, match="period"):
        Battery(pack, 0.0)
    with pytest.raises(ValueError, match="initial_soc"):
        Battery(pack, DT, initial_soc=-0.1)
    with pytest.raises(ValueError, match="capacity_ah"):
        Battery(PackConstants(4, 0.0, (0.0, 1.0), (3.0, 4.2), 0.05, 0.2), DT)
