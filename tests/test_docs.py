"""The API reference (``make docs``): it builds with warnings as errors, every System's page
draws its ports, the drawings list the ports the built Systems really have, every public
name is documented, and the ``.. pydrake_system::`` directive's text rendering and errors."""

import html.parser
import importlib
import importlib.util
import inspect
import os
import pathlib
import pkgutil
import subprocess
import sys
import textwrap

import numpy as np
import pytest
import yaml
from pydrake.systems.framework import Diagram, LeafSystem

import manta_drake

ROOT = pathlib.Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
GROUPS = ("station", "control")


def sphinx_build(source: pathlib.Path, out: pathlib.Path, builder: str = "html"):
    """Runs Sphinx as ``make docs`` does: warnings are errors; Python as a user runs it (free
    to write bytecode)."""
    env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
    return subprocess.run(
        [
            sys.executable,
            "-m",
            "sphinx",
            "-b",
            builder,
            "-E",
            "-W",
            "--keep-going",
            "-q",
            "-d",
            str(out.parent / f"doctrees-{builder}"),
            str(source),
            str(out),
        ],
        capture_output=True,
        text=True,
        timeout=600,
        cwd=ROOT,
        env=env,
    )


EXT_CACHE = DOCS / "_ext" / "__pycache__"
EXT_CACHE_BEFORE = EXT_CACHE.exists()  # at collection, before any build of this module


@pytest.fixture(scope="module")
def html_out(tmp_path_factory):
    out = tmp_path_factory.mktemp("docs") / "html"
    result = sphinx_build(DOCS, out)
    assert result.returncode == 0, f"sphinx failed:\n{result.stdout}\n{result.stderr}"
    assert "WARNING" not in result.stderr and "ERROR" not in result.stderr, result.stderr
    return out


@pytest.mark.slow
def test_a_build_writes_nothing_into_the_checkout(html_out):
    """docs/conf.py writes no bytecode (docs/_ext/__pycache__), and ``make docs`` puts Sphinx's
    cache beside DOCS_OUT: in docs/_build by default, outside the checkout when DOCS_OUT is."""
    assert EXT_CACHE_BEFORE or not EXT_CACHE.exists(), "the build wrote docs/_ext/__pycache__"
    assert (html_out.parent / "doctrees-html").is_dir()

    def sphinx_line(*args):
        done = subprocess.run(
            ["make", "-n", "docs", *args], cwd=ROOT, capture_output=True, text=True, timeout=60
        )
        assert done.returncode == 0, done.stderr
        return next(line for line in done.stdout.splitlines() if "-m sphinx" in line)

    outside = sphinx_line("DOCS_OUT=/tmp/site/html")
    assert outside.endswith(" -d /tmp/site/doctrees docs /tmp/site/html"), outside
    default = sphinx_line()
    assert default.endswith(f" -d {ROOT}/docs/_build/doctrees docs docs/_build/html"), default


class DiagramParser(html.parser.HTMLParser):
    """Collects the port diagrams of a page: system name -> {"inputs", "outputs", "noted",
    "box", "x"} (port names in order; the ports drawn with a note; the box's x extent;
    each port label's x)."""

    def __init__(self):
        super().__init__()
        self.diagrams: dict[str, dict] = {}
        self._current = None
        self._port = None

    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        classes = (a.get("class") or "").split()
        if tag == "div" and "pydrake-system" in classes:
            self._current = self.diagrams.setdefault(
                a["data-system"], {"inputs": [], "outputs": [], "noted": set(), "x": {}}
            )
        elif self._current is None:
            return
        elif tag == "rect":
            x, w = float(a["x"]), float(a["width"])
            self._current["box"] = (x, x + w)
        elif tag == "text" and "pydrake-port" in classes:
            side = "inputs" if "pydrake-input" in classes else "outputs"
            self._port = a["data-port"]
            self._current[side].append(self._port)
            self._current["x"][self._port] = float(a["x"])
        elif tag == "tspan" and "pydrake-port-note" in classes and self._port:
            self._current["noted"].add(self._port)

    def handle_endtag(self, tag):
        if tag == "text":
            self._port = None
        elif tag == "svg":
            self._current = None


def diagrams(page: pathlib.Path) -> dict:
    parser = DiagramParser()
    parser.feed(page.read_text(encoding="utf-8"))
    return parser.diagrams


def docstring_block(doc: str) -> dict:
    """The YAML of the ``.. pydrake_system::`` block in a docstring (read here with PyYAML,
    not with the extension)."""
    doc = inspect.cleandoc(doc)
    assert ".. pydrake_system::" in doc
    lines = doc.split(".. pydrake_system::", 1)[1].splitlines()[1:]
    block = []
    for line in lines:
        if line.strip() and not line.startswith(" "):
            break
        block.append(line)
    return yaml.safe_load(textwrap.dedent("\n".join(block)))


def port_name(label) -> str:
    return str(label).split(" (")[0]


def leaf_systems():
    """(group, module name, class) of every LeafSystem defined in station/ and control/."""
    found = []
    for group in GROUPS:
        package = importlib.import_module(f"manta_drake.{group}")
        for info in pkgutil.iter_modules(package.__path__):
            module = importlib.import_module(f"manta_drake.{group}.{info.name}")
            for value in vars(module).values():
                if (
                    isinstance(value, type)
                    and issubclass(value, LeafSystem)
                    and value.__module__ == module.__name__
                ):
                    found.append((group, info.name, value))
    return found


def test_the_package_has_systems():
    names = {cls.__name__ for _, _, cls in leaf_systems()}
    assert {
        "FuzzyDepthEstimator",
        "CpgOscillators",
        "WallDetector",
        "PotentialTransition",
        "HydrodynamicForces",
        "BalloonBuoyancy",
        "PressureSensor",
    } <= names


@pytest.mark.slow
def test_every_system_page_draws_its_ports(html_out):
    for group, module, cls in leaf_systems():
        page = html_out / "api" / group / f"{module}.html"
        assert page.is_file(), f"{cls.__name__}: no page {page.relative_to(html_out)}"
        block = docstring_block(cls.__doc__)
        assert block["name"] == cls.__name__
        drawn = diagrams(page)
        assert cls.__name__ in drawn, f"{page.name} draws {sorted(drawn)}, not {cls.__name__}"
        d = drawn[cls.__name__]
        assert d["inputs"] == [port_name(p) for p in block.get("input_ports") or []], cls
        assert d["outputs"] == [port_name(p) for p in block.get("output_ports") or []], cls


@pytest.mark.slow
def test_depth_estimator_diagram(html_out):
    d = diagrams(html_out / "api" / "control" / "depth.html")["FuzzyDepthEstimator"]
    assert d["inputs"] == ["depth"]
    assert d["outputs"] == ["h_hat", "z_hat"]
    assert not d["noted"]
    left, right = d["box"]  # inputs left of the box, outputs right of it
    assert d["x"]["depth"] < left < right < min(d["x"]["h_hat"], d["x"]["z_hat"])


@pytest.mark.slow
def test_the_builders_pages_draw_the_halves(html_out):
    station = diagrams(html_out / "api" / "wiring" / "station.html")["station"]
    controller = diagrams(html_out / "api" / "wiring" / "controller.html")["controller"]
    assert station["inputs"] == ["desired_state", "balloon_command"]
    assert {"depth", "depth_image", "camera_pose", "measured_joint_state"} <= set(
        station["outputs"]
    )
    from manta_drake.modalities import READINGS

    assert controller["inputs"] == [
        "depth",
        "depth_image",
        "camera_pose",
        *(r.port for r in READINGS),
        "battery",
    ]
    assert {"imu", "flow_velocity", "altitude"} <= set(controller["inputs"])
    assert controller["outputs"][:2] == ["desired_state", "balloon_command"]


def _walk(system):
    for sub in system.GetSystems():
        yield sub
        if isinstance(sub, Diagram):
            yield from _walk(sub)


def _ports(system):
    return (
        [system.get_input_port(i).get_name() for i in range(system.num_input_ports())],
        [system.get_output_port(i).get_name() for i in range(system.num_output_ports())],
    )


def _check_drawn_against_built(name, drawn, built):
    """Every real port is drawn; every port drawn without a note (such as ``(optional)`` or
    ``(camera on)``) is really there."""
    for side, real in zip(("inputs", "outputs"), built):
        documented = set(drawn[side])
        unconditional = documented - drawn["noted"]
        assert set(real) <= documented, (
            f"{name}: {side} {sorted(set(real) - documented)} are not in its diagram"
        )
        assert unconditional <= set(real), (
            f"{name}: {side} "
            f"{sorted(unconditional - set(real))} are drawn but the built system lacks them"
        )


@pytest.mark.slow
def test_diagrams_match_the_built_systems(html_out):
    """The three-behaviour scenario has every sensor, the camera, the transition and the
    energy model: its diagram holds one of each System of the package."""
    from manta_drake import build_diagram, load_scenario

    scenario = load_scenario("three_behaviors", overrides={"visualization.meshcat": False})
    diagram, _ = build_diagram(scenario)
    pages = {
        cls: html_out / "api" / group / f"{module}.html" for group, module, cls in leaf_systems()
    }
    checked = set()
    for system in _walk(diagram):
        if type(system) in pages:
            drawn = diagrams(pages[type(system)])[type(system).__name__]
            _check_drawn_against_built(type(system).__name__, drawn, _ports(system))
            checked.add(type(system).__name__)
        elif isinstance(system, Diagram) and system.get_name() in ("station", "controller"):
            page = html_out / "api" / "wiring" / f"{system.get_name()}.html"
            drawn = diagrams(page)[system.get_name()]
            _check_drawn_against_built(system.get_name(), drawn, _ports(system))
            checked.add(system.get_name())
    public = {
        name
        for name in manta_drake.__all__
        if isinstance(getattr(manta_drake, name), type)
        and issubclass(getattr(manta_drake, name), LeafSystem)
    }
    assert public | {"station", "controller"} <= checked, checked


@pytest.mark.slow
def test_every_public_name_is_documented_and_linked(html_out):
    pages = [p.read_text(encoding="utf-8") for p in (html_out / "api").rglob("*.html")]
    front = (html_out / "api" / "package.html").read_text(encoding="utf-8")
    for name in manta_drake.__all__:
        if name == "__version__":
            continue
        target = f"{manta_drake._API[name]}.{name}"
        assert any(f'id="{target}"' in page for page in pages), f"{target} is not documented"
        assert f'#{target}"' in front, f"the public API page does not link {target}"
    assert (html_out / "index.html").read_text().count("api/index.html") >= 1


# --- the directive itself -----------------------------------------------------------------


def _extension():
    spec = importlib.util.spec_from_file_location(
        "pydrake_system_ext", DOCS / "_ext" / "pydrake_system.py"
    )
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _tiny_project(folder: pathlib.Path, body: str) -> pathlib.Path:
    source = folder / "src"
    source.mkdir()
    (source / "conf.py").write_text(
        "import sys\nsys.dont_write_bytecode = True\n"
        f"sys.path.insert(0, {str(DOCS / '_ext')!r})\nextensions = ['pydrake_system']\n"
    )
    (source / "index.rst").write_text("Ports\n=====\n\n" + textwrap.dedent(body))
    return source


def test_text_builders_get_ascii_art(tmp_path):
    source = _tiny_project(
        tmp_path,
        """\
        .. pydrake_system::

            name: FuzzyDepthEstimator
            input_ports:
            - depth
            output_ports:
            - h_hat
            - z_hat
        """,
    )
    result = sphinx_build(source, tmp_path / "text", "text")
    assert result.returncode == 0, result.stderr
    text = (tmp_path / "text" / "index.txt").read_text()
    expected = textwrap.indent(
        textwrap.dedent("""\
                +---------------------+
                |                     |-> h_hat
        depth ->| FuzzyDepthEstimator |
                |                     |-> z_hat
                +---------------------+"""),
        "   ",
    )
    assert expected in text


@pytest.mark.parametrize(
    "body, message",
    [
        ("name: X\ninput_ports: [a]\noutputs: [b]\n", "unknown key"),
        ("input_ports: [a]\n", "'name' must be a non-empty string"),
        ("name: X\ninput_ports: a\n", "must be a list"),
        ("name: X\ninput_ports: [{a: 1}]\n", "a port must be a name"),
        ("name: [X\n", "invalid YAML"),
    ],
)
def test_a_malformed_block_is_refused(body, message):
    with pytest.raises(ValueError, match=message):
        _extension().parse_system_yaml(body)


def test_a_malformed_block_fails_the_build_at_its_line(tmp_path):
    source = _tiny_project(
        tmp_path,
        """\
        .. pydrake_system::

            name: X
            outputs: [y]
        """,
    )
    result = sphinx_build(source, tmp_path / "html")
    assert result.returncode != 0
    assert "index.rst:4: ERROR: pydrake_system: unknown key(s) ['outputs']" in result.stderr


def test_labels_are_escaped_and_notes_split():
    ext = _extension()
    assert ext.split_label('body_poses (inputs="contract")') == (
        "body_poses",
        '(inputs="contract")',
    )
    assert ext.split_label("noise") == ("noise", "")
    svg = ext.render_svg("A<B", ["x (optional)"], ["y&z"])
    assert "A&lt;B" in svg and "y&amp;z" in svg and "<B" not in svg
    assert 'data-port="x"' in svg and "(optional)" in svg


# --- docs/gaits.md ------------------------------------------------------------------------

GAITS_PAGE = DOCS / "gaits.md"


def _yaml_blocks(page: pathlib.Path) -> list[str]:
    """The page's fenced YAML blocks, in order."""
    text = page.read_text(encoding="utf-8")
    return [part.split("```", 1)[0] for part in text.split("```yaml\n")[1:]]


def test_the_gait_page_is_linked_where_the_gait_file_format_is_named():
    assert GAITS_PAGE.is_file()
    assert "](gaits.md)" in (DOCS / "index.md").read_text()
    assert "](docs/gaits.md)" in (ROOT / "README.md").read_text()
    header = (ROOT / "models" / "gaits.yaml").read_text().split("\ngaits:")[0]
    named = [
        word.strip("`.,;:()")
        for word in header.split()
        if word.startswith(("docs/", "manta_drake/"))
    ]
    assert "docs/gaits.md" in named
    assert all((ROOT / path).exists() for path in named), named


def test_the_gait_pages_example_loads_as_written(tmp_path):
    """The page's ``my_gaits.yaml`` and ``my_scenario.yaml``, written side by side: the wider
    trot takes the trot's other matrices, the second gait the wider trot's with the walk's
    phases, and the page's second command (``--set controller.gait=wide_walk``) resolves."""
    from manta_drake.control.gaits import GAITS
    from manta_drake.scenario import load_scenario

    _, gait_file, scenario_file = _yaml_blocks(GAITS_PAGE)
    (tmp_path / "my_gaits.yaml").write_text(gait_file)
    (tmp_path / "my_scenario.yaml").write_text(scenario_file)
    s = load_scenario(tmp_path / "my_scenario.yaml")
    wide, walk = s.gait("wide_trot"), s.gait("wide_walk")
    np.testing.assert_allclose(np.degrees(wide.R[:, 0]), [30, -30, 30, -30])
    for field in ("X", "Phi", "Phi_prime"):
        np.testing.assert_array_equal(getattr(wide, field), getattr(GAITS["trot"], field))
    np.testing.assert_array_equal(walk.Phi_prime, GAITS["walk"].Phi_prime)
    np.testing.assert_array_equal(walk.R, wide.R)
    assert s.controller.gait_files == [str(tmp_path / "my_gaits.yaml")]
    text = GAITS_PAGE.read_text()
    assert "--set controller.gait=wide_walk" in text
    again = load_scenario(tmp_path / "my_scenario.yaml", overrides={"controller.gait": "wide_walk"})
    assert again.controller.gait == "wide_walk"


def test_the_gait_pages_limits_are_the_codes():
    """The keys, the degree bound and the joints' ranges the page gives are the loader's and
    the robot's."""
    import math
    import re

    from manta_drake.control import gait_files as G
    from manta_drake.model.robot_params import DEFAULT_ROBOT

    text = " ".join(GAITS_PAGE.read_text().split())
    keys = re.search(r"A gait's keys: (.*?); nothing else", text).group(1)
    assert re.findall(r"`(\w+)`", keys) == list(G.GAIT_KEYS)
    assert f"within +-{G.MAX_DEGREES:g} deg" in text
    shown = re.search(
        r"the joints' ranges \(yaw \+-(\d+), roll1 \+-(\d+), pitch \+-(\d+), "
        r"roll2 \+-(\d+) deg\)",
        text,
    )
    assert shown, "docs/gaits.md: the joints' ranges are not given"
    for value, (lo, hi) in zip(shown.groups(), DEFAULT_ROBOT.position_limits):
        assert float(value) == pytest.approx(math.degrees(hi)) == pytest.approx(-math.degrees(lo))
    keeps = re.search(r"`mirror_keep`: a list of (.*?)\. \*", text.split("## The limits")[1])
    assert keeps and all(f"`{m}`" in keeps.group(1) for m in G.MIRRORED_MATRICES)
    assert all(c in keeps.group(1) for c in G.JOINT_COLUMNS)
