"""The fin strips' flapping-foil model against a published heaving-pitching foil experiment.

The committed reference (models/reference/heaving_pitching_foil.yaml) holds the data with its
source (`data`) and the model's numbers on the same kinematics (`model`, made by
``python -m manta_drake.studies.validation.foil_data``). Here: the data's provenance is there,
the strip model recomputed on three of the data's points gives the committed numbers (it is
deterministic), thrust grows with the Strouhal number at the data's fixed h0/c and alpha_max,
the model's lift-slope law at the experiment's aspect ratio meets the data within the acceptance,
and the model meets Garrick's small-amplitude plunge.
"""

import math
import re

import numpy as np
import pytest

from manta_drake.studies import REPO as ROOT
from manta_drake.studies.validation import SECTIONS
from manta_drake.studies.validation import foil_data as FD

REL = 1e-6
POINTS = (0, 2)  # St 0.20 and 0.30 of the data (recomputed; the rest is committed)


@pytest.fixture(scope="module")
def ref():
    return FD.load_reference(FD.YAML_PATH)


@pytest.fixture(scope="module")
def shipped_runs(ref):
    """The shipped-parameter model on POINTS, recomputed (shared by two tests)."""
    pts = FD.data_points(ref["data"])
    p = FD.base_parameters("shipped")
    return {i: FD.model_point(pts[i], p) for i in POINTS}


def test_reference_records_its_source_and_conditions(ref):
    data = ref["data"]
    src = data["source"]
    for key in FD.PROVENANCE_FIELDS:
        assert str(src.get(key, "")).strip(), key
    assert re.fullmatch(
        r"https://github\.com/wagenhoffer/Puffer/blob/[0-9a-f]{40}/"
        r"test/pan_comparisons\.jl",
        src["url"],
    )
    assert src["url"].split("/")[6] in src["commit"]
    assert "10.1017/jfm.2012.119" in src["digitized_from"]
    cond = data["conditions"]
    assert cond["h0_over_c"] == 0.75 and cond["alpha_max_deg"] == 15.0
    assert cond["psi_deg"] == 90.0 and cond["pivot_from_leading_edge"] == pytest.approx(1 / 3)
    for key in ("thrust_coefficient", "efficiency"):
        block = data[key]
        assert len(block["strouhal"]) == len(block["value"]) == 5
        assert np.all(np.diff(block["strouhal"]) > 0)
    assert data["accuracy"] and data["not_used"]
    assert "foil-data" in SECTIONS and SECTIONS["foil-data"][0] == FD.__name__


def test_committed_model_uses_the_shipped_parameters_and_bands(ref):
    """The committed `model` is the one of the shipped hydrodynamics.yaml; the sensitivity bands
    are the ones its sources state."""
    shipped = FD.shipped_parameters()
    assert ref["model"]["bases"]["shipped"]["parameters"] == pytest.approx(shipped, rel=1e-9), (
        "hydrodynamics.yaml's fins changed: regenerate with " + FD.COMMAND
    )
    from manta_drake.model.coefficients import load_coefficients

    fins = load_coefficients().fins
    for key, (lo, hi) in FD.BANDS.items():
        src = getattr(fins, key).source
        assert f"band {lo:g}-{hi:g}" in src or f"band {lo}-{hi}" in src, (key, src)


@pytest.mark.slow
def test_strip_model_recomputed_gives_the_committed_numbers(ref, shipped_runs):
    committed = ref["model"]["bases"]
    for i, run in shipped_runs.items():
        c = committed["shipped"]["points"][i]
        for key in ("ct", "cp", "eta", "theta0_deg", "alpha34_max_deg"):
            assert run[key] == pytest.approx(c[key], rel=REL), (i, key)
        assert c["ratio"] == pytest.approx(c["ct"] / c["ct_data"], rel=1e-9)
    pt = FD.data_points(ref["data"])[0]
    two = FD.model_point(pt, FD.base_parameters("2d"))
    assert two["ct"] == pytest.approx(committed["2d"]["points"][0]["ct"], rel=REL)
    assert two["eta"] == pytest.approx(committed["2d"]["points"][0]["eta"], rel=REL)


def test_experiment_base_is_helmbold_at_the_data_foil_and_accepted(ref):
    """The acceptance case applies the model's own law (Helmbold at the plate's aspect ratio) to
    the data foil, 0.6 m / 0.1 m = AR 6, a = 2 pi 6 / (2 + sqrt 40); every committed point is
    within the acceptance, one is recomputed, and the acceptance block is the points' worst."""
    ar = FD.experiment_aspect_ratio(ref["data"])
    assert ar == pytest.approx(6.0)
    a = 2.0 * math.pi * 6.0 / (2.0 + math.sqrt(40.0))
    model = ref["model"]
    exp = model["bases"][FD.ACCEPTED_BASE]
    assert model["aspect_ratio"] == pytest.approx(ar)
    assert exp["parameters"]["lift_slope"] == pytest.approx(a, rel=1e-9)
    assert FD.base_parameters("experiment", aspect_ratio=ar)["lift_slope"] == pytest.approx(
        a, rel=1e-12
    )
    ratios = [r["ratio"] for r in exp["points"]]
    assert all(abs(x - 1.0) <= FD.ACCEPT for x in ratios), ratios
    worst = max(ratios, key=lambda x: abs(x - 1.0))
    assert model["acceptance"]["worst_ratio"] == pytest.approx(worst, rel=1e-12)
    assert model["acceptance"]["within"] is True
    pt = FD.data_points(ref["data"])[1]
    run = FD.model_point(pt, FD.base_parameters("experiment", aspect_ratio=ar))
    assert run["ct"] == pytest.approx(exp["points"][1]["ct"], rel=REL)
    # The steeper slope gives more thrust than the fin's at every point: C_T grows with a.
    ship = model["bases"]["shipped"]["points"]
    assert all(e["ct"] > s["ct"] for e, s in zip(exp["points"], ship))
    with pytest.raises(ValueError, match="aspect ratio"):
        FD.base_parameters("experiment")


def test_kinematics_hit_the_data_s_alpha_max(ref):
    for pt in FD.data_points(ref["data"]):
        th = FD.pitch_amplitude(pt["strouhal"], math.radians(pt["alpha_max_deg"]))
        assert 0.0 < th < math.atan(math.pi * pt["strouhal"])
        assert math.degrees(FD.alpha_max_of(pt["strouhal"], th, math.pi / 2)) == pytest.approx(
            pt["alpha_max_deg"], abs=1e-6
        )


def test_thrust_grows_with_strouhal_at_fixed_h0c(ref, shipped_runs):
    """At the data's fixed h0/c and alpha_max, C_T grows with St: in the data, in the shipped
    model and in attached flow (the committed series, tied to the code by the recomputed
    points; the 2 pi model with the stall blend does not grow: see the page)."""
    data = ref["data"]["thrust_coefficient"]["value"]
    assert np.all(np.diff(data) > 0)
    bases = ref["model"]["bases"]
    shipped = [r["ct"] for r in bases["shipped"]["points"]]
    assert np.all(np.diff(shipped) > 0), shipped
    assert np.all(np.diff([shipped_runs[i]["ct"] for i in POINTS]) > 0)
    attached = bases["2d"]["sensitivity"]["attached (no stall)"]
    assert np.all(np.diff(attached["ct"]) > 0), attached["ct"]
    pt = FD.data_points(ref["data"])[0]
    run = FD.model_point(pt, FD.base_parameters("2d") | {"stall_angle_deg": 180.0})
    assert attached["parameters"]["stall_angle_deg"] == 180.0
    assert run["ct"] == pytest.approx(attached["ct"][0], rel=REL)


@pytest.mark.slow
def test_garrick_small_amplitude_plunge(ref):
    committed = ref["model"]["garrick"]
    assert len(committed) == len(FD.GARRICK_K)
    for c in committed:  # every committed row, the two cheaper ones recomputed below
        assert abs(c["ratio"] - 1.0) <= FD.GARRICK_TOL and c["within_tol"], c
    rows = FD.garrick_rows(FD.GARRICK_K[:2])
    for row, c in zip(rows, committed):
        assert abs(row["ratio"] - 1.0) <= FD.GARRICK_TOL, row
        assert abs(row["ratio_jones"] - 1.0) <= 0.01, row  # Jones's C(k) is the model's
        assert row["ct_model"] == pytest.approx(c["ct_model"], rel=REL)


def test_page_renders_from_the_committed_reference(ref, tmp_path):
    """``--from-yaml``: RUNS/foil_data.md and .json, and a new OUT/validation.md with the
    block, which is the committed page's block."""
    argv = ["--runs", str(tmp_path / "runs"), "--out", str(tmp_path / "page"), "--from-yaml"]
    assert FD.main(argv) == 0
    text = (tmp_path / "runs" / "foil_data.md").read_text()
    begin, end = f"<!-- section: {FD.SECTION} -->", f"<!-- end section: {FD.SECTION} -->"
    assert text.startswith(begin) and text.rstrip().endswith(end)
    assert ref["data"]["source"]["url"] in text
    assert f"`{FD.COMMAND}`; the data and the numbers are" in text
    assert (tmp_path / "runs" / "foil_data.json").is_file()
    page = (tmp_path / "page" / "validation.md").read_text()
    assert page.startswith("# Validation\n\nMade ")
    assert text in page and text in (ROOT / "docs" / "validation.md").read_text()
