"""The CFD study of the hull's damping by the paper's method (section 2.3): OpenFOAM cases.

Runs the cases (validation: the sphere at Re 1e5 and the hull alone; robot: three meshes at
0.4 m/s for grid convergence, then 0.4/0.8/1.2 m/s x pitch -30..30 deg and yaw 15, 30 deg on
one mesh), each in its own folder of ``--runs DIR`` (default ``out/cfd``) and skipped when its
result exists, on a Dask local cluster (one OpenFOAM run per worker), and writes the samples of
every finished case under ``--runs`` to ``--csv-dir`` (default the checkout's ``models/cfd/``:
``robot_samples.csv``, ``validation_samples.csv``), a progress page and the results block of
the report ``OUT/cfd.md`` (``--out DIR``, default the checkout's ``docs/``).
"""

from __future__ import annotations

import csv
import datetime
import json
import os
import pathlib
import shlex
import sys
import time

from manta_drake.config_io import ScenarioError
from manta_drake.studies import REPO
from manta_drake.studies.options import StudyParser

SPEEDS = (0.4, 0.8, 1.2)
PITCHES = (-30.0, -15.0, 0.0, 15.0, 30.0)
YAWS = (15.0, 30.0)  # yaw is symmetric: the paper's -30..30 from the positive half
CASE_SETS = ("validation", "robot", "level", "sweep", "all")
MESH_CHOICES = ("coarse", "medium", "fine")
MAX_WORKERS = 2  # each case is one single-threaded OpenFOAM run
CSV_DIR = REPO / "models" / "cfd"  # the checkout's committed samples
PAGE = "cfd.md"  # the report in the --out folder
PAGE_TITLE = "The hull's damping from CFD (the paper's section 2.3)"
DEFAULT_RUNS = "out/cfd"
BEGIN, END = "<!-- cfd results: begin (manta-drake study cfd) -->", "<!-- cfd results: end -->"
# The validation sphere's reference: the standard drag curve of a smooth sphere, subcritical
# at Re = 1e5 (laminar separation ahead of the equator): C_D = 0.47 (Schlichting,
# Boundary-Layer Theory, Fig. 1.21 / the standard curve; Achenbach 1972, J. Fluid Mech. 54,
# 565-575, measured 0.47-0.50 at 1e5).
SPHERE_CD_REFERENCE = 0.47
# The hull alone at 0.4 m/s, k-epsilon, same kind of mesh (shared/reference/hydro_refs.md
# section 3): level 3 (41 k cells) 0.108 N, level 4 (75 k cells) 0.129 N.
HULL_REFERENCE_N = {"medium": (0.108, 41_000), "fine": (0.129, 75_000)}
# ``--tables-only --runs -``: no cases folder, the page from the samples in --csv-dir alone.
TABLES_FROM_SAMPLES = "-"


class CfdError(ScenarioError):
    """A study option that cannot work; one line says why (exit status 2)."""


def validation_cases():
    from manta_drake.studies.cfd.case import SPHERE_SPEED, CaseSpec

    return [CaseSpec("sphere", SPHERE_SPEED, mesh=m) for m in ("coarse", "medium", "fine")] + [
        CaseSpec("hull", 0.4, mesh=m) for m in ("medium", "fine")
    ]


def robot_cases(mesh: str = "medium"):
    """Grid convergence first (0.4 m/s, zero incidence, three meshes), then the sweep on
    ``mesh``: each speed at zero incidence, pitch, then yaw."""
    from manta_drake.studies.cfd.case import CaseSpec

    cases = [CaseSpec("robot", 0.4, mesh=m) for m in MESH_CHOICES]
    sweep = [CaseSpec("robot", u, pitch_deg=p, mesh=mesh) for p in PITCHES for u in SPEEDS]
    sweep += [CaseSpec("robot", u, yaw_deg=y, mesh=mesh) for y in YAWS for u in SPEEDS]
    # Level first, then by angle (pitch and yaw at 15 deg before either at 30 deg), so a
    # sweep stopped part-way holds every axis.
    sweep.sort(
        key=lambda c: (abs(c.pitch_deg) + abs(c.yaw_deg), c.yaw_deg != 0, c.speed, c.pitch_deg)
    )
    names = {c.name for c in cases}
    return cases + [c for c in sweep if c.name not in names]


def cases_for(which: str, mesh: str):
    """The cases of a set: ``validation``, ``robot`` (grid convergence and the sweep),
    ``level`` (the robot at zero incidence at each speed on ``mesh``), ``sweep`` (the
    robot's pitched and yawed cases on ``mesh`` only) or ``all``."""
    if which == "validation":
        return validation_cases()
    if which == "robot":
        return robot_cases(mesh)
    if which == "level":
        return [c for c in robot_cases(mesh) if c.mesh == mesh and not (c.pitch_deg or c.yaw_deg)]
    if which == "sweep":
        return [c for c in robot_cases(mesh) if c.pitch_deg or c.yaw_deg]
    return validation_cases() + robot_cases(mesh)


# --- samples -----------------------------------------------------------------------------------

CSV_COLUMNS = (
    "speed",
    "pitch_deg",
    "yaw_deg",
    "u",
    "v",
    "w",
    "Fx",
    "Fy",
    "Fz",
    "Mx",
    "My",
    "Mz",
    "Fx_pressure",
    "Fy_pressure",
    "Fz_pressure",
    "Fx_viscous",
    "Fy_viscous",
    "Fz_viscous",
    "Mx_pressure",
    "My_pressure",
    "Mz_pressure",
    "Mx_viscous",
    "My_viscous",
    "Mz_viscous",
    "drag",
    "drag_tail_mean",
    "drag_tail_spread",
    "cd",
    "a_ref",
    "shape",
    "mesh",
    "cells",
    "yplus_avg",
    "yplus_max",
    "res_p",
    "res_Ux",
    "res_Uy",
    "res_Uz",
    "res_k",
    "res_epsilon",
    "iterations",
    "converged",
    "wall_s",
    "cpu_s",
    "openfoam",
    "date",
    "command",
    # The means over the last 10 % of the iterations (at least 20): the better estimate where
    # a case ends at the iteration cap with its forces still wandering (drag_tail_spread).
    "Fx_mean",
    "Fy_mean",
    "Fz_mean",
    "Mx_mean",
    "My_mean",
    "Mz_mean",
    "stopped_by",
    # The same means on the hull's patch alone and on the four fins' (blank for cases run
    # before the parts were written apart).
    *(f"{q}{a}_{part}" for part in ("hull", "fins") for q in "FM" for a in "xyz"),
    # The pressure part of each part's Fx (its viscous part is Fx_<part> - this).
    "Fx_hull_pressure",
    "Fx_fins_pressure",
)


def sample_row(result: dict) -> dict:
    """One CSV row of a finished case: body-frame forces (N) and moments about the CG (N m)
    on the whole body (final iteration), x forward, y left, z up."""
    f, m = result["final"]["force"], result["final"]["moment"]
    spec = result["spec"]
    row = {"speed": spec["speed"], "pitch_deg": spec["pitch_deg"], "yaw_deg": spec["yaw_deg"]}
    row.update(dict(zip("uvw", (round(x, 6) for x in result["body_velocity"]))))
    for comp, name in ((f["total"], "F"), (m["total"], "M")):
        row.update({f"{name}{a}": comp[i] for i, a in enumerate("xyz")})
    for part in ("pressure", "viscous"):
        row.update({f"F{a}_{part}": f[part][i] for i, a in enumerate("xyz")})
        row.update({f"M{a}_{part}": m[part][i] for i, a in enumerate("xyz")})
    res = result.get("residuals", {})
    row.update(
        {
            "drag": result["drag_n"],
            "drag_tail_mean": result["drag_tail_mean_n"],
            "drag_tail_spread": result["drag_tail_spread"],
            "cd": result["cd"],
            "a_ref": result["a_ref_m2"],
            "shape": spec["shape"],
            "mesh": spec["mesh"],
            "cells": result["cells"],
            "yplus_avg": result["yplus_avg"],
            "yplus_max": result["yplus_max"],
            **{f"res_{k}": res.get(k, "") for k in ("p", "Ux", "Uy", "Uz", "k", "epsilon")},
            "iterations": result["iterations"],
            "converged": result["converged"],
            "wall_s": result["wall_s"],
            "cpu_s": result["cpu_s"],
            "openfoam": result["openfoam"],
            "date": result["finished"][:10],
            "command": result.get("command", ""),
        }
    )
    fm, mm = result["tail_mean"]["force"]["total"], result["tail_mean"]["moment"]["total"]
    row.update({f"F{a}_mean": fm[i] for i, a in enumerate("xyz")})
    row.update({f"M{a}_mean": mm[i] for i, a in enumerate("xyz")})
    for part, fm_part in result.get("parts", {}).items():
        for q, key in (("F", "force"), ("M", "moment")):
            row.update({f"{q}{a}_{part}": fm_part[key][i] for i, a in enumerate("xyz")})
        if "pressure_force" in fm_part:
            row[f"Fx_{part}_pressure"] = fm_part["pressure_force"][0]
    row["stopped_by"] = result.get(
        "stopped_by", "residuals" if result["converged"] else "iteration cap"
    )
    for k, v in row.items():
        if isinstance(v, float):
            row[k] = float(f"{v:.6g}")
    return row


def finished_results(out: pathlib.Path) -> list[dict]:
    results = []
    for path in sorted(pathlib.Path(out).glob("*/result.json")):
        try:
            results.append(json.loads(path.read_text()))
        except (OSError, ValueError):
            continue
    return results


def _sample_key(row: dict) -> tuple:
    return (
        row["shape"],
        row["mesh"],
        float(row["speed"]),
        float(row["pitch_deg"]),
        float(row["yaw_deg"]),
    )


def read_samples(path: pathlib.Path) -> list[dict]:
    """The rows of a samples CSV (its comment line skipped), as strings; [] if absent."""
    from manta_drake.model.damping_identification import sample_rows

    return sample_rows(path) if path.exists() else []


def write_samples(out: pathlib.Path, csv_dir: pathlib.Path) -> dict[str, int]:
    """Writes the ok cases under ``out`` to ``csv_dir``, robot and validation samples, keeping
    the rows already there for cases not under ``out`` (a case run here replaces its row);
    sorted by shape, mesh, speed, pitch, yaw. Returns the rows per file."""
    results = [r for r in finished_results(out) if r.get("status") == "ok"]
    order = {"coarse": 0, "medium": 1, "fine": 2, "tiny": -1}
    files = {
        "robot_samples.csv": [sample_row(r) for r in results if r["spec"]["shape"] == "robot"],
        "validation_samples.csv": [sample_row(r) for r in results if r["spec"]["shape"] != "robot"],
    }
    counts = {}
    csv_dir.mkdir(parents=True, exist_ok=True)
    for name, rows in files.items():
        path = csv_dir / name
        new = {_sample_key(r) for r in rows}
        rows += [r for r in read_samples(path) if _sample_key(r) not in new]
        if not rows:
            continue
        rows.sort(
            key=lambda r: (
                r["shape"],
                order.get(r["mesh"], 9),
                float(r["speed"]),
                float(r["pitch_deg"]),
                float(r["yaw_deg"]),
            )
        )
        with open(path, "w", newline="") as fh:
            fh.write(
                "# CFD samples of manta-drake study cfd (docs/cfd.md): OpenFOAM simpleFoam, "
                "standard k-epsilon, standard wall functions; forces in N and moments "
                "about the CG in N m on the whole body, Drake body frame (x forward, y "
                "left, z up); u, v, w the body's velocity through the water in that "
                "frame; pitch nose up, yaw nose to starboard (NED senses); Fx..Mz at the last "
                "iteration, Fx_mean..Mz_mean over the last 10 % of the iterations\n"
            )
            writer = csv.DictWriter(fh, fieldnames=CSV_COLUMNS)
            writer.writeheader()
            for r in rows:
                writer.writerow(r)
        counts[name] = len(rows)
    return counts


def _grid_convergence(drags):
    """Observed order and the fine mesh's grid convergence index (Roache; Celik et al. 2008,
    safety factor 1.25) from drags on the coarse, medium and fine meshes (refinement ratio
    sqrt 2); None where the changes are not monotone."""
    import math

    f3, f2, f1 = drags  # coarse, medium, fine
    r = math.sqrt(2.0)
    e32, e21 = f3 - f2, f2 - f1
    if e21 == 0 or e32 == 0 or (e32 / e21) <= 0:
        return None, None
    p = abs(math.log(abs(e32 / e21))) / math.log(r)
    gci = 1.25 * abs(e21 / f1) / (r**p - 1.0)
    return p, gci


def _num(row: dict, key: str) -> float:
    return float(row[key])


def _case_name(row: dict) -> str:
    """The case a sample row comes from (``CaseSpec.name``)."""
    from manta_drake.studies.cfd.case import CaseSpec

    return CaseSpec(
        row["shape"],
        _num(row, "speed"),
        pitch_deg=_num(row, "pitch_deg"),
        yaw_deg=_num(row, "yaw_deg"),
        mesh=row["mesh"],
    ).name


def _iterations(row: dict) -> str:
    how = row.get("stopped_by") or (
        "residuals" if str(row["converged"]) == "True" else "iteration cap"
    )
    return f"{int(float(row['iterations']))}{'' if how == 'residuals' else f' ({how})'}"


def _drag_parts(row: dict) -> str:
    """Pressure / viscous drag [N] of a case at zero incidence (the body moves along +x)."""
    return f"{-_num(row, 'Fx_pressure'):.4f} / {-_num(row, 'Fx_viscous'):.4f}"


def sweep_mesh_of(rows) -> str:
    """The mesh the robot's pitched and yawed samples were run on (the most common one)."""
    meshes = [
        r["mesh"]
        for r in rows
        if r["shape"] == "robot" and (_num(r, "pitch_deg") or _num(r, "yaw_deg"))
    ]
    return max(MESH_CHOICES, key=meshes.count) if meshes else "medium"


def report_block(rows: list[dict]) -> str:
    """The results of docs/cfd.md (between its markers) from the samples: the rows of
    ``models/cfd/robot_samples.csv`` and ``validation_samples.csv`` (or ``sample_row`` of
    finished cases), the sweep's mesh read from them."""
    mesh = sweep_mesh_of(rows)
    by_name = {_case_name(r): r for r in rows}
    planned = [c.name for c in cases_for("all", mesh)]
    extra = [n for n in by_name if n not in planned]
    lines = [
        BEGIN,
        "",
        f"Cases finished: {sum(n in by_name for n in planned)} of "
        f"{len(planned)} (the sweep on the {mesh} mesh), and {len(extra)} more on "
        "another mesh.",
        "",
    ]
    lines += _validation_lines(by_name) + _grid_lines(by_name) + _sweep_lines(rows)
    left = [n for n in planned if n not in by_name]
    lines += [
        "",
        f"Not run yet ({len(left)}): " + (", ".join(left) if left else "none") + ".",
        "",
        END,
    ]
    return "\n".join(lines)


def _validation_lines(by_name: dict) -> list[str]:
    from manta_drake.studies.cfd.case import SPHERE_SPEED, CaseSpec

    lines = [
        "### Validation: sphere at Re = 1e5",
        "",
        f"Reference C_D = {SPHERE_CD_REFERENCE} (subcritical, standard drag curve).",
        "",
        "| mesh | cells | C_D | C_D / 0.47 | pressure / viscous (N) | y+ avg / max | "
        "iterations | wall (s) | CPU (s) |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for mesh in ("coarse", "medium", "fine"):
        r = by_name.get(CaseSpec("sphere", SPHERE_SPEED, mesh=mesh).name)
        if r:
            cd = _num(r, "cd")
            lines.append(
                f"| {mesh} | {r['cells']} | {cd:.3f} | "
                f"{cd / SPHERE_CD_REFERENCE:.2f} | {_drag_parts(r)} | "
                f"{_num(r, 'yplus_avg'):.0f} / {_num(r, 'yplus_max'):.0f} | "
                f"{_iterations(r)} | {r['wall_s']} | {r['cpu_s']} |"
            )
    lines += [
        "",
        "### Pipeline check: the hull alone at 0.4 m/s",
        "",
        "| mesh | cells | drag (N) | hydro_refs.md (N, cells) | pressure / viscous (N) | "
        "y+ avg / max | iterations | wall (s) |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for mesh, (ref, ref_cells) in HULL_REFERENCE_N.items():
        r = by_name.get(CaseSpec("hull", 0.4, mesh=mesh).name)
        if r:
            lines.append(
                f"| {mesh} | {r['cells']} | {_num(r, 'drag'):.4f} | {ref} "
                f"({ref_cells}) | {_drag_parts(r)} | {_num(r, 'yplus_avg'):.1f} / "
                f"{_num(r, 'yplus_max'):.0f} | {_iterations(r)} | {r['wall_s']} |"
            )
    return lines


def _grid_lines(by_name: dict) -> list[str]:
    from manta_drake.studies.cfd.case import CaseSpec

    lines = [
        "",
        "### Robot: grid convergence at 0.4 m/s, zero incidence",
        "",
        "| mesh | base cell (m) | cells | drag (N) | change from the previous mesh | "
        "pressure / viscous (N) | y+ avg / max | iterations | wall (s) | CPU (s) |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    drags, prev = [], None
    for mesh in MESH_CHOICES:
        case = CaseSpec("robot", 0.4, mesh=mesh)
        r = by_name.get(case.name)
        if not r:
            continue
        drag = _num(r, "drag")
        change = f"{100 * (drag / prev - 1):+.1f} %" if prev else ""
        prev = drag
        drags.append(drag)
        lines.append(
            f"| {mesh} | {case.mesh_spec.base_cell:.4g} | {r['cells']} | "
            f"{drag:.4f} | {change} | {_drag_parts(r)} | "
            f"{_num(r, 'yplus_avg'):.1f} / {_num(r, 'yplus_max'):.0f} | "
            f"{_iterations(r)} | {r['wall_s']} | {r['cpu_s']} |"
        )
    if len(drags) == 3:
        p, gci = _grid_convergence(drags)
        lines += [
            "",
            (
                f"Observed order {p:.2f}, fine-mesh GCI {100 * gci:.1f} % (Celik et al. "
                "2008, safety factor 1.25)."
                if p is not None
                else "The three drags do not change monotonically: no observed order."
            ),
        ]
    return lines


def _sweep_lines(rows) -> list[str]:
    from manta_drake.model.coefficients import fit_damping

    mesh = sweep_mesh_of(rows)
    lines = [
        "",
        "### Robot: the sweep (body frame: x forward, y left, z up; N and N m about "
        "the CG; the last iteration's forces, and the drag's spread over the last 10 % "
        "of the iterations)",
        "",
        "| U (m/s) | pitch | yaw | mesh | Fx | Fy | Fz | Mx | My | Mz | cells | "
        "iterations | drag spread (last 10 %) | wall (s) |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    sweep = [
        r
        for r in rows
        if r["shape"] == "robot"
        and not (
            _num(r, "speed") == 0.4
            and not _num(r, "pitch_deg")
            and not _num(r, "yaw_deg")
            and r["mesh"] not in (mesh, "medium")
        )
    ]
    order = {m: i for i, m in enumerate(MESH_CHOICES)}
    sweep.sort(
        key=lambda r: (
            order[r["mesh"]] != order[mesh],
            order[r["mesh"]],
            _num(r, "yaw_deg"),
            _num(r, "pitch_deg"),
            _num(r, "speed"),
        )
    )
    for r in sweep:
        forces = " | ".join(f"{_num(r, k):.4g}" for k in ("Fx", "Fy", "Fz", "Mx", "My", "Mz"))
        lines.append(
            f"| {_num(r, 'speed'):g} | {_num(r, 'pitch_deg'):g} | "
            f"{_num(r, 'yaw_deg'):g} | {r['mesh']} | {forces} | {r['cells']} | "
            f"{_iterations(r)} | {100 * _num(r, 'drag_tail_spread'):.1f} % | "
            f"{r['wall_s']} |"
        )
    for m in dict.fromkeys(r["mesh"] for r in sweep):
        surge = sorted(
            (_num(r, "speed"), -_num(r, "Fx"))
            for r in sweep
            if r["mesh"] == m and not _num(r, "pitch_deg") and not _num(r, "yaw_deg")
        )
        if len(surge) >= 2:
            h, res = fit_damping([u for u, _ in surge], [x for _, x in surge])
            lines += [
                "",
                f"Eq. (4) on the {len(surge)} zero-incidence samples of the {m} "
                f"mesh (surge, resisting force -Fx against u): X_u = {h[0]:.4g} "
                f"N s/m, X_u|u| = {h[1]:.4g} N s^2/m^2, RMS residual "
                f"{float((res**2).mean() ** 0.5):.3g} N (for reading only: "
                "the model's damping is identified from the hull's and fins' "
                "parts by `scripts/identify_damping.py`).",
            ]
    return lines


def samples(csv_dir: pathlib.Path) -> list[dict]:
    """Every committed sample row (robot and validation) of ``csv_dir``."""
    return [
        r
        for name in ("validation_samples.csv", "robot_samples.csv")
        for r in read_samples(pathlib.Path(csv_dir) / name)
    ]


def write_report(rows: list[dict], page: pathlib.Path) -> None:
    """Replaces the results block of ``page`` (a missing page is written with its title,
    stamp and the block)."""
    from manta_drake.studies.stamp import replace_marked_block

    command = f"manta-drake study cfd --tables-only --runs {TABLES_FROM_SAMPLES}"
    replace_marked_block(page, report_block(rows), BEGIN, END, new_page=(PAGE_TITLE, command))


def write_progress(
    path: pathlib.Path, out: pathlib.Path, cases, command: str, started: float
) -> None:
    results = {r["case"]: r for r in finished_results(out)}
    lines = [
        "# CFD study progress",
        "",
        f"Updated {datetime.datetime.now(datetime.UTC):%Y-%m-%d %H:%M} UTC by "
        f"`{command}` (pid {os.getpid()}, {time.time() - started:.0f} s in). Resume: run "
        "the same command again (finished cases are skipped).",
        "",
        "| case | status | cells | drag (N) | iterations | converged | wall (s) | CPU (s) |",
        "|---|---|---|---|---|---|---|---|",
    ]
    left = []
    for c in cases:
        r = results.get(c.name)
        if r is None:
            left.append(c.name)
            continue
        if r.get("status") == "ok":
            lines.append(
                f"| {c.name} | ok | {r['cells']} | {r['drag_n']:.4g} | "
                f"{r['iterations']} | {r['converged']} | {r['wall_s']} | "
                f"{r['cpu_s']} |"
            )
        else:
            lines.append(
                f"| {c.name} | {r.get('status')}: {r.get('reason', '')[:200]} | | | "
                f"| | {r.get('wall_s', '')} | |"
            )
    lines += ["", f"Left ({len(left)}): " + (", ".join(left) if left else "none"), ""]
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text("\n".join(lines))


# --- the command -------------------------------------------------------------------------------


def parse_args(argv, prog):
    parser = StudyParser(prog=prog, description=__doc__.splitlines()[0])
    parser.add_argument(
        "--runs",
        default=DEFAULT_RUNS,
        metavar="DIR",
        help="the cases' root folder (one folder per case; rerunning skips the finished "
        f"ones; default {DEFAULT_RUNS})",
    )
    parser.add_argument(
        "--cases", default="all", metavar="SET", help=f"one of {', '.join(CASE_SETS)} (default all)"
    )
    parser.add_argument(
        "--workers",
        default="1",
        metavar="N",
        help=f"cases run side by side on a Dask local cluster, 0..{MAX_WORKERS} "
        "(0: in this process; default 1)",
    )
    parser.add_argument(
        "--mesh",
        default="medium",
        metavar="MESH",
        help=f"the sweep's mesh: {', '.join(MESH_CHOICES)} (default medium; "
        "grid convergence runs all three)",
    )
    parser.add_argument(
        "--csv-dir",
        default=None,
        metavar="DIR",
        help="where the samples CSVs go (default models/cfd of the checkout; '' for none)",
    )
    parser.add_argument(
        "--progress",
        default=None,
        metavar="FILE",
        help="a progress page rewritten after each case (default RUNS/progress.md)",
    )
    parser.add_argument(
        "--retry-failed",
        action="store_true",
        help="run failed cases again (default: keep their result)",
    )
    parser.add_argument(
        "--out",
        default=None,
        metavar="DIR",
        help=f"the report's folder: DIR/{PAGE}, whose results block is rewritten (default "
        "the checkout's docs/)",
    )
    parser.add_argument(
        "--tables-only",
        action="store_true",
        help="run nothing: write the samples from the cases already under "
        "--runs, then the report from the samples in --csv-dir (--runs "
        f"{TABLES_FROM_SAMPLES}: from the samples alone)",
    )
    args = parser.parse_args(argv)
    check_choices(args)
    check_folders(args, prog)
    return args


def check_choices(args) -> None:
    """--cases, --mesh and --workers (the latter made an integer)."""
    if args.cases not in CASE_SETS:
        raise CfdError(f"--cases {args.cases!r}: expected one of {', '.join(CASE_SETS)}")
    if args.mesh not in MESH_CHOICES:
        raise CfdError(f"--mesh {args.mesh!r}: expected one of {', '.join(MESH_CHOICES)}")
    try:
        args.workers = int(args.workers)
    except ValueError:
        raise CfdError(
            f"--workers {args.workers!r}: expected an integer 0..{MAX_WORKERS}"
        ) from None
    if not 0 <= args.workers <= MAX_WORKERS:
        raise CfdError(
            f"--workers {args.workers}: expected 0..{MAX_WORKERS} (each case is one "
            "single-threaded OpenFOAM run; this machine shares 2 cores)"
        )


def check_folders(args, prog: str) -> None:
    """--runs, --out (made ``args.page``, the report) and --csv-dir (its default the
    checkout's models/cfd; '' becomes None: no samples written)."""
    from manta_drake.studies.report import output_folder

    if not args.runs.strip():
        raise CfdError("--runs: empty path")
    runs = pathlib.Path(args.runs)
    if runs.exists() and not runs.is_dir():
        raise CfdError(f"--runs {args.runs}: exists and is not a folder")
    if args.tables_only and not runs.is_dir() and args.runs != TABLES_FROM_SAMPLES:
        raise CfdError(
            f"--runs {args.runs}: no such folder of cases (--runs "
            f"{TABLES_FROM_SAMPLES} with --tables-only: the page from the "
            "committed samples alone)"
        )
    args.page = output_folder(args.out, prog) / PAGE
    if args.csv_dir is None:
        args.csv_dir = output_folder(None, prog, default="models", option="--csv-dir DIR") / "cfd"
    args.csv_dir = pathlib.Path(args.csv_dir) if str(args.csv_dir) else None
    if args.tables_only and args.csv_dir is None:
        raise CfdError("--tables-only: --csv-dir '' names no samples; name their folder")


def tables_only(args) -> int:
    """``--tables-only``: the samples from the cases under --runs (none with ``--runs -``),
    then the page from the samples in --csv-dir."""
    if args.runs != TABLES_FROM_SAMPLES:
        print(f"samples: {write_samples(pathlib.Path(args.runs), args.csv_dir)}")
    write_report(samples(args.csv_dir), args.page)
    print(f"report: {args.page}")
    return 0


def run_cases(cases, args, out: pathlib.Path, progress: pathlib.Path, command: str) -> int:
    """Runs ``cases`` in ``out`` (in this process with --workers 0, else on a Dask local
    cluster), writing the samples and the progress page after each; returns how many
    failed."""
    from manta_drake.studies.cfd import run

    jobs = [(c.to_json(), str(out), args.retry_failed, command) for c in cases]
    started = time.time()
    failed = 0

    def finished(result) -> None:
        nonlocal failed
        status = result.get("status")
        failed += status != "ok"
        note = " (skipped: done before)" if result.get("skipped") else ""
        detail = (
            f"drag {result['drag_n']:.4g} N, {result['cells']} cells, "
            f"{result['iterations']} it, {result['wall_s']} s"
            if status == "ok"
            else result.get("reason", "")
        )
        print(f"{result['case']}: {status}{note}: {detail}", flush=True)
        if args.csv_dir is not None:
            write_samples(out, args.csv_dir)
        write_progress(progress, out, cases, command, started)

    write_progress(progress, out, cases, command, started)
    print(f"{len(cases)} cases under {out}; progress: {progress}", flush=True)
    if args.workers == 0:
        for job in jobs:
            finished(run.run_case_job(job))
        return failed
    from manta_drake.cluster import completed_resubmitting_lost, dask_client

    with dask_client(workers=args.workers, dashboard="") as client:
        for job, outcome in completed_resubmitting_lost(
            client,
            run.run_case_job,
            jobs,
            lambda j: j,
            lambda j: f"cfd-{cfd_name(j)}",
            window=lambda: 2 * args.workers,
        ):
            if isinstance(outcome, dict):
                finished(outcome)
            else:
                failed += 1
                print(f"{cfd_name(job)}: task failed: {outcome.reason()}", flush=True)
                write_progress(progress, out, cases, command, started)
    return failed


def main(argv=None, prog=None) -> int:
    prog = prog or "manta-drake study cfd"
    argv = sys.argv[1:] if argv is None else list(argv)
    args = parse_args(argv, prog)
    from manta_drake.studies.cfd import run

    if args.tables_only:
        return tables_only(args)
    if not run.openfoam_available():
        raise CfdError(
            "OpenFOAM's simpleFoam is not installed: run `bash "
            "scripts/ensure_debian.sh openfoam` (Debian's openfoam) or `make cfd`"
        )
    out = pathlib.Path(args.runs).resolve()
    out.mkdir(parents=True, exist_ok=True)
    progress = pathlib.Path(args.progress) if args.progress else out / "progress.md"
    cases = cases_for(args.cases, args.mesh)
    command = f"{prog} {shlex.join(argv)}"
    failed = run_cases(cases, args, out, progress, command)
    if args.csv_dir is not None:
        counts = write_samples(out, args.csv_dir)
        print(f"samples: {', '.join(f'{args.csv_dir / k} ({v} rows)' for k, v in counts.items())}")
        if args.page.exists():
            write_report(samples(args.csv_dir), args.page)
            print(f"report: {args.page}")
    return 1 if failed else 0


def cfd_name(job) -> str:
    from manta_drake.studies.cfd.case import CaseSpec

    return CaseSpec(**job[0]).name
