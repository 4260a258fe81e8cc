"""How large a plant step the water's coupling stands: every shipped locomotion scenario and
float_sink at plant (and integrator) steps from 1 ms to the scenario's 10 ms limit, printed as
a table (docs/design.md, section 4).

    .venv/bin/python scripts/time_step_scan.py [--duration S] [--steps 0.001 0.002 ...]
        [--fin-model foil|cross_flow]

A run is *stable* when it ends ``ok`` with finite states, the hull's angular rate stays under
``MAX_RATE`` and no joint moves faster than ``MAX_JOINT_SPEED`` (both far above what any stable
run here reaches, far below what a diverging one does). For each run it prints the status,
the largest hull angular rate and joint speed, and the forward speed u against the 1 ms run's.
"""

from __future__ import annotations

import argparse
import math
import tempfile

import numpy as np

SCENARIOS = (
    "locomotion_swim",
    "locomotion_trot",
    "locomotion_walk",
    "locomotion_crab",
    "locomotion_turning",
    "float_sink",
)
STEPS = (0.001, 0.002, 0.005, 0.01)
MAX_RATE = 20.0  # rad/s, hull
MAX_JOINT_SPEED = 30.0  # rad/s


def run_one(name: str, dt: float, duration: float, fin_model: str) -> dict:
    from manta_drake.scenario import load_scenario
    from manta_drake.simulate import run

    s = load_scenario(
        name,
        overrides={
            "visualization.meshcat": False,
            "duration": duration,
            "water.fin_model": fin_model,
        },
    )
    s.time_step = s.simulator.max_step_size = dt
    s.log_period = max(s.log_period, dt)
    s.steady_after = min(s.steady_after, duration / 2)
    with tempfile.TemporaryDirectory() as folder:
        r = run(s.validate(), folder, progress=False, write_outputs=False)
    log, m = r.log, r.metrics
    finite = all(np.all(np.isfinite(log[k])) for k in ("body_xyz", "joint_angles"))
    rate = float(np.abs(log["body_w_world"]).max()) if finite else math.inf
    joint = float(np.abs(log["joint_velocities"]).max()) if finite else math.inf
    u = (m.get("mean_velocity_body") or [math.nan])[0]
    stable = m["status"] == "ok" and finite and rate < MAX_RATE and joint < MAX_JOINT_SPEED
    return {"status": m["status"], "stable": stable, "rate": rate, "joint": joint, "u": u}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--duration", type=float, default=6.0)
    parser.add_argument("--steps", type=float, nargs="+", default=list(STEPS))
    parser.add_argument("--fin-model", default="foil", choices=("foil", "cross_flow"))
    args = parser.parse_args()
    print(f"fin model {args.fin_model}, {args.duration:g} s runs")
    print(
        f"{'scenario':20s} {'step ms':>7} {'status':>7} {'stable':>6} {'hull rad/s':>10} "
        f"{'joint rad/s':>11} {'u m/s':>7}"
    )
    for name in SCENARIOS:
        for dt in args.steps:
            r = run_one(name, dt, args.duration, args.fin_model)
            print(
                f"{name:20s} {dt * 1e3:7.1f} {r['status']:>7} {str(r['stable']):>6} "
                f"{r['rate']:10.2f} {r['joint']:11.2f} {r['u']:7.3f}",
                flush=True,
            )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
