"""The stand diagram: the robot holds the gait stance X_gait on the pool floor (gravity only)."""

import json
import pathlib
import subprocess
import sys

import numpy as np
import pytest

from manta_drake.control.gaits import GAITS

ROOT = pathlib.Path(__file__).resolve().parent.parent


@pytest.fixture(scope="module")
def stand_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("stand")
    result = subprocess.run(
        [sys.executable, "diagrams/stand.py", "--out", str(out)],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert result.returncode == 0, result.stderr[-2000:]
    log = dict(np.load(out / "log.npz"))
    metrics = json.loads((out / "metrics.json").read_text())
    return out, log, metrics


@pytest.mark.slow
def test_body_height_settles(stand_run):
    _, log, metrics = stand_run
    t, z = log["t"], log["body_xyz"][:, 2]
    last = t >= t[-1] - 1.0
    assert metrics["status"] == "ok"
    assert z[last].max() - z[last].min() < 0.002
    # Standing on the fins, clear of the floor (z = -0.5): the hull's bottom (0.07 m
    # below its centre) does not touch it.
    assert z[-1] - 0.07 > -0.5 + 0.05


@pytest.mark.slow
def test_no_fin_penetrates_the_floor(stand_run):
    _, _, metrics = stand_run
    assert 0.0 < metrics["max_penetration_m"] < 0.005  # in contact, but not sinking in


@pytest.mark.slow
def test_joints_hold_the_gait_stance(stand_run):
    _, log, _ = stand_run
    target = GAITS["trot"].X.ravel()
    err = np.abs(log["joint_angles"][-1] - target)
    assert err.max() < 0.05, dict(enumerate(err.round(3)))


@pytest.mark.slow
def test_outputs_written(stand_run):
    out, _, _ = stand_run
    html = (out / "recording.html").read_text()
    assert "<html" in html.lower() and "meshcat" in html.lower() and "animation" in html.lower()
    assert len(html) > 100_000  # the recording carries the robot's meshes and frames
    for name in ("joints.png", "states.png", "trajectory.png"):
        assert (out / name).stat().st_size > 10_000


@pytest.mark.slow
def test_the_four_feet_carry_the_dry_weight_and_hold(stand_run):
    """Dry, the floor carries the whole robot, m g (Table 1's 8.4 kg), on its four fin tips
    (``foot_contacts``, from the plant's hydroelastic contact patches), each leg all the
    time, none sliding; the hull does not touch."""
    _, log, metrics = stand_run
    feet = metrics["feet"]
    legs = ("fl", "fr", "rl", "rr")
    weight = 8.4 * 9.81
    assert sum(feet[leg]["normal_force_n"] for leg in legs) == pytest.approx(weight, rel=0.01)
    # The logged samples over the last second, not just their means.
    last = log["t_foot_contacts"] >= log["t_foot_contacts"][-1] - 1.0
    loads = log["foot_contacts"][last].reshape(-1, 5, 3)
    np.testing.assert_allclose(loads[:, :4, 0].sum(axis=1), weight, rtol=0.01)
    for leg in legs:
        assert feet[leg]["duty"] == 1.0
        assert 0.1 * weight < feet[leg]["normal_force_n"] < 0.4 * weight
        assert feet[leg]["slip_speed_m_s"] < 1e-3
    assert feet["legs_down_mean"] == 4.0
    assert feet["hull"]["duty"] == 0.0 and feet["hull"]["load_share"] == 0.0
