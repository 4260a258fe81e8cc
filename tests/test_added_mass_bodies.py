"""The fins' added-mass bodies in the plant: their mass acts along each plate's normal on
the floating hull, their moments about the plates' in-plane axes, nothing edgewise."""

import copy

import numpy as np
import pytest
from pydrake.systems.framework import DiagramBuilder

from manta_drake.model.added_mass import (
    fin_plates,
    heave_body_inertia,
    plate_added_mass,
    split_hull_added_mass,
)
from manta_drake.model.coefficients import load_coefficients
from manta_drake.model.plant import FIN_ADDED_MASS_INSTANCE, add_plant
from manta_drake.model.robot_params import DEFAULT_ROBOT as P
from manta_drake.model.robot_params import LEGS

FACTORS = (0.68, 0.64)


def _plant(fin_added_mass):
    coeffs = copy.deepcopy(load_coefficients())
    coeffs.fins.added_mass_factor.value = list(FACTORS)
    handles = add_plant(
        DiagramBuilder(), hydro=coeffs, with_pool=False, fin_added_mass=fin_added_mass
    )
    return handles, coeffs


def _hull_effective(handles):
    """The hull's 6x6 effective inertia (about its origin, [w, v] world axes) with the
    robot's joints held and every other joint (the added-mass bodies' planar joints) free:
    the Schur complement of the mass matrix."""
    plant = handles.plant
    context = plant.CreateDefaultContext()
    M = plant.CalcMassMatrix(context)
    hull = list(
        range(
            handles.body.floating_velocities_start_in_v(),
            handles.body.floating_velocities_start_in_v() + 6,
        )
    )
    robot_joints = [
        plant.GetJointByName(n, handles.robot).velocity_start() for n in handles.joint_names
    ]
    free = [i for i in range(plant.num_velocities()) if i not in hull + robot_joints]
    A = M[np.ix_(hull, hull)]
    if not free:
        return A, context
    B, C = M[np.ix_(hull, free)], M[np.ix_(free, free)]
    return A - B @ np.linalg.solve(C, B.T), context


def _about_hull(handles, context):
    """The hull's welded added-mass body's spatial inertia about the hull's origin, world
    axes, as the 6x6 [w, v] block of the mass matrix it adds."""
    plant = handles.plant
    body = plant.GetBodyByName("added_mass")
    X_WB = body.EvalPoseInWorld(context)
    p_WH = handles.body.EvalPoseInWorld(context).translation()
    M = body.default_spatial_inertia().ReExpress(X_WB.rotation())
    return M.Shift(p_WH - X_WB.translation()).CopyToFullMatrix6()


def test_bodies_add_their_mass_along_the_plate_normals_only():
    with_bodies, coeffs = _plant("bodies")
    hinge, _ = _plant("hinge")
    M_b, context = _hull_effective(with_bodies)
    M_h, _ = _hull_effective(hinge)
    plant = with_bodies.plant
    instance = plant.GetModelInstanceByName(FIN_ADDED_MASS_INSTANCE)
    assert not plant.gravity_field().is_enabled(instance)
    rho = coeffs.water_density.value
    expected = np.zeros((6, 6))
    p_hull = with_bodies.body.EvalPoseInWorld(context).translation()
    for leg in LEGS:
        for plate, factor in zip(fin_plates(P), FACTORS):
            m, (i_c, i_s, _) = plate_added_mass(plate.chord, plate.span, rho, factor)
            X = plant.GetBodyByName(f"{leg}_{plate.name}_added_mass").EvalPoseInWorld(context)
            R, r = X.rotation().matrix(), X.translation() - p_hull
            n = R[:, 2]
            # Normal velocity of the body's centre for hull rates [w, v]: n . (w x r + v).
            J = np.concatenate([np.cross(r, n), n])
            expected += m * np.outer(J, J)
            I_inplane = R @ np.diag([i_c, i_s, 0.0]) @ R.T
            expected[:3, :3] += I_inplane
    # The hull's heave body (at the hull's origin, along its z) and the hull's welded
    # added-mass body, which differs between the two plants (split_hull_added_mass).
    heave = plant.GetBodyByName("body_heave_added_mass")
    m_h = heave.default_mass()
    expected[5, 5] += m_h
    expected[:3, :3] += np.diag(heave_body_inertia(m_h)) * [1.0, 1.0, 0.0]
    expected += _about_hull(with_bodies, context) - _about_hull(
        hinge, hinge.plant.CreateDefaultContext()
    )
    np.testing.assert_allclose(M_b - M_h, expected, atol=1e-9)
    # At the zero pose the plates are level: heave gets all of it, surge none.
    total = sum(
        plate_added_mass(pl.chord, pl.span, rho, k)[0] for pl, k in zip(fin_plates(P), FACTORS)
    ) * len(LEGS)
    iso_b, _, m_heave = split_hull_added_mass(
        coeffs.body.added_mass.value, coeffs.fins.hull_interaction_added_mass.value
    )
    assert m_heave == pytest.approx(m_h)
    iso_h = hinge.plant.GetBodyByName("added_mass").default_mass()
    assert iso_h == pytest.approx(
        0.5 * (min(coeffs.body.added_mass.value) + max(coeffs.body.added_mass.value))
    )
    assert (M_b - M_h)[5, 5] == pytest.approx(total + m_h + iso_b - iso_h, rel=1e-9)
    assert (M_b - M_h)[3, 3] == pytest.approx(iso_b - iso_h, rel=1e-9)  # surge: the split only


def test_bodies_replace_the_hinges_reflected_inertia():
    with_bodies, _ = _plant("bodies")
    hinge, _ = _plant("hinge")
    for handles, expect_rotor in ((with_bodies, False), (hinge, True)):
        plant = handles.plant
        context = plant.CreateDefaultContext()
        rotor = [
            plant.get_joint_actuator(i).calc_reflected_inertia(context)
            for i in plant.GetJointActuatorIndices(handles.robot)
        ]
        assert (max(rotor) > 0) == expect_rotor


def test_bad_factors_are_refused():
    coeffs = copy.deepcopy(load_coefficients())
    coeffs.fins.added_mass_factor.value = [0.7]
    with pytest.raises(ValueError, match="fins.added_mass_factor"):
        add_plant(DiagramBuilder(), hydro=coeffs, with_pool=False, fin_added_mass="bodies")
    with pytest.raises(ValueError, match="fin_added_mass"):
        add_plant(DiagramBuilder(), hydro=coeffs, with_pool=False, fin_added_mass="wings")
