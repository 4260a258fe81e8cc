"""Residuals in standard scores: a simulated trajectory against a measured one, and the
mean velocities against their targets."""

from __future__ import annotations

import math

import numpy as np

from manta_drake.calibrate.config import Sigma

# Residual (in standard scores) of a sample a failed simulation did not reach: large, so the
# optimiser steps away, but finite, so least_squares keeps going.
FAILED_RESIDUAL = 100.0


def trajectory_residuals(measured: dict, simulated: dict, columns, sigma: Sigma) -> np.ndarray:
    """Standard scores (simulated - measured) / sigma at the measured times, column after
    column; yaw differences wrapped to (-pi, pi]. Samples the simulation did not reach (it
    failed, or was shorter) score ``FAILED_RESIDUAL``."""
    t = measured["t"]
    sim_t = np.asarray(simulated.get("t", []), dtype=float)
    reached = t <= (sim_t[-1] + 1e-9 if len(sim_t) else -np.inf)
    parts = []
    for col in columns:
        r = np.full(len(t), FAILED_RESIDUAL)
        if reached.any():
            sim = np.interp(t[reached], sim_t, simulated[col])
            diff = sim - measured[col][reached]
            if col == "yaw":
                r[reached] = np.angle(np.exp(1j * diff)) / math.radians(sigma.yaw_deg)
            else:
                r[reached] = diff / sigma.position_m
        parts.append(r)
    return np.concatenate(parts)


def target_residuals(target: dict, simulated: dict, sigma: Sigma) -> np.ndarray:
    """Standard scores of the mean-velocity targets (``FAILED_RESIDUAL`` where missing)."""
    scale = {
        "u": sigma.velocity_m_s,
        "v": sigma.velocity_m_s,
        "yaw_rate_deg_s": sigma.yaw_rate_deg_s,
    }
    out = []
    for key, want in target.items():
        got = simulated.get(key, math.nan)
        out.append((got - want) / scale[key] if math.isfinite(got) else FAILED_RESIDUAL)
    return np.asarray(out, dtype=float)
