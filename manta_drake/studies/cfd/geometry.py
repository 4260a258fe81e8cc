"""The CFD study's surfaces: STL files of the hull ellipsoid, of the paper's "simplified robot
model" (the hull fairing and the four fins' plates at the zero pose) and of the validation
sphere, in metres, in the Drake body frame (x forward, y left, z up; origin at the hull's
centre, the CG).

Every surface comes from ``robot_params`` as the SDFormat model does (``model_sdf``): the hull
is ``body_semi_axes``; each fin is its proximal plate (``fin_thickness`` x ``proximal_chord`` x
``d3``) and its distal plate (``fin_thickness`` x ``distal_chord`` x ``dE``) posed by
``kinematics.link_poses_at_zero`` (the links' frames at q = 0, the SDFormat's link poses) with
``model_sdf.fin_plate_geometry``'s centres. The two plates of a fin share their joint edge, so
a fin is one closed prism: the outline of both plates (one polygon in the plates' plane)
extruded by the thickness. The servo brackets are left out (the paper's model is
"simplified"), as are the fin-tip feet.

Each part is one closed, consistently oriented (outward normals) triangle surface; a file may
hold several parts as named ``solid`` blocks (snappyHexMesh meshes the union; the fins'
roots overlap the hull). Written as ASCII STL with numpy alone.
"""

from __future__ import annotations

import dataclasses as dc
import pathlib

import numpy as np

from manta_drake.model.kinematics import link_poses_at_zero
from manta_drake.model.model_sdf import fin_plate_geometry
from manta_drake.model.robot_params import DEFAULT_ROBOT, RobotParams


@dc.dataclass(frozen=True)
class Part:
    """One closed surface: vertices (n, 3) in metres and triangles (m, 3), outward normals."""

    name: str
    vertices: np.ndarray
    triangles: np.ndarray

    def transformed(self, R: np.ndarray) -> Part:
        """This part rotated by R (3x3) about the origin."""
        return Part(self.name, self.vertices @ np.asarray(R).T, self.triangles)


# --- closed surfaces ---------------------------------------------------------------------------


def _icosphere(subdivisions: int) -> tuple[np.ndarray, np.ndarray]:
    """A unit icosphere: the icosahedron with each face split into 4^subdivisions, the new
    vertices pushed onto the unit sphere."""
    t = (1.0 + 5.0**0.5) / 2.0
    v = [
        (-1, t, 0),
        (1, t, 0),
        (-1, -t, 0),
        (1, -t, 0),
        (0, -1, t),
        (0, 1, t),
        (0, -1, -t),
        (0, 1, -t),
        (t, 0, -1),
        (t, 0, 1),
        (-t, 0, -1),
        (-t, 0, 1),
    ]
    f = [
        (0, 11, 5),
        (0, 5, 1),
        (0, 1, 7),
        (0, 7, 10),
        (0, 10, 11),
        (1, 5, 9),
        (5, 11, 4),
        (11, 10, 2),
        (10, 7, 6),
        (7, 1, 8),
        (3, 9, 4),
        (3, 4, 2),
        (3, 2, 6),
        (3, 6, 8),
        (3, 8, 9),
        (4, 9, 5),
        (2, 4, 11),
        (6, 2, 10),
        (8, 6, 7),
        (9, 8, 1),
    ]
    verts = [np.array(p, float) / np.linalg.norm(p) for p in v]
    faces = list(f)

    def mid(midpoint, i, j):
        key = (min(i, j), max(i, j))
        if key not in midpoint:
            m = verts[i] + verts[j]
            verts.append(m / np.linalg.norm(m))
            midpoint[key] = len(verts) - 1
        return midpoint[key]

    for _ in range(subdivisions):
        midpoint: dict = {}
        new = []
        for a, b, c in faces:
            ab, bc, ca = mid(midpoint, a, b), mid(midpoint, b, c), mid(midpoint, c, a)
            new += [(a, ab, ca), (b, bc, ab), (c, ca, bc), (ab, bc, ca)]
        faces = new
    return np.array(verts), np.array(faces, dtype=np.int64)


def ellipsoid_part(
    semi_axes, subdivisions: int = 5, name: str = "hull", center=(0.0, 0.0, 0.0)
) -> Part:
    """An ellipsoid with ``semi_axes`` (a, b, c): a unit icosphere scaled per axis
    (20 * 4^subdivisions triangles; 5: 20480, about 0.1 % low in volume)."""
    v, f = _icosphere(subdivisions)
    return Part(name, v * np.asarray(semi_axes, float) + np.asarray(center, float), f)


def _polygon_triangles(outline: np.ndarray) -> list[tuple[int, int, int]]:
    """Ear-clipping triangulation of a simple counter-clockwise polygon (k, 2)."""
    idx = list(range(len(outline)))
    tris = []

    def cross(o, a, b):
        return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])

    guard = 0
    while len(idx) > 3 and guard < 10000:
        guard += 1
        for k in range(len(idx)):
            i0, i1, i2 = idx[k - 1], idx[k], idx[(k + 1) % len(idx)]
            a, b, c = outline[i0], outline[i1], outline[i2]
            if cross(a, b, c) <= 1e-15:
                continue  # reflex or collinear corner
            inside = False
            for j in idx:
                if j in (i0, i1, i2):
                    continue
                p = outline[j]
                if cross(a, b, p) >= 0 and cross(b, c, p) >= 0 and cross(c, a, p) >= 0:
                    inside = True
                    break
            if not inside:
                tris.append((i0, i1, i2))
                idx.pop(k)
                break
    tris.append(tuple(idx))
    return tris


def prism_part(outline: np.ndarray, thickness: float, X: np.ndarray, name: str) -> Part:
    """A closed prism: the counter-clockwise polygon ``outline`` (k, 2) in the (u, v) plane
    of the pose ``X`` (4x4; columns u, v, n and origin), extruded +-thickness/2 along n."""
    outline = np.asarray(outline, float)
    k = len(outline)
    h = thickness / 2.0
    local = np.vstack(
        [np.column_stack([outline, np.full(k, -h)]), np.column_stack([outline, np.full(k, h)])]
    )
    cap = _polygon_triangles(outline)
    tris = [(a + k, b + k, c + k) for a, b, c in cap]  # top (+n), counter-clockwise
    tris += [(a, c, b) for a, b, c in cap]  # bottom (-n), reversed
    for i in range(k):
        j = (i + 1) % k
        tris += [(i, j, j + k), (i, j + k, i + k)]
    X = np.asarray(X, float)
    verts = local @ X[:3, :3].T + X[:3, 3]
    return Part(name, verts, np.array(tris, dtype=np.int64))


FIN_SECTIONS = ("naca0012", "plate")
NACA_POINTS = 25  # chordwise stations per side (cosine spaced), leading to trailing edge
FIN_TRANSITION = 0.004  # m of span over which the proximal section lofts into the distal one


def naca_half_thickness(xi, thickness: float):
    """NACA 4-digit symmetric section with a closed trailing edge (the -0.1036 x^4 term):
    half-thickness at the chord fraction ``xi`` for a maximum thickness ``thickness`` (m),
    reached at 30 % chord (Abbott and von Doenhoff 1959, eq. 6.2)."""
    xi = np.asarray(xi, float)
    return (
        5.0
        * thickness
        * (0.2969 * np.sqrt(xi) - 0.1260 * xi - 0.3516 * xi**2 + 0.2843 * xi**3 - 0.1036 * xi**4)
    )


def _section_ring(chord: float, thickness: float, section: str) -> np.ndarray:
    """The closed outline of a fin section in its (chord v, normal n) plane, counter-
    clockwise, leading edge at v = +chord/2 (the chord's +v points forward)."""
    if section == "plate":
        h, c = thickness / 2, chord / 2
        return np.array([(c, -h), (c, h), (-c, h), (-c, -h)])
    xi = 0.5 * (1.0 - np.cos(np.linspace(0.0, np.pi, NACA_POINTS)))
    h = naca_half_thickness(xi, thickness)
    v = chord / 2 - xi * chord
    upper = [(v[k], h[k]) for k in range(1, NACA_POINTS - 1)]
    lower = [(v[k], -h[k]) for k in range(NACA_POINTS - 2, 0, -1)]
    return np.array([(v[0], 0.0)] + upper + [(v[-1], 0.0)] + lower)


def loft_part(stations, X: np.ndarray, name: str) -> Part:
    """A closed solid lofted through ``stations``: a list of (span u, ring (M, 2) of (v, n)
    points, the same M for all), ruled between consecutive stations, capped at both ends
    (fans from the ring's centroid: the rings are convex), posed by ``X`` (4x4: columns u,
    v, n and origin)."""
    rings = [np.asarray(r, float) for _, r in stations]
    M = len(rings[0])
    verts = []
    for u, r in stations:
        verts += [(u, a, b) for a, b in r]
    tris = []
    for j in range(len(stations) - 1):
        for i in range(M):
            a, b = j * M + i, j * M + (i + 1) % M
            c, d = (j + 1) * M + (i + 1) % M, (j + 1) * M + i
            tris += [(a, b, c), (a, c, d)]
    for j, flip in ((0, True), (len(stations) - 1, False)):
        centre = len(verts)
        verts.append((stations[j][0], *rings[j].mean(axis=0)))
        for i in range(M):
            a, b = j * M + i, j * M + (i + 1) % M
            tris.append((centre, b, a) if flip else (centre, a, b))
    local = np.array(verts)
    X = np.asarray(X, float)
    part = Part(name, local @ X[:3, :3].T + X[:3, 3], np.array(tris, dtype=np.int64))
    if volume(part) < 0:  # outward normals
        part = Part(name, part.vertices, part.triangles[:, ::-1].copy())
    return part


def fin_part(leg: str, p: RobotParams = DEFAULT_ROBOT, section: str = "naca0012") -> Part:
    """A leg-fin's two plates at the zero pose as one closed solid, in the body frame.

    In link 3 (``model_sdf.fin_plate_geometry``): x is the plates' normal, y the chord, z the
    span; the proximal plate spans z in [0, d3] with chord +-proximal_chord/2, the distal
    plate (in link 4: -y the span, z the chord) continues it from z = d3 to d3 + dE with chord
    +-distal_chord/2 about the same chord line (checked here). ``section``: ``naca0012``
    (the 3-D printed fins: a NACA 4-digit section ``fin_thickness`` thick, robot_params; the
    proximal section lofts into the distal one over the first ``FIN_TRANSITION`` of the
    distal plate) or ``plate`` (the SDFormat's boxes, blunt edges)."""
    if section not in FIN_SECTIONS:
        raise ValueError(f"fin section {section!r}: expected one of {', '.join(FIN_SECTIONS)}")
    poses = link_poses_at_zero(leg, p)
    X3 = poses["X_Body_L1"] @ poses["X_Lprev_L"][0] @ poses["X_Lprev_L"][1]
    X4 = X3 @ poses["X_Lprev_L"][2]
    g = fin_plate_geometry(p)
    prox_t, prox_chord, prox_span = g["proximal"]["size"]
    dist_t, dist_span, dist_chord = g["distal"]["size"]
    # The distal plate's centre and axes seen from link 3: it must continue the proximal one.
    X34 = np.linalg.inv(X3) @ X4
    c4 = X34[:3, :3] @ np.asarray(g["distal"]["center"]) + X34[:3, 3]
    if not (
        np.allclose(c4, [0.0, 0.0, prox_span + dist_span / 2], atol=1e-9)
        and np.allclose(X34[:3, 0], [1.0, 0.0, 0.0], atol=1e-9)
        and np.isclose(prox_t, dist_t)
    ):
        raise ValueError(
            f"fin {leg}: the distal plate does not continue the proximal plate "
            "in its plane; fin_part assumes it does"
        )
    s1, s2 = prox_span, prox_span + dist_span
    X = np.eye(4)  # u = span (link 3 z), v = chord (link 3 y), n = normal (link 3 x)
    X[:3, 0], X[:3, 1], X[:3, 2] = X3[:3, 2], X3[:3, 1], X3[:3, 0]
    X[:3, 3] = X3[:3, 3]
    if section == "plate":
        # Both plates' outline in the (span, chord) plane, extruded by the thickness.
        hp, hd = prox_chord / 2, dist_chord / 2
        outline = np.array(
            [(0.0, -hp), (s1, -hp), (s1, -hd), (s2, -hd), (s2, hd), (s1, hd), (s1, hp), (0.0, hp)]
        )
        Xp = X.copy()
        Xp[:3, 2] = -X3[:3, 0]  # u x v = n for the prism's right-handed frame
        return prism_part(outline, prox_t, Xp, f"fin_{leg}")
    prox = _section_ring(prox_chord, prox_t, section)
    dist = _section_ring(dist_chord, dist_t, section)
    stations = [(0.0, prox), (s1, prox), (s1 + FIN_TRANSITION, dist), (s2, dist)]
    return loft_part(stations, X, f"fin_{leg}")


def hull_parts(p: RobotParams = DEFAULT_ROBOT, subdivisions: int = 5) -> list[Part]:
    """The hull fairing alone: the ellipsoid ``body_semi_axes``."""
    return [ellipsoid_part(p.body_semi_axes, subdivisions, "hull")]


def robot_parts(
    p: RobotParams = DEFAULT_ROBOT, subdivisions: int = 5, fin_section: str = "naca0012"
) -> list[Part]:
    """The paper's simplified robot model: the hull fairing and the four fins at the zero
    pose (each fin's two plates as one solid, ``fin_part``)."""
    return hull_parts(p, subdivisions) + [fin_part(m.name, p, fin_section) for m in p.mounts]


def sphere_parts(diameter: float, subdivisions: int = 5) -> list[Part]:
    """The validation sphere, centred at the origin."""
    r = diameter / 2.0
    return [ellipsoid_part((r, r, r), subdivisions, "sphere")]


# --- measures ----------------------------------------------------------------------------------


def _triangle_vectors(part: Part):
    v = part.vertices[part.triangles]
    return v[:, 0], v[:, 1], v[:, 2]


def volume(part: Part) -> float:
    """Enclosed volume (divergence theorem); positive for outward normals."""
    a, b, c = _triangle_vectors(part)
    return float(np.einsum("ij,ij->i", a, np.cross(b, c)).sum() / 6.0)


def area(part: Part) -> float:
    a, b, c = _triangle_vectors(part)
    return float(0.5 * np.linalg.norm(np.cross(b - a, c - a), axis=1).sum())


def projected_area(part: Part, direction=(1.0, 0.0, 0.0)) -> float:
    """Area of the shadow along ``direction`` of a convex closed part: half the integral of
    |n . d| over the surface (exact for a convex polyhedron)."""
    a, b, c = _triangle_vectors(part)
    n2 = np.cross(b - a, c - a)  # twice the area times the normal
    d = np.asarray(direction, float) / np.linalg.norm(direction)
    return float(0.25 * np.abs(n2 @ d).sum())


def is_closed(part: Part) -> bool:
    """Watertight and consistently oriented: every directed edge appears once and its
    reverse once (each edge shared by exactly two triangles, traversed in opposite
    senses), and every vertex is used."""
    t = part.triangles
    edges = np.concatenate([t[:, [0, 1]], t[:, [1, 2]], t[:, [2, 0]]])
    directed = {tuple(e) for e in edges.tolist()}
    if len(directed) != len(edges):
        return False
    if any((b, a) not in directed for a, b in directed):
        return False
    return len(np.unique(t)) == len(part.vertices)


def ellipsoid_volume(semi_axes) -> float:
    a, b, c = semi_axes
    return 4.0 / 3.0 * np.pi * a * b * c


def ellipsoid_frontal_area(semi_axes) -> float:
    """Shadow of the ellipsoid along x: the ellipse pi b c."""
    _, b, c = semi_axes
    return float(np.pi * b * c)


# --- files -------------------------------------------------------------------------------------


def write_stl(path, parts: list[Part]) -> pathlib.Path:
    """Writes ``parts`` to ``path`` as ASCII STL, one ``solid NAME`` block per part."""
    path = pathlib.Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    lines = []
    for part in parts:
        a, b, c = _triangle_vectors(part)
        n = np.cross(b - a, c - a)
        n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-300)
        lines.append(f"solid {part.name}")
        for k in range(len(n)):
            lines.append(f"  facet normal {n[k, 0]:.9e} {n[k, 1]:.9e} {n[k, 2]:.9e}")
            lines.append("    outer loop")
            for v in (a[k], b[k], c[k]):
                lines.append(f"      vertex {v[0]:.9e} {v[1]:.9e} {v[2]:.9e}")
            lines.append("    endloop")
            lines.append("  endfacet")
        lines.append(f"endsolid {part.name}")
    path.write_text("\n".join(lines) + "\n")
    return path


def read_stl(path) -> list[Part]:
    """Reads an ASCII STL written by ``write_stl`` back into parts (vertices merged
    exactly), so a test can check the file itself."""
    parts, name, tri = [], None, []
    for line in pathlib.Path(path).read_text().splitlines():
        w = line.split()
        if not w:
            continue
        if w[0] == "solid":
            name, tri = (w[1] if len(w) > 1 else "solid"), []
        elif w[0] == "vertex":
            tri.append(tuple(float(x) for x in w[1:4]))
        elif w[0] == "endsolid":
            pts = np.array(tri)
            uniq, inverse = np.unique(pts, axis=0, return_inverse=True)
            parts.append(Part(name, uniq, inverse.reshape(-1, 3)))
    return parts


def bounds(parts: list[Part]) -> tuple[np.ndarray, np.ndarray]:
    """Axis-aligned bounding box (lo, hi) of the parts."""
    v = np.vstack([p.vertices for p in parts])
    return v.min(axis=0), v.max(axis=0)


def rotation(pitch_deg: float = 0.0, yaw_deg: float = 0.0) -> np.ndarray:
    """The body's attitude in the water (domain) frame for the paper's pitch and yaw (NED
    sense: pitch positive nose up, yaw positive nose to starboard), in the Drake body frame
    (z up, y left): R = R_z(-yaw) R_y(-pitch)."""
    th, ps = np.radians(pitch_deg), np.radians(yaw_deg)
    Ry = np.array([[np.cos(-th), 0, np.sin(-th)], [0, 1, 0], [-np.sin(-th), 0, np.cos(-th)]])
    Rz = np.array([[np.cos(-ps), -np.sin(-ps), 0], [np.sin(-ps), np.cos(-ps), 0], [0, 0, 1]])
    return Rz @ Ry
