#!/usr/bin/env python3
"""Identifies the hull's damping coefficients by the least-squares fit of Eq. (4).

By default from the CFD samples (``models/cfd/robot_samples.csv``, the hull patch's forces;
``manta_drake.model.damping_identification``: surge with the laminar law at low speed, heave
and sway with the body lift, rotation from the cross-flow strips). With ``--csv`` from a
table of (axis, velocity, force) samples of your own (axes surge, sway, heave, roll, pitch,
yaw): force = d_lin * u + d_quad * u|u| per axis. Prints the coefficients and their
residuals and, with --write, writes them into the body's entries of the hydrodynamics YAML.

Usage: python scripts/identify_damping.py [--cfd models/cfd/robot_samples.csv]
                                          [--csv TABLE] [--yaml models/hydrodynamics.yaml]
                                          [--write]
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
            return line[len("# source:") :].strip()
    return "source unstated"


def identify_cfd(path) -> tuple[dict, str]:
    """The body's entries (name -> values) and their source from the CFD samples."""
    from manta_drake.model import damping_identification as di
    from manta_drake.model.robot_params import DEFAULT_ROBOT

    fit = di.identify(di.read_cfd_samples(path), DEFAULT_ROBOT.body_semi_axes)
    print(
        f"hull form drag C_Dp {fit.form_drag_coefficient:.4f}; surge fit error: "
        + ", ".join(f"{u:g} m/s {e:+.1%}" for u, e in fit.surge_errors.items())
    )
    print(
        "relative RMS residuals: " + ", ".join(f"{k} {v:.1%}" for k, v in fit.relative_rms.items())
    )
    for name, values in (("linear", fit.linear), ("quadratic", fit.quadratic)):
        print(f"{name:9s} " + " ".join(f"{a} {x:.4g}" for a, x in zip(AXES, values)))
    print("body lift Y_uv {:.4g} Z_uw {:.4g} M_uw {:.4g} N_uv {:.4g}".format(*fit.lift))
    source = (
        f"identified by scripts/identify_damping.py from {pathlib.Path(path).name} "
        f"(OpenFOAM, the hull patch's forces on the {di.CFD_MESH} mesh, docs/cfd.md): "
        "surge Eq. (4) on the level samples and the laminar law below 0.4 m/s "
        f"(C_Dp {fit.form_drag_coefficient:.4f}, Blasius friction), relative RMS "
        f"{fit.relative_rms['surge']:.1%}; heave and sway Z_w|w|, Y_v|v| with the body "
        f"lift on the pitched and yawed samples (RMS {fit.relative_rms['heave']:.1%}, "
        f"{fit.relative_rms['sway']:.1%}); roll, pitch, yaw from cross-flow strips, "
        f"2-D C_D {di.ROTATIONAL_DRAG_COEFFICIENTS} (Hoerner 1965) "
        f"+-{100 * di.ROTATIONAL_BAND:.0f} %"
    )
    lift_source = (
        f"identified by scripts/identify_damping.py from {pathlib.Path(path).name}: "
        "least squares on the hull patch's pitched and yawed samples (relative RMS "
        f"M_uw {fit.relative_rms['pitch moment']:.1%}, N_uv "
        f"{fit.relative_rms['yaw moment']:.1%}; Y_uv and Z_uw with the heave and "
        "sway fits)"
    )
    return (
        {
            "linear_damping": (fit.linear, source),
            "quadratic_damping": (fit.quadratic, source),
            "body_lift": (fit.lift, lift_source),
        },
        source,
    )


def identify_table(path) -> dict:
    """The body's entries from a table of (axis, velocity, force) samples."""
    coeffs, rms = identify(read_samples(path))
    print(f"{'axis':6s} {'d_lin':>10s} {'d_quad':>10s} {'rms resid':>10s}")
    for axis in AXES:
        lin, quad = coeffs[axis]
        print(f"{axis:6s} {lin:10.4g} {quad:10.4g} {rms[axis]:10.3g}")
    source = (
        f"least-squares fit of Eq. (4) to {pathlib.Path(path).name} "
        f"({table_source(path)}) by scripts/identify_damping.py; RMS residuals "
        + ", ".join(f"{a} {rms[a]:.3g}" for a in AXES)
    )
    return {
        "linear_damping": ([coeffs[a][0] for a in AXES], source),
        "quadratic_damping": ([coeffs[a][1] for a in AXES], source),
    }


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--cfd",
        default=MODELS / "cfd" / "robot_samples.csv",
        help="the CFD samples (default models/cfd/robot_samples.csv)",
    )
    parser.add_argument("--csv", help="a table of axis,velocity,force samples instead")
    parser.add_argument("--yaml", default=MODELS / "hydrodynamics.yaml")
    parser.add_argument("--write", action="store_true", help="write the fit into --yaml")
    args = parser.parse_args()
    entries = identify_table(args.csv) if args.csv else identify_cfd(args.cfd)[0]
    if args.write:
        path = pathlib.Path(args.yaml)
        text = path.read_text()
        header = "".join(line for line in text.splitlines(True) if line.startswith("#"))
        data = yaml.safe_load(text)
        for name, (values, source) in entries.items():
            data["body"][name] = {"value": [round(float(x), 5) for x in values], "source": source}
        path.write_text(header + yaml.safe_dump(data, sort_keys=False, width=100))
        print(f"wrote the fit into {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
