"""The hull's damping identified from the CFD samples: the committed coefficients are the
fit of the committed samples, the fit recovers known coefficients, and the samples agree
with the boundary-layer theory the low-speed law rests on."""

import math

import numpy as np
import pytest

from manta_drake.model import damping_identification as di
from manta_drake.model import hull_resistance as hr
from manta_drake.model.coefficients import load_coefficients
from manta_drake.model.robot_params import DEFAULT_ROBOT

AXES = DEFAULT_ROBOT.body_semi_axes


@pytest.fixture(scope="module")
def rows():
    return di.read_cfd_samples()


def test_the_yaml_is_the_fit_of_the_committed_samples(rows):
    fit = di.identify(rows, AXES)
    body = load_coefficients().body
    np.testing.assert_allclose(body.linear_damping.value, fit.linear, atol=1e-5)
    np.testing.assert_allclose(body.quadratic_damping.value, fit.quadratic, rtol=1e-5, atol=1e-5)
    np.testing.assert_allclose(body.body_lift.value, fit.lift, rtol=1e-5, atol=1e-5)
    assert "robot_samples.csv" in body.quadratic_damping.source
    assert fit.samples == {"surge": len(di.LOW_SPEEDS) + 3, "heave": 12, "sway": 6}


def _synthetic_rows(x_uu, z_ww, z_uw, y_vv, y_uv, m_uw, n_uv, cdp):
    """CFD-like rows made from known coefficients: forces are the model's, exactly."""
    frontal = math.pi * AXES[1] * AXES[2]
    out = []
    for speed in (0.4, 0.8, 1.2):
        for pitch, yaw in ((0, 0), (-30, 0), (-15, 0), (15, 0), (30, 0), (0, 15), (0, 30)):
            th, ps = math.radians(pitch), math.radians(yaw)
            u = speed * math.cos(th) * math.cos(ps)
            v, w = speed * math.sin(ps), -speed * math.sin(th)
            out.append(
                {
                    "speed": speed,
                    "pitch_deg": pitch,
                    "yaw_deg": yaw,
                    "u": u,
                    "v": v,
                    "w": w,
                    "Fx_hull": -x_uu * u * u,
                    "Fx_hull_pressure": -0.5 * 1000 * cdp * frontal * u * u,
                    "Fy_hull": -(y_vv * v * abs(v) + y_uv * u * v),
                    "Fz_hull": -(z_ww * w * abs(w) + z_uw * u * w),
                    "My_hull": -m_uw * u * w,
                    "Mz_hull": -n_uv * u * v,
                }
            )
    return out


def test_the_fit_recovers_known_lift_and_cross_flow_coefficients():
    fit = di.identify(_synthetic_rows(0.8, 17.0, 45.0, 2.5, 0.5, -4.4, 1.3, 0.04), AXES)
    np.testing.assert_allclose(fit.lift, [0.5, 45.0, -4.4, 1.3], rtol=1e-10)
    np.testing.assert_allclose(fit.quadratic[1:3], [2.5, 17.0], rtol=1e-10)
    assert fit.form_drag_coefficient == pytest.approx(0.04, rel=1e-12)
    assert fit.relative_rms["heave"] < 1e-10 and fit.relative_rms["yaw moment"] < 1e-10
    # Rotation is the strips' closed form, whatever the samples.
    np.testing.assert_allclose(
        fit.quadratic[3:],
        hr.cross_flow_rotational_damping(AXES, di.ROTATIONAL_DRAG_COEFFICIENTS, 1000.0),
    )


def test_the_cfd_hull_friction_is_laminar_and_the_surge_fit_holds_at_the_robots_speeds(rows):
    level = [r for r in rows if r["pitch_deg"] == 0 and r["yaw_deg"] == 0]
    wetted, length = hr.ellipsoid_surface_area(AXES), 2 * AXES[0]
    for r in level:
        viscous = -(r["Fx_hull"] - r["Fx_hull_pressure"])
        q = 0.5 * 1000 * r["u"] ** 2 * wetted
        re = r["u"] * length / hr.WATER_VISCOSITY
        # k-epsilon with wall functions at y+ ~20-30 gives nearly laminar friction: within
        # 25 % of Blasius's, under half of the ITTC turbulent line's.
        assert viscous == pytest.approx(q * hr.laminar_skin_friction(re), rel=0.25)
        assert viscous < 0.5 * q * hr.turbulent_skin_friction(re)
    fit = di.identify(rows, AXES)
    # Eq. (4) cannot hold U^1.5 friction exactly: its error over 0.02-1.2 m/s is the band.
    assert max(abs(e) for e in fit.surge_errors.values()) < 0.15
    assert set(di.REPORT_SPEEDS) <= set(fit.surge_errors)
    # The heave force collapses on u w (lift), not on w|w|: the lift term carries most of it.
    pitched = [r for r in rows if r["pitch_deg"] != 0]
    lift_share = [fit.lift[1] * r["u"] * r["w"] / -r["Fz_hull"] for r in pitched]
    assert min(lift_share) > 0.7


def test_bad_sample_files_are_one_line_errors(tmp_path):
    path = tmp_path / "s.csv"
    path.write_text("# c\nspeed,pitch_deg,yaw_deg,mesh\n0.4,0,0,coarse\n")
    with pytest.raises(ValueError, match="s.csv: no Fx_hull column"):
        di.read_cfd_samples(path)
    with pytest.raises(ValueError, match="on mesh 'fine'"):
        di.read_cfd_samples(mesh="fine")
