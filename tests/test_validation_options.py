"""The folders of ``manta-drake study validation --section NAME``: ``--runs DIR`` for a
section's work, ``--out DIR`` for the page, each reference file's own option; checked before
anything is computed (no section is computed here: ``--from-yaml`` renders the committed
numbers)."""

import pytest

from manta_drake.config_io import ScenarioError
from manta_drake.studies import REPO, report
from manta_drake.studies.validation import SECTIONS, main
from manta_drake.studies.validation import vortex_lattice as V


@pytest.mark.parametrize("section", list(SECTIONS))
def test_runs_and_out_that_are_files_are_one_line(tmp_path, capsys, section):
    from manta_drake import cli

    (tmp_path / "f").write_text("")
    for option in ("--runs", "--out"):
        argv = ["study", "validation", "--section", section, option, str(tmp_path / "f")]
        assert cli.main(argv) == 2
        err = capsys.readouterr().err.strip()
        assert err == (
            f"manta-drake: error: {option} {tmp_path / 'f'}: is a file, not a folder (--debug "
            "shows the traceback)"
        )
    assert [p.name for p in tmp_path.iterdir()] == ["f"]  # nothing was started


@pytest.mark.parametrize(
    "section, argv, needle",
    [
        ("released", [], "--out DIR is required"),
        ("added-mass", [], "--yaml FILE is required"),
        ("added-mass", ["--yaml", "x.yaml"], "--out DIR is required"),
        ("foil-data", [], "--yaml FILE is required"),
        ("vortex-lattice", [], "--reference FILE is required"),
        ("vortex-lattice", ["--reference", "x.yaml"], "--out DIR is required"),
    ],
)
def test_an_installed_package_must_name_the_page_and_the_reference(
    tmp_path, monkeypatch, section, argv, needle
):
    """No checkout above the package: its docs/ and models/reference/ are no defaults; the
    message names the option that would give the folder or file."""
    monkeypatch.setattr(report, "REPO", tmp_path)
    with pytest.raises(ScenarioError) as err:
        main(["--section", section, "--runs", str(tmp_path / "runs"), *argv], prog="v")
    assert str(err.value).startswith(f"v --section {section}: {needle}: this manta_drake is ")
    assert list(tmp_path.iterdir()) == []


def test_vortex_lattice_renders_the_committed_page_into_out(tmp_path):
    argv = ["--runs", str(tmp_path / "runs"), "--out", str(tmp_path), "--from-yaml"]
    assert V.main(argv) == 0
    block = (tmp_path / "runs" / "vortex_lattice.md").read_text()
    assert f"`{V.COMMAND}`; the numbers are `models/reference/vortex_lattice.yaml`." in block
    assert block in (tmp_path / "validation.md").read_text()
    assert block in (REPO / "docs" / "validation.md").read_text()


def test_a_quick_vortex_lattice_run_writes_no_page_unless_named(tmp_path, monkeypatch):
    """--quick writes neither the committed summary nor the page by default: it needs no
    checkout (here an installed package, which would refuse the default page)."""
    monkeypatch.setattr(report, "REPO", tmp_path / "installed")
    argv = ["--runs", str(tmp_path / "runs"), "--quick", "--from-yaml"]
    assert V.main(argv + ["--reference", str(V.YAML_PATH)]) == 0
    assert sorted(p.name for p in tmp_path.iterdir()) == ["runs"]
    assert [p.name for p in (tmp_path / "runs").iterdir()] == ["vortex_lattice.md"]
    assert V.main(argv + ["--reference", str(V.YAML_PATH), "--out", str(tmp_path / "p")]) == 0
    assert [p.name for p in (tmp_path / "p").iterdir()] == ["validation.md"]
