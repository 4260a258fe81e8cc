"""The hull's damping and body lift identified from the CFD samples (the paper's section
2.3, Eq. 4), extended to the robot's own speeds by the laminar law (pure maths).

The samples are the hull patch's forces of ``models/cfd/robot_samples.csv`` (OpenFOAM, the
robot held at its zero pose, ``manta-drake study cfd``): the simulator carries the fins'
forces in their blade elements and the servo cases' in the links' damping, so the hull's
coefficients are fitted to the hull's own force, not to the whole robot's.

* **Surge**, Eq. (4) X = X_u u + X_u|u| u|u| by least squares on the relative residuals, on
  the zero-incidence CFD samples (0.4-1.2 m/s) and on the laminar law of
  ``hull_resistance.hull_surge_resistance`` at ``LOW_SPEEDS`` (0.02-0.3 m/s, where the robot
  moves and the paper has no samples), its form drag C_Dp the CFD hull patch's pressure drag.
* **Heave and sway**: a static case at incidence moves the body at (u, w), and its
  force is mostly lift: the CFD's heave force collapses on u w, not on w|w| (water.body_lift).
  Least squares of Z = Z_w|w| w|w| + Z_uw |u| w on the pitched samples and of
  Y = Y_v|v| v|v| + Y_uv |u| v on the yawed ones; no linear term (nothing in the samples
  resolves one: a bluff cross-flow at Re ~1e4 is quadratic).
* **Pitch and yaw moments at incidence**: M = M_uw u w, N = N_uv u v on the same samples.
* **Rotation** (K_p|p|, M_q|q|, N_r|r|): a static case has no angular rate;
  ``hull_resistance.cross_flow_rotational_damping`` with the sections' 2-D drag
  coefficients ``ROTATIONAL_DRAG_COEFFICIENTS``. No linear rotational terms.
"""

from __future__ import annotations

import csv
import dataclasses as dc
import math
import pathlib

import numpy as np

from manta_drake.model import MODELS_DIR
from manta_drake.model import hull_resistance as hr
from manta_drake.model.coefficients import fit_damping

CFD_SAMPLES = MODELS_DIR / "cfd" / "robot_samples.csv"
CFD_MESH = "coarse"  # the mesh the whole sweep ran on (docs/cfd.md: grid convergence)
CFD_DENSITY = 1000.0  # kg/m^3, the CFD cases' rhoInf (studies.cfd.case.RHO)
LOW_SPEEDS = (0.02, 0.05, 0.1, 0.15, 0.2, 0.3)  # m/s, the law's samples
REPORT_SPEEDS = (0.02, 0.1, 0.3)  # m/s, where the fit's error against the law is reported
# The hull's sections in the three rotations (Hoerner 1965, Fluid-Dynamic Drag, ch. 3,
# 2-D elliptic cylinders, subcritical): roll and pitch see the a x c and b x c ellipses
# broadside (thickness ratios 0.37, 0.58: C_D 1.6, 1.5, between the plate's 2.0 and the
# circle's 1.2); yaw sees the b x c ellipse along its major axis (C_D 0.6). Band +-30 %.
ROTATIONAL_DRAG_COEFFICIENTS = (1.6, 1.5, 0.6)
ROTATIONAL_BAND = 0.3


@dc.dataclass(frozen=True)
class Identification:
    """The fitted coefficients (Drake body axes surge, sway, heave, roll, pitch, yaw) and the
    numbers behind them."""

    linear: np.ndarray  # (6,) N s/m | N m s
    quadratic: np.ndarray  # (6,) N s^2/m^2 | N m s^2
    lift: np.ndarray  # (4,) Y_uv, Z_uw, M_uw, N_uv
    form_drag_coefficient: float  # the hull's C_Dp on its frontal area, from the CFD
    surge_errors: dict  # speed -> (fit - reference) / reference (the law; the CFD at its own)
    relative_rms: dict  # fit -> RMS of its relative residuals over its samples
    samples: dict  # fit -> number of samples


def sample_rows(path) -> list[dict]:
    """The rows of a CFD samples CSV (``manta-drake study cfd`` writes them under one comment
    line), as strings."""
    with pathlib.Path(path).open(newline="") as fh:
        return list(csv.DictReader(line for line in fh if not line.startswith("#")))


def read_cfd_samples(path=CFD_SAMPLES, mesh: str = CFD_MESH) -> list[dict]:
    """The rows of ``path`` on ``mesh`` that carry the hull patch's forces, as floats."""
    path = pathlib.Path(path)
    rows = sample_rows(path)
    if rows and "Fx_hull" not in rows[0]:
        raise ValueError(
            f"{path}: no Fx_hull column (the hull patch's forces); rerun "
            "manta-drake study cfd --tables-only on its cases"
        )
    keep = [r for r in rows if r["mesh"] == mesh and r.get("Fx_hull")]
    if not keep:
        raise ValueError(f"{path}: no samples with the hull patch's forces on mesh {mesh!r}")
    numeric = {
        k
        for k in keep[0]
        if k not in ("shape", "mesh", "openfoam", "date", "command", "stopped_by", "converged")
    }
    return [{k: (float(v) if k in numeric and v != "" else v) for k, v in r.items()} for r in keep]


def _hull_areas(semi_axes) -> tuple[float, float, float]:
    a, b, c = semi_axes
    return math.pi * b * c, hr.ellipsoid_surface_area(semi_axes), 2.0 * a


def surge_law(level, semi_axes, rho: float = CFD_DENSITY):
    """(C_Dp, law): the hull's form-drag coefficient from the level (zero-incidence) samples'
    pressure drag and the laminar law U -> X(U) with it."""
    frontal, wetted, length = _hull_areas(semi_axes)
    cdp = hr.hull_form_drag_coefficient(
        [-r["Fx_hull_pressure"] for r in level], [r["u"] for r in level], frontal, rho
    )
    return cdp, lambda u: hr.hull_surge_resistance(u, cdp, frontal, wetted, length, rho)


def _lstsq(columns, target):
    A = np.column_stack(columns)
    h, *_ = np.linalg.lstsq(A, target, rcond=None)
    return h, float(np.sqrt(np.mean(((A @ h - target) / target) ** 2)))


def identify(rows, semi_axes, rho: float = CFD_DENSITY) -> Identification:
    """The hull's coefficients from the CFD rows (``read_cfd_samples``); see the module."""
    level = [r for r in rows if r["pitch_deg"] == 0 and r["yaw_deg"] == 0]
    pitched = [r for r in rows if r["pitch_deg"] != 0 and r["yaw_deg"] == 0]
    yawed = [r for r in rows if r["yaw_deg"] != 0 and r["pitch_deg"] == 0]
    if len(level) < 2 or len(pitched) < 2 or len(yawed) < 2:
        raise ValueError(
            f"need >= 2 level, pitched and yawed samples; got {len(level)}, "
            f"{len(pitched)}, {len(yawed)}"
        )
    cdp, law = surge_law(level, semi_axes, rho)
    u_cfd = np.array([r["u"] for r in level])
    x_cfd = -np.array([r["Fx_hull"] for r in level])
    low = np.array(LOW_SPEEDS)
    u_all, x_all = np.concatenate([low, u_cfd]), np.concatenate([law(low), x_cfd])
    (x_u, x_uu), res = fit_damping(u_all, x_all, relative=True)
    col = {k: np.array([r[k] for r in pitched]) for k in ("u", "w", "Fz_hull", "My_hull")}
    (z_ww, z_uw), rms_z = _lstsq(
        [col["w"] * np.abs(col["w"]), np.abs(col["u"]) * col["w"]], -col["Fz_hull"]
    )
    (m_uw,), rms_m = _lstsq([col["u"] * col["w"]], -col["My_hull"])
    col = {k: np.array([r[k] for r in yawed]) for k in ("u", "v", "Fy_hull", "Mz_hull")}
    (y_vv, y_uv), rms_y = _lstsq(
        [col["v"] * np.abs(col["v"]), np.abs(col["u"]) * col["v"]], -col["Fy_hull"]
    )
    (n_uv,), rms_n = _lstsq([col["u"] * col["v"]], -col["Mz_hull"])
    rot = hr.cross_flow_rotational_damping(semi_axes, ROTATIONAL_DRAG_COEFFICIENTS, rho)
    fitted = lambda u: x_u * u + x_uu * u * np.abs(u)  # noqa: E731
    errors = {s: float((fitted(s) - law(s)) / law(s)) for s in REPORT_SPEEDS}
    errors.update({float(u): float((fitted(u) - x) / x) for u, x in zip(u_cfd, x_cfd)})
    return Identification(
        linear=np.array([x_u, 0.0, 0.0, 0.0, 0.0, 0.0]),
        quadratic=np.array([x_uu, y_vv, z_ww, *rot]),
        lift=np.array([y_uv, z_uw, m_uw, n_uv]),
        form_drag_coefficient=cdp,
        surge_errors=errors,
        relative_rms={
            "surge": float(np.sqrt(np.mean((res / x_all) ** 2))),
            "heave": rms_z,
            "sway": rms_y,
            "pitch moment": rms_m,
            "yaw moment": rms_n,
        },
        samples={"surge": len(u_all), "heave": len(pitched), "sway": len(yawed)},
    )
