"""The package's layers: every import statement (at the top of a module or inside a
function) points down the layers of docs/design.md, and no modules import each other in
a loop. Read from the source with ``ast``, so an import hidden inside a function counts."""

import ast
import pathlib

import pytest

PACKAGE = pathlib.Path(__file__).resolve().parents[1] / "manta_drake"

# Bottom up. A module may import modules of lower layers, and of its own layer only where
# the layer says so (``within``); the package face (manta_drake/__init__.py) is above all.
LAYERS = [
    ("config I/O", ["manta_drake.config_io", "manta_drake.version", "manta_drake.jit"], False),
    ("model", ["manta_drake.model", "manta_drake.models", "manta_drake.lcmtypes"], True),
    ("halves", ["manta_drake.station", "manta_drake.control"], True),
    ("modalities", ["manta_drake.modalities"], False),
    ("scenario", ["manta_drake.scenario"], True),
    # ROS 2 messages, topic map and bags: below the run that writes a bag and the seam
    # that will publish the same messages.
    ("ros2", ["manta_drake.ros2"], True),
    ("wiring", ["manta_drake.wiring"], True),
    (
        "running",
        [
            "manta_drake.metrics",
            "manta_drake.plots",
            "manta_drake.simulate",
            "manta_drake.run_folder",
            "manta_drake.interrupts",
        ],
        True,
    ),
    ("seam", ["manta_drake.seam", "manta_drake.lcm_seam"], True),
    (
        "many runs",
        [
            "manta_drake.cluster",
            "manta_drake.sweep",
            "manta_drake.calibrate",
            "manta_drake.optimize",
            "manta_drake.studies",
        ],
        True,
    ),
    ("front ends", ["manta_drake.cli", "manta_drake.__main__"], True),
]
# Pairs that share a layer but must never import each other.
APART = [("manta_drake.station", "manta_drake.control")]


def _module_name(path: pathlib.Path) -> str:
    parts = list(path.relative_to(PACKAGE.parent).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


MODULES = {_module_name(p): p for p in sorted(PACKAGE.rglob("*.py"))}


def _resolve(name: str) -> str:
    """The package module an imported name refers to (a module, or its package)."""
    while name not in MODULES and "." in name:
        name = name.rsplit(".", 1)[0]
    return name


def imports_of(module: str) -> set[str]:
    """The package modules ``module`` imports, from every import statement in it."""
    tree = ast.parse(MODULES[module].read_text())
    is_package = MODULES[module].name == "__init__.py"
    out = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:  # relative: from the module's package
                anchor = module.split(".") if is_package else module.split(".")[:-1]
                anchor = anchor[: len(anchor) - node.level + 1]
                base = ".".join(anchor + ([base] if base else []))
            names = [f"{base}.{a.name}" for a in node.names]
        else:
            continue
        for name in names:
            if name == "manta_drake" or name.startswith("manta_drake."):
                target = _resolve(name)
                if target != module:
                    out.add(target)
    return out


GRAPH = {m: imports_of(m) for m in MODULES}


def layer_of(module: str) -> int | None:
    for rank, (_, prefixes, _) in enumerate(LAYERS):
        if any(module == p or module.startswith(p + ".") for p in prefixes):
            return rank
    return None


def test_every_module_has_a_layer():
    unplaced = [m for m in MODULES if m != "manta_drake" and layer_of(m) is None]
    assert not unplaced, f"modules in no layer of LAYERS: {unplaced}"


def test_imports_point_down_the_layers():
    wrong = []
    for module, targets in GRAPH.items():
        if module == "manta_drake":
            continue
        rank = layer_of(module)
        for target in targets:
            t_rank = layer_of(target) if target != "manta_drake" else len(LAYERS)
            if t_rank > rank or (t_rank == rank and not LAYERS[rank][2]):
                wrong.append(f"{module} ({LAYERS[rank][0]}) -> {target}")
    assert not wrong, "imports that point up or sideways:\n" + "\n".join(wrong)


@pytest.mark.parametrize("a, b", APART)
def test_station_and_control_are_apart(a, b):
    def inside(m, p):
        return m == p or m.startswith(p + ".")

    ties = [
        f"{m} -> {t}"
        for m, ts in GRAPH.items()
        for t in ts
        if (inside(m, a) and inside(t, b)) or (inside(m, b) and inside(t, a))
    ]
    assert not ties, ties


def test_no_import_cycle():
    # Tarjan's strongly connected components over the module graph.
    index, low, stack, on_stack, cycles = {}, {}, [], set(), []

    def visit(v):
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in GRAPH.get(v, ()):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                cycles.append(sorted(component))

    for v in GRAPH:
        if v not in index:
            visit(v)
    assert not cycles, f"import cycles: {cycles}"


def test_the_checker_sees_imports_inside_functions(tmp_path):
    """The walk reads function bodies: a late import is an import."""
    tree = ast.parse("def f():\n    from manta_drake.station.water import cross\n")
    found = [n.module for n in ast.walk(tree) if isinstance(n, ast.ImportFrom)]
    assert found == ["manta_drake.station.water"]
    # And the real graph holds at least the known downward edges.
    assert "manta_drake.model.plant" in GRAPH["manta_drake.wiring.station"]
    assert "manta_drake.config_io" in GRAPH["manta_drake.model.coefficients"]
