"""The metric functions of the transitions study (manta_drake.studies.transitions) on
signals with known answers; its page's template and the folders it writes."""

import argparse

import numpy as np
import pytest

from manta_drake.studies import transitions


@pytest.fixture(scope="module")
def tb():
    return transitions


def test_a_step_is_the_largest_jump(tb):
    t = np.arange(0.0, 2.0, 0.001)
    x = np.column_stack([0.1 * np.sin(t), np.where(t >= 1.0, 0.3, 0.0)])
    assert tb.max_step(x) == pytest.approx(0.3)
    assert tb.max_rate(t, x) == pytest.approx(0.3 / 0.001)
    assert tb.max_step(x[:1]) != tb.max_step(x[:1])  # NaN for a single sample


def test_rate_of_a_ramp(tb):
    t = np.linspace(0.0, 1.0, 101)
    assert tb.max_rate(t, -2.5 * t) == pytest.approx(2.5)
    assert tb.max_rate(t, np.column_stack([t, 3 * t])) == pytest.approx(3.0)


def test_peak_and_excursion(tb):
    assert tb.peak_abs(np.array([[1.0, -4.0], [2.0, 3.0]])) == 4.0
    a = np.radians(np.array([-3.0, 10.0, 2.0]))
    assert tb.excursion_deg(a) == pytest.approx(13.0)


def test_outside_the_envelope_by_5_deg(tb):
    t = np.linspace(0.0, 10.0, 1001)
    steady = np.column_stack([0.5 * np.sin(t), 0.2 * np.cos(t) - 0.3])
    lo, hi = tb.envelope(steady)
    assert tb.outside(steady, lo, hi) == 0.0
    x = steady.copy()
    x[500, 1] = hi[1] + np.radians(5.0)
    x[700, 0] = lo[0] - np.radians(2.0)
    assert np.degrees(tb.outside(x, lo, hi)) == pytest.approx(5.0)


def test_gait_envelope_is_bias_minus_plus_amplitude(tb):
    from manta_drake.control.gaits import GAITS

    gait = GAITS["trot"]
    lo, hi = tb.gait_envelope(gait.to_vector())
    assert np.allclose(lo, gait.X.ravel() - np.abs(gait.R.ravel()))
    assert np.allclose(hi, gait.X.ravel() + np.abs(gait.R.ravel()))


def test_settle_time_is_the_last_entry_into_the_band(tb):
    t = np.arange(0.0, 10.0, 0.01)
    x = np.exp(-t)[:, None] * np.array([1.0, -2.0])  # reaches |x| <= 0.01 at t = ln 200
    s = tb.settle_time(t, x, [0.0, 0.0], 0.01, 0.0, 10.0, angles=False)
    assert s == pytest.approx(np.log(200.0), abs=0.011)
    # A later excursion moves the settling time after it.
    x[600] = 0.5
    assert tb.settle_time(t, x, [0.0, 0.0], 0.01, 0.0, 10.0, angles=False) == pytest.approx(6.01)
    # Still outside at the end: None.
    assert tb.settle_time(t, x, [0.0, 0.0], 0.01, 0.0, 3.0, angles=False) is None
    # Angles are compared on the torus: pi and -pi are the same.
    assert tb.settle_time(t, np.full((len(t), 1), np.pi), [-np.pi], 1e-9, 0.0, 10.0) == 0.0


def test_running_envelope_is_a_forward_window(tb):
    t = np.arange(0.0, 3.0, 0.01)
    x = np.column_stack([np.sin(7 * t), 2 * np.cos(3 * t)])
    lo, hi = tb.running_envelope(t, x, 0.5)
    k = 50
    ref_lo = np.array([x[i : i + k + 1].min(axis=0) for i in range(len(t) - k)])
    ref_hi = np.array([x[i : i + k + 1].max(axis=0) for i in range(len(t) - k)])
    assert np.array_equal(lo[: len(t) - k], ref_lo)
    assert np.array_equal(hi[: len(t) - k], ref_hi)
    assert np.isnan(lo[len(t) - k :]).all()


def test_joint_settle_time_of_an_amplitude_change(tb):
    # Amplitude 1 until t = 4.5 (the sine at its peak), then 0.5 with bias 0.2: the target
    # range is [-0.3, 0.7]; just before 4.5 the old signal is near 1, far outside it.
    t = np.arange(0.0, 12.0, 0.001)
    amp = np.where(t < 4.5, 1.0, 0.5)
    bias = np.where(t < 4.5, 0.0, 0.2)
    q = (bias + amp * np.sin(2 * np.pi * 0.5 * t))[:, None]
    s = tb.joint_settle_time(t, q, np.array([-0.3]), np.array([0.7]), 0.01, 2.0, 0.0, 12.0)
    # Every window that holds a sample before the change is off: settled at t = 4.5.
    assert s == pytest.approx(4.5, abs=0.002)


def test_transition_event_of_a_switch_and_a_blend(tb):
    src, dst = np.zeros(3), np.array([1.0, -2.0, np.pi])
    t = np.arange(0.0, 10.0, 0.02)
    # An abrupt switch at t = 5 (after a sample at the source): the event is the sample before.
    psi = np.where((t >= 5.0)[:, None], dst, src)
    assert tb.transition_event(t, psi, src, dst, 0.05) == pytest.approx(4.98)
    # A blend from t = 3 to t = 7: psi leaves the 0.05 band when pi w = 0.05, at
    # t = 3 + 0.2 / pi = 3.064, so the last sample at the source is t = 3.06.
    w = np.clip((t - 3.0) / 4.0, 0.0, 1.0)[:, None]
    psi = (1 - w) * src + w * dst
    assert tb.transition_event(t, psi, src, dst, 0.05) == pytest.approx(3.06)
    # Never reaching the target: None; arrivals before ``after`` are ignored.
    assert tb.transition_event(t, psi * 0.5, src, dst, 0.05) is None
    assert tb.transition_event(t, psi, src, dst, 0.05, after=9.9) == pytest.approx(3.06)


def test_the_switch_target_series_jumps_at_half_depth(tb):
    from manta_drake.control.gaits import GAITS

    z = np.array([0.0, 0.2, 0.49, 0.51, 1.0])
    psi_d = tb.target_series(z, "switch", 1.0)
    swim, trot = GAITS["swim"].to_vector(), GAITS["trot"].to_vector()
    assert np.array_equal(psi_d[:3], np.tile(swim, (3, 1)))
    assert np.array_equal(psi_d[3:], np.tile(trot, (2, 1)))
    linear = tb.target_series(z, "linear", 1.0)
    assert np.allclose(linear[1], 0.8 * swim + 0.2 * trot)


def test_markdown_table_formats_missing_values(tb):
    rows = [
        {
            "method": "m",
            "transition": "swim->trot",
            "event_s": 1.0,
            "window_s": [1.0, 13.0],
            "settle_params_s": None,
            "max_cmd_step_rad": float("nan"),
        }
    ]
    table = tb.markdown_table(rows)
    assert "> 12" in table and "n/a" in table and table.count("\n") == 2


def test_gait_changes_counts_chatter(tb):
    assert tb.gait_changes([None, "trot", "trot"], "swim") == 1
    assert tb.gait_changes(["swim", "trot", None, "swim", "trot"], "swim") == 3
    assert tb.gait_changes([None, None], "swim") == 0


def _three_gaits():
    from manta_drake.control.gaits import GAITS

    return [GAITS[b].to_vector() for b in ("swim", "trot", "turning")]


def _eq12(z, s, swim, trot, turning, z_t, normalise):
    """Eq. (12) written out here (the text's w(s), a = pi/2 (min(z / z_t, 1) - 1)), with its
    weights divided by their sum if ``normalise``."""
    a = 0.5 * np.pi * (min(z / z_t, 1.0) - 1.0)
    w = 0.5 * (1.0 - np.cos(np.pi * s))
    w_swim, w_gait = -np.sin(a), np.cos(a)
    if normalise:
        w_swim, w_gait = w_swim / (w_swim + w_gait), w_gait / (w_swim + w_gait)
    return w_swim * swim + w_gait * (w * turning + (1.0 - w) * trot)


def _outside(x, lo, hi):
    return float(np.maximum(np.maximum(lo - x, x - hi), 0.0).max())


@pytest.mark.slow
@pytest.mark.parametrize("z_t", [1.0, 0.6])
def test_the_normalised_blend_commands_nothing_outside_the_gaits_range(tb, z_t):
    from manta_drake.control.transition import target_params

    gaits = _three_gaits()
    stacked = np.array(gaits)
    lo, hi = stacked.min(axis=0), stacked.max(axis=0)  # entrywise over swim, trot, turning
    n = stacked.shape[1] // 4
    R, X = np.abs(stacked[:, :n]), stacked[:, n : 2 * n]
    j_lo, j_hi = (X - R).min(axis=0), (X + R).max(axis=0)  # what a locked CPG commands
    z_grid, s_grid = np.linspace(0.0, 1.0, 201), np.linspace(0.0, 1.0, 11)
    worst = {}
    for blend in ("normalised", "potential"):
        params = joints = 0.0
        for z in z_grid:
            for s in s_grid:
                psi_d = target_params(z, s, *gaits, z_t, blend)
                assert np.allclose(
                    psi_d, _eq12(z, s, *gaits, z_t, blend == "normalised"), rtol=0.0, atol=1e-12
                )
                params = max(params, _outside(psi_d, lo, hi))
                r, x = np.abs(psi_d[:n]), psi_d[n : 2 * n]
                joints = max(joints, _outside(x - r, j_lo, np.inf), _outside(x + r, -np.inf, j_hi))
        worst[blend] = (params, joints)
    # Convex: inside up to round-off, every entry and the joints' envelope.
    assert worst["normalised"][0] <= 1e-12 and worst["normalised"][1] <= 1e-12
    # Eq. (12) as printed leaves both (its weights sum to sqrt 2 at z = z_t / 2).
    assert worst["potential"][0] > 0.1 and worst["potential"][1] > 0.1
    # At z = z_t / 2, s = 0, an entry on which swim and trot agree is scaled by sqrt 2.
    mid = target_params(0.5 * z_t, 0.0, *gaits, z_t, "potential")
    same = np.flatnonzero((gaits[0] == gaits[1]) & (gaits[0] != 0.0))
    assert len(same)
    assert np.allclose(mid[same], np.sqrt(2.0) * gaits[0][same])
    # The study's measure agrees with this one on the same grid.
    for blend, (params, joints) in worst.items():
        got = tb.target_outside(blend, z_t, z_grid, s_grid)
        assert got["params_rad"] == pytest.approx(params, abs=1e-12)
        assert got["joints_rad"] == pytest.approx(joints, abs=1e-12)


def test_the_normalised_blend_sits_between_swim_and_the_gait(tb):
    # At z = 1/2 (z_t = 1) the two normalised weights are equal: the midpoint; at z = 1/3,
    # a = -pi/3: weights sin(pi/3), cos(pi/3) over their sum.
    from manta_drake.control.transition import target_params

    swim, trot, turning = _three_gaits()
    assert np.allclose(
        target_params(0.5, 0.0, swim, trot, turning, 1.0, "normalised"), 0.5 * (swim + trot)
    )
    a, b = np.sin(np.pi / 3), np.cos(np.pi / 3)
    assert np.allclose(
        target_params(1 / 3, 0.0, swim, trot, turning, 1.0, "normalised"),
        (a * swim + b * trot) / (a + b),
    )


@pytest.mark.slow
def test_the_normalised_comparison_names_its_costs_and_gains(tb):
    def row(method, transition, **values):
        base = {
            "method": method,
            "transition": transition,
            "event_s": 10.0,
            "window_s": [8.0, 22.0],
            "outside_gaits_deg": 0.0,
            "outside_steady_deg": 0.0,
            "arrival_s": 3.0,
            "settle_params_s": 5.0,
            "settle_joints_s": 4.0,
            "max_cmd_rate_rad_s": 3.0,
            "max_meas_vel_rad_s": 3.0,
            "peak_torque_nm": 4.0,
            "pitch_exc_deg": 20.0,
            "roll_exc_deg": 15.0,
        }
        return {**base, **values}

    rows = [
        row("potential/descent", "swim->trot", outside_gaits_deg=14.6),
        row("normalised/descent", "swim->trot", arrival_s=3.5, peak_torque_nm=3.0),
        row("potential/descent", "trot->swim", outside_gaits_deg=8.7),
        row("normalised/descent", "trot->swim", settle_joints_s=None),
    ]
    text = "\n".join(tb.normalised_section(rows, 1.0))
    costs = next(line for line in text.splitlines() if line.startswith("* What it costs"))
    gains = next(line for line in text.splitlines() if line.startswith("* What it gains"))
    assert "first arrival 0.50 s later (swim->trot)" in costs
    assert "settle, joints not within the window for normalised (trot->swim)" in costs
    assert "peak abs torque 1.00 N m smaller (swim->trot)" in gains
    assert "in range, outside the two gaits' range (X -+ |R|) 14.6 deg smaller" in gains
    assert "in smoothness, nothing" in costs and "in range, nothing" in costs
    assert "pitch" not in costs + gains  # equal values are neither
    assert "by at most 0.0 deg, Eq. (12)'s by 14.6 deg" in text
    # Without a normalised run there is nothing to compare.
    assert tb.normalised_section(rows[::2], 1.0) == []


def _page_rows():
    """Two methods' rows of swim->trot (no trot->swim event in the run)."""
    steady = {
        "max_cmd_step_rad": 0.006,
        "max_cmd_rate_rad_s": 5.98,
        "max_meas_vel_rad_s": 6.02,
        "peak_torque_nm": 4.95,
        "roll_exc_deg": 25.0,
        "pitch_exc_deg": 45.8,
    }
    paper = {
        "method": "potential/descent",
        "transition": "swim->trot",
        "blend": "potential",
        "event_s": 11.56,
        "window_s": [9.56, 23.56],
        "max_cmd_step_rad": 0.00351,
        "max_cmd_rate_rad_s": 3.531,
        "max_meas_vel_rad_s": 3.9,
        "peak_torque_nm": 9.744,
        "roll_exc_deg": 23.2,
        "pitch_exc_deg": 63.46,
        "psi_gait_changes": 1,
        "arrival_s": 4.42,
        "settle_params_s": None,
        "settle_joints_s": None,
        "outside_steady_deg": 7.6,
        "outside_gaits_deg": 14.8,
        "worst_joint": 2,
        "steady": steady,
    }
    switch = {
        **paper,
        "method": "switch/direct",
        "blend": "switch",
        "event_s": 8.16,
        "window_s": [6.16, 20.16],
        "max_cmd_step_rad": 0.006,
        "peak_torque_nm": 7.19,
        "pitch_exc_deg": 59.2,
        "psi_gait_changes": 9,
        "arrival_s": 0.04,
        "settle_params_s": 6.02,
        "outside_steady_deg": 0.0,
        "outside_gaits_deg": 0.0,
    }
    later = {"transition": "trot->swim", "event_s": None, "note": "never"}
    return [
        paper,
        {**later, "method": "potential/descent"},
        switch,
        {**later, "method": "switch/direct"},
    ]


def _facts():
    return {
        "max_descent_step": 0.0589,
        "period_ms": 20.0,
        "a": 20.0,
        "b": 20.0,
        "effort": (4.5, 9.2),
        "velocity": (8.0, 8.0),
        "change": 3.14159,
        "settle_tol": 0.0314159,
        "tolerance": 0.05,
        "frequency": 0.5,
        "log_ms": 1.0,
        "z_t": 1.0,
        "commands": [(8.0, 0.0), (38.0, 1.0)],
    }


def test_the_page_puts_each_number_in_its_place(tb):
    checks = [
        {"method": "potential/descent", "kind": "limit", "limit": (4.5, 9.2), "value": 3},
        {"method": "switch/direct", "kind": "direct", "value": 0.0},
    ]
    command = "manta-drake study transitions --duration 30 --runs R"
    lines = tb.page(_page_rows(), checks, _facts(), command, 30.0).splitlines()
    assert lines[2] == (
        "Made unknown at commit unknown. Regenerate with `manta-drake study transitions "
        "--duration 30 --runs R` (four runs of 30 s, one after the other; `--reuse` recomputes "
        "this page from the existing runs in `--runs`, default `out/transitions`)."
    )
    text = "\n".join(lines)
    assert "the balloon is commanded to fill 0 at 8 s, then fill 1 at 38 s: the robot" in text
    assert "at most 0.059 rad per 20 ms update" in text
    assert "(servo limit in the model: 8 rad/s)" in text
    assert "the PD's effort limit is 4.5-9.2 N m." in text
    # The tables: the rows in order, each cell to its digits; a reference row per transition.
    motion = lines.index("How abrupt:") + 2
    assert lines[motion + 2 : motion + 5] == [
        "| potential/descent | swim->trot | 11.56 | 0.0035 | 3.53 | 3.90 | 9.74 | 23.2 | 63.5 |",
        "| switch/direct | swim->trot | 8.16 | 0.0060 | 3.53 | 3.90 | 7.19 | 23.2 | 59.2 |",
        "| *steady swim and trot (ref.)* | swim->trot | n/a | 0.0060 | 5.98 | 6.02 | 4.95 | "
        "25.0 | 45.8 |",
    ]
    timing = lines.index("How long, and how far off the two gaits:") + 2
    assert lines[timing + 2] == (
        "| potential/descent | swim->trot | 1 | 4.42 | > 12 | > 12 | 7.6 | 14.8 |"
    )
    assert "| switch/direct | swim->trot | 9 | 0.04 | 6.02 | > 12 | 0.0 | 0.0 |" in lines
    assert (
        "* swim->trot: largest commanded step: switch/direct; largest torque peak: "
        "potential/descent; largest pitch excursion: potential/descent; largest excursion "
        "outside the steady envelope: potential/descent." in lines
    )
    assert (
        "* trot->swim: largest commanded step: n/a; largest torque peak: n/a; largest pitch "
        "excursion: n/a; largest excursion outside the steady envelope: n/a." in lines
    )
    assert (
        "* switch/direct, swim->trot: psi went between the two gaits 9 times within the window "
        "(the target chattered as z_hat crossed the threshold back and forth)." in lines
    )
    assert "| potential | 74.6 | 0.50, 0.00 | 18.6 | 0.50, 0.00 |" in lines
    assert "| switch | 0.0 | n/a | 0.0 | n/a |" in lines
    # Without a normalised run there is no comparison: one blank line before the checks.
    assert "### The normalised blend" not in text
    checks_at = lines.index("Checks made by the script on these runs:")
    assert lines[checks_at - 2].startswith("| switch |") and lines[checks_at - 1] == ""
    assert lines[checks_at + 2 : checks_at + 4] == [
        "* potential/descent: samples (1 ms) with a joint at its effort limit (4.5-9.2 N m), "
        "whole run: 3",
        "* switch/direct: logged cpg_params = psi_d(z_hat) one update later, max difference "
        "(rad): 0.00e+00",
    ]
    assert "![transitions](figures/transition_baselines.png)" in lines
    assert text.endswith("for the four methods.")


@pytest.mark.slow
@pytest.mark.filterwarnings("ignore:No artists with labels")  # no trot->swim in these runs
def test_out_holds_the_page_and_the_figure_and_runs_the_runs(tb, tmp_path, monkeypatch):
    from manta_drake.studies import REPO

    runs = tmp_path / "runs"
    for *_, folder in tb.METHODS:  # --reuse: the runs' files must be there
        (runs / folder).mkdir(parents=True)
        for name in ("log.npz", "metrics.json"):
            (runs / folder / name).write_text("")
    rows = _page_rows()
    t = np.arange(0.0, 30.0, 0.01)
    log = {
        "t": t,
        "t_command": t,
        "t_z_hat": t,
        "commanded_joint_angles": np.zeros((len(t), 16)),
        "body_rpy": np.zeros((len(t), 3)),
        "z_hat": np.zeros((len(t), 1)),
    }
    logs = {"potential/descent": (log, {}), "switch/direct": (log, {})}
    monkeypatch.setattr(tb, "analyse_runs", lambda folder: (logs, rows, [], _facts(), 70.0))
    out = tmp_path / "report"
    assert tb.main(["--reuse", "--runs", str(runs), "--out", str(out)], prog="x") == 0
    assert sorted(str(p.relative_to(tmp_path)) for p in tmp_path.rglob("*.*")) == sorted(
        [
            f"runs/{folder}/{name}"
            for *_, folder in tb.METHODS
            for name in ("log.npz", "metrics.json")
        ]
        + [
            "report/transitions.md",
            "report/figures/transition_baselines.png",
            "runs/transition_baselines.json",
        ]
    )
    page = (out / "transitions.md").read_text()
    assert "Regenerate with `manta-drake study transitions` (four runs of 70 s," in page
    assert "| switch/direct | swim->trot | 8.16 |" in page
    # Where the page goes without --out: the checkout's docs/, or beside a shortened run.
    args = argparse.Namespace(runs=str(runs), out=None, duration=None, reuse=False)
    assert tb.check_arguments(args, "x") == (runs, REPO / "docs")
    args.duration = 30.0
    assert tb.check_arguments(args, "x") == (runs, runs)
