"""Synthetic measurements: the experiments simulated with known coefficient scales, plus
seeded Gaussian noise (to test a calibration against a known truth)."""

from __future__ import annotations

import math

import numpy as np

from manta_drake.calibrate.config import CalibrationConfig, Sigma
from manta_drake.calibrate.measured import TRAJECTORY_COLUMNS
from manta_drake.calibrate.run import simulate_trajectory
from manta_drake.calibrate.scenarios import experiment_scenario, scenario_text


def synthesize_measurements(
    config: CalibrationConfig,
    truth_scales: dict[str, float],
    noise: Sigma,
    seed: int,
    period: float = 0.1,
    client=None,
) -> dict[str, dict]:
    """Synthetic "measured" trajectories: every experiment with a ``measured`` file simulated
    with the coefficients scaled by ``truth_scales``, sampled every ``period`` s, plus
    Gaussian noise (``noise.position_m`` on x, y, z; ``noise.yaw_deg`` on yaw) from
    ``numpy.random.default_rng(seed)``.

    Returns:
        experiment name -> {t, x, y, z, yaw} arrays.
    """
    rng = np.random.default_rng(seed)
    texts = {
        e.name: scenario_text(experiment_scenario(config, e, truth_scales))
        for e in config.experiments
        if e.measured
    }
    if client is None:
        sims = {name: simulate_trajectory(text) for name, text in texts.items()}
    else:
        futures = {
            name: client.submit(simulate_trajectory, text, pure=False)
            for name, text in texts.items()
        }
        sims = {name: f.result() for name, f in futures.items()}
    out = {}
    for name, sim in sims.items():  # in file order: the noise does not depend on timing
        if sim["status"] != "ok":
            raise RuntimeError(f"synthesizing {name}: {sim['reason']}")
        t = np.arange(0.0, sim["t"][-1] + 1e-9, period)
        data = {"t": t}
        for col in TRAJECTORY_COLUMNS:
            data[col] = np.interp(t, sim["t"], sim[col])
            sd = math.radians(noise.yaw_deg) if col == "yaw" else noise.position_m
            data[col] = data[col] + rng.normal(0.0, sd, len(t))
        out[name] = data
    return out
