"""Makes the synthetic "measured" data set of a calibration file.

Every experiment of the calibration file that names a ``measured`` CSV is simulated with the
coefficients scaled by the *truth* (a known perturbation, e.g. hull damping x1.25), sampled
every ``--period`` s, and Gaussian noise is added (seeded). The CSVs and ``truth.yaml`` (what
the calibration should recover) go where the calibration file expects them, so that

    python scripts/make_calibration_data.py
    manta-drake calibrate diagrams/sweeps/calibration.yaml --out out/calibration

checks that the Sim2Real loop recovers coefficients it did not see.

Usage:
    python scripts/make_calibration_data.py [--config diagrams/sweeps/calibration.yaml]
        [--truth body.linear_damping=1.25 --truth body.quadratic_damping=1.25]
        [--noise-position 0.002] [--noise-yaw-deg 0.2] [--seed 11] [--period 0.1]
"""

import argparse
import pathlib
import sys
import time

import yaml

from manta_drake.calibrate import Sigma, load_calibration, synthesize_measurements, write_measured
from manta_drake.scenario import coefficient_names

ROOT = pathlib.Path(__file__).resolve().parent.parent
DEFAULT_TRUTH = ("body.linear_damping=1.25", "body.quadratic_damping=1.25")


def parse_truth(items) -> dict[str, float]:
    """``NAME=FACTOR`` items as {coefficient name: factor}; names are checked."""
    truth = {}
    for item in items:
        name, sep, value = item.partition("=")
        if not sep or name not in coefficient_names():
            raise SystemExit(
                f"--truth {item}: expected COEFFICIENT=FACTOR with a coefficient "
                f"of {', '.join(coefficient_names())}"
            )
        truth[name] = float(value)
    return truth


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--config", default=str(ROOT / "diagrams/sweeps/calibration.yaml"))
    parser.add_argument(
        "--truth",
        action="append",
        metavar="COEFFICIENT=FACTOR",
        help=f"the known perturbation (default: {' '.join(DEFAULT_TRUTH)})",
    )
    parser.add_argument("--noise-position", type=float, default=0.002, help="m (std)")
    parser.add_argument("--noise-yaw-deg", type=float, default=0.2, help="deg (std)")
    parser.add_argument("--seed", type=int, default=11, help="seed of the noise")
    parser.add_argument("--period", type=float, default=0.1, help="sample period [s]")
    args = parser.parse_args(argv)

    config = load_calibration(args.config, require_data=False)
    truth = parse_truth(args.truth or DEFAULT_TRUTH)
    noise = Sigma(position_m=args.noise_position, yaw_deg=args.noise_yaw_deg)
    start = time.perf_counter()
    data = synthesize_measurements(config, truth, noise, args.seed, args.period)
    written = []
    for e in config.experiments:
        if e.name in data:
            path = config.folder / e.measured
            write_measured(
                path,
                data[e.name],
                comment=(
                    f"synthetic measurement for {config.name}/{e.name}: {e.scenario} with "
                    f"{e.overrides}, coefficients scaled by {truth},\nnoise position "
                    f"{args.noise_position} m, yaw {args.noise_yaw_deg} deg (seed {args.seed}); "
                    "made by scripts/make_calibration_data.py"
                ),
            )
            written.append(path)
    truth_file = (
        (config.folder / config.experiments[0].measured).parent / "truth.yaml" if written else None
    )
    if truth_file is not None:
        truth_file.write_text(
            "# The known perturbation behind the synthetic data "
            "(scripts/make_calibration_data.py)\n"
            + yaml.safe_dump(
                {
                    "calibration": pathlib.Path(args.config).name,
                    "coefficient_scales": truth,
                    "noise": {"position_m": args.noise_position, "yaw_deg": args.noise_yaw_deg},
                    "seed": args.seed,
                    "period_s": args.period,
                },
                sort_keys=False,
            )
        )
    for path in written + ([truth_file] if truth_file else []):
        print(f"wrote {path}")
    print(f"({time.perf_counter() - start:.1f} s)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
