"""The fin strips' flapping-foil model against pterasoftware's unsteady vortex lattice.

The committed UVLM numbers (models/reference/vortex_lattice.yaml, made by
``python -m manta_drake.studies.validation.vortex_lattice``) are the reference; the strip
model (station/foil.py, numpy) is recomputed here on the same prescribed stroke of the model's
own fin and held to the acceptance: within +-30 % of the converged UVLM in pure roll
at 0.4 m/s. With pterasoftware installed, one tiny case checks the solver still gives the
committed numbers (slow: the numba JIT) and its movement moves the model's fin.
"""

import math

import numpy as np
import pytest

from manta_drake.station import foil
from manta_drake.studies.validation import vortex_lattice as V


@pytest.fixture(scope="module")
def committed():
    return V.load_summary(V.YAML_PATH)


def test_committed_summary_is_the_model_s_fin_and_stroke(committed):
    """The committed cases are this robot's fin and this gait's stroke, unchanged since."""
    dims = V.fin_dimensions()
    for key in ("d3", "dE", "proximal_chord", "distal_chord"):
        assert committed["fin"][key] == pytest.approx(dims[key], rel=1e-6), key
    gait = V.gait_stroke()
    swim = committed["strokes"]["swim"]
    assert swim["amp_deg"] == pytest.approx(list(gait.amp_deg))
    assert swim["phase_deg"] == pytest.approx(list(gait.phase_deg))
    assert swim["frequency_hz"] == pytest.approx(gait.frequency_hz)
    assert not committed["provenance"]["quick"]


@pytest.mark.slow
def test_strip_model_within_30_percent_of_converged_uvlm_in_pure_roll(committed):
    """The acceptance: the strip model with Helmbold's lift slope at the fin's aspect ratio,
    attached flow, suction efficiency 1, no friction, within +-30 % of UVLM's converged mean
    thrust in pure roll +-45 deg at 0.5 Hz and 0.4 m/s; the committed strip numbers are the
    ones the model gives now."""
    a = committed["a_pure_roll"]
    uvlm = a["converged"]["thrust"]
    roll = V.roll_stroke()
    slope = foil.helmbold_lift_slope(V.fin_dimensions()["aspect_ratio"])
    strip = V.strip_thrust(roll, a["speed"], slope, stall=False)["thrust"]
    assert abs(strip / uvlm - 1.0) <= V.ACCEPT
    assert strip == pytest.approx(a["strip"]["helmbold_attached"]["thrust"], rel=1e-3)
    # The 2-D slope and Garrick's 2-D strips both overshoot the 3-D fin (AR 2.6).
    two_d = V.strip_thrust(roll, a["speed"], 2 * math.pi, stall=False)["thrust"]
    assert two_d == pytest.approx(a["strip"]["2d_attached"]["thrust"], rel=1e-3)
    assert two_d > strip and two_d / uvlm > 1.0 + V.ACCEPT
    assert V.garrick_strip_thrust(roll, a["speed"]) == pytest.approx(a["garrick_2d"], rel=1e-4)


def test_uvlm_thrust_is_converged_and_periodic_in_pure_roll(committed):
    """The reference is converged: the last two nc within 2 %, every nc periodic by cycle 3."""
    a = committed["a_pure_roll"]
    assert abs(a["converged"]["change_last"]) < 0.02
    assert all(
        r["cycles_to_periodic"] is not None and r["cycles_to_periodic"] <= 3 for r in a["uvlm"]
    )
    for c in a["checks"]:  # the time step and the spanwise panels
        assert abs(c["change"]) < 0.05


@pytest.mark.slow
def test_per_plate_thrusts_add_up_to_the_fin_s(committed):
    """UVLM's panel forces summed per plate add up to the wing's force, and the strip model's
    per-plate thrusts (recomputed) to its total."""
    assert committed["plates"]
    for r in committed["plates"]:
        assert sum(r["uvlm"].values()) == pytest.approx(r["uvlm_thrust"], rel=1e-3)
    r = committed["plates"][0]
    stroke = V.roll_stroke() if r["stroke"] == "pure_roll" else V.gait_stroke()
    slope = foil.helmbold_lift_slope(V.fin_dimensions()["aspect_ratio"])
    strip = V.strip_thrust(stroke, r["speed"], slope, stall=False)
    assert sum(strip["plates"].values()) == pytest.approx(strip["thrust"], rel=1e-9)
    for k in ("proximal", "distal"):
        assert strip["plates"][k] == pytest.approx(r["strip_helmbold"][k], rel=1e-3, abs=1e-4)


def test_garrick_strip_sum_is_the_closed_form_for_one_strip():
    """garrick_strip_thrust on many strips converges to the integral of Garrick's T'(r)."""
    roll = V.roll_stroke()
    p = V.FIN_ROBOT
    omega = 2 * math.pi * roll.frequency_hz
    th = math.radians(roll.amp_deg[0])
    r = np.linspace(0.0, p.d3 + p.dE, 20001)
    c = np.where(r < p.d3, p.proximal_chord, p.distal_chord)
    tp = foil.garrick_plunge_thrust(V.RHO, c / 2, omega, r * th, 0.4)
    assert V.garrick_strip_thrust(roll, 0.4, n_strips=400) == pytest.approx(
        np.trapezoid(tp, r), rel=2e-3
    )


def test_strip_motion_is_the_dh_chain_differentiated():
    """The strips' velocities are d/dt of their DH positions plus the swimming speed, and
    the gait's stroke rolls, pitches and bends the fin as its joints say."""
    g = V.gait_stroke()
    t = np.array([0.3, 0.7])
    m = V.strip_motion(g, 0.2, t)
    h = 1e-4
    pp = V.strip_motion(g, 0.2, t + h)["p"]
    pm = V.strip_motion(g, 0.2, t - h)["p"]
    v = (pp - pm) / (2 * h)
    v[..., 0] += 0.2
    np.testing.assert_allclose(m["v_mid"], v, atol=1e-6)
    # Rigid plates: every strip of a plate has the plate's angular velocity, and the velocity
    # difference of two strips is omega x their separation.
    prox = m["layout"]["plate"] == 0
    d = m["p"][:, 1] - m["p"][:, 0]
    np.testing.assert_allclose(
        m["v_mid"][:, 1] - m["v_mid"][:, 0], np.cross(m["omega"][:, 0], d), atol=1e-8
    )
    assert prox[0] and prox[1]


@pytest.mark.slow
def test_gait_uvlm_is_an_upper_bound_of_the_stalled_strip_model(committed):
    """At the gait's Strouhal numbers the stalled strip model makes less thrust than the
    inviscid UVLM at every swim speed (UVLM is the upper bound)."""
    gait = V.gait_stroke()
    slope = foil.helmbold_lift_slope(V.fin_dimensions()["aspect_ratio"])
    for case in committed["b_gait"].values():
        strip = V.strip_thrust(gait, case["speed"], slope, stall=True)["thrust"]
        assert strip == pytest.approx(case["strip"]["helmbold_stall"]["thrust"], rel=1e-3)
        assert strip < case["converged"]["thrust"]


PTERA_REASON = (
    "pterasoftware is the optional extra vortex-lattice (pip install "
    "'manta_drake[vortex-lattice]', about 1.1 GB)"
)


@pytest.mark.slow
def test_tiny_pterasoftware_case_gives_the_committed_thrust(committed):
    """nc 4, 2 cycles of pure roll at 0.4 m/s: the second cycle's mean thrust is the committed
    4-cycle nc-4 value (the run is periodic from cycle 2) and lies in Garrick's 0.5-1.2 band.
    About 10 s of CPU with pterasoftware's numba cache warm, 25 s wall on the shared 2-core
    machine; 90 s wall on a cold cache (the JIT): hence slow."""
    pytest.importorskip("pterasoftware", reason=PTERA_REASON)
    a = committed["a_pure_roll"]
    result = V.run_uvlm(V.Case(V.roll_stroke(), 0.4, 4, 2))
    assert result["finite"]
    nc4 = next(r for r in a["uvlm"] if r["nc"] == 4)
    assert result["thrust"] == pytest.approx(nc4["thrust"], rel=0.01)
    assert 0.5 <= result["thrust"] / a["garrick_2d"] <= 1.2


def test_uvlm_moves_the_model_s_fin():
    """The pterasoftware movement of the gait's stroke puts the panels' corners where the DH
    chain puts the plates (the roll2 hinge half the step row outboard of d3)."""
    pytest.importorskip("pterasoftware", reason=PTERA_REASON)
    gait = V.gait_stroke()
    move = V.uvlm_movement(V.Case(gait, 0.2, 4, 1, steps_per_cycle=8))
    p = V.FIN_ROBOT
    c1, c2 = p.proximal_chord, p.distal_chord
    for step in range(9):
        corners = V.uvlm_panel_corners(move, step)
        R3, o3, R4, o4 = (x[0] for x in V.plate_frames(gait.angles([step * gait.period / 8])))
        root_le = o3 - c1 / 2 * R3[:, 1]
        prox_te = o3 + (p.d3 - V.STEP_GAP / 2) * R3[:, 2] + c1 / 2 * R3[:, 1]
        tip_te = o4 - p.dE * R4[:, 1] + c2 / 2 * R4[:, 2]
        np.testing.assert_allclose(corners[0, 0, 0], root_le, atol=1e-9)
        np.testing.assert_allclose(corners[-1, V.SPANWISE_PANELS[0] - 1, 2], prox_te, atol=1e-9)
        np.testing.assert_allclose(corners[-1, -1, 2], tip_te, atol=2e-3)
