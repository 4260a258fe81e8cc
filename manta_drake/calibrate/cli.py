"""``manta-drake calibrate CALIBRATION.yaml --out DIR`` (``manta_drake.cli`` dispatches
here).

Exit status: 0 when the coefficients are written; 1 when the fit ran but a simulation at the
fitted point did not run to its end (no coefficients file: ``calibration.json`` says why);
2 when the input is refused (one line naming the file or option and the field; nothing
simulated)."""

from __future__ import annotations

import sys

from manta_drake.calibrate.fit import OUTPUTS, calibrate, check_calibration_out
from manta_drake.calibrate.loading import load_calibration
from manta_drake.cluster import cluster_client
from manta_drake.sweep.options import add_many_run_options, check_many_run_options

# Exit status of a fit that gives no coefficients.
NOT_CALIBRATED = 1


def add_calibrate_parser(subparsers) -> None:
    """Adds ``manta-drake calibrate``."""
    p = subparsers.add_parser(
        "calibrate",
        help="fit hydrodynamic coefficients to measured runs on Dask (Sim2Real; docs/sweeps.md)",
        description="Fits the calibration file's parameters (factors on hydrodynamic "
        "coefficients) so simulated runs match the measured ones; writes "
        "DIR/coefficients.yaml, DIR/calibration.png and DIR/calibration.json. "
        "Exit status 1 when the fitted point's simulations did not all run to "
        "their end (no coefficients), 2 when the input is refused.",
    )
    p.add_argument("calibration", help="calibration YAML file (docs/sweeps.md)")
    add_many_run_options(p)


def calibrate_main(args) -> int:
    """``manta-drake calibrate``: check the options, load (errors are one line), fit, print
    the result; the exit status as the module says."""
    # Before the load and the fit: a fit never ends by finding it cannot write.
    check_many_run_options(args, OUTPUTS, [args.calibration])
    config = load_calibration(args.calibration)
    check_calibration_out(config, args.out, [args.calibration])
    with cluster_client(args) as client:
        result = calibrate(config, args.out, client, progress=not args.quiet)
    print(f"\n  {config.name}: {result.message}")
    for name, x0, x, se in zip(result.names, result.x0, result.x, result.standard_error):
        print(f"  {name:<28} {x0:.4g} -> {x:.4g} (+- {se:.2g})")
    print(
        f"  cost {result.initial_cost:.4g} -> {result.cost:.4g}; {result.evaluations} points, "
        f"{result.simulations} simulations, {result.wall_time_s:.1f} s"
    )
    print(f"  coefficients: {result.coefficients_file or 'none written'}")
    print(f"  figure:       {result.figure}")
    print(f"  history:      {result.history_file}")
    if result.coefficients_file is None:
        print(f"manta-drake: calibrate {config.name}: {result.message}", file=sys.stderr)
        return NOT_CALIBRATED
    return 0
