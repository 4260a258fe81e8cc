"""Behaviours and modalities as data: the paper's runs against the heading hold and the
flow-, depth- and energy-driven run (docs/behaviours.md).

Runs two_behaviors, three_behaviors, locomotion_swim, swim_heading_hold,
two_behaviors_heading_hold and four_behaviors (one Dask task each), reads every number from
their logs (transitions, walls, the free-water window, speeds, yaw rates, the trim, the
estimates) and writes docs/behaviours.md, docs/figures/heading_hold.png and
docs/figures/four_behaviors.png.

Usage: manta-drake study behaviours [--out out/behaviours] [--workers N | --scheduler ADDRESS]
       [--reuse]
"""

from __future__ import annotations

import json
import pathlib
import shutil

import numpy as np

from manta_drake.cluster import (
    add_cluster_arguments,
    check_cluster_arguments,
    cluster_client,
)
from manta_drake.metrics import transition_span
from manta_drake.studies import REPO
from manta_drake.studies.stamp import stamp_line, write_stamped

SCENARIOS = (
    "two_behaviors",
    "three_behaviors",
    "locomotion_swim",
    "swim_heading_hold",
    "two_behaviors_heading_hold",
    "four_behaviors",
    "swim_heading_hold_reversed",
)
# Runs that are a shipped scenario with overrides: name -> (scenario, overrides).
VARIANTS = {"swim_heading_hold_reversed": ("swim_heading_hold", {"heading_hold.turn_sign": -1})}
COMMAND = "`manta-drake study behaviours`"
# The modalities' registry and the altimeter's floor detection: prose and a measurement the
# study does not rerun (diagrams/nose_up_trot.py makes it), kept beside the generator.
MODALITIES_SECTION = (
    pathlib.Path(__file__).resolve().parent / "templates" / "behaviours_modalities.md"
)
# What drove each of four_behaviors' changes: the estimate whose node changed the target.
DRIVERS = {
    ("trot", "walk"): "flow (flow_hat rises: the cross current on the floor)",
    ("walk", "trot"): "flow (flow_hat falls)",
    ("trot", "swim"): "depth (z_hat falls: the balloon rule on flow filled the balloon)",
    ("swim", "rest"): "energy (energy_hat rises: the charge reaches the reserve)",
}


def run_one(name: str, out: str) -> dict:
    """Runs the shipped scenario ``name`` into ``out``; its metrics (the log stays there)."""
    from manta_drake.scenario import load_scenario
    from manta_drake.simulate import run

    base, overrides = VARIANTS.get(name, (name, {}))
    scenario = load_scenario(base, overrides={"visualization.meshcat": False, **overrides})
    return run(scenario, out, progress=False).metrics


def _runs(args) -> dict:
    out = pathlib.Path(args.out)
    todo = [n for n in SCENARIOS if not (args.reuse and (out / n / "metrics.json").is_file())]
    with cluster_client(args) as client:
        if client is None:
            for name in todo:
                run_one(name, str(out / name))
        else:
            futures = [client.submit(run_one, n, str(out / n), pure=False) for n in todo]
            client.gather(futures)
    return {n: json.loads((out / n / "metrics.json").read_text()) for n in SCENARIOS}


def _transitions(m: dict) -> str:
    return (
        "; ".join(
            f"{t['from']} -> {t['to']} {transition_span(t)} s" for t in m.get("transitions", [])
        )
        or "none"
    )


def _walls(m: dict) -> str:
    near = m.get("near_wall_at_s")
    return (
        (f"within 0.3 m of a wall from {near:.1f} s" if near is not None else "never within 0.3 m")
        + f"; closest {max(m['min_wall_clearance_m'], 0.0):.2f} m"
        + ("; touched" if m["touched_wall"] else "")
    )


def _uv(m: dict) -> str:
    uv = m.get("mean_velocity_body")
    return "-" if uv is None else f"{uv[0]:.3f}, {uv[1]:.3f}"


def _heading_figure(out: pathlib.Path, path: pathlib.Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    from matplotlib.figure import Figure

    fig = Figure(figsize=(10, 6))
    ax1, ax2 = fig.subplots(2, 1, sharex=True)
    for name, label in (
        ("locomotion_swim", "swim (printed Phi'_swim lag)"),
        ("swim_heading_hold", "the same swim, heading held by the IMU"),
    ):
        log = np.load(out / name / "log.npz")
        ax1.plot(log["t"], np.degrees(np.unwrap(log["body_rpy"][:, 2])), label=label)
        if "heading_trim" in log.files:
            ax2.plot(
                log["t_heading_trim"],
                log["heading_trim"][:, 0],
                label="trim u (left x (1+u), right x (1-u))",
            )
    ax1.set_ylabel("yaw [deg]")
    ax1.legend(fontsize=8)
    ax2.set_ylabel("heading trim")
    ax2.set_xlabel("time [s]")
    ax2.legend(fontsize=8)
    for ax in (ax1, ax2):
        ax.grid(alpha=0.3)
    fig.suptitle("Heading hold: the swim's yaw with and without the IMU's trim")
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def _four_figure(out: pathlib.Path, metrics: dict, path: pathlib.Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    from manta_drake import plots
    from manta_drake.scenario import load_scenario

    data = np.load(out / "four_behaviors" / "log.npz")
    log = {k: data[k] for k in data.files}
    plots.fig_transition_run(
        log,
        metrics,
        path,
        "four_behaviors: flow, depth and the battery choose the behaviour (cf. paper Fig. 11)",
        leaves=load_scenario("four_behaviors").behaviour_tree().leaves,
    )


def _estimates_at(out: pathlib.Path, times) -> list:
    log = np.load(out / "four_behaviors" / "log.npz")

    def at(key, t):
        return float(log[key][min(np.searchsorted(log[f"t_{key}"], t), len(log[key]) - 1), 0])

    return [
        (t, at("z_hat", t), at("flow_hat", t), at("energy_hat", t), at("balloon_command", t))
        for t in times
    ]


def page(metrics: dict, out: pathlib.Path) -> str:
    """docs/behaviours.md for these runs."""
    m = metrics
    swim, held = m["locomotion_swim"], m["swim_heading_hold"]
    four = m["four_behaviors"]
    behaviours = sorted({b for t in four["transitions"] for b in (t["from"], t["to"])})
    from manta_drake.scenario import load_scenario

    spec = load_scenario("four_behaviors")
    keys = spec.water.current_schedule
    strong = [k.time for k in keys if np.linalg.norm(k.velocity) > 0]
    on_until, off_at = max(strong), min(k.time for k in keys if k.time > max(strong))
    speed_now = max(np.linalg.norm(k.velocity) for k in keys)
    rule, est = spec.balloon.rule, spec.energy_estimator
    soc0 = spec.actuators.initial_soc
    lines = [
        "# Behaviours and modalities as data",
        "",
        stamp_line(
            COMMAND + " (the runs: `manta-drake run NAME` for each scenario below; "
            "`python diagrams/four_behaviors.py`)."
        ),
        "",
        "The paper's controller blends three gaits by two estimates (Eq. 12: swim, trot and "
        "turning by the depth z_hat and the wall rate s_hat), and names its own future work: "
        "behaviour decisions from posture, flow velocity and power. Here the gaits are files, "
        "the blend is a tree in the scenario and the station has the sensors those decisions "
        "need; Eq. (12) is the default tree and the paper's runs are unchanged by any of it.",
        "",
        "## Gaits as data",
        "",
        "A gait file (`manta_drake.control.gait_files`) holds `gaits: {NAME: {R_deg, X_deg, "
        "Phi_deg, Phi_prime_deg}}`, each 4x4 in degrees (rows fl, fr, rl, rr; columns yaw, roll1, "
        "pitch, roll2), with an optional `base:` gait for the matrices left out and "
        "`mirror_keep:` for what the mirrored reading leaves as written. `models/gaits.yaml` "
        "holds the paper's gaits and our readings (every `<name>_printed` form included), "
        "bit-identical to the matrices written as `PI / 18`...; a scenario adds its own files "
        "with `controller.gait_files` (relative to the scenario file). Every mistake is one "
        "line naming the file, the gait, the entry and the problem; a name defined twice names "
        "both files.",
        "",
        "## Behaviours as a tree",
        "",
        "`transition.tree` maps node names to `{modality, weight, children, full_at, threshold, "
        "hysteresis}` (`threshold` and `hysteresis` a switch's only: another node that sets "
        "either is refused); the top node is `root`, a child is a node or a gait. A node's "
        "coordinate "
        "is x = min(clip(m, 0, 1) / full_at, 1) of its modality m and its weight function one of:",
        "",
        "| weight | w0 (first child), w1 (second) | |",
        "| --- | --- | --- |",
        (
            "| `potential` | -sin(a), cos(a), a = pi/2 (x - 1) | Eq. (12)'s depth pair; sums to up "
            "to 1.41 |"
        ),
        "| `cosine` | 1 - w, w with w = (1 - cos(pi x)) / 2 | Eq. (12)'s vision weight |",
        "| `linear` | 1 - x, x | Eq. (11) |",
        (
            "| `normalised` | the potential's, divided by their sum | a convex blend "
            "(docs/transitions.md) |"
        ),
        "| `switch` | 0/1 at threshold +- hysteresis / 2 | a decision with memory |",
        "",
        "A node with N children places them at x = k / (N - 1) and blends neighbours. The "
        "estimates are `z_hat` (depth, Eq. 9), `s_hat` (walls, Eq. 10), `flow_hat` "
        "(`FlowEstimator`: the flow sensor's speed on a chosen axis between two thresholds), "
        "`posture_hat` (`PostureEstimator`: the IMU's tilt between 10 and 30 deg), "
        "`energy_hat` (`EnergyEstimator`: the charge below a reserve) and `floor_hat` "
        "(`AltimeterEstimator`: the altimeter's range below a floor band); "
        "`manta_drake.modalities` lists them. Every node's field can be "
        "set or swept as `transition.tree.NODE.FIELD`. Without a tree the target is Eq. (12) to "
        "the last bit: two_behaviors and three_behaviors give the same metrics and the same log "
        "arrays, every one, as before trees existed (tests/test_behaviour_tree.py checks the "
        "targets, tests/test_modalities.py a tree written out as Eq. (12)).",
        "",
        "## The new modalities",
        "",
        "* `imu` (station, `imu.enabled`): the hull's attitude, body rate and specific force at "
        "the sensor, sampled at `imu.rate_hz`, with white noise and a per-run bias from Drake "
        "random sources seeded from the scenario.",
        "* `flow_velocity` (`flow_sensor.enabled`): the water's velocity relative to the head in "
        "the body frame, from the current the water model applies (`water.current` or the "
        "time-keyed `water.current_schedule`), with white noise. It reads relative flow: a robot "
        "drifting with a current reads only its own motion, a robot held by its feet reads "
        "the current.",
        "* `battery`: the pack's state of charge, voltage and current (the energy model); the "
        "estimate uses the charge, a fuel gauge's count, without added noise (its error is the "
        "capacity's uncertainty, which the actuator scales of the energy band cover).",
        "",
        MODALITIES_SECTION.read_text().rstrip("\n") + " `balloon.rule` fills the balloon "
        "from an estimate (above a band: one fill; below it: another; from `after` on), and "
        "`heading_hold` trims the swim from the IMU.",
        "",
        "## Feedback from posture: the heading hold",
        "",
        "`HeadingHold` is a PID heading autopilot (Fossen, *Handbook of Marine Craft "
        "Hydrodynamics and Motion Control*, 2011, ch. 15) whose actuator is a differential "
        "flapping amplitude, as batoid robots steer (e.g. Low et al.'s RoMan ray robots): the "
        "left fins' roll amplitudes are multiplied by 1 + u and the right fins' by 1 - u, by "
        "the swim leaves' share of the behaviour tree (the legged gaits are untouched). Its "
        "gains (kp 0.5 /rad, ki 0.05 /(rad s), kd 0.5 s/rad on the gyro rate, |u| <= 0.3) are "
        "the defaults; the sign (a larger left amplitude turns the robot right) is the "
        "model's: with the opposite sign (`heading_hold.turn_sign: -1`) the same swim turns at "
        f"{m['swim_heading_hold_reversed']['yaw_rate_deg_s']:.1f} deg/s, faster than without "
        "the hold.",
        "",
        "| run | u, v m/s | yaw rate deg/s | free-water window s | walls | mean trim |",
        "| --- | --- | --- | --- | --- | --- |",
    ]
    for name, label in (
        ("locomotion_swim", "swim (printed Phi'_swim lag)"),
        ("swim_heading_hold", "swim_heading_hold"),
        ("swim_heading_hold_reversed", "the hold with the opposite sign"),
    ):
        r = m[name]
        log = np.load(out / name / "log.npz")
        w = r["steady_window_s"]
        trim = "-"
        if "heading_trim" in log.files:
            sel = (log["t_heading_trim"] >= w[0]) & (log["t_heading_trim"] <= w[1])
            trim = f"{log['heading_trim'][sel, 0].mean():+.3f}"
        lines.append(
            f"| {label} | {_uv(r)} | {r['yaw_rate_deg_s']:.2f} | {w[0]:.1f}-{w[1]:.1f} | "
            f"{_walls(r)} | {trim} |"
        )
    yaw_held = abs(held["yaw_rate_deg_s"])
    lines += [
        "",
        f"The hold brings the swim's yaw rate from {swim['yaw_rate_deg_s']:.1f} to "
        f"{held['yaw_rate_deg_s']:.2f} deg/s ({'within' if yaw_held <= 1.0 else 'outside'} "
        f"1 deg/s) at u = {held['mean_velocity_body'][0]:.3f} m/s "
        f"({'at least' if held['mean_velocity_body'][0] >= 0.07 else 'below'} 0.07 m/s) over "
        f"its free-water window; the swim without it leaves free water at "
        f"{swim['near_wall_at_s'] or swim['steady_window_s'][1]:.1f} s. "
        "![heading hold](figures/heading_hold.png)",
        "",
        "The paper's two-behaviour run with the same hold while it swims:",
        "",
        "| run | transitions | walls | u, v m/s | yaw rate deg/s |",
        "| --- | --- | --- | --- | --- |",
    ]
    for name in ("two_behaviors", "two_behaviors_heading_hold", "three_behaviors"):
        r = m[name]
        yaw = "-" if r.get("yaw_rate_deg_s") is None else f"{r['yaw_rate_deg_s']:.2f}"
        lines.append(f"| {name} | {_transitions(r)} | {_walls(r)} | {_uv(r)} | {yaw} |")
    lines += [
        "",
        "two_behaviors and three_behaviors are the paper's runs, with no tree, sensor or hold "
        "of the new kinds: their numbers are the README's.",
        "",
        "## A fourth behaviour from new modalities: four_behaviors",
        "",
        f"The robot starts on the floor in a {speed_now:g} m/s cross current (to its left; "
        f"0-{on_until:g} s, then down to 0 by {off_at:g} s). The tree: `root` blends `active` "
        "and the gait `rest` (a gait file "
        "beside the scenario: no oscillation, the swim's stance) by `energy_hat` (cosine); "
        "`active` blends swim and `floor` by `z_hat` (Eq. 12's potential); `floor` switches "
        "between trot and walk by `flow_hat` (hysteresis 0.6). `balloon.rule` keeps the balloon "
        f"empty while `flow_hat` is high and fills it when it is low, from {rule.after:g} s on. "
        f"The battery starts at {100 * soc0:g} % with its reserve at "
        f"{100 * est.soc_low:g}-{100 * est.soc_high:g} %.",
        "",
        "| change | s | driven by |",
        "| --- | --- | --- |",
    ]
    for t in four["transitions"]:
        driver = DRIVERS.get((t["from"], t["to"]), "-")
        lines.append(f"| {t['from']} -> {t['to']} | {transition_span(t)} | {driver} |")
    lines += [
        "",
        f"{len(behaviours)} behaviours ({', '.join(behaviours)}); {_walls(four)}. "
        f"The estimates the decisions read (from the log):",
        "",
        "| t s | z_hat | flow_hat | energy_hat | balloon command |",
        "| --- | --- | --- | --- | --- |",
    ]
    for t, z, f, e, b in _estimates_at(
        out, (4.0, on_until, off_at + 4.0, off_at + 8.0, 30.0, 50.0, 65.0)
    ):
        lines.append(f"| {t:.0f} | {z:.2f} | {f:.2f} | {e:.2f} | {b:.0f} |")
    energy = four.get("energy", {})
    log = np.load(out / "four_behaviors" / "log.npz")
    t, speed = log["t_flow_speed_hat"], log["flow_speed_hat"][:, 0]
    xy = log["body_xyz"][:, 1]
    # From the balloon rule's start to the current's end: on the floor, walking, in the current.
    a, b = rule.after, on_until
    lo_in, hi_in = speed[(t >= a) & (t <= b)].min(), speed[(t >= a) & (t <= b)].max()
    drift = (np.interp(b, log["t"], xy) - np.interp(a, log["t"], xy)) / (b - a)
    tz, z = log["t_z_hat"], log["z_hat"][:, 0]
    z_low = z[tz <= 5.0].min()
    low, high = spec.flow_estimator.speed_low, spec.flow_estimator.speed_high
    back = next(
        (tr["start_s"] for tr in four["transitions"] if (tr["from"], tr["to"]) == ("walk", "trot")),
        None,
    )
    if lo_in >= low:
        reads = f"above the thresholds ({low:g}-{high:g} m/s)"
    else:
        reads = (
            f"falling below the lower threshold ({low:g} m/s; the band is "
            f"{low:g}-{high:g} m/s) as the robot drifts with it"
        )
    if back is not None and back < on_until:
        back_text = (
            f" The walk gives way to the trot at {back:.1f} s, before the current "
            f"stops at {on_until:g} s: drifting with it, the robot sees too little of it."
        )
    elif back is not None:
        back_text = f" The walk gives way to the trot at {back:.1f} s, once the current stops."
    else:
        back_text = ""
    if z_low < 0.99:
        settle = (
            f"While the robot settles on its feet (the first 5 s) z_hat dips to "
            f"{z_low:.2f}, which gives the swim a share of the target for a moment."
        )
    else:
        settle = f"While the robot settles on its feet (the first 5 s) z_hat stays at {z_low:.2f}."
    lines += [
        "",
        f"The current drags the walking robot along the floor at {drift:.3f} m/s ({a:g}-{b:g} s; "
        f"its feet hold it only partly), so the filtered flow speed reads {lo_in:.3f}-{hi_in:.3f} "
        f"m/s in the {speed_now:g} m/s current, {reads}; a "
        f"{spec.flow_estimator.time_constant:g} s filter averages the walk's own sway over its "
        "2 s cycle. Drifting at the surface the robot could not see a steady current at all; "
        "that is why the decision to leave the floor is made on the current's absence, not on "
        f"its start.{back_text} {settle}",
        "",
        f"Energy: {energy.get('mean_electrical_power_w', float('nan')):.1f} W mean, the charge "
        f"from {100 * soc0:g} % to {100 * energy.get('battery_soc_end', float('nan')):.2f} %.",
        "",
        "![four_behaviors](figures/four_behaviors.png)",
        "",
    ]
    return "\n".join(lines)


def main(argv=None, prog=None) -> int:
    """The command line (``manta-drake study behaviours``); returns the exit status."""
    from manta_drake.config_io import check_writable_folder
    from manta_drake.studies.options import StudyParser

    parser = StudyParser(prog=prog, description=__doc__.splitlines()[0])
    parser.add_argument(
        "--out",
        type=pathlib.Path,
        default=pathlib.Path("out/behaviours"),
        help="where the runs go (default out/behaviours)",
    )
    parser.add_argument(
        "--reuse",
        action="store_true",
        help="reuse runs already in --out (their metrics.json and log.npz)",
    )
    add_cluster_arguments(parser)
    args = parser.parse_args(argv)
    check_cluster_arguments(args)  # every option before a cluster or a run starts
    check_writable_folder(args.out, "--out", example="out/behaviours")
    metrics = _runs(args)
    figures = REPO / "docs" / "figures"
    figures.mkdir(parents=True, exist_ok=True)
    _heading_figure(args.out, figures / "heading_hold.png")
    _four_figure(args.out, metrics["four_behaviors"], figures / "four_behaviors.png")
    written = write_stamped(REPO / "docs" / "behaviours.md", page(metrics, args.out))
    print(f"docs/behaviours.md {'written' if written else 'unchanged'}; figures in {figures}")
    for name in SCENARIOS:
        print(f"{name:28s} {_transitions(metrics[name])} | {_walls(metrics[name])}")
    shutil.rmtree(args.out / "dask-worker-space", ignore_errors=True)
    return 0
