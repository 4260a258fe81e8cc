"""docs/tutorial.ipynb: committed without outputs, and executed (nbclient, in a temporary
working directory) it runs every step: the runs, the changed field, the gait given as data
and the four-run sweep on a local Dask cluster, with the results the physics says, each
speed averaged over whole CPG cycles (at least two)."""

import csv
import json
import pathlib
import time

import nbformat
import pytest
import yaml

NOTEBOOK = pathlib.Path(__file__).resolve().parents[1] / "docs" / "tutorial.ipynb"


def test_committed_without_outputs():
    nb = nbformat.read(NOTEBOOK, as_version=4)
    nbformat.validate(nb)
    code = [cell for cell in nb.cells if cell.cell_type == "code"]
    assert 6 <= len(code) <= 14
    for cell in code:
        assert cell.outputs == [] and cell.execution_count is None, cell.source[:60]
    # every step is explained: a markdown cell before each code cell but the imports
    for before, cell in zip(nb.cells, nb.cells[1:]):
        if cell.cell_type == "code" and "import csv" not in cell.source:
            assert before.cell_type == "markdown", cell.source[:60]


@pytest.fixture(scope="module")
def executed(tmp_path_factory):
    from nbclient import NotebookClient

    work = tmp_path_factory.mktemp("tutorial")
    nb = nbformat.read(NOTEBOOK, as_version=4)
    start = time.monotonic()
    NotebookClient(
        nb, timeout=600, kernel_name="python3", resources={"metadata": {"path": str(work)}}
    ).execute()
    print(f"tutorial executed in {time.monotonic() - start:.1f} s")
    return nb, work / "out" / "tutorial"


def _metrics(folder: pathlib.Path) -> dict:
    return json.loads((folder / "metrics.json").read_text())


def _assert_whole_cycles(window, frequency_hz: float, at_least: int) -> None:
    """The steady window spans a whole number (at least ``at_least``) of CPG cycles."""
    cycles = (window[1] - window[0]) * frequency_hz
    assert cycles >= at_least and cycles == pytest.approx(round(cycles), abs=1e-9), (
        window,
        frequency_hz,
        cycles,
    )


def _scenario(folder: pathlib.Path) -> dict:
    return yaml.safe_load((folder / "scenario.yaml").read_text())


def _steady(folder: pathlib.Path):
    """The run's log restricted to its steady window: (log, mask)."""
    import numpy as np

    log = np.load(folder / "log.npz")
    return log, log["t"] >= _metrics(folder)["steady_window_s"][0]


def _path_speed(folder: pathlib.Path) -> float:
    """Mean horizontal speed of the hull over the steady window [m/s]."""
    import numpy as np

    log, window = _steady(folder)
    return float(np.linalg.norm(log["body_v_world"][window, :2], axis=1).mean())


@pytest.mark.slow
def test_the_runs_and_the_changed_field(executed):
    _, out = executed
    swim = _metrics(out / "swim")
    still, against = _metrics(out / "swim_no_lag"), _metrics(out / "swim_current")
    for m in (swim, still, against):
        assert m["status"] == "ok" and m["sim_time_s"] == pytest.approx(6.0)
        _assert_whole_cycles(m["steady_window_s"], 0.5, at_least=2)
    assert _scenario(out / "swim_no_lag")["water"]["current_schedule"] == []
    assert _scenario(out / "swim_current")["water"]["current_schedule"] == [
        {"time": 0.0, "velocity": [-0.03, 0.0, 0.0]}
    ]
    # The straight swim against a 0.03 m/s current: slowed over the ground, but by less than
    # the current (started at rest on the ground, it has not picked the current up in 6 s).
    slowed = still["mean_velocity_body"][0] - against["mean_velocity_body"][0]
    assert 0.003 < slowed < 0.03, slowed


@pytest.mark.slow
def test_the_gait_given_as_data(executed):
    _, out = executed
    library, no_lag = _metrics(out / "swim"), _metrics(out / "swim_no_lag")
    assert no_lag["status"] == "ok"
    # without Phi_prime's left-right lag the mirror-symmetric swim goes straight
    assert abs(library["yaw_rate_deg_s"]) > 2.0
    assert abs(no_lag["yaw_rate_deg_s"]) < 0.5
    assert no_lag["mean_velocity_body"][0] > 0.05


@pytest.mark.slow
def test_the_sweep_table(executed):
    _, out = executed
    with open(out / "sweep" / "results.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == 4
    assert [row["status"] for row in rows] == ["ok"] * 4
    freq, damping = "cpg.frequency_hz", "water.coefficient_scales.links.quadratic_damping"
    grid = {(float(row[freq]), float(row[damping])) for row in rows}
    assert grid == {(0.4, 0.8), (0.4, 1.2), (0.6, 0.8), (0.6, 1.2)}
    # The swim turns (more so at 0.6 Hz), so its speed is the path's, not the displacement's.
    speed = {
        (float(row[freq]), float(row[damping])): _path_speed(out / "sweep" / "runs" / row["run_id"])
        for row in rows
    }
    for d in (0.8, 1.2):
        assert speed[0.6, d] > speed[0.4, d]  # faster fins, faster swim
    for f in (0.4, 0.6):
        assert speed[f, 1.2] < speed[f, 0.8]  # more drag, slower swim
    for row in rows:  # each run's resolved scenario holds its own parameters
        resolved = _scenario(out / "sweep" / "runs" / row["run_id"])
        assert resolved["cpg"]["frequency_hz"] == float(row[freq])
        assert resolved["water"]["coefficient_scales"] == {
            "links.quadratic_damping": float(row[damping])
        }
        assert resolved["duration"] == 7.0
        window = (float(row["steady_start_s"]), float(row["steady_end_s"]))
        _assert_whole_cycles(window, float(row[freq]), at_least=2)


@pytest.mark.slow
def test_the_figures_are_shown(executed):
    nb, _ = executed
    images = [
        output
        for cell in nb.cells
        if cell.cell_type == "code"
        for output in cell.outputs
        if "image/png" in output.get("data", {})
    ]
    assert len(images) == 3
    errors = [
        output
        for cell in nb.cells
        if cell.cell_type == "code"
        for output in cell.outputs
        if output.output_type == "error"
    ]
    assert not errors
