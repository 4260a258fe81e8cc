"""The added-mass validation (manta_drake.studies.validation.added_mass): the meshes are the
model's geometry (the plant's link poses, closed outward surfaces), capytaine reproduces Lamb's
ellipsoid and the committed whole-robot numbers, and the committed results file carries its
provenance and consistent numbers."""

import math

import numpy as np
import pytest

from manta_drake.model.robot_params import DEFAULT_ROBOT, LEGS
from manta_drake.studies import REPO
from manta_drake.studies.validation import added_mass as am

RHO = 1000.0


def _load():
    if not am.YAML_PATH.is_file():
        pytest.skip(f"no committed results {am.YAML_PATH}")
    return am.load_results(am.YAML_PATH)


def _closed_volume(quads) -> float:
    """Enclosed volume by the divergence theorem over the quads split into two triangles
    (positive for outward normals)."""
    a, b, c, d = (quads[:, k] for k in range(4))
    return float(
        (np.einsum("ij,ij->i", a, np.cross(b, c)) + np.einsum("ij,ij->i", a, np.cross(c, d))).sum()
        / 6.0
    )


# --- geometry (no capytaine) ------------------------------------------------------------------


def test_link_poses_are_the_plants(robot_plant, rng):
    """The plates are posed where MultibodyPlant puts links 3 and 4 (the SDFormat model)."""
    _, h = robot_plant
    plant = h.plant
    context = plant.CreateDefaultContext()
    joints = [plant.GetJointByName(n, h.robot) for n in h.joint_names]
    body_frame = h.body.body_frame()
    worst = 0.0
    for _ in range(20):
        q = rng.uniform(-1.5, 1.5, 16)
        for joint, qi in zip(joints, q):
            joint.set_angle(context, qi)
        for k, leg in enumerate(LEGS):
            ours = am.link_poses(leg, q[4 * k : 4 * k + 4])
            for i in (1, 2, 3, 4):
                X = (
                    plant.GetBodyByName(f"{leg}_link{i}", h.robot)
                    .body_frame()
                    .CalcPose(context, body_frame)
                    .GetAsMatrix4()
                )
                worst = max(worst, np.abs(X - ours[i - 1]).max())
    assert worst < 1e-9


def test_box_and_hull_meshes_are_closed_and_outward():
    box, _ = am.plate_box("proximal")
    quads = box.quads(0.01)
    t, c, s = box.size
    assert _closed_volume(quads) == pytest.approx(t * c * s, rel=1e-12)
    a, b, cc = DEFAULT_ROBOT.body_semi_axes
    hull = am.hull().quads(24)
    # the inscribed polyhedron: a little below the ellipsoid's volume
    assert _closed_volume(hull) == pytest.approx(4 / 3 * math.pi * a * b * cc, rel=0.02)
    assert _closed_volume(hull) < 4 / 3 * math.pi * a * b * cc


def test_flat_plates_match_the_cfd_studys_fins():
    """At q = 0 each fin's two boxes fill the CFD study's fin prism (cfd.geometry.fin_part,
    built from the same parameters by another route): same bounds (to 10 um: the STL
    study's prism differs from the boxes by ~1 um)."""
    from manta_drake.studies.cfd.geometry import bounds, fin_part

    q = np.zeros(4)
    for leg in LEGS:
        quads = np.concatenate([b.quads(0.02) for b in am.fin_plates(leg, q)])
        lo, hi = bounds([fin_part(leg)])
        np.testing.assert_allclose(quads.reshape(-1, 3).min(axis=0), lo, atol=1e-5)
        np.testing.assert_allclose(quads.reshape(-1, 3).max(axis=0), hi, atol=1e-5)


def test_union_keeps_no_panel_inside_another_part():
    parts = am.robot_parts(am.POSES["stroke_feathered"][1])
    quads, owner, counts = am.union_panels(parts, 0.024, 12)
    centres = quads.mean(axis=1)
    for i, part in enumerate(parts):
        others = owner != i
        assert not part.contains(centres[others]).any(), part.name
    # every plate lost its shared joint face or its root inside the hull; the seam was split
    assert all(c["dropped"] > 0 for c in counts.values() if c is not counts["hull"])
    assert sum(c["split"] for c in counts.values()) > 0


def test_dnv_table_and_strip_values():
    assert am.dnv_rectangular_plate_ca(1.25) == pytest.approx(0.642)
    assert am.dnv_rectangular_plate_ca(0.20 / 0.14) == pytest.approx(0.676, abs=5e-4)
    ca, mass = am.dnv_plate_heave(0.14, 0.20, RHO)
    assert mass == pytest.approx(ca * RHO * math.pi / 4 * 0.14**2 * 0.20)
    assert am.strip_plate_heave(0.14, 0.20, RHO) == pytest.approx(
        RHO * math.pi * 0.14**2 / 4 * 0.20
    )
    with pytest.raises(ValueError):
        am.dnv_rectangular_plate_ca(12.0)


def test_matrix_about_moves_the_reference_point():
    """A point mass m at r about the origin is m on translations and m |r|^2 about an axis
    through the origin perpendicular to r; moved to r, only m remains."""
    r = np.array([0.3, -0.2, 0.1])
    m = 2.0
    J = np.hstack([np.eye(3), -am._skew(r)])  # v(r) = v_O + w x r
    A_origin = m * J.T @ J
    A_r = am.matrix_about(A_origin, r)
    np.testing.assert_allclose(A_r[:3, :3], m * np.eye(3), atol=1e-12)
    np.testing.assert_allclose(A_r[3:, 3:], 0.0, atol=1e-12)


# --- the committed results -------------------------------------------------------------------


def test_committed_results_have_provenance_and_consistent_numbers():
    data = _load()
    p = data["provenance"]
    for key in (
        "generator",
        "command",
        "capytaine",
        "method",
        "fluid",
        "rho",
        "frame",
        "date",
        "commit",
        "seam_depth",
    ):
        assert p.get(key) not in (None, ""), key
    assert isinstance(p["uncommitted"], list)
    assert p["method"] == "direct" and p["capytaine"].startswith("3.0")
    assert "--section added-mass" in p["command"]
    # (a) every mesh within 1 % (translations) / 2.5 % (rotations) of Lamb, finer ones closer
    errors = np.abs([m["error"] for m in data["hull"]["meshes"]])
    assert errors[-1, :3].max() < 0.01 and errors[-1, 3:].max() < 0.01
    assert np.all(np.diff(errors.max(axis=1)) < 0)
    np.testing.assert_allclose(data["hull"]["lamb"][:3], (1.3006, 2.8223, 7.8574), rtol=2e-4)
    # (b) the thin-plate limit near DNV; the 12 mm plate above it, below the 2-D strip
    for plate in data["plates"].values():
        assert plate["thin_limit"]["heave"] == pytest.approx(plate["dnv_heave"], rel=0.12)
        for run in plate["runs"]:
            assert plate["dnv_heave"] < run["heave"] < plate["strip_heave"]
    # (c) the fins dominate: the robot's heave and roll far above the hull's, and the robot
    # more than its parts alone (the front and rear fins act as one wider plate)
    hull = data["hull"]["meshes"][-1]["diagonal"]
    for name, pose in data["robot"]["poses"].items():
        finest = np.array(pose["meshes"][-1]["matrix"])
        assert finest[2, 2] > 1.5 * hull[2], name
        assert finest[3, 3] > 10 * hull[3], name
        np.testing.assert_allclose(finest, finest.T, atol=0.02 * np.abs(finest).max())
        assert np.all(np.linalg.eigvalsh(0.5 * (finest + finest.T)) > 0), name
        whole = np.array(pose["whole_at_parts_level"])
        parts = np.array(pose["parts"]["sum_hull_plates"])
        assert whole[2, 2] > parts[2, 2], name
        # the three meshes agree on heave and roll to 5 % (the seam where the plates cut the
        # hull's rim leaves a scatter of 1-2 %, not a monotone convergence)
        for k in (2, 3):
            values = [m["matrix"][k][k] for m in pose["meshes"]]
            assert max(values) / min(values) < 1.05, (name, k, values)
    flat = np.array(data["robot"]["poses"]["flat"]["meshes"][-1]["matrix"])
    assert flat[2, 2] > 3 * DEFAULT_ROBOT.total_mass  # heave added mass ~3.6 x the robot's


def test_the_page_renders_from_the_committed_results():
    data = _load()
    block = am.render_section(data)
    begin, end = "<!-- section: added-mass -->", "<!-- end section: added-mass -->"
    assert block.startswith(begin) and block.endswith(end)
    assert f"Regenerate with `{am.COMMAND}`;" in block and data["provenance"]["commit"] in block
    page = REPO / "docs" / "validation.md"
    if page.is_file():
        assert block in page.read_text(), (
            "docs/validation.md is stale: run the study with --from-yaml"
        )


# --- capytaine --------------------------------------------------------------------------------


@pytest.mark.slow
def test_hull_against_lamb():
    pytest.importorskip("capytaine", reason="capytaine is not installed (the validation extra)")
    from manta_drake.model.potential_flow import ellipsoid_added_mass

    r = am.solve_added_mass(am.hull().quads(24), RHO, verbose=False)
    assert r["panels"] == 1152
    mass, inertia = ellipsoid_added_mass(DEFAULT_ROBOT.body_semi_axes, RHO)
    diag = np.diag(r["matrix"])
    np.testing.assert_allclose(diag[:3], mass, rtol=0.01)
    np.testing.assert_allclose(diag[3:], inertia, rtol=0.02)
    off = r["matrix"] - np.diag(diag)
    assert np.abs(off).max() < 1e-4 * diag.max()


@pytest.mark.slow
def test_committed_whole_robot_is_reproduced_at_the_coarsest_mesh():
    pytest.importorskip("capytaine", reason="capytaine is not installed (the validation extra)")
    data = _load()
    pose = data["robot"]["poses"]["flat"]
    level = pose["meshes"][0]
    parts = am.robot_parts(am.POSES["flat"][1])
    quads, owner, _ = am.union_panels(
        parts, level["h"], level["hull_n"], data["provenance"]["seam_depth"]
    )
    r = am.solve_added_mass(quads, data["provenance"]["rho"], owner=owner, verbose=False)
    assert r["panels"] == level["panels"]
    np.testing.assert_allclose(np.diag(r["matrix"]), np.diag(level["matrix"]), rtol=0.03)


@pytest.mark.slow
def test_the_command_renders_its_block_beside_other_sections(tmp_path):
    """``--from-yaml`` solves nothing: it writes RUNS/added_mass.json and .md and puts its block
    into OUT/validation.md, which already holds another section (appended, then replaced in
    place)."""
    import json

    from manta_drake.studies.validation import main, section_markers

    data = _load()
    page = tmp_path / "validation.md"
    other_begin, other_end = section_markers("other")
    page.write_text(f"# Validation\n\n{other_begin}\nthe other section\n{other_end}\n")
    argv = ["--section", "added-mass", "--runs", str(tmp_path / "runs"), "--out", str(tmp_path)]
    argv += ["--from-yaml", "--yaml", str(am.YAML_PATH)]
    assert main(argv) == 0
    assert json.loads((tmp_path / "runs" / "added_mass.json").read_text()) == data
    text = page.read_text()
    assert "the other section" in text and am.render_section(data) in text
    assert main(argv) == 0
    assert page.read_text() == text  # regenerating changes no byte
    assert text.count("<!-- section: added-mass -->") == 1


def test_the_yaml_fin_hull_interaction_is_the_bem_difference():
    """fins.hull_interaction_added_mass is the whole robot's heave less the hull alone and
    the four fins alone at the flat pose (all at the parts' mesh), and it lies inside the
    band its source states over the three poses."""
    from manta_drake.model.coefficients import load_coefficients

    poses = _load()["robot"]["poses"]
    interaction = {
        name: pose["whole_at_parts_level"][2][2] - pose["parts"]["sum_hull_fins"][2][2]
        for name, pose in poses.items()
    }
    value = load_coefficients().fins.hull_interaction_added_mass.value
    assert value == pytest.approx(interaction["flat"], rel=1e-3)
    assert interaction["stroke_feathered"] < interaction["stroke"] < value
    assert interaction["stroke_feathered"] == pytest.approx(2.2, abs=0.05)
