#!/usr/bin/env python3
"""Identifies the hull's damping coefficients by the least-squares fit of Eq. (4).

Reads a CSV of (axis, velocity, force) samples (e.g. CFD output; axes surge, sway, heave,
roll, pitch, yaw), fits force = d_lin * u + d_quad * u|u| per axis, prints the
coefficients and their residuals, and (with --write) writes them into the body's
linear_damping / quadratic_damping entries of the hydrodynamics YAML.

Usage: python scripts/identify_damping.py [--csv models/damping_samples.csv]
                                          [--yaml models/hydrodynamics.yaml] [--write]
"""

import argparse
import pathlib
import sys

import numpy as np
import yaml

from manta_drake.model import MODELS_DIR as MODELS
from manta_drake.model.coefficients import AXES, fit_damping


def read_samples(path) -> dict:
    """axis -> (velocities, forces) from the CSV; '#' lines are comments."""
    samples = {}
    for n, line in enumerate(pathlib.Path(path).read_text().splitlines(), start=1):
        line = line.strip()
        if not line or line.startswith("#"):
            continue
        parts = line.split(",")
        if len(parts) != 3:
            raise ValueError(f"{path}:{n}: expected 'axis,velocity,force', got {line!r}")
        axis = parts[0].strip()
        if axis not in AXES:
            raise ValueError(f"{path}:{n}: unknown axis {axis!r}; expected one of {AXES}")
        u, f = float(parts[1]), float(parts[2])
        samples.setdefault(axis, ([], []))
        samples[axis][0].append(u)
        samples[axis][1].append(f)
    return {k: (np.array(u), np.array(f)) for k, (u, f) in samples.items()}


def identify(samples: dict) -> tuple[dict, dict]:
    """axis -> [d_lin, d_quad], axis -> RMS residual."""
    coeffs, rms = {}, {}
    for axis in AXES:
        if axis not in samples:
            raise ValueError(f"no samples for axis {axis}")
        h, res = fit_damping(*samples[axis])
        coeffs[axis], rms[axis] = h, float(np.sqrt(np.mean(res**2)))
    return coeffs, rms


def table_source(path) -> str:
    """What the table's ``# source:`` comment says it is ("unstated" without one)."""
    for line in pathlib.Path(path).read_text().splitlines():
        if line.startswith("# source:"):
            return line[len("# source:"):].strip()
    return "source unstated"


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--csv", default=MODELS / "damping_samples.csv")
    parser.add_argument("--yaml", default=MODELS / "hydrodynamics.yaml")
    parser.add_argument("--write", action="store_true", help="write the fit into --yaml")
    args = parser.parse_args()
    coeffs, rms = identify(read_samples(args.csv))
    print(f"{'axis':6s} {'d_lin':>10s} {'d_quad':>10s} {'rms resid':>10s}")
    for axis in AXES:
        lin, quad = coeffs[axis]
        print(f"{axis:6s} {lin:10.4g} {quad:10.4g} {rms[axis]:10.3g}")
    if args.write:
        path = pathlib.Path(args.yaml)
        text = path.read_text()
        header = "".join(line for line in text.splitlines(True) if line.startswith("#"))
        data = yaml.safe_load(text)
        source = (f"least-squares fit of Eq. (4) to {pathlib.Path(args.csv).name} "
                  f"({table_source(args.csv)}) by scripts/identify_damping.py; RMS residuals " +
                  ", ".join(f"{a} {rms[a]:.3g}" for a in AXES))
        data["body"]["linear_damping"] = {
            "value": [round(float(coeffs[a][0]), 5) for a in AXES], "source": source}
        data["body"]["quadratic_damping"] = {
            "value": [round(float(coeffs[a][1]), 5) for a in AXES], "source": source}
        path.write_text(header + yaml.safe_dump(data, sort_keys=False, width=100))
        print(f"wrote the fit into {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
