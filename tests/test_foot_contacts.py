"""FootContacts' maths: each carrier's normal load and load-weighted slip, and the run's
per-leg stance summary, against sums by hand."""

import numpy as np
import pytest

from manta_drake import metrics as M
from manta_drake.station.foot_contacts import CARRIERS, carrier_loads


def test_carrier_loads_sum_the_normal_force_and_weight_the_slip_by_it():
    # fl: two contacts, 3 N sliding at (0.1, 0) and 1 N holding; rr: one contact pulled
    # off the floor (a negative normal force counts as none); hull: one at (0, -0.2).
    carriers = [0, 0, 3, 4]
    forces = [
        np.array([0.5, 0.0, 3.0]),
        np.array([0.0, 0.2, 1.0]),
        np.array([0.0, 0.0, -2.0]),
        np.array([1.0, 1.0, 5.0]),
    ]
    velocities = [
        np.array([0.1, 0.0, -0.3]),
        np.zeros(3),
        np.array([1.0, 1.0, 0.0]),
        np.array([0.0, -0.2, 0.0]),
    ]
    out = carrier_loads(carriers, forces, velocities)
    assert out.shape == (len(CARRIERS), 3)
    np.testing.assert_allclose(out[0], [4.0, (3 * 0.1 + 1 * 0.0) / 4.0, 0.0])
    np.testing.assert_allclose(out[3], [0.0, 0.0, 0.0])  # pulled, not loaded
    np.testing.assert_allclose(out[4], [5.0, 0.0, -0.2])
    np.testing.assert_allclose(out[[1, 2]], 0.0)


def test_foot_summary_duty_load_and_slip_by_hand():
    t = np.arange(0.0, 1.0, 0.1)  # 10 samples
    loads = np.zeros((10, 5, 3))
    loads[:4, 0] = [2.0, 0.0, 0.1]  # fl down 4 of 10 samples, slipping sideways at 0.1
    loads[:, 1] = [1.0, -0.05, 0.0]  # fr down throughout, slipping back at 0.05
    loads[5, 4] = [0.05, 1.0, 0.0]  # the hull grazes below the loaded threshold
    yaw = np.full(10, np.pi / 2)  # heading +y: fl's sideways slip is its forward slip
    s = M.foot_summary(t, loads.reshape(10, 15), yaw, CARRIERS)
    assert s["fl"]["duty"] == pytest.approx(0.4) and s["fr"]["duty"] == 1.0
    assert s["fl"]["normal_force_n"] == pytest.approx(0.8)
    assert s["fl"]["stance_force_n"] == pytest.approx(2.0)
    assert s["fl"]["slip_speed_m_s"] == pytest.approx(0.1)
    assert s["fl"]["slip_forward_m_s"] == pytest.approx(0.1)
    assert s["fr"]["slip_forward_m_s"] == pytest.approx(0.0, abs=1e-12)  # sideways now
    total = 0.8 + 1.0 + 0.005
    assert s["fr"]["load_share"] == pytest.approx(1.0 / total)
    assert s["hull"]["duty"] == 0.0 and s["rl"]["stance_force_n"] is None
    assert s["rl"]["slip_speed_m_s"] is None
    # Legs down: fl and fr for 4 samples, fr alone for 6.
    assert s["legs_down_mean"] == pytest.approx((4 * 2 + 6 * 1) / 10)
    # A window keeps only its samples.
    w = M.foot_summary(t, loads.reshape(10, 15), yaw, CARRIERS, window=(0.45, 1.0))
    assert w["fl"]["duty"] == 0.0 and w["window_s"] == [pytest.approx(0.5), pytest.approx(0.9)]
