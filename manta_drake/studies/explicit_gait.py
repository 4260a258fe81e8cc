"""Runs of a gait given as data: a study's variant of a library gait (another reading of the
printed matrices, a phase bias removed) that has no name in the package's gait library.

``scenario_with_gait`` writes the ``GaitParams`` into a gait file (``control.gait_files``) in
a folder of the run and returns the scenario that names it (``controller.gait_files``,
``controller.gait``, ``initial_stance``), checked as every scenario is (the start pose
against the gait's stance included). The run is then an ordinary run of that scenario: its
``scenario.yaml`` reproduces it, and the package's gait library is never changed.
"""

from __future__ import annotations

import pathlib
import re

import numpy as np

from manta_drake.control.gait_files import write_gait_file
from manta_drake.control.gait_params import GaitParams
from manta_drake.scenario import load_scenario
from manta_drake.simulate import run

GAIT_FILE = "given_gait.yaml"


def gait_name_for(label: str) -> str:
    """A gait name for ``label`` (e.g. "swim, mirror_left" -> "given_swim_mirror_left"): a
    prefix no library gait has, then the label's letters and digits."""
    return "given_" + (re.sub(r"[^A-Za-z0-9]+", "_", str(label)).strip("_") or "gait")


def scenario_with_gait(scenario, gait: GaitParams, folder, label: str = "gait", stance=None):
    """``scenario`` running ``gait`` (from rest in its stance, or in ``stance``, 4x4).

    Writes ``folder/given_gait.yaml`` and returns the validated scenario that adds it to
    ``controller.gait_files`` and names its gait in ``controller.gait`` and
    ``initial_stance``. A separate ``stance`` is a second gait of the file (the gait's
    matrices with X = stance) that only ``initial_stance`` names.

    Raises:
        ScenarioError: the start pose does not fit the stance (as ``Scenario.validate``
            checks it), or the scenario is otherwise refused.
    """
    folder = pathlib.Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    name = gait_name_for(label)
    gaits = {name: gait}
    start = name
    if stance is not None and not np.array_equal(np.asarray(stance, dtype=float), gait.X):
        start = f"{name}_stance"
        gaits[start] = GaitParams(gait.R, np.asarray(stance, dtype=float), gait.Phi, gait.Phi_prime)
    path = write_gait_file(folder / GAIT_FILE, gaits, description=f"a gait given as data: {label}")
    files = list(scenario.controller.gait_files) + [str(path.resolve())]
    return load_scenario(
        defaults=scenario,
        overrides={
            "controller.gait_files": files,
            "controller.gait": name,
            "initial_stance": start,
        },
    )


def run_with_gait(
    scenario, gait: GaitParams, out_dir, stance=None, gait_name: str = "given"
) -> dict:
    """Simulates ``scenario`` with ``gait`` (``scenario_with_gait``, its gait file in
    ``out_dir``) through ``simulate.run`` and returns its metrics; ``out_dir`` gets the run's
    outputs, its ``scenario.yaml`` naming the gait file.

    Raises:
        ScenarioError: the start pose does not fit the gait's stance.
        SimulationError: the simulation failed (the log and metrics.json are written first).
    """
    s = scenario_with_gait(scenario, gait, out_dir, gait_name, stance)
    return run(s, out_dir, progress=False).metrics
