"""Running one CFD case with Debian's OpenFOAM: blockMesh, snappyHexMesh, checkMesh,
simpleFoam, in the case's own folder under an output root, and its ``result.json``.

A case whose ``result.json`` exists is not run again (a study restarts case by case); a
failed case keeps its logs and a result with ``status: failed`` and the reason, and is run
again only when asked (``retry_failed``). The result holds the full body's forces and
moments (rebuilt from the symmetry planes' mirror images) in the body frame, their pressure
and viscous parts, the cells, y+ per body patch, the final residuals, the iterations, wall
and CPU time per step, the OpenFOAM version and the mesh.
"""

from __future__ import annotations

import datetime
import json
import os
import pathlib
import re
import resource
import shutil
import subprocess
import time

import numpy as np

from manta_drake.studies.cfd import case as cfdcase

# The Debian binaries read their etc files from WM_PROJECT_DIR (without it: "Could not
# find mandatory etc entry 'controlDict'").
OPENFOAM_DIR = "/usr/share/openfoam"
STEPS = ("blockMesh", "snappyHexMesh", "checkMesh", "simpleFoam")
STEP_TIMEOUT_S = 6 * 3600
RESULT = "result.json"


class OpenFoamMissing(RuntimeError):
    """simpleFoam is not installed (scripts/ensure_debian.sh openfoam installs it)."""


def openfoam_available() -> bool:
    return shutil.which("simpleFoam") is not None and shutil.which("snappyHexMesh") is not None


def openfoam_environment() -> dict:
    env = dict(os.environ)
    env.setdefault("WM_PROJECT_DIR", OPENFOAM_DIR)
    env["OMP_NUM_THREADS"] = "1"
    return env


def openfoam_version() -> str:
    """The Debian package's version (e.g. ``1912.200626-1+b1``), or ``unknown``."""
    try:
        out = subprocess.run(
            ["dpkg-query", "-W", "-f=${Version}", "openfoam"],
            capture_output=True,
            text=True,
            timeout=20,
        )
        return out.stdout.strip() or "unknown"
    except (OSError, subprocess.SubprocessError):
        return "unknown"


# The solver is stopped (controlDict's stopAt set to writeNow, which simpleFoam rereads:
# runTimeModifiable) once the forces have settled: over the last SETTLE_WINDOW iterations
# every component of the meshed part's force moved by at most SETTLE_TOLERANCE of the
# force's magnitude (and the moment's by as much of |M| + |F| x 0.38 m), after at least
# SETTLE_MIN_ITERATIONS. The residual targets alone can stall just above their values with
# the forces steady to seven digits (the hull's level-3 case: U_y at 1.09e-5 for 1300
# iterations).
SETTLE_WINDOW = 100
SETTLE_TOLERANCE = 1e-4
SETTLE_MIN_ITERATIONS = 200
POLL_S = 10.0


def forces_settled(
    forces: np.ndarray,
    moments: np.ndarray,
    window: int = SETTLE_WINDOW,
    tolerance: float = SETTLE_TOLERANCE,
    min_iterations: int = SETTLE_MIN_ITERATIONS,
) -> bool:
    """Whether the totals (n, 3) of the last ``window`` iterations stay within ``tolerance``
    of their scale (see SETTLE_TOLERANCE)."""
    n = min(len(forces), len(moments))
    if n < max(window, min_iterations):
        return False
    f, m = forces[n - window : n], moments[n - window : n]
    f_scale = float(np.linalg.norm(f[-1]))
    m_scale = float(np.linalg.norm(m[-1])) + 0.38 * f_scale
    if f_scale == 0:
        return False
    return bool(
        np.ptp(f, axis=0).max() <= tolerance * f_scale
        and np.ptp(m, axis=0).max() <= tolerance * m_scale
    )


def _stop_when_settled(folder: pathlib.Path) -> bool:
    """Sets the case's stopAt to writeNow if its forces have settled; whether it did."""
    try:
        _, f = read_vectors(folder / "postProcessing/forces/0/force.dat")
        _, m = read_vectors(folder / "postProcessing/forces/0/moment.dat")
    except (OSError, CaseFailed, ValueError):
        return False
    if not forces_settled(f[:, 0], m[:, 0]):
        return False
    control = folder / "system" / "controlDict"
    text = control.read_text()
    control.write_text(
        re.sub(r"^stopAt\s+\w+;", "stopAt          writeNow;", text, count=1, flags=re.M)
    )
    return True


def _run_step(folder: pathlib.Path, args: list[str], log: str, watch_forces: bool = False) -> dict:
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.monotonic()
    stopped = False
    with open(folder / log, "w") as f:
        proc = subprocess.Popen(
            args, cwd=folder, stdout=f, stderr=subprocess.STDOUT, env=openfoam_environment()
        )
        try:
            while True:
                try:
                    proc.wait(timeout=POLL_S)
                    break
                except subprocess.TimeoutExpired:
                    if time.monotonic() - t0 > STEP_TIMEOUT_S:
                        raise
                    if watch_forces and not stopped:
                        stopped = _stop_when_settled(folder)
        finally:
            if proc.poll() is None:
                proc.kill()
                proc.wait()
    wall = time.monotonic() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    out = {
        "returncode": proc.returncode,
        "wall_s": round(wall, 2),
        "cpu_s": round(cpu, 2),
        "log": log,
    }
    if watch_forces:
        out["stopped_forces_settled"] = stopped
    return out


class CaseFailed(RuntimeError):
    pass


def _tail(path: pathlib.Path, n: int = 6) -> str:
    try:
        lines = [x for x in path.read_text(errors="replace").splitlines() if x.strip()]
    except OSError:
        return ""
    return " | ".join(lines[-n:])


# --- reading the outputs -----------------------------------------------------------------------


def read_vectors(path) -> tuple[np.ndarray, np.ndarray]:
    """A forces/moment .dat of v1912: ``Time (total) (pressure) (viscous)`` per line ->
    (iterations (n,), values (n, 3, 3): total, pressure, viscous)."""
    times, rows = [], []
    for line in pathlib.Path(path).read_text().splitlines():
        if not line.strip() or line.startswith("#"):
            continue
        nums = [float(x) for x in line.replace("(", " ").replace(")", " ").split()]
        if len(nums) < 10:
            continue
        times.append(nums[0])
        rows.append(np.array(nums[1:10]).reshape(3, 3))
    if not rows:
        raise CaseFailed(f"{path}: no force samples")
    return np.array(times), np.array(rows)


def read_yplus(path) -> dict:
    """yPlus.dat: the last time's ``patch min max average`` per body patch."""
    last = {}
    for line in pathlib.Path(path).read_text().splitlines():
        if not line.strip() or line.startswith("#"):
            continue
        w = line.split()
        if len(w) >= 5:
            last[w[1]] = {
                "time": float(w[0]),
                "min": float(w[2]),
                "max": float(w[3]),
                "avg": float(w[4]),
            }
    if not last:
        return {}
    t = max(v["time"] for v in last.values())
    return {k: {x: v[x] for x in ("min", "max", "avg")} for k, v in last.items() if v["time"] == t}


_RESIDUAL = re.compile(r"Solving for (\w+), Initial residual = ([-+0-9.eE]+)")


def read_solver_log(path) -> dict:
    """The final initial residual per field, the last iteration, convergence, the solver's
    own CPU (ExecutionTime) and the OpenFOAM build."""
    text = pathlib.Path(path).read_text(errors="replace")
    residuals = {}
    # The first solve of a field in an iteration is its initial residual (p is solved twice
    # with SIMPLEC's non-orthogonal corrector: keep the first of each iteration).
    blocks = re.split(r"\n(?:Time = )", text)
    for block in blocks[-2:-1] + blocks[-1:]:
        seen = {}
        for name, value in _RESIDUAL.findall(block):
            seen.setdefault(name, float(value))
        if seen:
            residuals = seen
    times = re.findall(r"^Time = (\S+)", text, flags=re.M)
    exec_times = re.findall(r"ExecutionTime = ([0-9.eE+-]+) s\s+ClockTime = ([0-9.eE+-]+) s", text)
    build = re.search(r"^Build\s*:\s*(.+)$", text, flags=re.M)
    return {
        "residuals": residuals,
        "iterations": int(float(times[-1])) if times else 0,
        "converged": "SIMPLE solution converged" in text,
        "solver_cpu_s": float(exec_times[-1][0]) if exec_times else None,
        "solver_clock_s": float(exec_times[-1][1]) if exec_times else None,
        "build": build.group(1).strip() if build else "unknown",
        "ended": bool(re.search(r"^End\s*$", text, flags=re.M)),
        "floating_point_error": "Floating point exception" in text or "sigFpe" in text,
    }


def read_check_mesh(path) -> dict:
    text = pathlib.Path(path).read_text(errors="replace")
    cells = re.search(r"^\s*cells:\s+(\d+)", text, flags=re.M)
    failed = re.search(r"Failed (\d+) mesh checks", text)
    non_ortho = re.search(r"Mesh non-orthogonality Max: ([0-9.eE+-]+)", text)
    return {
        "cells": int(cells.group(1)) if cells else 0,
        "mesh_ok": "Mesh OK." in text,
        "failed_checks": int(failed.group(1)) if failed else 0,
        "max_non_orthogonality": float(non_ortho.group(1)) if non_ortho else None,
    }


def full_body(v: np.ndarray, symmetry_axes, moment: bool) -> np.ndarray:
    """The whole body's force (or moment) from the meshed part's, mirrored in the symmetry
    planes (the plane normal to axis i): a force's i component cancels and the others double;
    a moment's (a pseudo-vector) i component doubles and the others cancel."""
    out = np.array(v, dtype=float)
    for i in symmetry_axes:
        mirror = np.full(3, 2.0)
        if moment:
            mirror[:] = 0.0
            mirror[i] = 2.0
        else:
            mirror[i] = 0.0
        out = out * mirror
    return out


def summarise(folder: pathlib.Path, spec: cfdcase.CaseSpec) -> dict:
    """The case's forces in the body frame and its diagnostics, from its outputs."""
    settings = json.loads((folder / "case.json").read_text())
    sym = settings["d"]["symmetry_axes"]
    R = np.array(settings["s"]["rotation"])
    it_f, forces = read_vectors(folder / "postProcessing/forces/0/force.dat")
    it_m, moments = read_vectors(folder / "postProcessing/forces/0/moment.dat")
    n = len(forces)
    tail = slice(max(0, n - max(20, n // 10)), n)  # the last 10 % (at least 20 iterations)

    def frame(v, moment):
        return R.T @ full_body(v, sym, moment)  # domain (water) frame -> body frame

    def parts(rows, moment, how):
        sel = rows[-1] if how == "final" else rows[tail].mean(axis=0)
        return {
            k: frame(sel[j], moment).tolist()
            for j, k in enumerate(("total", "pressure", "viscous"))
        }

    out = {}
    for how in ("final", "tail_mean"):
        out[how] = {"force": parts(forces, False, how), "moment": parts(moments, True, how)}
    out["parts"] = {}
    for name in settings["s"].get("part_patches", {}):
        _, pf = read_vectors(folder / f"postProcessing/forces_{name}/0/force.dat")
        _, pm = read_vectors(folder / f"postProcessing/forces_{name}/0/moment.dat")
        t = slice(max(0, len(pf) - max(20, len(pf) // 10)), len(pf))
        out["parts"][name] = {
            "force": frame(pf[t, 0].mean(axis=0), False).tolist(),
            "pressure_force": frame(pf[t, 1].mean(axis=0), False).tolist(),
            "moment": frame(pm[t, 0].mean(axis=0), True).tolist(),
        }
    # Drag: the force along the water's flow (-x in the domain), on the whole body.
    drag_series = -np.array([full_body(f[0], sym, False)[0] for f in forces])
    drag_tail = drag_series[tail]
    speed = spec.speed
    q = 0.5 * cfdcase.RHO * speed**2
    a_ref = settings["s"]["a_ref"]
    velocity_body = (R.T @ np.array([speed, 0.0, 0.0])).tolist()
    return {
        **out,
        "drag_n": float(drag_series[-1]),
        "drag_tail_mean_n": float(drag_tail.mean()),
        "drag_tail_spread": float(
            (drag_tail.max() - drag_tail.min()) / max(abs(drag_tail.mean()), 1e-30)
        ),
        "drag_pressure_n": float(-full_body(forces[-1][1], sym, False)[0]),
        "drag_viscous_n": float(-full_body(forces[-1][2], sym, False)[0]),
        "cd": float(drag_series[-1] / (q * a_ref)),
        "a_ref_m2": a_ref,
        "body_velocity": velocity_body,
        "force_iterations": int(it_f[-1]),
    }


def _area_weighted_yplus(yplus: dict, areas: dict) -> tuple[float | None, float | None]:
    if not yplus:
        return None, None
    w, s = 0.0, 0.0
    for patch, v in yplus.items():
        region = patch[len("body_") :] if patch.startswith("body_") else None
        a = areas.get(region, sum(areas.values()) if region is None else 0.0)
        w += a
        s += a * v["avg"]
    avg = s / w if w > 0 else float(np.mean([v["avg"] for v in yplus.values()]))
    return avg, max(v["max"] for v in yplus.values())


# --- one case ----------------------------------------------------------------------------------


def result_path(root, spec: cfdcase.CaseSpec) -> pathlib.Path:
    return pathlib.Path(root) / spec.name / RESULT


def run_case(spec: cfdcase.CaseSpec, root, retry_failed: bool = False, command: str = "") -> dict:
    """Runs ``spec`` in ``root/spec.name`` unless its result exists (a failed one: only with
    ``retry_failed``); returns the result. ``command`` is recorded in it."""
    folder = pathlib.Path(root) / spec.name
    done = folder / RESULT
    if done.exists():
        result = _earlier_result(done, spec, retry_failed)
        if result is not None:
            return result
    if not openfoam_available():
        raise OpenFoamMissing(
            "simpleFoam is not installed: run scripts/ensure_debian.sh openfoam (Debian's openfoam)"
        )
    if folder.exists():
        shutil.rmtree(folder)  # a half-run case starts again from nothing
    folder.mkdir(parents=True)
    result = _new_result(spec, command)
    try:
        cfdcase.write_case(spec, folder)
        _run_steps(folder, result)
        log = read_solver_log(folder / "log.simpleFoam")
        yplus = _yplus(folder)
        areas = json.loads((folder / "case.json").read_text())["part_areas"]
        yavg, ymax = _area_weighted_yplus(yplus, areas)
        result.update(summarise(folder, spec))
        result.update(_solver_fields(result, log))
        result.update({"yplus": yplus, "yplus_avg": yavg, "yplus_max": ymax})
        result["status"] = "ok"
    except (CaseFailed, subprocess.TimeoutExpired, OSError, ValueError, KeyError, IndexError) as e:
        result["status"] = "failed"
        result["reason"] = f"{type(e).__name__}: {' '.join(str(e).split())}"[:2000]
    _write_result(result, done)
    # The fields of the last iteration are kept (the result's numbers come from the
    # function objects); the mesh's polyMesh stays for inspection.
    return result


def _earlier_result(done: pathlib.Path, spec: cfdcase.CaseSpec, retry_failed: bool) -> dict | None:
    """The result at ``done``, marked ``skipped``, if it is of this ``spec`` and ok (or failed,
    without ``retry_failed``); else None: the case runs again."""
    result = json.loads(done.read_text())
    same = result.get("spec") == spec.to_json()  # else: a case of another definition
    if same and (result.get("status") == "ok" or not retry_failed):
        result["skipped"] = True
        return result
    return None


def _new_result(spec: cfdcase.CaseSpec, command: str) -> dict:
    """A case's result as it starts: ``running``, no steps yet."""
    started = datetime.datetime.now(datetime.UTC)
    return {
        "case": spec.name,
        "spec": spec.to_json(),
        "status": "running",
        "started": started.isoformat(timespec="seconds"),
        "openfoam": openfoam_version(),
        "mesh": spec.mesh,
        "command": command,
        "mesh_spec": cfdcase.dc.asdict(spec.mesh_spec),
        "steps": {},
    }


def _run_steps(folder: pathlib.Path, result: dict) -> None:
    """Runs the meshing and the solver (STEPS) in ``folder``, each step's record into
    ``result["steps"]`` and checkMesh's report into ``result["check_mesh"]``; CaseFailed on
    a step that exits with an error or a mesh without cells."""
    for step, args in (
        ("blockMesh", ["blockMesh"]),
        ("snappyHexMesh", ["snappyHexMesh", "-overwrite"]),
        ("checkMesh", ["checkMesh"]),
        ("simpleFoam", ["simpleFoam"]),
    ):
        info = _run_step(folder, args, f"log.{step}", watch_forces=step == "simpleFoam")
        result["steps"][step] = info
        if info["returncode"] != 0:
            raise CaseFailed(
                f"{step} exited with {info['returncode']}: {_tail(folder / info['log'])}"
            )
        if step == "checkMesh":
            result["check_mesh"] = read_check_mesh(folder / "log.checkMesh")
            if result["check_mesh"]["cells"] == 0:
                raise CaseFailed("checkMesh reports no cells")


def _yplus(folder: pathlib.Path) -> dict:
    """y+ per patch of the solution's last iteration (``read_yplus``), computed by
    simpleFoam's yPlus function when the run did not write it; {} if there is none."""
    if not (folder / "postProcessing/yPlus/0/yPlus.dat").exists():
        _run_step(
            folder, ["simpleFoam", "-postProcess", "-func", "yPlus", "-latestTime"], "log.yPlus"
        )
    yplus_file = folder / "postProcessing/yPlus/0/yPlus.dat"
    if not yplus_file.exists():
        yplus_file = next(folder.glob("postProcessing/yPlus/*/yPlus.dat"), yplus_file)
    return read_yplus(yplus_file) if yplus_file.exists() else {}


def _solver_fields(result: dict, log: dict) -> dict:
    """The result's fields from the solver's log (``read_solver_log``) and its run: the
    cells, residuals, iterations, whether and why it stopped, the solver's CPU time."""
    return {
        "cells": result["check_mesh"]["cells"],
        "residuals": log["residuals"],
        "iterations": log["iterations"],
        "converged": log["converged"],
        "openfoam_build": log["build"],
        "forces_settled": result["steps"]["simpleFoam"]["stopped_forces_settled"],
        "stopped_by": (
            "residuals"
            if log["converged"]
            else "forces settled"
            if result["steps"]["simpleFoam"]["stopped_forces_settled"]
            else "iteration cap"
        ),
        "solver_cpu_s": log["solver_cpu_s"],
    }


def _write_result(result: dict, done: pathlib.Path) -> None:
    """Adds the steps' total wall and CPU time and the finish time to ``result`` and writes
    it to ``done`` (atomically: a kill leaves no half-written result)."""
    result["wall_s"] = round(sum(s["wall_s"] for s in result["steps"].values()), 1)
    result["cpu_s"] = round(sum(s["cpu_s"] for s in result["steps"].values()), 1)
    result["finished"] = datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds")
    tmp = done.parent / (RESULT + ".tmp")
    tmp.write_text(json.dumps(result, indent=1))
    tmp.replace(done)


def run_case_job(job: tuple) -> dict:
    """The Dask task: ``(spec as dict, root, retry_failed, command)`` -> the result."""
    spec, root, retry, command = job
    return run_case(cfdcase.CaseSpec(**spec), root, retry, command)
