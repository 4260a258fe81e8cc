"""The studies' shared output folder and report templates (manta_drake.studies.report)."""

import pytest

from manta_drake.config_io import ScenarioError
from manta_drake.studies import REPO, report


def test_output_folder_defaults_to_the_checkouts_docs():
    # The tests run from the checkout: its pyproject.toml and .git are beside the package.
    assert report.checkout() == REPO
    assert report.output_folder(None, "manta-drake study energy") == REPO / "docs"
    assert report.output_folder(None, "x", default="models") == REPO / "models"


def test_output_folder_takes_out(tmp_path):
    assert report.output_folder(tmp_path / "new", "x") == tmp_path / "new"
    (tmp_path / "file").write_text("")
    with pytest.raises(ScenarioError, match=r"^--out .*file: is a file, not a folder$"):
        report.output_folder(tmp_path / "file", "x")


def test_an_installed_package_must_be_told_where_to_write(tmp_path, monkeypatch):
    # An installed package: the folder above manta_drake/ holds no pyproject.toml nor .git.
    monkeypatch.setattr(report, "REPO", tmp_path)
    assert report.checkout() is None
    with pytest.raises(ScenarioError) as err:
        report.output_folder(None, "manta-drake study energy")
    message = str(err.value)
    assert "\n" not in message
    assert message.startswith("manta-drake study energy: --out DIR is required")
    assert str(tmp_path / "manta_drake") in message
    assert report.output_folder(tmp_path / "out", "x") == tmp_path / "out"


def test_template_filters(tmp_path):
    (tmp_path / "t.md.j2").write_text(
        "{{ a | g }} {{ a | g(2) }} {{ a | f }} {{ a | f(1) }} {{ b | signed(2) }} "
        "{{ c | pct }} {{ none | f }}\n"
    )
    text = report.render("t.md.j2", folder=tmp_path, a=3.14159, b=0.5, c=-0.0123, none=None)
    assert text == "3.142 3.1 3.142 3.1 +0.50 -1.23 % -\n"


def test_a_name_the_study_does_not_give_fails(tmp_path):
    import jinja2

    (tmp_path / "t.md.j2").write_text("{{ missing }}")
    with pytest.raises(jinja2.UndefinedError, match="missing"):
        report.render("t.md.j2", folder=tmp_path)


def test_a_data_files_own_option_is_named_when_refused(tmp_path, monkeypatch):
    monkeypatch.setattr(report, "REPO", tmp_path)
    with pytest.raises(ScenarioError) as err:
        report.output_folder(None, "manta-drake study x", default="models", option="--yaml FILE")
    assert str(err.value) == (
        f"manta-drake study x: --yaml FILE is required: this manta_drake is installed "
        f"({tmp_path / 'manta_drake'}), not a source checkout whose models/ the study could "
        "rewrite"
    )
