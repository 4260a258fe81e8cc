"""The water's forces compiled with numba: the same maths as ``manta_drake.station.water``.

``water.py`` stays the readable reference (one numpy function per term, tested against
closed forms); these kernels compute exactly the same forces (the tests compare them to
1e-12 on random states) in one compiled pass, without the per-call cost of numpy on
arrays of 17 bodies and ~40 strips (each numpy call costs ~1 us whatever its size, and
the reference makes a few hundred of them per evaluation).

Three kernels, fed by plain arrays that ``pack_*`` builds once:

* ``body_kinematics``: the hydro bodies' poses and spatial velocities, and each revolute
  or planar joint's world axes and origin, from the plant's state vector [q, v] (forward
  kinematics of the tree: quaternion floating base, revolute and planar joints, welds),
  so the wrapper reads one vector instead of the plant's per-body Python objects.
* ``spatial_wrenches``: every term of ``HydrodynamicForces.compute_reference`` summed per
  body as rows [tau_W, f_W] about the body origin (buoyancy, balloon, damping, blade
  elements, added-mass weight cancellation, residual added mass).
* ``generalized_forces``: J^T F, the generalized forces of those spatial forces (what the
  plant's ``applied_spatial_force`` input would apply), by one backward pass over the
  tree: each body's wrench is shifted to its parent and projected on the joint axes.

Compilation: ``@njit(cache=True)``. The first import compiles (a few seconds) and writes
the machine code to numba's cache; later processes load it in well under a second.
numba keeps the cache in the ``__pycache__`` folder beside this file, or, when that is
not writable (a system-wide, non-editable install), in its user-wide cache folder
(``$XDG_CACHE_HOME`` or ``~/.cache``, sub-folder ``numba``); the ``NUMBA_CACHE_DIR``
environment variable overrides both. The cache is keyed on this file's contents and the
CPU, so an edited kernel or another machine recompiles by itself. Where none of those
folders is writable (a read-only install), ``manta_drake.jit`` caches in a temporary
folder or compiles without a cache instead of failing at import.
"""

from __future__ import annotations

import numpy as np

from manta_drake.jit import njit

# Joint types in the packed tree.
WELD, REVOLUTE, QUATERNION_FLOATING, PLANAR = 0, 1, 2, 3

# Layout of the packed scalar parameters (``pack_params``).
P_RHO, P_G, P_CN, P_CF, P_PITCH_MAX, P_PITCH_P, P_ISO = range(7)
P_CURRENT, P_MOUNT, P_M_RES, P_I_RES = 7, 10, 13, 16
NUM_PARAMS = 19


# --- packing (plain numpy, once per system) --------------------------------------------------


def pack_elements(el: dict) -> tuple[np.ndarray, np.ndarray]:
    """The arrays of ``water.build_elements`` as two float tables.

    Returns:
        (elements (ne, 8): [body, p_B (3), semi-axes (3), volume],
         strips (ns, 12): [body, element, p_B (3), normal (3), chord (3), area]).
    """
    elements = np.column_stack([el["body"], el["p"], el["axes"], el["volume"]]).astype(float)
    strips = np.column_stack(
        [
            el["strip_body"],
            el["strip_element"],
            el["strip_p"],
            el["strip_n"],
            el["strip_c"],
            el["strip_area"],
        ]
    ).astype(float)
    return np.ascontiguousarray(elements), np.ascontiguousarray(strips)


def pack_params(
    rho,
    g,
    c_normal,
    c_friction,
    pitch_max,
    pitch_pressure,
    added_mass_iso,
    current,
    balloon_mount,
    residual_mass,
    residual_inertia,
) -> np.ndarray:
    """The scalar and 3-vector parameters as one float vector (layout: the P_* indices)."""
    prm = np.empty(NUM_PARAMS)
    prm[:7] = (rho, g, c_normal, c_friction, pitch_max, pitch_pressure, added_mass_iso)
    prm[P_CURRENT : P_CURRENT + 3] = current
    prm[P_MOUNT : P_MOUNT + 3] = balloon_mount
    prm[P_M_RES : P_M_RES + 3] = residual_mass
    prm[P_I_RES : P_I_RES + 3] = residual_inertia
    return prm


def pack_tree(plant, body_indices) -> tuple[np.ndarray, np.ndarray]:
    """The kinematic tree of the hydro bodies, for ``body_kinematics``.

    Args:
        plant: a finalized MultibodyPlant.
        body_indices: the hydro bodies' BodyIndex values, parents before children.

    Returns:
        (tree_i (nb, 4) int: [parent row (-1: world), joint type, q start, v start],
         tree_f (nb, 27): [R_PF (9, row-major), p_PF (3), R_MC (9), p_MC (3), axis_F (3)]).

    Raises:
        ValueError: a body's parent is neither the world nor an earlier hydro body, or its
            inboard joint is not a weld, a revolute or planar joint or a quaternion floating
            joint (the kernels handle those only; ``HydrodynamicForces`` with
            ``inputs="contract"`` handles any plant).
    """
    rows = {int(b): k for k, b in enumerate(body_indices)}
    world = int(plant.world_body().index())
    inboard = _inboard_joints(plant)
    nb = len(body_indices)
    tree_i = np.zeros((nb, 4), dtype=np.int64)
    tree_f = np.zeros((nb, 27))
    for k, b in enumerate(body_indices):
        joint = inboard.get(int(b))
        name = plant.get_body(b).name()
        if joint is None:
            raise ValueError(f"hydro body {name} has no inboard joint")
        parent = int(joint.parent_body().index())
        if parent != world and rows.get(parent, nb) >= k:
            raise ValueError(
                f"hydro body {name}: its parent {joint.parent_body().name()} "
                "is not an earlier hydro body (the compiled path needs the tree)"
            )
        kind = _joint_kind(joint, name)
        X_PF, X_MC = _joint_frames(joint, kind, name)
        axis = joint.revolute_axis() if kind == REVOLUTE else np.zeros(3)
        tree_i[k] = (
            -1 if parent == world else rows[parent],
            kind,
            joint.position_start(),
            joint.velocity_start(),
        )
        tree_f[k] = np.concatenate(
            [X_PF.rotation().matrix().ravel(), X_PF.translation()]
            + [X_MC.rotation().matrix().ravel(), X_MC.translation(), axis]
        )
    return tree_i, tree_f


def _inboard_joints(plant) -> dict:
    """Each child body's index -> the joint whose child it is."""
    inboard = {}
    for j in plant.GetJointIndices():
        joint = plant.get_joint(j)
        inboard[int(joint.child_body().index())] = joint
    return inboard


def _joint_kind(joint, name: str) -> int:
    """The packed joint type (WELD, REVOLUTE, PLANAR, QUATERNION_FLOATING) of the inboard
    joint of hydro body ``name``; ValueError for any other joint."""
    kind = {
        "weld": WELD,
        "revolute": REVOLUTE,
        "planar": PLANAR,
        "quaternion_floating": QUATERNION_FLOATING,
    }.get(joint.type_name())
    if kind is None:
        raise ValueError(
            f"hydro body {name}: joint type {joint.type_name()!r} is not "
            "supported by the compiled path (weld, revolute, planar, "
            "quaternion_floating)"
        )
    return kind


def _joint_frames(joint, kind: int, name: str):
    """(X_PF, X_MC) of the inboard joint of hydro body ``name``: its frame on the parent,
    with a weld's own fixed X_FM folded in, and the child body in its frame on the child;
    ValueError for a floating joint with offset frames."""
    X_PF = joint.frame_on_parent().GetFixedPoseInBodyFrame()
    X_MC = joint.frame_on_child().GetFixedPoseInBodyFrame().inverse()
    if kind == WELD:  # a weld's own fixed X_FM folds into the parent's offset
        X_PF = X_PF @ joint.X_FM()
    if kind == QUATERNION_FLOATING and not (
        np.array_equal(X_PF.GetAsMatrix4(), np.eye(4))
        and np.array_equal(X_MC.GetAsMatrix4(), np.eye(4))
    ):
        raise ValueError(
            f"hydro body {name}: a floating joint with offset frames "
            "is not supported by the compiled path"
        )
    return X_PF, X_MC


# --- kernels ---------------------------------------------------------------------------------


@njit(cache=True)
def _mul33(A, B, out):
    """out = A @ B for 3x3 (no BLAS call for a 3x3 product)."""
    for i in range(3):
        for j in range(3):
            out[i, j] = A[i, 0] * B[0, j] + A[i, 1] * B[1, j] + A[i, 2] * B[2, j]


@njit(cache=True)
def body_kinematics(x, nq, tree_i, tree_f):
    """Forward kinematics of the packed tree from the plant's state x = [q, v].

    Returns:
        (R (nb, 3, 3), p (nb, 3), w (nb, 3), v (nb, 3), axis_W (nb, 9), origin_W (nb, 3)):
        body orientations, origins, angular velocities and origin velocities in the world,
        and each body's inboard joint's axes and origin Mo in the world: for a revolute
        joint its unit axis (columns 0-2) and Fo = Mo; for a planar joint the joint frame
        F's z, x and y axes (columns 0-2, 3-5, 6-8) and Mo (zero for other joints). Same
        composition as Drake's: X_WB = X_WP X_PF X_FM(q) X_MB; a planar joint's
        q = [x, y, theta] (translation in F, rotation about F's z), v = their rates.
    """
    nb = tree_i.shape[0]
    R = np.empty((nb, 3, 3))
    p = np.empty((nb, 3))
    w = np.empty((nb, 3))
    v = np.empty((nb, 3))
    axis_W = np.zeros((nb, 9))
    origin_W = np.zeros((nb, 3))
    R_WF = np.empty((3, 3))
    R_FM = np.empty((3, 3))
    R_WM = np.empty((3, 3))
    for b in range(nb):
        parent, kind, qs, vs = tree_i[b, 0], tree_i[b, 1], tree_i[b, 2], tree_i[b, 3]
        R_PF = tree_f[b, 0:9].reshape(3, 3)
        R_MC = tree_f[b, 12:21].reshape(3, 3)
        if kind == QUATERNION_FLOATING:  # F = world, M = body frame (checked in pack_tree)
            qw, qx, qy, qz = x[qs], x[qs + 1], x[qs + 2], x[qs + 3]
            # Drake's QuaternionToRotationMatrix (valid for a non-unit quaternion too).
            s = 2.0 / (qw * qw + qx * qx + qy * qy + qz * qz)
            sx, sy, sz = s * qx, s * qy, s * qz
            swx, swy, swz = sx * qw, sy * qw, sz * qw
            sxx, sxy, sxz = sx * qx, sy * qx, sz * qx
            syy, syz, szz = sy * qy, sz * qy, sz * qz
            R[b, 0, 0] = 1.0 - syy - szz
            R[b, 0, 1] = sxy - swz
            R[b, 0, 2] = sxz + swy
            R[b, 1, 0] = sxy + swz
            R[b, 1, 1] = 1.0 - sxx - szz
            R[b, 1, 2] = syz - swx
            R[b, 2, 0] = sxz - swy
            R[b, 2, 1] = syz + swx
            R[b, 2, 2] = 1.0 - sxx - syy
            for i in range(3):
                p[b, i] = x[qs + 4 + i]
                w[b, i] = x[nq + vs + i]
                v[b, i] = x[nq + vs + 3 + i]
            continue
        # Parent's pose and velocity (the world is at rest at the identity).
        if parent < 0:
            for i in range(3):
                for j in range(3):
                    R_WF[i, j] = R_PF[i, j]
                origin_W[b, i] = tree_f[b, 9 + i]
            wP0 = wP1 = wP2 = 0.0
            vF0 = vF1 = vF2 = 0.0
        else:
            _mul33(R[parent], R_PF, R_WF)
            for i in range(3):
                origin_W[b, i] = p[parent, i] + (
                    R[parent, i, 0] * tree_f[b, 9]
                    + R[parent, i, 1] * tree_f[b, 10]
                    + R[parent, i, 2] * tree_f[b, 11]
                )
            wP0, wP1, wP2 = w[parent, 0], w[parent, 1], w[parent, 2]
            # Velocity of the point Fo fixed on the parent.
            d0 = origin_W[b, 0] - p[parent, 0]
            d1 = origin_W[b, 1] - p[parent, 1]
            d2 = origin_W[b, 2] - p[parent, 2]
            vF0 = v[parent, 0] + wP1 * d2 - wP2 * d1
            vF1 = v[parent, 1] + wP2 * d0 - wP0 * d2
            vF2 = v[parent, 2] + wP0 * d1 - wP1 * d0
        if kind == REVOLUTE:
            a0, a1, a2 = tree_f[b, 24], tree_f[b, 25], tree_f[b, 26]
            angle, rate = x[qs], x[nq + vs]
            # Eigen's AngleAxis::toRotationMatrix.
            c, s = np.cos(angle), np.sin(angle)
            sa0, sa1, sa2 = s * a0, s * a1, s * a2
            ca0, ca1, ca2 = (1.0 - c) * a0, (1.0 - c) * a1, (1.0 - c) * a2
            R_FM[0, 1] = ca0 * a1 - sa2
            R_FM[1, 0] = ca0 * a1 + sa2
            R_FM[0, 2] = ca0 * a2 + sa1
            R_FM[2, 0] = ca0 * a2 - sa1
            R_FM[1, 2] = ca1 * a2 - sa0
            R_FM[2, 1] = ca1 * a2 + sa0
            R_FM[0, 0] = ca0 * a0 + c
            R_FM[1, 1] = ca1 * a1 + c
            R_FM[2, 2] = ca2 * a2 + c
            _mul33(R_WF, R_FM, R_WM)
            for i in range(3):
                axis_W[b, i] = R_WF[i, 0] * a0 + R_WF[i, 1] * a1 + R_WF[i, 2] * a2
            wJ0, wJ1, wJ2 = axis_W[b, 0] * rate, axis_W[b, 1] * rate, axis_W[b, 2] * rate
        elif kind == PLANAR:
            tx, ty, theta = x[qs], x[qs + 1], x[qs + 2]
            vx, vy, rate = x[nq + vs], x[nq + vs + 1], x[nq + vs + 2]
            c, s = np.cos(theta), np.sin(theta)
            R_FM[0, 0], R_FM[0, 1], R_FM[0, 2] = c, -s, 0.0
            R_FM[1, 0], R_FM[1, 1], R_FM[1, 2] = s, c, 0.0
            R_FM[2, 0], R_FM[2, 1], R_FM[2, 2] = 0.0, 0.0, 1.0
            _mul33(R_WF, R_FM, R_WM)
            for i in range(3):
                axis_W[b, i] = R_WF[i, 2]
                axis_W[b, 3 + i] = R_WF[i, 0]
                axis_W[b, 6 + i] = R_WF[i, 1]
            # Mo = Fo + R_WF [x, y, 0], moving with the parent and along F.
            d0 = R_WF[0, 0] * tx + R_WF[0, 1] * ty
            d1 = R_WF[1, 0] * tx + R_WF[1, 1] * ty
            d2 = R_WF[2, 0] * tx + R_WF[2, 1] * ty
            origin_W[b, 0] += d0
            origin_W[b, 1] += d1
            origin_W[b, 2] += d2
            vF0 += (wP1 * d2 - wP2 * d1) + R_WF[0, 0] * vx + R_WF[0, 1] * vy
            vF1 += (wP2 * d0 - wP0 * d2) + R_WF[1, 0] * vx + R_WF[1, 1] * vy
            vF2 += (wP0 * d1 - wP1 * d0) + R_WF[2, 0] * vx + R_WF[2, 1] * vy
            wJ0, wJ1, wJ2 = axis_W[b, 0] * rate, axis_W[b, 1] * rate, axis_W[b, 2] * rate
        else:  # weld
            for i in range(3):
                for j in range(3):
                    R_WM[i, j] = R_WF[i, j]
            wJ0 = wJ1 = wJ2 = 0.0
        _mul33(R_WM, R_MC, R[b])
        for i in range(3):  # origin_W is Mo (= Fo but for a planar joint)
            p[b, i] = origin_W[b, i] + (
                R_WM[i, 0] * tree_f[b, 21] + R_WM[i, 1] * tree_f[b, 22] + R_WM[i, 2] * tree_f[b, 23]
            )
        w[b, 0], w[b, 1], w[b, 2] = wP0 + wJ0, wP1 + wJ1, wP2 + wJ2
        d0 = p[b, 0] - origin_W[b, 0]
        d1 = p[b, 1] - origin_W[b, 1]
        d2 = p[b, 2] - origin_W[b, 2]
        v[b, 0] = vF0 + w[b, 1] * d2 - w[b, 2] * d1
        v[b, 1] = vF1 + w[b, 2] * d0 - w[b, 0] * d2
        v[b, 2] = vF2 + w[b, 0] * d1 - w[b, 1] * d0
        if kind == WELD:
            axis_W[b, 0] = axis_W[b, 1] = axis_W[b, 2] = 0.0
    return R, p, w, v, axis_W, origin_W


@njit(cache=True)
def _submersion(p0, p1, p2, R, A0, A1, A2):
    """``water.ellipsoid_submersion`` for one ellipsoid: (fraction, centroid x, y, z)."""
    m0, m1, m2 = A0 * R[2, 0], A1 * R[2, 1], A2 * R[2, 2]
    norm = np.sqrt(m0 * m0 + m1 * m1 + m2 * m2)
    s = -p2 / norm
    h = min(max(1.0 + s, 0.0), 2.0)
    fraction = h * h * (3.0 - h) / 4.0
    u_n = -3.0 * (2.0 - h) ** 2 / (4.0 * (3.0 - h))
    k = u_n / norm
    u0, u1, u2 = A0 * (k * m0), A1 * (k * m1), A2 * (k * m2)
    c0 = p0 + (R[0, 0] * u0 + R[0, 1] * u1 + R[0, 2] * u2)
    c1 = p1 + (R[1, 0] * u0 + R[1, 1] * u1 + R[1, 2] * u2)
    c2 = p2 + (R[2, 0] * u0 + R[2, 1] * u1 + R[2, 2] * u2)
    return fraction, c0, c1, c2


@njit(cache=True)
def spatial_wrenches(
    R, p, w, v, balloon_volume, hull_accel, has_accel, elements, strips, damping, prm, frac
):
    """``HydrodynamicForces.compute_reference`` compiled: (nb, 6) rows [tau_W, f_W].

    Args:
        R, p, w, v: (nb, 3, 3), (nb, 3) x 3 body kinematics in the world.
        balloon_volume: [m^3] (finite).
        hull_accel: (6,) [a_W, alpha_W] of the hull, used when ``has_accel``.
        elements, strips: ``pack_elements``; damping: (nb, 16) [d_lin, d_quad, d_lift];
        prm: ``pack_params``.
        frac: (ne,) filled with each volume element's submerged fraction.
    """
    nb = R.shape[0]
    ne = elements.shape[0]
    ns = strips.shape[0]
    rho, g = prm[P_RHO], prm[P_G]
    F = np.zeros((nb, 6))
    body_volume = np.zeros(nb)
    body_submerged = np.zeros(nb)
    # Buoyancy of each volume element (water.buoyancy_wrenches).
    for e in range(ne):
        b = int(elements[e, 0])
        Rb = R[b]
        x0, x1, x2 = elements[e, 1], elements[e, 2], elements[e, 3]
        q0 = p[b, 0] + (Rb[0, 0] * x0 + Rb[0, 1] * x1 + Rb[0, 2] * x2)
        q1 = p[b, 1] + (Rb[1, 0] * x0 + Rb[1, 1] * x1 + Rb[1, 2] * x2)
        q2 = p[b, 2] + (Rb[2, 0] * x0 + Rb[2, 1] * x1 + Rb[2, 2] * x2)
        fe, c0, c1, c2 = _submersion(q0, q1, q2, Rb, elements[e, 4], elements[e, 5], elements[e, 6])
        volume = elements[e, 7]
        frac[e] = fe
        lift = rho * g * volume * fe
        F[b, 0] += (c1 - p[b, 1]) * lift
        F[b, 1] += -(c0 - p[b, 0]) * lift
        F[b, 5] += lift
        body_volume[b] += volume
        body_submerged[b] += volume * fe
    body_frac = np.zeros(nb)  # bodies without a volume (the added-mass bodies): 0
    for b in range(nb):
        if body_volume[b] > 0.0:
            body_frac[b] = body_submerged[b] / body_volume[b]
    # The balloon (water.balloon_wrench).
    if balloon_volume > 1e-9:
        radius = (3.0 * balloon_volume / (4.0 * np.pi)) ** (1.0 / 3.0)
        R0 = R[0]
        x0, x1, x2 = prm[P_MOUNT], prm[P_MOUNT + 1], prm[P_MOUNT + 2]
        q0 = p[0, 0] + (R0[0, 0] * x0 + R0[0, 1] * x1 + R0[0, 2] * x2)
        q1 = p[0, 1] + (R0[1, 0] * x0 + R0[1, 1] * x1 + R0[1, 2] * x2)
        q2 = p[0, 2] + (R0[2, 0] * x0 + R0[2, 1] * x1 + R0[2, 2] * x2)
        fe, c0, c1, c2 = _submersion(q0, q1, q2, R0, radius, radius, radius)
        lift = rho * g * balloon_volume * fe
        F[0, 0] += (c1 - p[0, 1]) * lift
        F[0, 1] += -(c0 - p[0, 0]) * lift
        F[0, 5] += lift
    # Damping per body axis (water.damping_wrenches).
    cur0, cur1, cur2 = prm[P_CURRENT], prm[P_CURRENT + 1], prm[P_CURRENT + 2]
    nu = np.empty(6)
    for b in range(nb):
        Rb = R[b]
        r0, r1, r2 = v[b, 0] - cur0, v[b, 1] - cur1, v[b, 2] - cur2
        for i in range(3):
            nu[i] = Rb[0, i] * r0 + Rb[1, i] * r1 + Rb[2, i] * r2
            nu[3 + i] = Rb[0, i] * w[b, 0] + Rb[1, i] * w[b, 1] + Rb[2, i] * w[b, 2]
        u, v_, w_ = nu[0], nu[1], nu[2]
        for i in range(6):
            nu[i] = -(damping[b, i] + damping[b, 6 + i] * abs(nu[i])) * nu[i]
        # The body lift (water.body_lift).
        nu[1] -= damping[b, 12] * abs(u) * v_
        nu[2] -= damping[b, 13] * abs(u) * w_
        nu[4] -= damping[b, 14] * u * w_
        nu[5] -= damping[b, 15] * u * v_
        for i in range(6):
            nu[i] *= body_frac[b]
        for i in range(3):
            F[b, i] += Rb[i, 0] * nu[3] + Rb[i, 1] * nu[4] + Rb[i, 2] * nu[5]
            F[b, 3 + i] += Rb[i, 0] * nu[0] + Rb[i, 1] * nu[1] + Rb[i, 2] * nu[2]
    # Blade elements (water.fin_strip_forces, passive_pitch, plate_forces), summed per body
    # first and then added, as the reference does.
    c_n, c_f = prm[P_CN], prm[P_CF]
    pitch_max, pitch_p = prm[P_PITCH_MAX], prm[P_PITCH_P]
    S = np.zeros((nb, 6))
    for k in range(ns):
        b = int(strips[k, 0])
        Rb = R[b]
        x0, x1, x2 = strips[k, 2], strips[k, 3], strips[k, 4]
        r0 = Rb[0, 0] * x0 + Rb[0, 1] * x1 + Rb[0, 2] * x2
        r1 = Rb[1, 0] * x0 + Rb[1, 1] * x1 + Rb[1, 2] * x2
        r2 = Rb[2, 0] * x0 + Rb[2, 1] * x1 + Rb[2, 2] * x2
        wb0, wb1, wb2 = w[b, 0], w[b, 1], w[b, 2]
        vs0 = v[b, 0] + (wb1 * r2 - wb2 * r1) - cur0
        vs1 = v[b, 1] + (wb2 * r0 - wb0 * r2) - cur1
        vs2 = v[b, 2] + (wb0 * r1 - wb1 * r0) - cur2
        x0, x1, x2 = strips[k, 5], strips[k, 6], strips[k, 7]
        n0 = Rb[0, 0] * x0 + Rb[0, 1] * x1 + Rb[0, 2] * x2
        n1 = Rb[1, 0] * x0 + Rb[1, 1] * x1 + Rb[1, 2] * x2
        n2 = Rb[2, 0] * x0 + Rb[2, 1] * x1 + Rb[2, 2] * x2
        if pitch_max > 0.0:
            x0, x1, x2 = strips[k, 8], strips[k, 9], strips[k, 10]
            ch0 = Rb[0, 0] * x0 + Rb[0, 1] * x1 + Rb[0, 2] * x2
            ch1 = Rb[1, 0] * x0 + Rb[1, 1] * x1 + Rb[1, 2] * x2
            ch2 = Rb[2, 0] * x0 + Rb[2, 1] * x1 + Rb[2, 2] * x2
            vn = vs0 * n0 + vs1 * n1 + vs2 * n2
            beta = pitch_max * np.tanh(0.5 * rho * c_n * vn * vn / pitch_p)
            cb = np.cos(beta)
            sb = np.sign(vn) * np.sin(beta)
            n0, n1, n2 = cb * n0 - sb * ch0, cb * n1 - sb * ch1, cb * n2 - sb * ch2
        vn = vs0 * n0 + vs1 * n1 + vs2 * n2
        t0, t1, t2 = vs0 - vn * n0, vs1 - vn * n1, vs2 - vn * n2
        half_rho_area = 0.5 * rho * strips[k, 11]
        fn = -(half_rho_area * c_n * abs(vn) * vn)
        ft = -(half_rho_area * c_f * np.sqrt(t0 * t0 + t1 * t1 + t2 * t2))
        scale = frac[int(strips[k, 1])]
        f0 = (fn * n0 + ft * t0) * scale
        f1 = (fn * n1 + ft * t1) * scale
        f2 = (fn * n2 + ft * t2) * scale
        S[b, 0] += r1 * f2 - r2 * f1
        S[b, 1] += r2 * f0 - r0 * f2
        S[b, 2] += r0 * f1 - r1 * f0
        S[b, 3] += f0
        S[b, 4] += f1
        S[b, 5] += f2
    for b in range(nb):
        for i in range(6):
            F[b, i] += S[b, i]
    # The isotropic added mass is in the mass matrix: cancel its weight.
    F[0, 5] += prm[P_ISO] * g
    # Residual added mass and inertia (water.residual_added_mass_wrench).
    if has_accel:
        R0 = R[0]
        fb = body_frac[0]
        for i in range(3):  # a_B = R^T a, alpha_B = R^T alpha, then scaled per hull axis
            nu[i] = -prm[P_M_RES + i] * (
                R0[0, i] * hull_accel[0] + R0[1, i] * hull_accel[1] + R0[2, i] * hull_accel[2]
            )
            nu[3 + i] = -prm[P_I_RES + i] * (
                R0[0, i] * hull_accel[3] + R0[1, i] * hull_accel[4] + R0[2, i] * hull_accel[5]
            )
        for i in range(3):
            F[0, i] += (R0[i, 0] * nu[3] + R0[i, 1] * nu[4] + R0[i, 2] * nu[5]) * fb
            F[0, 3 + i] += (R0[i, 0] * nu[0] + R0[i, 1] * nu[1] + R0[i, 2] * nu[2]) * fb
    return F


@njit(cache=True)
def generalized_forces(F, p, axis_W, origin_W, tree_i, nv):
    """J^T F: the generalized forces of spatial forces F (nb, 6) [tau_W, f_W] applied at
    the body origins (as the plant applies its ``applied_spatial_force`` input).

    One backward pass (children before parents): each body's accumulated wrench, shifted
    to its joint's origin and projected on the joint's world axis, is that revolute
    joint's torque; the floating base takes the whole tree's wrench about its origin
    (Drake's order: [torque, force], world frame); then the wrench moves to the parent.
    """
    nb = tree_i.shape[0]
    acc = F.copy()
    tau = np.zeros(nv)
    for b in range(nb - 1, -1, -1):
        parent, kind, vs = tree_i[b, 0], tree_i[b, 1], tree_i[b, 3]
        t0, t1, t2 = acc[b, 0], acc[b, 1], acc[b, 2]
        f0, f1, f2 = acc[b, 3], acc[b, 4], acc[b, 5]
        if kind == REVOLUTE:
            # The torque about the joint origin Fo (on the axis), along the axis.
            d0 = p[b, 0] - origin_W[b, 0]
            d1 = p[b, 1] - origin_W[b, 1]
            d2 = p[b, 2] - origin_W[b, 2]
            tau[vs] = (
                axis_W[b, 0] * (t0 + (d1 * f2 - d2 * f1))
                + axis_W[b, 1] * (t1 + (d2 * f0 - d0 * f2))
                + axis_W[b, 2] * (t2 + (d0 * f1 - d1 * f0))
            )
        elif kind == PLANAR:
            # [f . x_F, f . y_F, torque about Mo . z_F].
            d0 = p[b, 0] - origin_W[b, 0]
            d1 = p[b, 1] - origin_W[b, 1]
            d2 = p[b, 2] - origin_W[b, 2]
            tau[vs] = axis_W[b, 3] * f0 + axis_W[b, 4] * f1 + axis_W[b, 5] * f2
            tau[vs + 1] = axis_W[b, 6] * f0 + axis_W[b, 7] * f1 + axis_W[b, 8] * f2
            tau[vs + 2] = (
                axis_W[b, 0] * (t0 + (d1 * f2 - d2 * f1))
                + axis_W[b, 1] * (t1 + (d2 * f0 - d0 * f2))
                + axis_W[b, 2] * (t2 + (d0 * f1 - d1 * f0))
            )
        elif kind == QUATERNION_FLOATING:
            tau[vs], tau[vs + 1], tau[vs + 2] = t0, t1, t2
            tau[vs + 3], tau[vs + 4], tau[vs + 5] = f0, f1, f2
        if parent >= 0:
            d0 = p[b, 0] - p[parent, 0]
            d1 = p[b, 1] - p[parent, 1]
            d2 = p[b, 2] - p[parent, 2]
            acc[parent, 0] += t0 + (d1 * f2 - d2 * f1)
            acc[parent, 1] += t1 + (d2 * f0 - d0 * f2)
            acc[parent, 2] += t2 + (d0 * f1 - d1 * f0)
            acc[parent, 3] += f0
            acc[parent, 4] += f1
            acc[parent, 5] += f2
    return tau


@njit(cache=True)
def generalized_forces_from_state(x, nq, nv, F_flat, tree_i, tree_f):
    """``generalized_forces`` at the configuration of the state x, for held forces given
    flat (nb * 6, rows [tau_W, f_W]: the held discrete state as it is stored)."""
    R, p, w, v, axis_W, origin_W = body_kinematics(x, nq, tree_i, tree_f)
    F = F_flat.reshape(tree_i.shape[0], 6)
    return generalized_forces(F, p, axis_W, origin_W, tree_i, nv)


@njit(cache=True)
def hull_acceleration(v_hull, w_hull, t, v_prev):
    """``hydro._hull_acceleration`` compiled: finite-difference hull accelerations
    against the newest stored sample taken strictly before ``t``.

    Args:
        v_hull, w_hull: (3,) the hull's velocity and angular velocity now (world).
        t: now [s].
        v_prev: (14,) two samples [v_W (3), w_W (3), t], newest first; t < 0: none.

    Returns:
        ((6,) [a_W, alpha_W], known): ``known`` is False when no sample qualifies.
    """
    accel = np.zeros(6)
    for k in range(2):
        ts = v_prev[7 * k + 6]
        if 0.0 <= ts < t - 1e-12:
            dt = t - ts
            for i in range(3):
                accel[i] = (v_hull[i] - v_prev[7 * k + i]) / dt
                accel[3 + i] = (w_hull[i] - v_prev[7 * k + 3 + i]) / dt
            return accel, True
    return accel, False


@njit(cache=True)
def forces_from_state(
    x, nq, balloon_volume, t, v_prev, tree_i, tree_f, elements, strips, damping, prm, frac
):
    """``spatial_wrenches`` from the plant's state x = [q, v] in one call (kinematics, the
    hull's acceleration estimate from ``v_prev`` as in ``hull_acceleration``, forces):
    one crossing from Python instead of three. Returns (F, R, p, w, v): the forces and
    the kinematics they came from."""
    R, p, w, v, axis_W, origin_W = body_kinematics(x, nq, tree_i, tree_f)
    accel, known = hull_acceleration(v[0], w[0], t, v_prev)
    F = spatial_wrenches(
        R, p, w, v, balloon_volume, accel, known, elements, strips, damping, prm, frac
    )
    return F, R, p, w, v
