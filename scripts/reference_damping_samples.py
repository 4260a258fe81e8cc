#!/usr/bin/env python3
"""Writes models/damping_samples.csv: a velocity-force table for scripts/identify_damping.py.

The paper identifies its damping from Autodesk CFD runs (0.4-1.2 m/s, +-30 deg) that are
not published. This table stands in for them: forces from textbook drag coefficients
(Hoerner, Fluid-Dynamic Drag, 1965) on the hull's projected areas, strip-integrated for
the rotations, plus a small linear (skin-friction) part, with 3 % seeded noise. Replace
the CSV with your own CFD or tow-tank table and re-run identify_damping.py.

Usage: python scripts/reference_damping_samples.py [--out models/damping_samples.csv]
"""

import argparse
import pathlib
import sys

import numpy as np

from manta_drake.model import MODELS_DIR
from manta_drake.model.robot_params import DEFAULT_ROBOT

RHO = 1000.0
a, b, c = DEFAULT_ROBOT.body_semi_axes
# axis: (linear coefficient, drag coefficient C_D, area or strip moment, speed range)
REFERENCE = {
    "surge": (1.5, 0.35, np.pi * b * c, (0.4, 1.2)),        # blunt flat ellipsoid, frontal
    "sway": (2.0, 0.50, np.pi * a * c, (0.2, 0.8)),         # side area
    "heave": (4.0, 1.10, np.pi * a * b, (0.1, 0.6)),        # planform, disc-like
    # Rotations: M = 1/2 rho C_D int w(s) |s|^3 ds q|q|; for an ellipse of half-length L and
    # half-width W, int 2W sqrt(1 - s^2/L^2) |s|^3 ds = 8 W L^4 / 15.
    "roll": (0.05, 1.10, 8 * a * b**4 / 15, (0.5, 3.0)),
    "pitch": (0.10, 1.10, 8 * b * a**4 / 15, (0.5, 3.0)),
    "yaw": (0.05, 0.50, 8 * c * a**4 / 15, (0.5, 3.0)),
}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default=MODELS_DIR
                        / "damping_samples.csv")
    parser.add_argument("--seed", type=int, default=4)
    args = parser.parse_args()
    rng = np.random.default_rng(args.seed)
    lines = ["# axis,velocity,force  (velocity m/s or rad/s; resisting force N or N m, sign of velocity)",
             "# source: synthetic, not measured: scripts/reference_damping_samples.py (textbook "
             "drag, Hoerner 1965, plus a chosen linear term; 3 % noise)"]
    for axis, (lin, cd, area, (lo, hi)) in REFERENCE.items():
        quad = 0.5 * RHO * cd * area
        for u in np.concatenate([-np.linspace(lo, hi, 9), np.linspace(lo, hi, 9)]):
            force = (lin + quad * abs(u)) * u * (1 + 0.03 * rng.standard_normal())
            lines.append(f"{axis},{u:.4f},{force:.6g}")
    pathlib.Path(args.out).write_text("\n".join(lines) + "\n")
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
