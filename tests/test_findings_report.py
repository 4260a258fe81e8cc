"""The criteria of the findings study (manta_drake.studies.findings) on small synthetic
tables with known answers."""

import csv
import pathlib

import pytest

from manta_drake.studies import findings

ROOT = pathlib.Path(__file__).resolve().parent.parent
SHIPPED = ROOT / "diagrams" / "sweeps" / "data" / "findings_results.csv"


@pytest.fixture(scope="module")
def fr():
    return findings


def point(fr, **gaits):
    """{gait: Motion}; a gait given as None is a run without a mean velocity."""
    return {g: (fr.UNDETERMINED if m is None else fr.Motion(*m)) for g, m in gaits.items()}


# A band point where the paper's five findings all hold: (u, v, yaw).
GOOD = {
    "swim": (0.05, 0.0, 0.5),
    "trot": (0.06, 0.0, 0.5),
    "walk": (0.08, 0.0, -1.0),
    "crab": (0.002, -0.015, 0.3),
    "turning": (0.0, -0.005, -8.0),
}


def test_a_point_where_everything_holds(fr):
    p = point(fr, **GOOD)
    assert fr.every_gait_forward(p) is True
    assert fr.walk_fastest(p) is True
    assert fr.swim_slower_than_walk(p) is True
    assert fr.crab_sideways(p) is True
    assert fr.turning_turns(p) is True


def test_walk_behind_trot_fails_walk_fastest(fr):
    p = point(fr, **{**GOOD, "walk": (0.07, 0.0, 0.0), "trot": (0.08, 0.0, 0.0)})
    assert fr.walk_fastest(p) is False
    assert fr.walk_fastest(p, ("crab", "turning")) is True  # the variant without the trot
    assert fr.swim_slower_than_walk(p) is True


def test_a_fast_swim_fails_findings_2_and_3_but_not_the_floor_variant(fr):
    p = point(fr, **{**GOOD, "swim": (0.107, -0.02, -11.0)})
    assert fr.walk_fastest(p) is False
    assert fr.swim_slower_than_walk(p) is False
    assert fr.walk_fastest(p, ("trot", "crab", "turning")) is True
    # Its yaw of 11 deg/s beats the turning gait's 8: finding 5 fails, its floor variant holds.
    assert fr.turning_turns(p) is False
    assert fr.turning_turns(p, ("trot", "walk", "crab")) is True


def test_empty_u_is_undetermined_never_holds_or_fails(fr):
    p = point(fr, **{**GOOD, "walk": None})
    assert fr.every_gait_forward(p) is None
    assert fr.walk_fastest(p) is None
    assert fr.swim_slower_than_walk(p) is None
    assert fr.moves_forward(p, "walk") is None
    # ... but a definite failure elsewhere is still a failure (three-valued AND).
    p = point(fr, **{**GOOD, "walk": None, "trot": (0.005, 0.0, 0.0)})
    assert fr.every_gait_forward(p) is False
    # A missing gait (no row) is undetermined too.
    p = point(fr, **{g: m for g, m in GOOD.items() if g != "crab"})
    assert fr.crab_sideways(p) is None
    assert fr.walk_fastest(p) is None  # walk beats all it can see, but the crab is unknown


def test_forward_threshold(fr):
    assert fr.moves_forward(point(fr, trot=(0.0101, 0, 0)), "trot") is True
    assert fr.moves_forward(point(fr, trot=(0.0099, 0, 0)), "trot") is False
    assert fr.moves_forward(point(fr, trot=(-0.05, 0, 0)), "trot") is False
    p = point(fr, **{**GOOD, "trot": (0.007, 0.0, 0.0)})
    assert fr.every_gait_forward(p) is False
    # Finding 1 is about the forward gaits: a crab or turning gait that does not go forward
    # does not fail it.
    assert fr.every_gait_forward(point(fr, **GOOD)) is True
    assert fr.moves_forward(point(fr, **GOOD), "turning") is False


def test_crab_sideways(fr):
    def crab(u, v):
        return fr.crab_sideways(point(fr, crab=(u, v, 0.0)))

    assert crab(0.004, -0.011) is True  # |v| > 2|u| and moving
    assert crab(0.0071, -0.0085) is False  # more sideways than forward, but not 2:1
    assert crab(0.0, 0.008) is False  # purely sideways but below 0.01 m/s: not moving
    assert crab(-0.004, 0.011) is True  # signs do not matter
    assert crab(0.044, -0.021) is False
    assert fr.crab_sideways(point(fr, crab=None)) is None


def test_turning_turns(fr):
    base = {**GOOD}
    assert fr.turning_turns(point(fr, **{**base, "turning": (0.0, 0.0, 2.9)})) is False
    assert fr.turning_turns(point(fr, **{**base, "turning": (0.0, 0.0, 3.1)})) is True
    # Larger in magnitude, either sense, than every other gait at the point.
    assert fr.turning_turns(point(fr, **{**base, "crab": (0.0, 0.0, -8.5)})) is False
    assert (
        fr.turning_turns(
            point(fr, **{**base, "turning": (0.0, 0.0, 9.0), "crab": (0.0, 0.0, -8.5)})
        )
        is True
    )
    # Below 3 deg/s it fails even if another gait's yaw rate is unknown; above, it is undetermined.
    assert fr.turning_turns(point(fr, **{**base, "turning": (0, 0, 1.0), "swim": None})) is False
    assert fr.turning_turns(point(fr, **{**base, "swim": None})) is None


def _rows(fr, points):
    """results.csv-like rows (strings) for {(friction, damping, weight): {gait: (u, v, yaw)}}."""
    rows = []
    for (f, d, w), gaits in points.items():
        for g, m in gaits.items():
            u, v, yaw = ("", "", "") if m is None else (repr(m[0]), repr(m[1]), repr(m[2]))
            rows.append(
                {
                    "base": f"locomotion_{g}",
                    "contact.friction": str(f),
                    "hull_damping": str(d),
                    "net_weight_kg": str(w),
                    "status": "ok",
                    "u": u,
                    "v": v,
                    "yaw_rate_deg_s": yaw,
                    "steady_start_s": "6.0",
                    "steady_end_s": "20.0" if m else "6.5",
                }
            )
    return rows


def test_band_tally_counts_holds_fails_and_undetermined(fr):
    pts = {
        (0.5, 1.0, 0.85): dict(GOOD),
        (0.8, 1.0, 0.85): {**GOOD, "walk": (0.07, 0.0, 0.0), "trot": (0.08, 0.0, 0.0)},
        (0.8, 1.3, 0.85): {**GOOD, "walk": None},
    }
    points = fr.band_points(_rows(fr, pts))
    assert len(points) == 3 and points[(0.8, 1.3, 0.85)]["walk"] == fr.UNDETERMINED
    tallies, verdicts = fr.evaluate(points)
    t = {x.key: x for x in tallies}
    assert (t["walk_fastest"].holds, t["walk_fastest"].fails, t["walk_fastest"].undetermined) == (
        1,
        1,
        1,
    )
    assert t["walk_fastest"].fraction == pytest.approx(1 / 3)  # undetermined never counts
    assert t["crab_sideways"].holds == 3
    assert verdicts[(0.8, 1.3, 0.85)]["swim_slower"] is None
    stats = fr.gait_stats(points)
    assert stats["walk"]["undetermined"] == 1 and stats["walk"]["n"] == 3
    assert stats["walk"]["u"] == (pytest.approx(0.075), 0.07, 0.08)


def test_a_failed_run_is_undetermined_and_duplicates_are_refused(fr):
    rows = _rows(fr, {(0.5, 1.0, 0.85): dict(GOOD)})
    rows[0]["status"] = "failed"
    assert fr.band_points(rows)[(0.5, 1.0, 0.85)]["swim"] == fr.UNDETERMINED
    with pytest.raises(ValueError, match="appears twice"):
        fr.band_points(rows + rows[:1])
    assert fr.gait_of("path/to/locomotion_crab.yaml") == "crab"


def test_markdown_block_is_replaced_in_place(fr, tmp_path):
    md = tmp_path / "findings.md"
    md.write_text(f"# title\n\nintro\n\n{fr.MARK_BEGIN}\nstale table\n{fr.MARK_END}\n\nanalysis\n")
    points = fr.band_points(_rows(fr, {(0.5, 1.0, 0.85): dict(GOOD)}))
    tallies, verdicts = fr.evaluate(points)
    variants, _ = fr.evaluate(points, fr.VARIANTS)
    block = fr.markdown_block(tallies, variants, fr.gait_stats(points), verdicts, "x.csv")
    fr.write_markdown(md, block)
    text = md.read_text()
    assert text.startswith("# title\n\nintro\n\n") and text.endswith("\n\nanalysis\n")
    assert "stale table" not in text and "| 1. every gait moves forward |" in text
    assert "1/1" in text


# Two band points: everything holds at the first; the walk has no window at the second.
SMALL_BAND = {
    (0.5, 1.0, 0.85): dict(GOOD),
    (0.8, 1.3, 0.6): {**GOOD, "swim": (0.03, 0.01, 1.5), "walk": None},
}

# The block of SMALL_BAND, worked out by hand from the criteria.
SMALL_BLOCK = "\n".join(
    [
        "<!-- findings-report:begin -->",
        "<!-- generated by manta-drake study findings from small.csv; do not edit by hand -->",
        "",
        "| finding | criterion at each band point | holds | fails | undetermined | "
        "fraction of the band |",
        "| --- | --- | --- | --- | --- | --- |",
        "| 1. every gait moves forward | u > 0.01 m/s for swim, trot and walk | 1/2 | "
        "0 | 1 | 50 % (below 80 %) |",
        "| 2. walk is the fastest gait | u_walk > u of swim, trot, crab and turning | "
        "1/2 | 0 | 1 | 50 % (below 80 %) |",
        "| 3. swimming is slower than walking | u_swim < u_walk | 1/2 | 0 | 1 | "
        "50 % (below 80 %) |",
        "| 4. crab moves mostly sideways | \\|v\\| > 2 \\|u\\| and \\|v\\| > 0.01 m/s | 2/2 | "
        "0 | 0 | 100 % |",
        "| 5. turning turns | \\|yaw rate\\| >= 3 deg/s and > every other gait's | 1/2 | "
        "0 | 1 | 50 % (below 80 %) |",
        "",
        "Variants (not the paper's statements; they separate the causes):",
        "",
        "| variant | criterion | holds | fails | undetermined | fraction of the band |",
        "| --- | --- | --- | --- | --- | --- |",
        "| 2'. walk fastest among the floor gaits | "
        "u_walk > u of trot, crab and turning (swim left out) | 1/2 | 0 | 1 | 50 % (below 80 %) |",
        "| 5'. turning turns, compared with the floor gaits | "
        "\\|yaw rate\\| >= 3 deg/s and > trot's, walk's and crab's | "
        "1/2 | 0 | 1 | 50 % (below 80 %) |",
        "| swim moves forward | u_swim > 0.01 m/s | 2/2 | 0 | 0 | 100 % |",
        "| trot moves forward | u_trot > 0.01 m/s | 2/2 | 0 | 0 | 100 % |",
        "| walk moves forward | u_walk > 0.01 m/s | 1/2 | 0 | 1 | 50 % (below 80 %) |",
        "| crab moves forward | u_crab > 0.01 m/s | 0/2 | 2 | 0 | 0 % (below 80 %) |",
        "| turning moves forward | u_turning > 0.01 m/s | 0/2 | 2 | 0 | 0 % (below 80 %) |",
        "",
        "Per gait over the band: median (min to max) of the free-water window's mean velocity "
        "and yaw rate.",
        "",
        "| gait | runs | undetermined | u m/s | v m/s | yaw rate deg/s | window s |",
        "| --- | --- | --- | --- | --- | --- | --- |",
        "| swim | 2 | 0 | 0.040 (0.030 to 0.050) | 0.005 (0.000 to 0.010) | "
        "1.0 (0.5 to 1.5) | 14.0 (14.0 to 14.0) |",
        "| trot | 2 | 0 | 0.060 (0.060 to 0.060) | 0.000 (0.000 to 0.000) | "
        "0.5 (0.5 to 0.5) | 14.0 (14.0 to 14.0) |",
        "| walk | 2 | 1 | 0.080 (0.080 to 0.080) | 0.000 (0.000 to 0.000) | "
        "-1.0 (-1.0 to -1.0) | 14.0 (14.0 to 14.0) |",
        "| crab | 2 | 0 | 0.002 (0.002 to 0.002) | -0.015 (-0.015 to -0.015) | "
        "0.3 (0.3 to 0.3) | 14.0 (14.0 to 14.0) |",
        "| turning | 2 | 0 | 0.000 (0.000 to 0.000) | -0.005 (-0.005 to -0.005) | "
        "-8.0 (-8.0 to -8.0) | 14.0 (14.0 to 14.0) |",
        "",
        "Per band point (yes = holds, **no** = fails, ? = undetermined):",
        "",
        "| friction | hull damping x | net weight kg | 1 | 2 | 3 | 4 | 5 |",
        "| --- | --- | --- | --- | --- | --- | --- | --- |",
        "| 0.5 | 1 | 0.85 | yes | yes | yes | yes | yes |",
        "| 0.8 | 1.3 | 0.6 | ? | ? | ? | yes | ? |",
        "",
        "<!-- findings-report:end -->",
    ]
)


def test_the_template_puts_each_number_in_its_place(fr):
    points = fr.band_points(_rows(fr, SMALL_BAND))
    tallies, verdicts = fr.evaluate(points)
    variants, _ = fr.evaluate(points, fr.VARIANTS)
    block = fr.markdown_block(tallies, variants, fr.gait_stats(points), verdicts, "small.csv")
    assert block == SMALL_BLOCK


def _small_table(fr, path):
    rows = _rows(fr, SMALL_BAND)
    with open(path, "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=["run_id", *rows[0]])
        writer.writeheader()
        writer.writerows({"run_id": str(i), **row} for i, row in enumerate(rows))
    return path


@pytest.mark.slow
def test_out_writes_the_page_and_the_figure_there(fr, tmp_path, capsys):
    """Into an empty --out: a new page (title, stamp with the command, the block) and the
    figure under figures/; --page and --figure rename them; the checkout is not touched."""
    table = str(_small_table(fr, tmp_path / "small.csv"))
    out = tmp_path / "report"
    docs = (ROOT / "docs" / "findings.md").read_text()
    assert fr.main(["--results", table, "--sensitivity", "", "--out", str(out)]) == 0
    page = (out / "findings.md").read_text().split("\n")
    assert page[0] == "# Findings of section 4.1 over the uncertainty band"
    assert page[2].endswith(
        f". Regenerate with `manta-drake study findings --results {table} "
        f"--sensitivity '' --out {out}`."
    )
    assert "\n".join(page[4:]) == SMALL_BLOCK.replace("small.csv", table) + "\n"
    assert (out / "figures" / "findings.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    argv = ["--results", table, "--sensitivity", "", "--out", str(out)]
    assert fr.main([*argv, "--page", "stance", "--figure", "mirrored"]) == 0
    assert "| 0.8 | 1.3 | 0.6 | ? | ? | ? | yes | ? |" in (out / "stance.md").read_text()
    assert (out / "figures" / "mirrored.png").is_file()
    assert sorted(p.name for p in out.rglob("*")) == [
        "figures",
        "findings.md",
        "findings.png",
        "mirrored.png",
        "stance.md",
    ]
    assert (ROOT / "docs" / "findings.md").read_text() == docs
    assert capsys.readouterr().out.splitlines()[-1] == (
        f"wrote {out / 'stance.md'} and {out / 'figures' / 'mirrored.png'}"
    )


def test_an_installed_package_needs_out_and_names_are_plain(fr, tmp_path, monkeypatch):
    from manta_drake.config_io import ScenarioError
    from manta_drake.studies import report

    table = str(_small_table(fr, tmp_path / "small.csv"))
    for option, name in (("--page", "../x"), ("--figure", "f.png"), ("--page", "")):
        with pytest.raises(ScenarioError, match=f"^{option} .*: a file name without folder"):
            fr.main(["--results", table, "--out", str(tmp_path), option, name])
    monkeypatch.setattr(report, "REPO", tmp_path)  # no checkout above the package
    with pytest.raises(ScenarioError, match="^manta-drake study findings: --out DIR is required"):
        fr.main(["--results", table])
    assert sorted(p.name for p in tmp_path.iterdir()) == ["small.csv"]


@pytest.mark.skipif(not SHIPPED.exists(), reason="no shipped sweep table")
def test_shipped_table_is_a_full_band(fr):
    with open(SHIPPED, newline="") as f:
        points = fr.band_points(list(csv.DictReader(f)))
    assert len(points) == 27
    assert all(set(p) == set(fr.GAITS) for p in points.values())


# The diagnostics' pure functions (the simulations themselves are not run here).


def test_whole_cycles(fr):
    assert fr.whole_cycles((6.0, 20.0), 2.0) == (6.0, 20.0)
    assert fr.whole_cycles((6.0, 15.23), 2.0) == (6.0, 14.0)
    assert fr.whole_cycles((5.0, 6.5), 2.0) == (5.0, 6.5)  # shorter than a cycle: kept


def _samples(yaw, v_hull, contacts):
    import numpy as np

    n = len(contacts)
    return {
        "t": np.arange(n) * 0.001,
        "yaw": np.full(n, yaw),
        "v_world": np.tile(np.asarray(v_hull, dtype=float), (n, 1)),
        "contacts": contacts,
    }


def test_contact_summary_stride_and_slip_in_the_heading_frame(fr):
    import numpy as np

    zero = np.zeros(3)
    # Heading +y (yaw 90 deg), hull moving at 0.05 m/s along +y: forward in its own frame.
    # Leg fl holds (its point does not move: 3 N); leg rr's point slides back at 0.02 m/s (1 N).
    held = ("distal plate", "fl", zero, np.array([0.0, 0.1, 3.0]), zero, 0.0)
    sliding = ("foot", "rr", zero, np.array([0.0, 0.2, 1.0]), np.array([0.0, -0.02, 0.0]), 0.02)
    s = _samples(np.pi / 2, [0.0, 0.05, 0.0], [[held, sliding]] * 4)
    c = fr.contact_summary(s, (0.0, 1.0))
    assert c["load"] == pytest.approx(4.0)
    assert c["share"] == {"distal plate": pytest.approx(0.75), "foot": pytest.approx(0.25)}
    assert c["traction"] == pytest.approx(0.3)  # forward friction on the robot
    legs = c["legs"]
    assert legs["fl"]["noslip_u"] == pytest.approx(0.05) and legs["fl"]["slip_u"] == 0.0
    assert legs["rr"]["slip_u"] == pytest.approx(-0.02)
    assert legs["rr"]["noslip_u"] == pytest.approx(0.07)  # the stride the hull would have
    assert abs(legs["fl"]["noslip_v"]) < 1e-12  # nothing sideways in the heading frame
    assert c["all"]["noslip_u"] == pytest.approx((3 * 0.05 + 1 * 0.07) / 4)
    assert c["all"]["sliding"] == pytest.approx(0.25)  # rr's load slides (> 5 mm/s)
    assert legs["fl"]["duty"] == legs["rr"]["duty"] == c["all"]["duty"] == 1.0


def test_contact_summary_duty_factor_counts_loaded_samples(fr):
    import numpy as np

    zero = np.zeros(3)
    step = ("distal plate", "fl", zero, np.array([0.0, 0.0, 2.0]), zero, 0.0)
    graze = ("foot", "rr", zero, np.array([0.0, 0.0, 0.05]), zero, 0.0)  # below LOADED
    # fl stands in 3 of 4 samples; rr only grazes; nothing touches in the last sample.
    s = _samples(0.0, [0.0, 0.0, 0.0], [[step, graze], [step], [step, graze], []])
    c = fr.contact_summary(s, (0.0, 1.0))
    assert c["legs"]["fl"]["duty"] == pytest.approx(0.75)
    assert c["legs"]["rr"]["duty"] == 0.0
    assert c["all"]["duty"] == pytest.approx(0.75)


def test_contact_summary_without_contacts_is_nan_not_zero(fr):
    import math

    c = fr.contact_summary(_samples(0.0, [0.05, 0.0, 0.0], [[]] * 3), (0.0, 1.0))
    assert c["load"] == 0.0 and c["legs"] == {} and math.isnan(c["all"]["noslip_u"])


def test_shipped_diagnostics_set_the_fins_and_the_servo_they_name(fr):
    """Each shipped run's scenario, read back: its own gait, the fin model and the servo model
    its name says (no suffix: the datasheet servo, the scenarios' default)."""
    names = [n for n in fr.DIAGNOSTIC_NAMES if n.startswith("shipped_")]
    assert len(names) == 5 * 2 * 2
    for name in ("shipped_swim_foil", "shipped_trot_cross_flow_ideal", "shipped_crab_foil_ideal"):
        scenario, explicit = fr.diagnostic_scenario(name)
        gait = name.split("_")[1]
        assert explicit is None and scenario.controller.gait == gait
        assert scenario.water.fin_model == ("cross_flow" if "cross_flow" in name else "foil")
        servo = "ideal" if name.endswith("_ideal") else "datasheet"
        assert scenario.actuators.servo_model == servo


# The command line, and the diagnostics' gaits given as data (manta_drake.studies.explicit_gait).


@pytest.mark.slow
def test_the_study_command_writes_the_committed_findings_page(tmp_path, monkeypatch, capsys):
    """``manta-drake study findings`` on the shipped table reproduces docs/findings.md and its
    figure's file name; ``manta-drake study --help`` lists every study."""
    from manta_drake.cli import main
    from manta_drake.studies import STUDIES

    page = tmp_path / "findings.md"
    page.write_text((ROOT / "docs" / "findings.md").read_text())
    monkeypatch.chdir(ROOT)  # the page names the table by its path in the repository
    shipped = str(SHIPPED.relative_to(ROOT))
    assert main(["study", "findings", "--results", shipped, "--out", str(tmp_path)]) == 0
    assert page.read_text() == (ROOT / "docs" / "findings.md").read_text()
    assert (tmp_path / "figures" / "findings.png").stat().st_size > 0
    capsys.readouterr()
    with pytest.raises(SystemExit) as exit_info:
        main(["study", "--help"])
    assert exit_info.value.code == 0
    listing = capsys.readouterr().out
    assert set(STUDIES) == {
        "faults",
        "findings",
        "transitions",
        "stance",
        "readings",
        "energy",
        "wall-noise",
        "behaviours",
        "cfd",
        "validation",
    }
    assert all(f"  {name} " in listing for name in STUDIES)


def _short(name: str, duration: float = 0.2):
    from manta_drake.scenario import load_scenario

    return load_scenario(
        name,
        overrides={
            "duration": duration,
            "steady_after": duration / 2,
            "visualization.meshcat": False,
        },
    )


def test_a_gait_given_as_data_starts_at_its_own_stance_and_leaves_the_library_alone(tmp_path):
    """scenario_with_gait: the controller commands the given gait's parameters and its stance
    (r = 0: theta = chi = X, at rest), the plant's joints start there, the gait file holds it,
    and the library still holds its own gait."""
    import numpy as np

    from manta_drake.control.gait_files import load_gait_file
    from manta_drake.control.gaits import GAITS, MIRROR_SIGNS, GaitParams
    from manta_drake.studies.explicit_gait import scenario_with_gait
    from manta_drake.wiring.diagram import build_diagram

    trot = GAITS["trot"]
    library_trot = trot.to_vector().copy()
    X = trot.X.copy()
    X[[1, 3]] = MIRROR_SIGNS * X[[0, 2]]  # right fins mirror the left ones
    variant = GaitParams(trot.R, X, trot.Phi, trot.Phi_prime)
    s = scenario_with_gait(_short("locomotion_trot"), variant, tmp_path, "trot, mirrored X")
    assert s.controller.gait == s.initial_stance == "given_trot_mirrored_X"
    written = load_gait_file(tmp_path / "given_gait.yaml")["given_trot_mirrored_X"]
    np.testing.assert_array_equal(GaitParams(**written.matrices).to_vector(), variant.to_vector())
    diagram, handles = build_diagram(s)
    context = diagram.CreateDefaultContext()
    controller = handles.controller.GetMyContextFromRoot(context)
    np.testing.assert_array_equal(
        handles.controller.GetOutputPort("cpg_params").Eval(controller), variant.to_vector()
    )
    desired = handles.controller.GetOutputPort("desired_state").Eval(controller)
    np.testing.assert_allclose(desired[:16], X.ravel(), atol=1e-12)
    np.testing.assert_allclose(desired[16:], 0.0, atol=1e-12)
    plant, ph = handles.plant, handles.plant_handles
    pc = plant.GetMyContextFromRoot(context)
    q = [plant.GetJointByName(n, ph.robot).get_angle(pc) for n in ph.joint_names]
    np.testing.assert_allclose(q, X.ravel(), atol=1e-12)
    np.testing.assert_array_equal(GAITS["trot"].to_vector(), library_trot)
    assert "given_trot_mirrored_X" not in GAITS
    assert not np.allclose(variant.X, trot.X)


@pytest.mark.slow
def test_a_library_gait_given_as_data_runs_exactly_as_the_scenario_names_it(tmp_path):
    """run_with_gait with the scenario's own gait: the same log as simulate.run, sample for
    sample."""
    import numpy as np

    from manta_drake.control.gaits import GAITS
    from manta_drake.simulate import run
    from manta_drake.studies.explicit_gait import run_with_gait

    run(_short("locomotion_swim"), tmp_path / "named", progress=False, write_outputs=False)
    run_with_gait(_short("locomotion_swim"), GAITS["swim"], tmp_path / "data")
    named, data = np.load(tmp_path / "named" / "log.npz"), np.load(tmp_path / "data" / "log.npz")
    assert set(named.files) == set(data.files)
    for key in named.files:
        np.testing.assert_array_equal(named[key], data[key], err_msg=key)


@pytest.mark.slow
def test_foil_share_closes_the_robots_momentum_balance(fr):
    """What the water puts on the robot's own bodies plus what the added-mass bodies' joints
    pass on, with gravity, is the rate of change of the robot's own momentum (Newton for the
    robot alone, the added-mass bodies outside it): the in-plane centring force that the
    bodies need to follow a turning swim is not part of it."""
    import numpy as np
    from pydrake.multibody.tree import BodyIndex

    from manta_drake.scenario import load_scenario
    from manta_drake.simulate import make_simulator
    from manta_drake.wiring.diagram import build_diagram

    s = load_scenario("locomotion_swim")
    s.visualization.meshcat = False
    s.duration = 3.0
    diagram, h = build_diagram(s.validate())
    sim = make_simulator(diagram, s, diagram.CreateDefaultContext())
    root = sim.get_mutable_context()
    plant, hydro = h.plant, h.systems["hydro"]
    pctx = plant.GetMyContextFromRoot(root)
    # The robot with the isotropic added mass welded to its hull (it moves with the hull).
    robot = [h.plant_handles.robot, plant.GetModelInstanceByName("manta_added_mass")]
    robot_bodies = {int(i) for m in robot for i in plant.GetBodyIndices(m)}
    joints = fr.added_mass_joints(plant)
    assert len(joints) == 9  # 8 plates and the hull's heave body

    def momentum():
        return plant.CalcSpatialMomentumInWorldAboutPoint(pctx, robot, np.zeros(3)).translational()

    def share():
        return fr.foil_share(plant, pctx, hydro, root, robot_bodies, joints)

    sim.Initialize()
    mass = sum(plant.get_body(BodyIndex(i)).get_mass(pctx) for i in robot_bodies)
    gravity = mass * plant.gravity_field().gravity_vector()
    sim.AdvanceTo(2.0)
    p0, forces = momentum(), []
    for k in range(1, 401):  # 0.4 s of 1 ms steps: the force over each step, then the state
        forces.append(share() + gravity)
        sim.AdvanceTo(2.0 + 0.001 * k)
    rate = (momentum() - p0) / 0.4
    mean = np.mean(forces, axis=0)
    assert np.linalg.norm(rate) > 0.3  # the swim is heaving and turning: a real test
    np.testing.assert_allclose(mean, rate, atol=0.01)  # N; measured: within 1e-3 N


def _sweep_row(gait, params, motion):
    """A sweep results row: run_id, base, seed, the parameter cells, status, u, v, yaw."""
    u, v, yaw = motion
    return {
        "run_id": f"{gait}-x",
        "base": f"locomotion_{gait}",
        "seed": "0",
        "stall_angle": params.get("stall_angle", ""),
        "lift_slope": params.get("lift_slope", ""),
        "status": "ok",
        "reason": "",
        "u": repr(u),
        "v": repr(v),
        "yaw_rate_deg_s": repr(yaw),
        "steady_start_s": "6.0",
        "steady_end_s": "20.0",
    }


def test_parameter_sets_group_a_sweep_by_its_set_cells(fr):
    """The sensitivity table: the shipped point, one parameter at a time (each with its
    verdicts and speeds) and a tally over the sets that move more than one."""
    slow_walk = dict(GOOD, walk=(0.03, 0.0, -1.0))  # the swim (0.05) now beats the walk
    rows = [_sweep_row(g, {}, m) for g, m in GOOD.items()]
    rows += [_sweep_row(g, {"stall_angle": "0.667"}, m) for g, m in slow_walk.items()]
    both = {"stall_angle": "1.667", "lift_slope": "1.2"}
    rows += [_sweep_row(g, both, m) for g, m in GOOD.items()]
    sets = fr.parameter_sets(rows)
    assert list(sets) == [
        (),
        (("stall_angle", "0.667"),),
        (("stall_angle", "1.667"), ("lift_slope", "1.2")),
    ]
    assert sets[()]["walk"].u == 0.08 and sets[(("stall_angle", "0.667"),)]["walk"].u == 0.03
    table = fr.sensitivity(sets, "t.csv")
    assert [row["label"] for row in table["rows"]] == ["shipped", "stall_angle = 0.667"]
    assert table["points"] == 1 and [t.holds for t in table["hypercube"]] == [1] * 5
    points = fr.band_points(_rows(fr, {(0.5, 1.0, 0.85): dict(GOOD)}))
    tallies, verdicts = fr.evaluate(points)
    variants, _ = fr.evaluate(points, fr.VARIANTS)
    block = fr.markdown_block(tallies, variants, fr.gait_stats(points), verdicts, "x.csv", table)
    lines = block.split("\n")
    assert "(the sweep of t.csv: the five gaits at the shipped point" in block
    shipped = lines.index(
        "| shipped | yes | yes | yes | yes | yes | 0.050 | 0.080 | -0.015 | -8.0 |"
    )
    assert lines[shipped - 2 : shipped] == [
        "| parameter set | 1 | 2 | 3 | 4 | 5 | swim u | walk u | crab v | turning yaw deg/s |",
        "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |",
    ]
    # Walk no longer fastest (2) and the swim faster than the walk (3).
    stall = "| stall_angle = 0.667 | yes | **no** | **no** | yes | yes | 0.050 | 0.030 |"
    assert f"{stall} -0.015 | -8.0 |" in lines
    assert lines[-3:] == [
        "Over the 1 hypercube points: 1. holds at 1/1; 2. holds at 1/1; 3. holds at 1/1; "
        "4. holds at 1/1; 5. holds at 1/1.",
        "",
        fr.MARK_END,
    ]
    with pytest.raises(ValueError, match="twice"):
        fr.parameter_sets(rows + rows[:1])
