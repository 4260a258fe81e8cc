"""``manta-drake calibrate CALIBRATION.yaml --out DIR`` (``manta_drake.cli`` dispatches
here)."""

from __future__ import annotations

from manta_drake.calibrate.fit import calibrate
from manta_drake.calibrate.loading import load_calibration
from manta_drake.cluster import add_cluster_arguments, cluster_client


def add_calibrate_parser(subparsers) -> None:
    """Adds ``manta-drake calibrate``."""
    p = subparsers.add_parser(
        "calibrate", help="fit hydrodynamic coefficients to measured runs on Dask "
                          "(Sim2Real; docs/sweeps.md)",
        description="Fits the calibration file's parameters (factors on hydrodynamic "
                    "coefficients) so simulated runs match the measured ones; writes "
                    "DIR/coefficients.yaml, DIR/calibration.png and DIR/calibration.json.")
    p.add_argument("calibration", help="calibration YAML file (docs/sweeps.md)")
    p.add_argument("--out", required=True, help="output folder")
    add_cluster_arguments(p)
    p.add_argument("--quiet", action="store_true", help="no progress bar")


def calibrate_main(args) -> int:
    """``manta-drake calibrate``: load (errors are one line), fit, print the result."""
    config = load_calibration(args.calibration)
    with cluster_client(args) as client:
        result = calibrate(config, args.out, client, progress=not args.quiet)
    print(f"\n  {config.name}: {result.message}")
    for name, x0, x, se in zip(result.names, result.x0, result.x, result.standard_error):
        print(f"  {name:<28} {x0:.4g} -> {x:.4g} (+- {se:.2g})")
    print(f"  cost {result.initial_cost:.4g} -> {result.cost:.4g}; {result.evaluations} points, "
          f"{result.simulations} simulations, {result.wall_time_s:.1f} s")
    print(f"  coefficients: {result.coefficients_file}")
    print(f"  figure:       {result.figure}")
    print(f"  history:      {result.history_file}")
    return 0
