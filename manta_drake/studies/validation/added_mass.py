"""Added mass of the robot's own geometry by capytaine (BEM) against the closed forms.

``manta-drake study validation --section added-mass [--runs DIR] [--out DIR]`` (capytaine is a
boundary-element potential-flow solver, the ``validation`` extra).

Cases (every matrix is the 6x6 added-mass matrix of a rigid motion, about the hull's origin in
the Drake body frame (x forward, y left, z up), rows and columns surge, sway, heave, roll,
pitch, yaw; kg, kg m and kg m^2):

(a) the hull alone, the ellipsoid ``RobotParams.body_semi_axes``, against Lamb's exact values
    (``model.potential_flow.ellipsoid_added_mass``) at 512, 1152 and 3872 panels;
(b) one proximal and one distal fin plate alone, each a box of the SDFormat model's size
    (``model_sdf.fin_plate_geometry``: thickness x chord x span): heave normal to the plate
    and roll about its hinge line (the plate's root chord line: roll1 for the proximal, roll2
    for the distal plate) against the 2-D strip values (``coefficients.plate_added_mass_per_
    span``: rho pi c^2/4 per span, times the span; and times span^2/3 about the root) and the
    3-D rectangular plate of DNV-RP-H103 (2011) Appendix A Table A-2
    (A = C_A rho pi/4 a^2 b, a the short side, C_A interpolated in b/a), and feathering about
    the span line against rho pi c^4/128 per span; a mesh convergence at the real 12 mm, then
    6 and 3 mm for the thin-plate limit (linear in the thickness); and the elliptic plate
    inscribed in each (an ellipsoid, so Lamb is exact for it) as a thin body with an exact
    answer;
(c) the whole robot, the hull and the 8 plates posed by the model's forward kinematics at a
    joint configuration (the SDFormat's link poses, ``kinematics.link_poses_at_zero``, each
    joint turning its child link about the link's z axis), at the flat pose and two stroke
    poses of the swim gait, at three panel sizes; with the isolated parts (the hull, each
    plate, each fin, the four fins) at the middle size, and the added inertia about each
    fin's joints (roll1, pitch, roll2, the fin turning alone about its joint axis inside the
    whole robot: generalised modes of the same solve) against
    ``coefficients.fin_hinge_added_inertia``.

The fluid is unbounded (``free_surface=inf``, ``water_depth=inf``: the added-mass matrix is then
the matrix at any frequency) and every solve uses capytaine's direct (Green's identity)
method: its default (source) formulation converges only as O(h) (a sphere +3 % at 800
panels, an ellipsoid still +2 % at 3872, where the direct method is within 0.1-0.3 %).

Capytaine cannot mesh a zero-thickness sheet, so each plate is a closed box of the model's
12 mm thickness. The parts of the whole robot overlap (the plates' roots cut the hull's rim,
the two plates of a fin share their joint face): the robot's surface is the union's, made by
splitting the panels that cross another part (``SEAM_DEPTH`` times in four) and dropping every
panel whose centre lies inside (or on) another part (``union_panels``); what is left is the
wetted surface up to a seam h / 2^SEAM_DEPTH wide where a plate enters the hull.
"""

from __future__ import annotations

import dataclasses as dc
import datetime
import math
import pathlib
import sys
import time

import numpy as np

from manta_drake.model.kinematics import link_poses_at_zero, rot_z
from manta_drake.model.model_sdf import fin_plate_geometry
from manta_drake.model.robot_params import DEFAULT_ROBOT, JOINTS, LEGS, RobotParams
from manta_drake.studies import REPO
from manta_drake.studies.options import StudyParser
from manta_drake.studies.validation import (
    ValidationError,
    add_folder_options,
    check_runs,
    page_path,
    reference_file,
    render_template,
    round_floats,
    run_module,
    write_results,
)

SECTION = "added-mass"
COMMAND = "manta-drake study validation --section added-mass"
YAML_PATH = REPO / "models" / "reference" / "added_mass_bem.yaml"
TEMPLATE = "added_mass.md.j2"
DOFS = ("surge", "sway", "heave", "roll", "pitch", "yaw")
METHOD = "direct"

# DNV-RP-H103 (April 2011), Appendix A, Table A-2 "Analytical added mass coefficient for
# three-dimensional bodies", rectangular plates in normal motion: b/a -> C_A, with
# A = C_A rho pi/4 a^2 b (a the short side); C_A -> 1 (the strip value) as b/a -> infinity.
DNV_RECTANGULAR_PLATE_CA = (
    (1.00, 0.579),
    (1.25, 0.642),
    (1.50, 0.690),
    (1.59, 0.704),
    (2.00, 0.757),
    (2.50, 0.801),
    (3.00, 0.830),
    (3.17, 0.840),
    (4.00, 0.872),
    (5.00, 0.897),
    (6.25, 0.917),
    (8.00, 0.934),
    (10.00, 0.947),
)

# The cases' meshes. (a): lat-long ellipsoid meshes of n x 2n panels.
HULL_N = (16, 24, 44)  # 512, 1152, 3872 panels
# (b): panel size [m] for the convergence at the model's thickness; thicknesses for the
# thin-plate limit at the finest size.
PLATE_H = (0.010, 0.007, 0.005)
PLATE_THICKNESS = (0.012, 0.006, 0.003)
# (c): panel size [m] of the plates, and n of the hull's n x 2n mesh, per level.
ROBOT_LEVELS = ((0.024, 12), (0.017, 18), (0.012, 26))
PARTS_LEVEL = 1  # the isolated parts and the whole compared at this level


def _pose_q(roll1_deg=0.0, pitch_left_deg=0.0, pitch_right_deg=0.0):
    """4x4 joint angles [rad] (rows fl, fr, rl, rr; columns yaw, roll1, pitch, roll2)."""
    q = np.zeros((4, 4))
    q[:, 1] = math.radians(roll1_deg)
    for k, leg in enumerate(LEGS):
        q[k, 2] = math.radians(pitch_left_deg if leg[1] == "l" else pitch_right_deg)
    return q


# The swim gait (models/gaits.yaml ``swim``: roll1 and pitch amplitudes 45 deg, the right fins'
# pitch the mirror of the left ones'): the flat pose, the stroke's top (roll1 +45 deg, every tip
# up) and the same feathered (pitch +45 deg left, -45 deg right, so the pose stays symmetric).
POSES = {
    "flat": ("q = 0", _pose_q()),
    "stroke": ("roll1 +45 deg on all four fins, pitch 0", _pose_q(45.0)),
    "stroke_feathered": (
        "roll1 +45 deg, pitch +45 deg (left fins) / -45 deg (right fins, the swim gait's mirror)",
        _pose_q(45.0, 45.0, -45.0),
    ),
}


# --- references ---------------------------------------------------------------------------------


def dnv_rectangular_plate_ca(aspect: float) -> float:
    """C_A of DNV-RP-H103 Table A-2 for a rectangular plate of side ratio ``aspect`` = b/a
    >= 1, linear between the tabulated ratios (1 beyond them as b/a -> infinity is not
    interpolated: refused past 10)."""
    ratios, values = zip(*DNV_RECTANGULAR_PLATE_CA)
    if not ratios[0] <= aspect <= ratios[-1]:
        raise ValueError(f"side ratio {aspect:.3g} outside DNV-RP-H103 Table A-2's 1..10")
    return float(np.interp(aspect, ratios, values))


def dnv_plate_heave(chord: float, span: float, rho: float) -> tuple[float, float]:
    """(C_A, added mass [kg]) of a thin rectangular plate moving normal to itself,
    DNV-RP-H103 Table A-2: C_A rho pi/4 a^2 b with a the short side."""
    a, b = sorted((chord, span))
    ca = dnv_rectangular_plate_ca(b / a)
    return ca, ca * rho * math.pi / 4.0 * a * a * b


def strip_plate_heave(chord: float, span: float, rho: float) -> float:
    """2-D strip added mass of a plate of ``chord`` over ``span`` moving normal to itself:
    rho pi c^2/4 per span (Lewis, PNA 1989), times the span [kg]."""
    from manta_drake.model.coefficients import plate_added_mass_per_span

    return plate_added_mass_per_span(chord, rho) * span


def strip_plate_hinge_roll(chord: float, span: float, rho: float) -> float:
    """2-D strip added inertia of the same plate rolling about its root chord line:
    rho pi c^2/4 int_0^span r^2 dr [kg m^2]."""
    from manta_drake.model.coefficients import plate_added_mass_per_span

    return plate_added_mass_per_span(chord, rho) * span**3 / 3.0


def strip_plate_feather(chord: float, span: float, rho: float) -> float:
    """2-D strip added inertia of the plate turning about its mid-chord span line:
    rho pi c^4/128 per span, times the span [kg m^2]."""
    from manta_drake.model.coefficients import plate_added_inertia_per_span

    return plate_added_inertia_per_span(chord, rho) * span


def water_density() -> float:
    """The model's water density [kg/m^3] (models/hydrodynamics.yaml)."""
    from manta_drake.model.coefficients import load_coefficients

    return float(load_coefficients().water_density.value)


# --- geometry -----------------------------------------------------------------------------------


def link_poses(leg: str, q, params: RobotParams = DEFAULT_ROBOT) -> list[np.ndarray]:
    """The poses (4x4) of a leg-fin's links 1..4 in the Drake body frame at its joint angles
    ``q`` (yaw, roll1, pitch, roll2): the SDFormat's link poses at q = 0
    (``kinematics.link_poses_at_zero``), each joint turning its child link about the link's
    own z axis at its origin, as the plant does."""
    q = np.asarray(q, dtype=float).reshape(len(JOINTS))
    poses = link_poses_at_zero(leg, params)
    X = poses["X_Body_L1"] @ rot_z(q[0])
    out = [X]
    for i, X_prev_L in enumerate(poses["X_Lprev_L"], start=1):
        X = X @ X_prev_L @ rot_z(q[i])
        out.append(X)
    return out


@dc.dataclass(frozen=True)
class Box:
    """A closed box: edge lengths ``size`` along the axes of ``pose`` (4x4, its centre and axes
    in the body frame); ``splits`` are extra mesh lines per local axis (centred coordinates),
    so a face meets a neighbour's edge on a mesh line."""

    name: str
    pose: np.ndarray
    size: tuple
    splits: tuple = ((), (), ())

    def contains(self, points, tol: float = 1e-9) -> np.ndarray:
        """Whether each point (n, 3) is inside the box or on its surface (within ``tol``;
        a negative ``tol``: strictly inside by that much)."""
        local = (np.asarray(points) - self.pose[:3, 3]) @ self.pose[:3, :3]
        return np.all(np.abs(local) <= np.asarray(self.size) / 2.0 + tol, axis=1)

    def quads(self, h: float) -> np.ndarray:
        """The surface as quadrilaterals (n, 4, 3) of side <= ``h``, outward normals."""
        local = box_quads(self.size, h, self.splits)
        return local @ self.pose[:3, :3].T + self.pose[:3, 3]


@dc.dataclass(frozen=True)
class Ellipsoid:
    """The hull: an ellipsoid of ``semi_axes`` centred at the body origin, body axes."""

    name: str
    semi_axes: tuple

    def contains(self, points, tol: float = 1e-9) -> np.ndarray:
        """Whether each point (n, 3) is inside the ellipsoid or on it (within ``tol`` in the
        normalised radius squared; a negative ``tol``: strictly inside by that much)."""
        r2 = ((np.asarray(points) / np.asarray(self.semi_axes)) ** 2).sum(axis=1)
        return r2 <= 1.0 + tol

    def quads(self, n: int) -> np.ndarray:
        """A lat-long mesh of n x 2n panels (the poles on z), vertices on the surface."""
        return ellipsoid_quads(self.semi_axes, n)


def _breaks(length: float, h: float, extra=()) -> np.ndarray:
    """Mesh lines on [-length/2, length/2] at most ``h`` apart, through every ``extra``."""
    half = length / 2.0
    points = sorted({-half, half, *(float(e) for e in extra if -half < e < half)})
    out = [points[0]]
    for a, b in zip(points[:-1], points[1:]):
        n = max(1, math.ceil((b - a) / h - 1e-9))
        out.extend(np.linspace(a, b, n + 1)[1:])
    return np.array(out)


def box_quads(size, h: float, splits=((), (), ())) -> np.ndarray:
    """The six faces of a box of edge lengths ``size`` centred at the origin, as quads
    (n, 4, 3) with counter-clockwise vertices seen from outside."""
    lines = [_breaks(size[k], h, splits[k]) for k in range(3)]
    quads = []
    for k in range(3):
        i, j = (k + 1) % 3, (k + 2) % 3  # e_i x e_j = e_k
        u0, v0 = np.meshgrid(lines[i][:-1], lines[j][:-1], indexing="ij")
        u1, v1 = np.meshgrid(lines[i][1:], lines[j][1:], indexing="ij")
        u0, v0, u1, v1 = (a.ravel() for a in (u0, v0, u1, v1))
        for sign in (1.0, -1.0):
            corners = [(u0, v0), (u1, v0), (u1, v1), (u0, v1)]
            if sign < 0:
                corners = corners[::-1]
            face = np.zeros((len(u0), 4, 3))
            for c, (u, v) in enumerate(corners):
                face[:, c, k] = sign * size[k] / 2.0
                face[:, c, i] = u
                face[:, c, j] = v
            quads.append(face)
    return np.concatenate(quads)


def ellipsoid_quads(semi_axes, n: int) -> np.ndarray:
    """A lat-long mesh of an ellipsoid: n panels along a meridian, 2n around, as quads
    (the pole panels are triangles: a quad with a repeated vertex), outward normals."""
    theta = np.linspace(0.0, math.pi, n + 1)
    phi = np.linspace(0.0, 2.0 * math.pi, 2 * n + 1)
    a, b, c = semi_axes

    def point(t, p):
        return np.stack(
            [a * np.sin(t) * np.cos(p), b * np.sin(t) * np.sin(p), -c * np.cos(t)], axis=-1
        )

    t0, p0 = np.meshgrid(theta[:-1], phi[:-1], indexing="ij")
    t1, p1 = np.meshgrid(theta[1:], phi[1:], indexing="ij")
    # theta from the south pole (z = -c) up, phi counter-clockwise about z: (t0,p0), (t0,p1),
    # (t1,p1), (t1,p0) is counter-clockwise seen from outside.
    quads = np.stack([point(t0, p0), point(t0, p1), point(t1, p1), point(t1, p0)], axis=2)
    quads = quads.reshape(-1, 4, 3)
    # Exact poles, so the degenerate edge is one vertex.
    quads[np.isclose(quads[:, :, 2], -c) & (np.abs(quads[:, :, 0]) < 1e-12)] = (0.0, 0.0, -c)
    quads[np.isclose(quads[:, :, 2], c) & (np.abs(quads[:, :, 0]) < 1e-12)] = (0.0, 0.0, c)
    return quads


def hull(params: RobotParams = DEFAULT_ROBOT) -> Ellipsoid:
    return Ellipsoid("hull", tuple(float(s) for s in params.body_semi_axes))


def fin_plates(
    leg: str, q, params: RobotParams = DEFAULT_ROBOT, thickness: float | None = None
) -> tuple[Box, Box]:
    """A leg-fin's proximal (link 3) and distal (link 4) plates at its joint angles ``q``:
    the SDFormat model's boxes (``model_sdf.fin_plate_geometry``), in the body frame. The
    proximal plate's chord is split where the narrower distal plate meets its tip face."""
    g = fin_plate_geometry(params)
    X = link_poses(leg, q, params)
    boxes = []
    for name, X_link, splits in (
        ("proximal", X[2], ((), (-params.distal_chord / 2, params.distal_chord / 2), ())),
        ("distal", X[3], ((), (), ())),
    ):
        size = list(g[name]["size"])
        if thickness is not None:
            size[0] = thickness
        pose = X_link.copy()
        pose[:3, 3] = X_link[:3, :3] @ np.asarray(g[name]["center"]) + X_link[:3, 3]
        boxes.append(Box(f"{leg}_{name}", pose, tuple(size), splits))
    return boxes[0], boxes[1]


def robot_parts(q, params: RobotParams = DEFAULT_ROBOT) -> list:
    """The hull and the 8 plates at the joint angles ``q`` (4x4, rows fl, fr, rl, rr)."""
    q = np.asarray(q, dtype=float).reshape(4, 4)
    parts = [hull(params)]
    for k, leg in enumerate(LEGS):
        parts.extend(fin_plates(leg, q[k], params))
    return parts


SEAM_DEPTH = 2  # panels crossing another part are split 4-fold this many times (h/4)
_SAMPLES = np.linspace(0.0, 1.0, 5)


def _bilinear(quads, u, v) -> np.ndarray:
    """Points of the quads (n, 4, 3) at the bilinear coordinates u, v (arrays of one shape)."""
    p0, p1, p2, p3 = (quads[:, k, None, :] for k in range(4))
    u, v = u.ravel()[None, :, None], v.ravel()[None, :, None]
    return (1 - u) * (1 - v) * p0 + u * (1 - v) * p1 + u * v * p2 + (1 - u) * v * p3


def split_quads(quads) -> np.ndarray:
    """Each quad (n, 4, 3) split in four at its bilinear midpoints (same orientation)."""
    g = np.array([0.0, 0.5, 1.0])
    u, v = np.meshgrid(g, g, indexing="ij")
    p = _bilinear(quads, u, v).reshape(len(quads), 3, 3, 3)
    out = [
        np.stack([p[:, i, j], p[:, i + 1, j], p[:, i + 1, j + 1], p[:, i, j + 1]], axis=1)
        for i in range(2)
        for j in range(2)
    ]
    return np.concatenate(out)


def union_panels(
    parts, h: float, hull_n: int, seam_depth: int = SEAM_DEPTH
) -> tuple[np.ndarray, np.ndarray, dict]:
    """The panels of the union of ``parts``: each part's mesh (boxes at panel size ``h``,
    the hull at ``hull_n``) less what lies inside another part.

    A panel partly inside another part (some of 5 x 5 points on it strictly inside) is split
    in four, ``seam_depth`` times, so the seam where a plate enters the hull is resolved to
    h / 2^seam_depth; then every panel whose centre is inside or on another part (a face the
    two plates of a fin share) is dropped. Without the splitting, a coarse hull panel can
    cross a 12 mm plate with its centre a fraction of a millimetre off the plate's face, and
    the solve is then wrong by an order of magnitude (a heave added mass of 455 kg instead
    of 31 kg at 17 mm).

    Returns:
        (quads (n, 4, 3), the part index of each quad, per part name the panels ``kept``,
        ``dropped`` (their count) and ``split`` (panels made by splitting))."""
    u, v = np.meshgrid(_SAMPLES, _SAMPLES, indexing="ij")
    kept, owner, counts = [], [], {}
    for i, part in enumerate(parts):
        quads = part.quads(hull_n) if isinstance(part, Ellipsoid) else part.quads(h)
        others = [p for j, p in enumerate(parts) if j != i]
        n_split = 0
        for _ in range(seam_depth):
            points = _bilinear(quads, u, v)
            flat = points.reshape(-1, 3)
            strictly = np.zeros(len(flat), dtype=bool)
            for other in others:
                strictly |= other.contains(flat, tol=-1e-9)
            strictly = strictly.reshape(len(quads), -1)
            crossing = strictly.any(axis=1) & ~strictly.all(axis=1)
            if not crossing.any():
                break
            parts_split = split_quads(quads[crossing])
            n_split += len(parts_split)
            quads = np.concatenate([quads[~crossing], parts_split])
        centres = quads.mean(axis=1)
        inside = np.zeros(len(quads), dtype=bool)
        for other in others:
            inside |= other.contains(centres)
        kept.append(quads[~inside])
        owner.append(np.full(int((~inside).sum()), i))
        counts[part.name] = {
            "kept": int((~inside).sum()),
            "dropped": int(inside.sum()),
            "split": n_split,
        }
    return np.concatenate(kept), np.concatenate(owner), counts


# --- the solver ---------------------------------------------------------------------------------


def _capytaine():
    try:
        import capytaine as cpt
    except ImportError:
        raise ValidationError(
            "capytaine is not installed: pip install -e '.[validation]' (or "
            "pip install 'capytaine>=3.0,<3.1')"
        ) from None
    cpt.set_logging("ERROR")  # thin boxes: "aspect ratio > 5" warnings are harmless here
    return cpt


def capytaine_version() -> str:
    return str(_capytaine().__version__)


def rigid_mode(axis, point) -> np.ndarray:
    """The origin-based rigid velocity (surge..yaw) of a rotation at unit rate about ``axis``
    through ``point``: linear (point x axis), angular axis."""
    e = np.asarray(axis, float) / np.linalg.norm(axis)
    return np.concatenate([np.cross(np.asarray(point, float), e), e])


def solve_added_mass(
    quads, rho: float, owner=None, modes=None, label: str = "", verbose: bool = True
) -> dict:
    """The added-mass matrix of the rigid body meshed by ``quads`` (n, 4, 3) about the body
    origin (6x6), and of the generalised ``modes`` (name -> (part indices, axis, point): those
    parts turning at unit rate about the axis through the point, the rest still), by
    capytaine's direct method in an unbounded fluid.

    Returns:
        dict with ``matrix`` (6x6, rows and columns surge..yaw), ``modes`` (name -> the mode's
        own added inertia, and ``coupling``: its force on the six rigid modes), ``panels``,
        ``seconds``."""
    cpt = _capytaine()
    quads = np.asarray(quads, float)
    vertices = quads.reshape(-1, 3)
    faces = np.arange(len(vertices)).reshape(-1, 4)
    metadata = {"part": np.asarray(owner if owner is not None else np.zeros(len(quads), int))}
    mesh = cpt.Mesh(vertices, faces, faces_metadata=metadata, name=label or "body")
    dofs = cpt.rigid_body_dofs(rotation_center=(0.0, 0.0, 0.0))
    body = cpt.FloatingBody(mesh=mesh, dofs=dofs, name=label or "body")
    rigid = list(body.dofs)
    centres = np.asarray(body.mesh.faces_centers)
    part = np.asarray(body.mesh.faces_metadata["part"])
    for name, (parts, axis, point) in (modes or {}).items():
        s = rigid_mode(axis, point)
        motion = s[:3] + np.cross(s[3:], centres)
        motion[~np.isin(part, list(parts))] = 0.0
        body.dofs[name] = motion
    solver = cpt.BEMSolver()
    names = list(body.dofs)
    A = np.zeros((len(names), len(names)))
    started = time.time()
    # The six rigid modes give the 6x6; a generalised mode gives its own column (its added
    # inertia and its force on the rigid modes); the matrices and their LU are built once.
    for j, dof in enumerate(names):
        problem = cpt.RadiationProblem(
            body=body,
            radiating_dof=dof,
            free_surface=np.inf,
            water_depth=np.inf,
            omega=np.inf,
            rho=rho,
        )
        result = solver.solve(problem, method=METHOD, keep_details=False)
        for i, other in enumerate(names):
            A[i, j] = float(np.real(result.added_masses[other]))
    seconds = time.time() - started
    if verbose:
        print(
            f"  {label}: {body.mesh.nb_faces} panels, {len(names)} modes, {seconds:.1f} s",
            flush=True,
        )
    out = {"matrix": A[:6, :6], "panels": int(body.mesh.nb_faces), "seconds": seconds, "modes": {}}
    for k, name in enumerate(names[6:], start=6):
        out["modes"][name] = {"inertia": float(A[k, k]), "coupling": A[:6, k].tolist()}
    assert rigid == ["Surge", "Sway", "Heave", "Roll", "Pitch", "Yaw"], rigid
    return out


def matrix_about(A, point) -> np.ndarray:
    """The 6x6 added-mass matrix ``A`` (about the origin) moved to ``point`` (same axes)."""
    T = np.eye(6)
    # Velocity at the origin of a motion (v_P, w) given at P: v_O = v_P + w x (O - P).
    T[:3, 3:] = _skew(np.asarray(point, float))
    return T.T @ np.asarray(A) @ T


def _skew(r) -> np.ndarray:
    x, y, z = r
    return np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])


# --- the cases ----------------------------------------------------------------------------------


def hull_case(
    params: RobotParams = DEFAULT_ROBOT, rho: float = 1000.0, levels=HULL_N, verbose: bool = True
) -> dict:
    """(a) the hull alone at each lat-long mesh ``levels`` (n x 2n panels) against Lamb."""
    from manta_drake.model.coefficients import body_added_mass_strip_theory
    from manta_drake.model.potential_flow import ellipsoid_added_mass

    shape = hull(params)
    mass, inertia = ellipsoid_added_mass(shape.semi_axes, rho)
    lamb = np.concatenate([mass, inertia])
    strip = body_added_mass_strip_theory(shape.semi_axes, rho)
    out = {
        "semi_axes": list(shape.semi_axes),
        "lamb": lamb.tolist(),
        "strip_theory": np.concatenate([strip["mass"], strip["inertia"]]).tolist(),
        "meshes": [],
    }
    if verbose:
        print("(a) hull alone against Lamb", flush=True)
    for n in levels:
        r = solve_added_mass(shape.quads(n), rho, label=f"hull n={n}", verbose=verbose)
        A = r["matrix"]
        diag = np.diag(A)
        off = np.abs(A - np.diag(diag)).max() / np.abs(diag).max()
        out["meshes"].append(
            {
                "n": n,
                "panels": r["panels"],
                "seconds": r["seconds"],
                "diagonal": diag.tolist(),
                "error": (diag / lamb - 1).tolist(),
                "off_diagonal_max_rel": float(off),
                "matrix": A.tolist(),
            }
        )
    return out


def plate_box(
    which: str, params: RobotParams = DEFAULT_ROBOT, thickness: float | None = None
) -> tuple[Box, dict]:
    """One plate alone in its link's frame (the joint at the origin), and its axes there:
    ``normal`` (heave), ``hinge`` (the joint axis at its root: roll1 for the proximal plate,
    roll2 for the distal one), ``span`` (the feathering axis through mid-chord), its chord
    and span."""
    g = fin_plate_geometry(params)[which]
    size = list(g["size"])
    if thickness is not None:
        size[0] = thickness
    pose = np.eye(4)
    pose[:3, 3] = g["center"]
    if which == "proximal":  # link 3: x normal, y chord (the roll1 axis), z span
        axes = {"normal": (1, 0, 0), "hinge": (0, 1, 0), "span": (0, 0, 1)}
        chord, span = size[1], size[2]
    else:  # link 4: x normal, -y span, z chord (the roll2 axis)
        axes = {"normal": (1, 0, 0), "hinge": (0, 0, 1), "span": (0, -1, 0)}
        chord, span = size[2], size[1]
    info = {
        "chord": chord,
        "span": span,
        "thickness": size[0],
        "axes": axes,
        "centre": list(g["center"]),
    }
    return Box(which, pose, tuple(size)), info


def plate_case(
    params: RobotParams = DEFAULT_ROBOT,
    rho: float = 1000.0,
    sizes=PLATE_H,
    thicknesses=PLATE_THICKNESS,
    verbose: bool = True,
) -> dict:
    """(b) each plate alone: heave normal to it, roll about its hinge, feathering about its
    span line, against strip theory and DNV-RP-H103; the mesh convergence at the model's
    thickness, then the thinner plates at the finest size."""
    if verbose:
        print("(b) plates alone against strip theory and DNV-RP-H103", flush=True)
    out = {}
    for which in ("proximal", "distal"):
        _, info = plate_box(which, params)
        c, s = info["chord"], info["span"]
        entry = _plate_theory(c, s, rho)
        runs = [(h, params.fin_thickness) for h in sizes]
        runs += [(sizes[-1], t) for t in thicknesses if not math.isclose(t, params.fin_thickness)]
        for h, t in runs:
            entry["runs"].append(_plate_run(which, params, h, t, rho, verbose))
        entry["elliptic"] = elliptic_plate_case(c, s, params.fin_thickness, rho, verbose)
        thin_limit = _thin_limit(entry["runs"], sizes[-1])
        if thin_limit is not None:
            entry["thin_limit"] = thin_limit
        out[which] = entry
    return out


def _plate_theory(chord: float, span: float, rho: float) -> dict:
    """A plate's added masses by DNV-RP-H103 and by strip theory (heave, roll about its
    hinge, feathering), and an empty list of ``runs`` for the BEM's."""
    ca, dnv = dnv_plate_heave(chord, span, rho)
    return {
        "chord": chord,
        "span": span,
        "aspect": max(chord, span) / min(chord, span),
        "dnv_ca": ca,
        "dnv_heave": dnv,
        "strip_heave": strip_plate_heave(chord, span, rho),
        "strip_hinge_roll": strip_plate_hinge_roll(chord, span, rho),
        "strip_feather": strip_plate_feather(chord, span, rho),
        "dnv_hinge_roll": ca * strip_plate_hinge_roll(chord, span, rho),
        "runs": [],
    }


def _plate_run(which: str, params: RobotParams, h: float, t: float, rho: float, verbose: bool):
    """The BEM on plate ``which`` of thickness ``t`` with panels of size ``h``: its matrix
    about the joint in the link's axes, and from it the heave, hinge roll and feathering
    added masses."""
    box, info = plate_box(which, params, thickness=t)
    r = solve_added_mass(
        box.quads(h),
        rho,
        label=f"{which} t={t * 1e3:.0f} mm h={h * 1e3:.0f} mm",
        verbose=verbose,
    )
    A = r["matrix"]  # about the joint, link axes
    ax = info["axes"]
    centre = np.asarray(info["centre"])
    heave = rigid_mode_translation(ax["normal"])
    hinge_roll = rigid_mode(ax["hinge"], (0, 0, 0))
    feather = rigid_mode(ax["span"], centre)
    return {
        "thickness": t,
        "h": h,
        "panels": r["panels"],
        "seconds": r["seconds"],
        "heave": float(heave @ A @ heave),
        "hinge_roll": float(hinge_roll @ A @ hinge_roll),
        "feather": float(feather @ A @ feather),
        "matrix_about_joint": A.tolist(),
    }


def _thin_limit(runs: list[dict], h_fine: float) -> dict | None:
    """The added masses at zero thickness, linear in the thickness through the two thinnest
    runs at the panel size ``h_fine``; None with fewer than two."""
    fine = [r for r in runs if math.isclose(r["h"], h_fine)]
    fine.sort(key=lambda r: -r["thickness"])
    if len(fine) < 2:
        return None
    a, b = fine[-2], fine[-1]
    k = {
        q: (a[q] - b[q]) / (a["thickness"] - b["thickness"])
        for q in ("heave", "hinge_roll", "feather")
    }
    return {q: b[q] - k[q] * b["thickness"] for q in k}


ELLIPTIC_N = (24, 32)  # 1152, 2048 panels


def elliptic_plate_case(
    chord: float, span: float, thickness: float, rho: float, verbose: bool = True, levels=ELLIPTIC_N
) -> dict:
    """A thin body with an exact answer: the elliptic plate inscribed in the rectangular one
    (semi-axes chord/2, span/2, thickness/2) is an ellipsoid, so Lamb gives its heave added
    mass exactly; capytaine's error on it at ``levels`` (n x 2n panels, the poles on the
    thin axis)."""
    from manta_drake.model.potential_flow import ellipsoid_added_mass

    axes = (chord / 2.0, span / 2.0, thickness / 2.0)
    lamb = float(ellipsoid_added_mass(axes, rho)[0][2])
    out = {"semi_axes": list(axes), "lamb_heave": lamb, "runs": []}
    for n in levels:
        r = solve_added_mass(
            ellipsoid_quads(axes, n),
            rho,
            label=f"elliptic plate {chord:g} x {span:g} n={n}",
            verbose=verbose,
        )
        heave = float(r["matrix"][2, 2])
        out["runs"].append(
            {
                "n": n,
                "panels": r["panels"],
                "seconds": r["seconds"],
                "heave": heave,
                "error": heave / lamb - 1.0,
            }
        )
    return out


def rigid_mode_translation(axis) -> np.ndarray:
    e = np.asarray(axis, float) / np.linalg.norm(axis)
    return np.concatenate([e, np.zeros(3)])


def joint_modes(q, params: RobotParams = DEFAULT_ROBOT, part_index=None) -> dict:
    """The fins' joint modes at ``q``: name -> (part indices, axis, point) for ``roll1``
    (both plates about link 2's z axis), ``pitch`` (both plates about link 3's z) and
    ``roll2`` (the distal plate about link 4's z), per leg; ``part_index`` maps a plate's name
    to its index in the parts list."""
    q = np.asarray(q, dtype=float).reshape(4, 4)
    modes = {}
    for k, leg in enumerate(LEGS):
        X = link_poses(leg, q[k], params)
        prox, dist = part_index[f"{leg}_proximal"], part_index[f"{leg}_distal"]
        modes[f"{leg}_roll1"] = ((prox, dist), X[1][:3, 2], X[1][:3, 3])
        modes[f"{leg}_pitch"] = ((prox, dist), X[2][:3, 2], X[2][:3, 3])
        modes[f"{leg}_roll2"] = ((dist,), X[3][:3, 2], X[3][:3, 3])
    return modes


def robot_case(
    params: RobotParams = DEFAULT_ROBOT,
    rho: float = 1000.0,
    poses=None,
    levels=ROBOT_LEVELS,
    parts_level: int = PARTS_LEVEL,
    verbose: bool = True,
) -> dict:
    """(c) the whole robot at each pose and level; the isolated parts at ``parts_level``."""
    from manta_drake.model.coefficients import fin_hinge_added_inertia

    poses = POSES if poses is None else poses
    out = {
        "levels": [{"h": h, "hull_n": n} for h, n in levels],
        "parts_level": parts_level,
        "strip_hinge_inertia": dict(zip(JOINTS, fin_hinge_added_inertia(params, rho).tolist())),
        "poses": {},
    }
    for name, (text, q) in poses.items():
        if verbose:
            print(f"(c) robot, pose {name}: {text}", flush=True)
        parts = robot_parts(q, params)
        index = {p.name: i for i, p in enumerate(parts)}
        entry = {
            "description": text,
            "q_deg": np.degrees(q).tolist(),
            "meshes": [],
            "plate_normals": {p.name: p.pose[:3, 0].tolist() for p in parts[1:]},
        }
        for level, (h, n) in enumerate(levels):
            quads, owner, counts = union_panels(parts, h, n)
            modes = joint_modes(q, params, index) if level == len(levels) - 1 else None
            r = solve_added_mass(
                quads,
                rho,
                owner=owner,
                modes=modes,
                label=f"robot {name} h={h * 1e3:.0f} mm",
                verbose=verbose,
            )
            mesh = {
                "h": h,
                "hull_n": n,
                "panels": r["panels"],
                "seconds": r["seconds"],
                "dropped_panels": sum(c["dropped"] for c in counts.values()),
                "matrix": r["matrix"].tolist(),
            }
            if r["modes"]:
                mesh["joint_modes"] = r["modes"]
            entry["meshes"].append(mesh)
        entry["parts"] = isolated_parts(parts, levels[parts_level], rho, name, verbose)
        entry["whole_at_parts_level"] = entry["meshes"][parts_level]["matrix"]
        out["poses"][name] = entry
    return out


def isolated_parts(parts, level, rho: float, pose: str, verbose: bool = True) -> dict:
    """The 6x6 (about the body origin) of each part alone, of each fin alone (its two
    plates), of the four fins without the hull; and their sums."""
    h, n = level
    out = {
        "hull": solve_added_mass(
            parts[0].quads(n), rho, label=f"{pose}: hull alone", verbose=verbose
        )["matrix"].tolist(),
        "plates": {},
        "fins": {},
    }
    plates = parts[1:]
    for p in plates:
        out["plates"][p.name] = solve_added_mass(
            p.quads(h), rho, label=f"{pose}: {p.name} alone", verbose=verbose
        )["matrix"].tolist()
    for k in range(0, len(plates), 2):
        quads, owner, _ = union_panels(plates[k : k + 2], h, n)
        leg = plates[k].name.split("_")[0]
        out["fins"][leg] = solve_added_mass(
            quads, rho, owner=owner, label=f"{pose}: fin {leg} alone", verbose=verbose
        )["matrix"].tolist()
    quads, owner, _ = union_panels(plates, h, n)
    out["four_fins"] = solve_added_mass(
        quads, rho, owner=owner, label=f"{pose}: four fins", verbose=verbose
    )["matrix"].tolist()
    out["sum_hull_plates"] = (
        np.array(out["hull"]) + sum(np.array(m) for m in out["plates"].values())
    ).tolist()
    out["sum_hull_fins"] = (
        np.array(out["hull"]) + sum(np.array(m) for m in out["fins"].values())
    ).tolist()
    return out


def run_all(
    params: RobotParams = DEFAULT_ROBOT, rho: float | None = None, verbose: bool = True
) -> dict:
    """Every case, with the provenance; numbers rounded to 6 significant digits."""
    rho = water_density() if rho is None else rho
    started = time.time()
    results = {
        "hull": hull_case(params, rho, verbose=verbose),
        "plates": plate_case(params, rho, verbose=verbose),
        "robot": robot_case(params, rho, verbose=verbose),
    }
    results = round_floats(results, 6)
    return {"provenance": provenance(rho, time.time() - started), **results}


def uncommitted(
    paths=("manta_drake/model", "manta_drake/studies/validation", "models/hydrodynamics.yaml"),
) -> list[str]:
    """The files under ``paths`` of the checkout that differ from its commit (``git status``;
    empty outside a git checkout): the numbers were made from them, not from the commit."""
    import subprocess

    try:
        out = subprocess.run(
            ["git", "-C", str(REPO), "status", "--porcelain", "--", *paths],
            capture_output=True,
            text=True,
            timeout=30,
            check=True,
        ).stdout
    except (OSError, subprocess.SubprocessError):
        return []
    return sorted(line[3:] for line in out.splitlines() if line.strip())


def provenance(rho: float, seconds: float) -> dict:
    from manta_drake.studies.stamp import commit

    return {
        "generator": "manta_drake.studies.validation.added_mass",
        "command": COMMAND,
        "capytaine": capytaine_version(),
        "method": METHOD,
        "fluid": "unbounded ideal fluid (free_surface=inf, water_depth=inf, omega=inf)",
        "rho": rho,
        "frame": "Drake body frame (x forward, y left, z up), about the hull's origin; rows "
        "and columns surge, sway, heave, roll, pitch, yaw; kg, kg m, kg m^2",
        "date": datetime.date.today().isoformat(),
        "commit": commit(),
        "uncommitted": uncommitted(),
        "seconds": round(seconds, 1),
        "plate_thickness": DEFAULT_ROBOT.fin_thickness,
        "seam_depth": SEAM_DEPTH,
        "dnv_reference": "DNV-RP-H103 (April 2011), Appendix A, Table A-2, rectangular plates",
    }


# --- files --------------------------------------------------------------------------------------

HEADER = (
    "# Added mass of the robot's own geometry by capytaine (BEM, direct method, unbounded\n"
    "# fluid): the hull against Lamb, the fin plates against strip theory and DNV-RP-H103,\n"
    "# the whole robot at three poses. Generated by\n# `{command}`\n"
    '# (manta_drake/studies/validation/added_mass.py); docs/validation.md\'s "Added mass"\n'
    "# section is rendered from it. Do not edit.\n"
)


def write_yaml(path, results: dict) -> pathlib.Path:
    import yaml

    path = pathlib.Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    head = {"provenance": results["provenance"]}
    rest = {k: v for k, v in results.items() if k != "provenance"}
    text = (
        HEADER.format(command=results["provenance"]["command"])
        + yaml.safe_dump(head, sort_keys=False, default_flow_style=False, width=100)
        + yaml.safe_dump(rest, sort_keys=False, default_flow_style=None, width=100)
    )
    path.write_text(text)
    return path


def load_results(path=YAML_PATH) -> dict:
    from manta_drake.config_io import load_yaml_mapping

    data, _ = load_yaml_mapping(path, "added-mass results", ValidationError)
    return data


# --- the page -----------------------------------------------------------------------------------


def page_context(results: dict) -> dict:
    """Everything the template shows, computed from the results (the ratios, the sums)."""
    ctx = {
        "p": results["provenance"],
        "hull": results["hull"],
        "plates": results["plates"],
        "robot": results["robot"],
        "dofs": DOFS,
    }
    robot = results["robot"]
    rows = []
    for name, pose in robot["poses"].items():
        whole = np.array(pose["whole_at_parts_level"])
        parts = pose["parts"]
        hull_m = np.array(parts["hull"])
        plates = sum(np.array(m) for m in parts["plates"].values())
        fins = sum(np.array(m) for m in parts["fins"].values())
        four = np.array(parts["four_fins"])
        rows.append(
            {
                "pose": name,
                "entries": [
                    ("hull alone", hull_m),
                    ("8 plates alone, summed", plates),
                    ("4 fins alone (2 plates each), summed", fins),
                    ("4 fins together, no hull", four),
                    ("hull + 8 plates, summed", hull_m + plates),
                    ("whole robot", whole),
                ],
                "ratio_plates": np.diag(whole) / np.diag(hull_m + plates),
                "ratio_fins": np.diag(whole) / np.diag(hull_m + fins),
            }
        )
    ctx["parts_rows"] = rows
    # The sums the model's terms would give for heave: the hull's own value plus each plate's
    # normal added mass (strip, or DNV's 3-D plate) projected on z, (n . z)^2.
    plates = results["plates"]
    lamb_heave = results["hull"]["lamb"][2]
    sums = []
    for name, pose in robot["poses"].items():
        strip = dnv = 0.0
        for plate, normal in pose["plate_normals"].items():
            which = plate.split("_", 1)[1]
            nz2 = float(normal[2]) ** 2
            strip += plates[which]["strip_heave"] * nz2
            dnv += plates[which]["dnv_heave"] * nz2
        bem = pose["meshes"][-1]["matrix"][2][2]
        sums.append(
            {
                "pose": name,
                "bem": bem,
                "rows": [
                    (
                        "hull strip theory + plates' strip",
                        results["hull"]["strip_theory"][2] + strip,
                    ),
                    ("hull Lamb + plates' strip", lamb_heave + strip),
                    ("hull Lamb + plates' DNV 3-D", lamb_heave + dnv),
                ],
            }
        )
    ctx["model_sums"] = sums
    spreads = []
    for pose in robot["poses"].values():
        diag = np.array([np.diag(np.array(m["matrix"])) for m in pose["meshes"]])
        spreads.append(diag.max(axis=0) / diag.min(axis=0) - 1.0)
    ctx["spread"] = np.max(spreads, axis=0)  # per axis, the largest over the poses
    ctx["finest"] = {
        name: np.array(pose["meshes"][-1]["matrix"]) for name, pose in robot["poses"].items()
    }
    return ctx


def render_section(results: dict) -> str:
    """The section's block (markers included) rendered from the template."""
    from manta_drake.studies.validation import section_markers

    begin, end = section_markers(SECTION)
    body = render_template(TEMPLATE, **page_context(results), command=COMMAND)
    return f"{begin}\n{body.strip()}\n{end}"


def write_page(path, results: dict) -> None:
    """Replaces the section's block of ``path`` (appended to a page without one; a missing
    page is created)."""
    from manta_drake.studies.validation import write_section

    write_section(pathlib.Path(path), SECTION, render_section(results))


# --- the command --------------------------------------------------------------------------------


def parse_args(argv, prog):
    parser = StudyParser(prog=prog, description=__doc__.splitlines()[0])
    add_folder_options(
        parser,
        SECTION,
        "writes DIR/added_mass.json (the results) and DIR/added_mass.md (the section)",
    )
    parser.add_argument(
        "--yaml",
        default=None,
        metavar="FILE",
        help="the committed results (default models/reference/"
        "added_mass_bem.yaml of the checkout); '' writes none",
    )
    parser.add_argument(
        "--from-yaml",
        action="store_true",
        help="solve nothing: render the page from --yaml as committed",
    )
    args = parser.parse_args(argv)
    args.yaml = reference_file(args.yaml, prog, "--yaml FILE", YAML_PATH.name)
    args.page = page_path(args.out, prog)
    check_runs(args.runs)
    if args.from_yaml and not pathlib.Path(args.yaml).is_file():
        raise ValidationError(
            f"--from-yaml: no results file {args.yaml}; run without --from-yaml first"
        )
    return args


def main(argv=None, prog=None) -> int:
    prog = prog or "python -m manta_drake.studies.validation.added_mass"
    argv = sys.argv[1:] if argv is None else list(argv)
    args = parse_args(argv, prog)
    runs = pathlib.Path(args.runs)
    runs.mkdir(parents=True, exist_ok=True)
    if args.from_yaml:
        results = load_results(args.yaml)
    else:
        _capytaine()
        results = run_all()
        results["provenance"]["command"] = COMMAND
        if args.yaml:
            print(f"results: {write_yaml(args.yaml, results)}")
    written = write_results(runs, "added_mass", results, render_section(results))
    write_page(args.page, results)
    print(f"page: {args.page}")
    print(f"wrote {written[0]} and {written[1]}")
    return 0


if __name__ == "__main__":
    run_module(main)
