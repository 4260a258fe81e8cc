"""OpenFOAM cases of the CFD study: each ``CaseSpec`` (shape, inflow speed, pitch, yaw, mesh)
becomes a case folder of dictionaries rendered from the Jinja2 templates of ``templates/``
and the body's STL (``geometry``).

The paper's set-up (section 2.3): the simplified robot model 1.75 W from the velocity inlet
in a domain 7.1 W long, 3.5 W wide and 3.5 W high (W = 0.85 m, Table 1's width), a
zero-pressure outlet, standard k-epsilon with standard wall functions, static analyses at
0.4-1.2 m/s, pitch and yaw -30 to 30 deg. Here:

* Frames. The domain's axes are the body's Drake axes at zero incidence (x forward, y left,
  z up), origin at the hull's centre (the CG, the moments' centre). The water enters at the
  inlet (x max) with velocity (-U, 0, 0): the body moves forward through still water at U.
  "1.75 W from the inlet" is read as the body's origin 1.75 W downstream of the inlet plane.
* Incidence turns the STL (``geometry.rotation``: pitch nose up, yaw nose to starboard, the
  paper's NED senses) in the fixed flow; the forces are turned back into the body frame.
* Symmetry. The hull and the fins at the zero pose are symmetric about the body's xz and xy
  planes. At zero incidence a quarter domain (symmetry planes y = 0 and z = 0); pitch keeps
  the xz symmetry (half domain, y >= 0); yaw keeps the xy symmetry (half domain, z >= 0);
  both: the full domain. The full body's forces are rebuilt from the mirror images.
* The far-field sides are slip walls (the paper does not say; Autodesk CFD's default for an
  unassigned external face is a slip/symmetry wall).
* Validation shapes get body-sized domains: the sphere (Re 1e5) and the hull alone (the
  hydro_refs.md section 3 case: x from -2.4 to 1.0 m, y and z 0 to 0.8 m, 0.05 m blocks).
"""

from __future__ import annotations

import dataclasses as dc
import json
import math
import pathlib
import re

import numpy as np

from manta_drake.model.robot_params import DEFAULT_ROBOT
from manta_drake.studies.cfd import geometry

TEMPLATES = pathlib.Path(__file__).resolve().parent / "templates"

RHO = 1000.0  # kg/m^3, fresh water (hydrodynamics.yaml water_density)
NU = 1.0e-6  # m^2/s, water at 20 C
W = 0.85  # m, the robot's width (Table 1), the paper's domain unit
ROBOT_DOMAIN_W = {"length": 7.1, "width": 3.5, "height": 3.5, "inlet_to_body": 1.75}
SPHERE_DIAMETER = 0.1  # m: Re = U D / nu = 1e5 at 1 m/s
SPHERE_SPEED = 1.0
TURBULENCE_INTENSITY = 0.01
VISCOSITY_RATIO = 10.0
C_MU = 0.09

SHAPES = ("sphere", "hull", "robot")
MESH_NAMES = ("tiny", "coarse", "medium", "fine")


@dc.dataclass(frozen=True)
class MeshSpec:
    """blockMesh cell size and snappyHexMesh levels of one mesh of one shape."""

    base_cell: float  # m, the blockMesh cells (cubic up to rounding to whole cells)
    surface_level: int  # refinement level on the body (cell = base / 2^level)
    fin_level: int | None = None  # the fins' level (robot), else the surface level
    near_level: int = 2  # the box around the body
    wake_level: int = 1  # the box behind it
    max_iterations: int = 1500


# Robot: a refinement ratio of sqrt(2) in cell size between meshes (Celik et al. 2008, the
# ASME V&V grid-convergence procedure, asks r > 1.3) at fixed levels, so each mesh is the
# previous one scaled. Fins one level finer than the hull: the plates are 12 mm thick, 2.4
# cells at the coarse mesh's 5 mm.
MESHES = {
    "sphere": {
        # The far field needs no fine blocks: D/2 blocks, the body's cells D/16 .. D/64.
        "tiny": MeshSpec(0.05, 2, near_level=1, wake_level=0, max_iterations=400),
        "coarse": MeshSpec(0.05, 3, near_level=2, wake_level=1),
        "medium": MeshSpec(0.05, 4, near_level=3, wake_level=2),
        "fine": MeshSpec(0.05, 5, near_level=3, wake_level=2),
    },
    "hull": {
        "coarse": MeshSpec(0.05, 2, near_level=1, wake_level=1),
        "medium": MeshSpec(0.05, 3, near_level=2, wake_level=1),  # hydro_refs.md level 3
        "fine": MeshSpec(0.05, 4, near_level=2, wake_level=1),  # hydro_refs.md level 4
    },
    "robot": {
        "coarse": MeshSpec(0.16, 4, fin_level=5, near_level=3, wake_level=2, max_iterations=1000),
        "medium": MeshSpec(
            0.16 / math.sqrt(2), 4, fin_level=5, near_level=3, wake_level=2, max_iterations=1000
        ),
        "fine": MeshSpec(0.08, 4, fin_level=5, near_level=3, wake_level=2, max_iterations=1000),
    },
}


@dc.dataclass(frozen=True)
class CaseSpec:
    """One static CFD analysis."""

    shape: str  # sphere | hull | robot
    speed: float  # m/s, the body's speed through still water
    pitch_deg: float = 0.0  # nose up (NED sense)
    yaw_deg: float = 0.0  # nose to starboard (NED sense)
    mesh: str = "medium"
    turbulence_model: str = "kEpsilon"
    fin_section: str = "naca0012"  # robot: geometry.FIN_SECTIONS

    def __post_init__(self):
        if self.shape not in SHAPES:
            raise ValueError(f"shape {self.shape!r}: expected one of {', '.join(SHAPES)}")
        if self.mesh not in MESHES[self.shape]:
            raise ValueError(
                f"mesh {self.mesh!r} for {self.shape}: expected one of "
                f"{', '.join(MESHES[self.shape])}"
            )
        if not self.speed > 0:
            raise ValueError(f"speed {self.speed}: must be > 0")
        if self.shape != "robot" and (self.pitch_deg or self.yaw_deg):
            raise ValueError(f"{self.shape}: incidence is for the robot only")
        if self.fin_section not in geometry.FIN_SECTIONS:
            raise ValueError(
                f"fin section {self.fin_section!r}: expected one of "
                f"{', '.join(geometry.FIN_SECTIONS)}"
            )
        if self.turbulence_model != "kEpsilon":
            raise ValueError(
                "turbulence model: the paper's standard kEpsilon only (its "
                "wall functions are set for it)"
            )

    @property
    def name(self) -> str:
        def ang(x):
            return f"{'m' if x < 0 else 'p'}{abs(x):04.1f}".replace(".", "")

        fins = "_platefins" if self.shape == "robot" and self.fin_section == "plate" else ""
        return (
            f"{self.shape}_U{self.speed:.2f}_pitch{ang(self.pitch_deg)}"
            f"_yaw{ang(self.yaw_deg)}_{self.mesh}{fins}"
        ).replace(".", "")

    @property
    def mesh_spec(self) -> MeshSpec:
        return MESHES[self.shape][self.mesh]

    def to_json(self) -> dict:
        return dc.asdict(self)


# --- the parts and the domain ------------------------------------------------------------------


def body_parts(spec: CaseSpec) -> list[geometry.Part]:
    """The body's surfaces, turned to the case's incidence."""
    if spec.shape == "sphere":
        parts = geometry.sphere_parts(SPHERE_DIAMETER)
    elif spec.shape == "hull":
        parts = geometry.hull_parts()
    else:
        parts = geometry.robot_parts(fin_section=spec.fin_section)
    R = geometry.rotation(spec.pitch_deg, spec.yaw_deg)
    return [p.transformed(R) for p in parts]


def symmetry_axes(spec: CaseSpec) -> tuple[int, ...]:
    """Axes (1: y, 2: z) whose zero plane is a symmetry plane of the case."""
    axes = []
    if spec.yaw_deg == 0:
        axes.append(1)  # the xz plane survives pitch
    if spec.pitch_deg == 0:
        axes.append(2)  # the xy plane survives yaw
    return tuple(axes)


def full_domain(spec: CaseSpec) -> tuple[np.ndarray, np.ndarray]:
    """The whole domain box (lo, hi) before the symmetry cuts."""
    if spec.shape == "robot":
        x_in = ROBOT_DOMAIN_W["inlet_to_body"] * W
        length = ROBOT_DOMAIN_W["length"] * W
        hw, hh = ROBOT_DOMAIN_W["width"] * W / 2, ROBOT_DOMAIN_W["height"] * W / 2
        return np.array([x_in - length, -hw, -hh]), np.array([x_in, hw, hh])
    if spec.shape == "hull":
        return np.array([-2.4, -0.8, -0.8]), np.array([1.0, 0.8, 0.8])
    d = SPHERE_DIAMETER
    return np.array([-15 * d, -6 * d, -6 * d]), np.array([5 * d, 6 * d, 6 * d])


def domain(spec: CaseSpec) -> dict:
    """The meshed box, its blocks, its side patches (symmetry planes or slip walls) and a
    point inside the fluid."""
    lo, hi = full_domain(spec)
    sym = symmetry_axes(spec)
    for ax in sym:
        lo[ax] = 0.0
    base = spec.mesh_spec.base_cell
    cells = [max(1, int(round((hi[i] - lo[i]) / base))) for i in range(3)]
    # Vertex numbering of blockMeshDict.j2: 0 (lo lo lo), 1 (hi lo lo), 2 (hi hi lo),
    # 3 (lo hi lo), 4-7 the same at z hi.
    faces = {"ymin": "0 1 5 4", "ymax": "3 7 6 2", "zmin": "0 3 2 1", "zmax": "4 5 6 7"}
    sides = [
        {
            "name": name,
            "faces": f,
            "symmetry": (name == "ymin" and 1 in sym) or (name == "zmin" and 2 in sym),
        }
        for name, f in faces.items()
    ]
    # A point in the water: near the inlet, off every cell face (irrational fractions).
    loc = lo + (hi - lo) * np.array([0.9 + 0.0123, 0.6 + 0.0137, 0.6 + 0.0171])
    return {
        "lo": [_num(x) for x in lo],
        "hi": [_num(x) for x in hi],
        "cells": cells,
        "sides": sides,
        "symmetry_axes": list(sym),
        "location_in_mesh": [_num(x) for x in loc],
    }


def _num(x: float) -> float:
    return float(f"{float(x):.6g}")


def mesh_settings(spec: CaseSpec, parts) -> dict:
    """snappyHexMesh's levels and refinement boxes around the (turned) body."""
    m = spec.mesh_spec
    lo, hi = geometry.bounds(parts)
    size = hi - lo
    ref = float(size.max())
    near_lo = lo - 0.25 * ref
    near_hi = hi + 0.25 * ref
    wake_lo = lo - np.array([2.0 * ref, 0.5 * ref, 0.5 * ref])  # downstream is -x
    wake_hi = hi + np.array([0.5 * ref, 0.5 * ref, 0.5 * ref])
    boxes = [
        {
            "name": "near",
            "lo": [_num(x) for x in near_lo],
            "hi": [_num(x) for x in near_hi],
            "level": m.near_level,
        },
        {
            "name": "wake",
            "lo": [_num(x) for x in wake_lo],
            "hi": [_num(x) for x in wake_hi],
            "level": m.wake_level,
        },
    ]
    boxes = [b for b in boxes if b["level"] > 0]
    regions = {}
    if m.fin_level is not None:
        regions = {p.name: m.fin_level for p in parts if p.name.startswith("fin_")}
    return {
        "surface_level": m.surface_level,
        "region_levels": regions,
        "boxes": boxes,
        "feature_snap": spec.shape == "robot",
    }


# The parts whose forces are written apart from the whole body's (a ``forces_<part>``
# function object each): snappyHexMesh names a surface's patches ``body_<solid>``. The
# simulator carries the hull's force in its damping and the fins' in its blade elements, so
# the robot's identification needs the two apart.
PART_PATCHES = {"robot": {"hull": ["body_hull"], "fins": ["body_fin_.*"]}}


def solver_settings(spec: CaseSpec, parts) -> dict:
    """What controlDict, fvSolution, the turbulence and the fields need."""
    R = geometry.rotation(spec.pitch_deg, spec.yaw_deg)
    k = 1.5 * (TURBULENCE_INTENSITY * spec.speed) ** 2
    eps = C_MU * k * k / (VISCOSITY_RATIO * NU)
    if spec.shape == "sphere":
        l_ref, a_ref = SPHERE_DIAMETER, math.pi * SPHERE_DIAMETER**2 / 4
    else:
        a, b, c = DEFAULT_ROBOT.body_semi_axes
        l_ref, a_ref = 2 * a, geometry.ellipsoid_frontal_area((a, b, c))
    # forceCoeffs sees the meshed part of the body: scale its area by the kept fraction.
    kept = 0.5 ** len(symmetry_axes(spec))
    return {
        "speed": spec.speed,
        "inflow": [-spec.speed, 0.0, 0.0],
        "drag_dir": [-1, 0, 0],
        "rho": RHO,
        "nu": NU,
        "cofr": [0.0, 0.0, 0.0],
        "l_ref": l_ref,
        "a_ref": a_ref,
        "a_ref_domain": _num(a_ref * kept),
        "body_patches": ["body.*"],
        "part_patches": PART_PATCHES.get(spec.shape, {}),
        "turbulence_model": spec.turbulence_model,
        "nut_wall_function": "nutkWallFunction",
        "turbulence_intensity": TURBULENCE_INTENSITY,
        "viscosity_ratio": VISCOSITY_RATIO,
        "k_inlet": _num(k),
        "epsilon_inlet": _num(eps),
        "max_iterations": spec.mesh_spec.max_iterations,
        "residual_p": 1e-4,
        "residual_u": 1e-5,
        "rotation": R.tolist(),
    }


# --- rendering ---------------------------------------------------------------------------------

# Case file -> template. Every dictionary comes from a template file.
CASE_FILES = {
    "system/blockMeshDict": "blockMeshDict.j2",
    "system/snappyHexMeshDict": "snappyHexMeshDict.j2",
    "system/controlDict": "controlDict.j2",
    "system/fvSchemes": "fvSchemes.j2",
    "system/fvSolution": "fvSolution.j2",
    "constant/turbulenceProperties": "turbulenceProperties.j2",
    "constant/transportProperties": "transportProperties.j2",
    "0/U": "U.j2",
    "0/p": "p.j2",
    "0/k": "k.j2",
    "0/epsilon": "epsilon.j2",
    "0/nut": "nut.j2",
}


def _environment():
    import jinja2

    return jinja2.Environment(
        loader=jinja2.FileSystemLoader(str(TEMPLATES)),
        undefined=jinja2.StrictUndefined,
        keep_trailing_newline=True,
    )


def settings(spec: CaseSpec) -> dict:
    """Everything the templates see (also written to the case as ``case.json``)."""
    parts = body_parts(spec)
    return {
        "case": {**spec.to_json(), "name": spec.name},
        "d": domain(spec),
        "m": mesh_settings(spec, parts),
        "s": solver_settings(spec, parts),
    }


def render(spec: CaseSpec) -> dict[str, str]:
    """The case's dictionaries: relative path -> text."""
    env = _environment()
    ctx = settings(spec)
    return {
        path: env.get_template(t).render(template_name=t, **ctx) for path, t in CASE_FILES.items()
    }


def write_case(spec: CaseSpec, folder) -> pathlib.Path:
    """Writes the case (dictionaries, ``constant/triSurface/body.stl``, ``case.json``) into
    ``folder``."""
    folder = pathlib.Path(folder)
    for rel, text in render(spec).items():
        path = folder / rel
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text)
    parts = body_parts(spec)
    geometry.write_stl(folder / "constant" / "triSurface" / "body.stl", parts)
    areas = {p.name: geometry.area(p) for p in parts}
    (folder / "case.json").write_text(json.dumps({**settings(spec), "part_areas": areas}, indent=1))
    return folder


# --- reading dictionaries back -----------------------------------------------------------------

_TOKEN = re.compile(r'"[^"]*"|[(){};]|[^\s(){};"]+')


def _tokens(text: str) -> list[str]:
    """OpenFOAM's tokens; a word that runs straight into "(" (``div(phi,U)``,
    ``grad(U)``) keeps its balanced parentheses, as OpenFOAM's keywords do."""
    out, depth, end = [], 0, -1
    for m in _TOKEN.finditer(text):
        tok = m.group(0)
        if depth > 0:  # inside a word's parentheses
            out[-1] += tok
            depth += (tok == "(") - (tok == ")")
        elif (
            tok == "("
            and out
            and m.start() == end
            and out[-1][:1].isalpha()
            and out[-1] not in "(){};"
        ):
            out[-1] += tok
            depth = 1
        else:
            out.append(tok)
        end = m.end()
    return out


def parse_foam(text: str) -> dict:
    """Parses an OpenFOAM dictionary file (the subset the templates write: keywords, words,
    numbers, quoted strings, ( lists ) and { dictionaries }, // and /* */ comments) into
    Python: dicts, lists, floats/ints and strings. An entry of several values is a list."""
    text = re.sub(r"/\*.*?\*/", " ", text, flags=re.S)
    text = re.sub(r"//[^\n]*", " ", text)
    tokens = _tokens(text)
    pos = 0

    def atom(t):
        if t.startswith('"'):
            return t[1:-1]
        try:
            return int(t)
        except ValueError:
            pass
        try:
            return float(t)
        except ValueError:
            return t

    def value():
        nonlocal pos
        t = tokens[pos]
        if t == "(":
            pos += 1
            out = []
            while tokens[pos] != ")":
                out.append(value())
            pos += 1
            return out
        if t == "{":
            pos += 1
            out = dictionary("}")
            pos += 1
            return out
        pos += 1
        return atom(t)

    def dictionary(end):
        nonlocal pos
        out = {}
        while pos < len(tokens) and tokens[pos] != end:
            key = atom(tokens[pos])
            pos += 1
            if tokens[pos] == "{":
                pos += 1
                out[key] = dictionary("}")
                pos += 1
                continue
            vals = []
            while tokens[pos] != ";":
                vals.append(value())
            pos += 1
            out[key] = vals[0] if len(vals) == 1 else vals
        return out

    return dictionary(None)
