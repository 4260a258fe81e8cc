"""What README.md and docs/ say that can be checked against the code: the robot's size and
mass at the zero pose (computed here from the plant's geometry), the scenario block's values
(the dataclass defaults), the layout block's paths (the tree), and the report pages' stamps."""

import ast
import dataclasses as dc
import datetime
import pathlib
import re
import subprocess

import numpy as np
import pytest
import yaml

ROOT = pathlib.Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
REPORTS = (
    "findings.md",
    "stance.md",
    "transitions.md",
    "performance.md",
    "energy.md",
    "behaviours.md",
    "fault_campaign.md",
    "validation.md",
    "cfd.md",
    "physics_changes.md",
)


def _flat(text: str) -> str:
    """The text with every run of whitespace (line breaks included) as one space."""
    return " ".join(text.split())


def _as_shown(shown: str, value: float) -> bool:
    """Whether the number ``shown`` is ``value`` rounded to the digits shown."""
    digits = len(shown.split(".")[1]) if "." in shown else 0
    return abs(float(shown) - value) <= 0.5 * 10.0**-digits + 1e-9


def _fenced_after(text: str, marker: str, lang: str = "") -> str:
    """The first fenced block (```lang) after ``marker``."""
    start = text.index(marker)
    a = text.index(f"```{lang}\n", start) + len(f"```{lang}\n")
    return text[a : text.index("```", a)]


# --- the robot at the zero pose --------------------------------------------------------------


@pytest.fixture(scope="module")
def zero_pose():
    """The robot's plant at q = 0 (the default context: no pool, default fin sweep)."""
    from pydrake.systems.framework import DiagramBuilder

    from manta_drake.model.plant import add_plant

    builder = DiagramBuilder()
    h = add_plant(builder, with_pool=False)
    diagram = builder.Build()
    context = h.plant.GetMyContextFromRoot(diagram.CreateDefaultContext())
    assert not np.any(h.plant.GetPositions(context, h.robot)[7:])  # every joint at zero
    return h, context


def _points_of(shape, X_WG) -> np.ndarray:
    """Points of a shape whose axis-aligned box in the world is the shape's own: a box's eight
    corners, an ellipsoid's or a sphere's extreme points along each world axis."""
    kind = type(shape).__name__
    R, p = X_WG.rotation().matrix(), X_WG.translation()
    if kind == "Box":
        half = np.array([shape.width(), shape.depth(), shape.height()]) / 2
        corners = (
            np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)]) * half
        )
        return corners @ R.T + p
    if kind in ("Ellipsoid", "Sphere"):
        axes = (
            np.array([shape.a(), shape.b(), shape.c()])
            if kind == "Ellipsoid"
            else np.full(3, shape.radius())
        )
        # The support point of x^T (R A^-2 R^T) x = 1 in direction +-e_k: M e_k / |A R^T e_k|
        # with M = R A^2 R^T.
        M = R @ np.diag(axes**2) @ R.T
        out = []
        for k in range(3):
            d = M[:, k] / np.sqrt(M[k, k])
            out += [p + d, p - d]
        return np.array(out)
    raise AssertionError(f"a robot geometry of an unexpected shape: {kind}")


def test_readme_and_design_give_the_models_zero_pose_size_and_mass(zero_pose):
    from pydrake.geometry import Role

    from manta_drake.model.kinematics import fin_tip_pose
    from manta_drake.model.robot_params import LEGS

    h, context = zero_pose
    plant = h.plant
    query = plant.get_geometry_query_input_port().Eval(context)
    inspector = query.inspector()
    points = []
    for index in plant.GetBodyIndices(h.robot):
        body = plant.get_body(index)
        X_WB = plant.EvalBodyPoseInWorld(context, body)
        for gid in inspector.GetGeometries(plant.GetBodyFrameIdOrThrow(index), Role.kIllustration):
            points.append(_points_of(inspector.GetShape(gid), X_WB @ inspector.GetPoseInFrame(gid)))
    points = np.vstack(points)
    size = points.max(axis=0) - points.min(axis=0)  # L (x), W (y), H (z)
    tips = np.array([fin_tip_pose(leg, np.zeros(4))[:3, 3] for leg in LEGS])
    tip_span = np.ptp(tips[:, 1])
    mass = sum(plant.get_body(i).default_mass() for i in plant.GetBodyIndices(h.robot))

    readme = _flat(README.read_text())
    box = re.search(r"zero-pose bounding box ([\d.]+) x ([\d.]+) x ([\d.]+) m", readme)
    assert box, "README: no 'zero-pose bounding box L x W x H m'"
    assert all(map(_as_shown, box.groups(), size)), (box.groups(), size)
    tip = re.search(r"the fin tips' frames are ([\d.]+) m apart", readme)
    assert tip and _as_shown(tip.group(1), tip_span), tip_span
    total = re.search(r"Total mass ([\d.]+) kg", readme)
    assert total and _as_shown(total.group(1), mass), mass

    design = _flat((ROOT / "docs" / "design.md").read_text())
    model = re.search(
        r"The model: ([\d.]+) kg; at the zero pose ([\d.]+) m x ([\d.]+) m x "
        r"([\d.]+) m \(the box around its geometry; the fin tips' frames "
        r"([\d.]+) m apart\)",
        design,
    )
    assert model, "docs/design.md, section 3: no 'The model: M kg; at the zero pose ...'"
    assert _as_shown(model.group(1), mass)
    assert all(map(_as_shown, model.groups()[1:4], size)), (model.groups(), size)
    assert _as_shown(model.group(5), tip_span)


# --- the scenario block -----------------------------------------------------------------------

# Fields whose presence depends on the Drake version (SimulatorConfig's publish_every_time_step
# exists in Drake 1.51, not in 1.58); the block leaves them out.
VERSION_DEPENDENT = {"simulator.publish_every_time_step"}


def _readme_scenario_block() -> dict:
    return yaml.safe_load(_fenced_after(README.read_text(), "The sections, all optional", "yaml"))


def _leaves(tree: dict, prefix: str = "") -> dict:
    """Dotted path -> value of every leaf (an empty mapping is a leaf)."""
    out = {}
    for key, value in tree.items():
        path = f"{prefix}{key}"
        if isinstance(value, dict) and value:
            out.update(_leaves(value, path + "."))
        else:
            out[path] = value
    return out


def _default(path: str):
    from manta_drake.scenario import Scenario

    value = Scenario()
    for part in path.split("."):
        assert hasattr(value, part), f"README scenario block: {path} is not a Scenario field"
        value = getattr(value, part)
    return value


def test_readme_scenario_block_shows_every_field_at_its_default():
    from pydrake.common.yaml import yaml_dump_typed

    from manta_drake.scenario import Scenario, load_scenario

    block = _readme_scenario_block()
    shown = _leaves(block)
    for path, value in shown.items():
        default = _default(path)
        if dc.is_dataclass(default):
            raise AssertionError(f"README scenario block: {path} is a section, not a value")
        assert value == default, f"README scenario block: {path}: {value!r}, default {default!r}"
    # Every field is shown: each top-level field, each field of a dataclass section, and every
    # leaf of the typed dump (SimulatorConfig's fields).
    scenario = Scenario()
    for field in dc.fields(scenario):
        assert field.name in block, f"README scenario block: no {field.name}"
        section = getattr(scenario, field.name)
        if dc.is_dataclass(section):
            missing = {f.name for f in dc.fields(section)} - set(block[field.name] or {})
            assert not missing, f"README scenario block: {field.name} lacks {sorted(missing)}"
    dumped = _leaves(yaml.safe_load(yaml_dump_typed(scenario)))
    missing = [
        p
        for p in dumped
        if p not in VERSION_DEPENDENT
        and p not in shown
        and not any(s.startswith(p + ".") for s in shown)
    ]
    assert not missing, f"README scenario block lacks {missing}"
    # And the block, loaded as a scenario, is the default scenario.
    assert yaml_dump_typed(load_scenario(data=block)) == yaml_dump_typed(scenario)


# --- the layout block -------------------------------------------------------------------------

PATH_TOKEN = re.compile(r"^[\w*.-]+(/[\w*.-]+)*(/|\.(py|sdf|xml|yaml|csv|md|ipynb|toml))$")
NAME_COLUMN = 15  # where the layout block's descriptions start


def _without_parentheses(text: str) -> str:
    while True:
        stripped = re.sub(r"\([^()]*\)", "", text)
        if stripped == text:
            return text
        text = stripped


def layout_paths(block: str) -> list[str]:
    """The paths the README's layout block names, relative to the repository.

    Entries at column 0 are folders of the repository, entries indented by two spaces are in
    the last such folder; a description (and its continuation lines) names files and folders
    of the entry's folder (tokens ending in '/' or a file extension), and a subpackage's
    description lists its modules as comma-separated names (``model/  robot_params,
    kinematics (Eq. 1), ...``)."""
    paths, top, entry = [], None, None
    for line in block.splitlines():
        if not line.strip():
            continue
        if not line.startswith(" "):
            top, entry = line.split()[0], None
            paths.append(top)
            base, text = top, line[len(top) :]
        elif line.startswith("  ") and not line[2].isspace():
            entry = line.split()[0]
            paths.append(top + entry)
            base, text = top, line[2 + len(entry) :]
        else:
            assert line[:NAME_COLUMN].isspace(), f"layout block: unexpected line {line!r}"
            base, text = top, line
        tokens = [t.strip(".,;:`") for t in re.split(r"[\s,;()`]+", text)]
        paths += [base + t for t in tokens if t and PATH_TOKEN.match(t)]
        if entry and entry.endswith("/") and line.startswith(" "):
            listed = _without_parentheses(text).rsplit(":", 1)[-1]
            paths += [
                f"{top}{entry}{name.strip()}.py"
                for name in listed.split(",")
                if re.fullmatch(r"[a-z_][a-z0-9_]*", name.strip())
            ]
    return paths


def test_layout_parser_on_a_small_block():
    block = (
        "models/        data: a.sdf, scenarios/*.yaml\n"
        "pkg/\n"
        "  sub/         the Systems: one (Eq. 1), two,\n"
        "               three\n"
        "  m.py         run; n.py, other/: more\n"
    )
    assert layout_paths(block) == [
        "models/",
        "models/a.sdf",
        "models/scenarios/*.yaml",
        "pkg/",
        "pkg/sub/",
        "pkg/sub/one.py",
        "pkg/sub/two.py",
        "pkg/sub/three.py",
        "pkg/m.py",
        "pkg/n.py",
        "pkg/other/",
    ]


def test_every_path_of_the_readme_layout_exists():
    block = _fenced_after(README.read_text(), "## Layout")
    paths = layout_paths(block)
    assert "manta_drake/model/kinematics.py" in paths and "models/manta.sdf" in paths
    missing = [p for p in paths if not list(ROOT.glob(p.rstrip("/")))]
    assert not missing, f"README's layout names paths that do not exist: {missing}"


# --- the paths the scripts' docstrings name -----------------------------------------------------

# Folders of scripts run from the repository's root (`python diagrams/stand.py`), whose
# docstrings name the files they read and write by their paths from the root.
SCRIPT_FOLDERS = ("diagrams", "examples", "scripts")
DOCSTRING_PATH = re.compile(
    r"(?<![\w/.:<>-])((?:[\w.<>-]+/)+[\w.<>-]+\."
    r"(?:yaml|yml|py|csv|md|png|json|npz|sdf|txt|mcap|ipynb))\b"
)


def docstring_paths(text: str) -> list[str]:
    """The repository paths a docstring names (a folder and a file with its ending), as glob
    patterns: a placeholder (``locomotion_<gait>.yaml``) is any name; a path under a
    placeholder folder (``<out>/fig.png``) or under ``out/`` is what the script writes and
    is left out, as are URLs (``package://...``)."""
    paths = []
    for token in DOCSTRING_PATH.findall(text):
        if token.startswith(("<", "out/")):
            continue
        paths.append(re.sub(r"<[^<>/]*>", "*", token))
    return paths


def test_docstring_path_parser_on_a_small_docstring():
    text = (
        "Runs models/scenarios/locomotion_<gait>.yaml (each into <out>/<gait>/), writes\n"
        "<out>/fig7.png and out/run/log.npz; Usage: python diagrams/stand.py [--scenario\n"
        "models/scenarios/stand.yaml]; reads package://manta_drake/hydrodynamics.yaml and\n"
        "float_sink.png."
    )
    assert docstring_paths(text) == [
        "models/scenarios/locomotion_*.yaml",
        "diagrams/stand.py",
        "models/scenarios/stand.yaml",
    ]


def _docstrings(path: pathlib.Path):
    tree = ast.parse(path.read_text(encoding="utf-8"))
    for node in ast.walk(tree):
        if isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef)):
            text = ast.get_docstring(node)
            if text:
                yield text


def test_every_path_a_scripts_docstring_names_exists():
    """The scripts' docstrings name the scenario files they run and the pages they feed; a
    file moved without its docstring is found here."""
    named, missing = 0, []
    for folder in SCRIPT_FOLDERS:
        for script in sorted((ROOT / folder).rglob("*.py")):
            for text in _docstrings(script):
                for pattern in docstring_paths(text):
                    named += 1
                    if not list(ROOT.glob(pattern)):
                        missing.append(f"{script.relative_to(ROOT)}: {pattern}")
    assert named >= 10  # the diagrams name their scenarios: the parser finds paths
    assert not missing, f"docstrings name paths that do not exist: {missing}"


# --- the report pages' stamps -----------------------------------------------------------------

STAMP = re.compile(
    r"^Made (\d{4}-\d{2}-\d{2}|unknown) at commit ([0-9a-f]{7,40}|unknown)\. "
    r"Regenerate with `[^`]+`"
)


@pytest.mark.parametrize("page", REPORTS)
def test_each_report_page_starts_with_its_stamp(page):
    lines = (ROOT / "docs" / page).read_text().splitlines()
    assert lines[0].startswith("# ") and lines[1] == "", f"docs/{page}: a title, then a blank"
    paragraph = " ".join(lines[2 : lines.index("", 2)])
    stamp = STAMP.match(paragraph)
    assert stamp, f"docs/{page}: line 3 is not 'Made DATE at commit HASH. Regenerate with ...'"
    date, made_at = stamp.groups()
    if date != "unknown":
        assert datetime.date.fromisoformat(date) <= datetime.date.today()
    inside = subprocess.run(
        ["git", "-C", str(ROOT), "rev-parse", "--show-toplevel"], capture_output=True, text=True
    )
    if (
        made_at != "unknown"
        and inside.returncode == 0
        and pathlib.Path(inside.stdout.strip()).resolve() == ROOT
    ):
        known = subprocess.run(
            ["git", "-C", str(ROOT), "cat-file", "-e", f"{made_at}^{{commit}}"], capture_output=True
        )
        assert known.returncode == 0, f"docs/{page}: the stamp's commit {made_at} is unknown"


def test_a_regenerated_page_keeps_its_stamp_unless_its_text_changes(tmp_path, monkeypatch):
    from manta_drake.studies import stamp

    monkeypatch.setattr(stamp, "commit", lambda repo=None: "abc1234")
    page = tmp_path / "page.md"
    old = "# Title\n\nMade 2020-01-02 at commit 0123456. Regenerate with `x --y`.\n\n| 1 |\n"
    page.write_text(old)
    # The same text under any stamp: the file is not touched.
    same = old.replace("2020-01-02", "unknown").replace("0123456", "unknown")
    assert stamp.write_stamped(page, same) is False and page.read_text() == old
    # Changed numbers: today's date and the commit, the rest of the stamp line kept.
    assert stamp.write_stamped(page, same.replace("| 1 |", "| 2 |")) is True
    today = datetime.date.today().isoformat()
    assert page.read_text() == (
        f"# Title\n\nMade {today} at commit abc1234. Regenerate with `x --y`.\n\n| 2 |\n"
    )
    # A new page without a stamp line is written as given.
    other = tmp_path / "other.md"
    assert stamp.write_stamped(other, "# T\n\ntext\n") and other.read_text() == "# T\n\ntext\n"


def test_the_commit_outside_a_git_checkout_is_unknown(tmp_path):
    from manta_drake.studies.stamp import commit

    assert commit(tmp_path) == "unknown"


@pytest.mark.slow
def test_the_stance_study_regenerates_its_page_byte_for_byte(tmp_path):
    """``manta-drake study stance`` from the shipped table leaves docs/stance.md as it is
    (the kinematics are recomputed; the dynamics come from the shipped table)."""
    from manta_drake.studies import stance

    page = tmp_path / "stance.md"
    page.write_text((ROOT / "docs" / "stance.md").read_text())
    assert stance.main(["--out", str(tmp_path)]) == 0
    assert page.read_text() == (ROOT / "docs" / "stance.md").read_text()
    assert (tmp_path / "figures" / "stance.png").stat().st_size > 0


# --- the two-behaviour run at the side wall ---------------------------------------------------


def test_wall_spans_are_the_stretches_within_the_margin():
    from manta_drake import plots

    t = np.arange(0.0, 10.001, 0.5)
    y = np.where(t < 4.0, 0.0, np.where(t < 7.0, -0.8, 0.0))  # the hull's y, 1 m from a side wall
    log = {
        "t": t,
        "body_xyz": np.column_stack([np.zeros_like(t), y, np.full_like(t, -0.2)]),
        "body_quat_wxyz": np.tile([1.0, 0.0, 0.0, 0.0], (len(t), 1)),
    }
    # Clearance 1 - 0.12 (the hull's half-width) = 0.88 m, then 0.08 m from 4 s to 6.5 s.
    assert plots.wall_spans(log, 0.3) == [(4.0, 6.5)]
    assert plots.wall_spans(log, 0.05) == []


@pytest.mark.slow
def test_two_behaviors_runs_as_the_readme_says(tmp_path):
    """The README's account of two_behaviors, from a 70 s run: its two transitions at the
    stated times, within the free-water margin of a wall from the stated time, closest as
    stated, touching a wall if and only if it says so."""
    from manta_drake.scenario import load_scenario
    from manta_drake.simulate import run

    readme = _flat(README.read_text())
    said = re.search(
        r"two_behaviors goes swim -> trot \(([\d.]+)-([\d.]+) s; paper [^)]*\) and "
        r"trot -> swim \(([\d.]+)-([\d.]+) s; paper [^)]*\),? and (never comes|"
        r"comes) within the ([\d.]+) m free-water margin of a wall(?: at ([\d.]+) s)? "
        r"\(closest ([\d.]+) m(: [^)]*touches it)?\)",
        readme,
    )
    assert said, "README: the two-behaviour run's account is missing"
    *times, never, margin, near, closest, touches = said.groups()
    times, margin, closest = [float(x) for x in times], float(margin), float(closest)
    near = None if never.startswith("never") else float(near)

    s = load_scenario("two_behaviors", overrides={"visualization.meshcat": False})
    assert s.free_water_margin == margin and s.duration == 70.0
    m = run(s, tmp_path / "run", progress=False).metrics
    got = [(tr["from"], tr["to"], tr["start_s"], tr["end_s"]) for tr in m["transitions"]]
    assert [g[:2] for g in got] == [("swim", "trot"), ("trot", "swim")]
    np.testing.assert_allclose([x for g in got for x in g[2:]], times, atol=0.051)
    assert (
        m["near_wall_at_s"] is None
        if near is None
        else m["near_wall_at_s"] == pytest.approx(near, abs=0.051)
    )
    assert m["touched_wall"] is (touches is not None)
    assert m["min_wall_clearance_m"] == pytest.approx(closest, abs=0.005)


# --- the README's gait file and behaviour tree, run as written --------------------------------


@pytest.mark.slow
def test_the_readmes_gait_file_and_tree_run_as_written(tmp_path):
    """The two files of "Gaits, behaviours and modalities as data", written where the README
    says, run by its commands (shortened to 3 s); the user's gait is the trot with 25 deg yaw
    amplitudes, and the tree's nodes are the README's."""
    import json
    import sys

    from manta_drake.scenario import load_scenario

    text = README.read_text()
    (tmp_path / "my_gaits.yaml").write_text(_fenced_after(text, "`my_gaits.yaml`:", "yaml"))
    (tmp_path / "my_scenario.yaml").write_text(
        _fenced_after(text, "`my_scenario.yaml` beside it", "yaml")
    )
    s = load_scenario(tmp_path / "my_scenario.yaml")
    np.testing.assert_allclose(np.degrees(s.gait("long_trot").R[:, 0]), [25, -25, 25, -25])
    np.testing.assert_array_equal(s.gait("long_trot").X, s.gait("trot").X)
    tree = s.behaviour_tree()
    assert tree.leaves == ("swim", "long_trot", "walk")
    assert tree.modalities == ("z_hat", "posture_hat")
    start = text.index(".venv/bin/manta-drake run my_scenario.yaml --out out/mine --no-meshcat")
    commands = text[start : text.index("```", start)].replace("\\\n", " ")
    assert commands.count("manta-drake run") == 2
    lines = [c for c in commands.splitlines() if c.strip()]
    for line, out in zip(lines, ("out/mine", "out/mine2")):
        argv = line.split()[1:] + ["--set", "duration=3", "--quiet"]
        assert argv[0] == "run" and argv[1] == "my_scenario.yaml"
        done = subprocess.run(
            [sys.executable, "-m", "manta_drake.cli", *argv],
            cwd=tmp_path,
            capture_output=True,
            text=True,
            timeout=600,
        )
        assert done.returncode == 0, done.stderr
        metrics = json.loads((tmp_path / out / "metrics.json").read_text())
        assert metrics["status"] == "ok" and metrics["sim_time_s"] == pytest.approx(3.0)
    layered = yaml.safe_load((tmp_path / "out/mine2/scenario.yaml").read_text())
    assert layered["transition"]["tree"]["root"]["weight"] == "potential"
    assert layered["transition"]["tree"]["floor"]["threshold"] == 0.3


# --- a run's outputs: every log array and metrics key is in the README ------------------------


def _readme_section(heading: str) -> str:
    """The README's text under ``heading`` up to the next heading."""
    text = README.read_text()
    start = text.index(f"\n{heading}\n") + len(heading) + 2
    end = re.search(r"\n#{2,3} ", text[start:])
    return text[start : start + end.start()] if end else text[start:]


def _table_rows(section: str) -> list[list[str]]:
    """The cells of each body row of the Markdown table in ``section`` (``\\|`` is text)."""
    rows = []
    for line in section.splitlines():
        if line.startswith("| ") and not line.startswith("| ---"):
            rows.append([c.strip() for c in re.split(r"(?<!\\)\|", line)[1:-1]])
    return rows[1:]  # the header row


def _names(cell: str) -> list[str]:
    return re.findall(r"`([^`]+)`", cell)


@pytest.fixture(scope="module")
def short_runs(tmp_path_factory):
    """Two real short runs of four_behaviors (every sensor, the energy model, the tree and the
    heading hold) with the camera on: one that ends ok (0.3 s), and one whose battery starts at
    its cut-off, so it fails and writes its ``failure``; plus the ``running`` metrics.json that
    a run writes when it starts. Returns (log.npz arrays, [metrics.json of each], running)."""
    import json

    from manta_drake.scenario import load_scenario
    from manta_drake.simulate import SimulationError, run

    base = {"visualization.meshcat": False, "camera.enabled": True, "duration": 0.3}
    out = tmp_path_factory.mktemp("runs")
    run(
        load_scenario("four_behaviors", overrides=base),
        out / "ok",
        progress=False,
        write_outputs=False,
    )
    running = {}

    def read_running(handles, context):
        running.update(json.loads((out / "failed" / "metrics.json").read_text()))

    with pytest.raises(SimulationError, match="battery empty"):
        run(
            load_scenario("four_behaviors", overrides={**base, "actuators.initial_soc": 0.20001}),
            out / "failed",
            progress=False,
            write_outputs=False,
            prepare=read_running,
        )
    with np.load(out / "ok" / "log.npz") as log:
        arrays = {name: log[name] for name in log.files}
    metrics = [json.loads((out / name / "metrics.json").read_text()) for name in ("ok", "failed")]
    return arrays, metrics, running


@pytest.mark.slow
def test_the_readme_lists_every_log_array_with_its_times_and_columns(short_runs):
    from manta_drake.simulate import LOG_KEYS
    from manta_drake.wiring.diagram import _LOGGED

    arrays = short_runs[0]
    rows = _table_rows(_readme_section("### `log.npz`"))
    listed = {}  # array -> (its times, its columns cell)
    for name, times, columns, _ in rows:
        (key,), stamp = _names(name), _names(times)
        listed[key] = (stamp[0] if stamp else None, columns)
    missing = sorted(
        k for k in arrays if k not in listed and k not in {v[0] for v in listed.values()}
    )
    assert not missing, f"README's log.npz table lacks {missing}"
    # Every array listed is one a run can write (nothing stale), with the times it has.
    logged = {port for _, port, _ in _LOGGED} - {"plant_state", "desired_state"}
    possible = set(LOG_KEYS) | logged | {"sim_time"}
    assert set(listed) <= possible, sorted(set(listed) - possible)
    for key, (times, columns) in listed.items():
        expected = (
            "t_command"
            if key == "commanded_joint_angles"
            else None
            if key in ("t", "sim_time")
            else "t"
            if key in LOG_KEYS
            else f"t_{key}"
        )
        assert times == expected, f"README log.npz: {key}'s times are {times}, not {expected}"
        if key in arrays and times:
            assert len(arrays[times]) == len(arrays[key]), key
        count = re.match(r"(\d+)\b", columns)
        if key in arrays and count:  # the number of columns the README gives
            assert arrays[key].shape[1:] == (int(count.group(1)),), (key, arrays[key].shape)


@pytest.mark.slow
def test_the_readme_lists_every_metrics_key(short_runs):
    _, metrics, running = short_runs
    rows = {
        tuple(_names(row[0])): row[1] for row in _table_rows(_readme_section("### `metrics.json`"))
    }
    listed = {name for names in rows for name in names}
    written = {k for m in metrics for k in m} | {
        f"energy.{k}" for m in metrics for k in m.get("energy", {})
    }
    assert "failure" in metrics[1] and "max_penetration_m" in metrics[0]
    missing = sorted(written - listed)
    assert not missing, f"README's metrics.json table lacks {missing}"
    assert listed <= written, f"README lists keys no run wrote: {sorted(listed - written)}"

    def row_of(key):
        return next(text for names, text in rows.items() if key in names)

    assert set(metrics[1]["failure"]) <= set(_names(row_of("failure")))
    assert running["status"] == "running"
    assert set(running) - {"scenario", "status"} <= set(_names(row_of("status")))
