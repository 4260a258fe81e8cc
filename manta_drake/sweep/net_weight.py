"""The derived parameter ``net_weight_kg``: the robot's deflated net weight, set through a
scale of the hull's sealed ellipsoid (``hull_scale_for_net_weight`` is the closed form)."""

from __future__ import annotations

import functools
import math
import pathlib

from manta_drake.config_io import ScenarioError, check_number
from manta_drake.model import resolve_path
from manta_drake.model.coefficients import load_coefficients, scale_coefficients
from manta_drake.model.robot_params import DEFAULT_ROBOT
from manta_drake.scenario import Scenario
from manta_drake.station.water import build_elements, deflated_net_weight_kg  # noqa: F401


def hull_scale_for_net_weight(
    net_weight_kg: float,
    total_mass_kg: float,
    water_density: float,
    hull_volume_m3: float,
    other_volume_m3: float,
) -> float:
    """Linear scale of the hull's sealed ellipsoid that gives a deflated net weight.

    The deflated robot's net weight is its mass minus the water displaced by its sealed
    volumes (hull, servo cases, fin plates) with the balloon empty:
    ``W = M - rho (V_hull + V_other)``. Scaling the hull's semi-axes by ``s`` scales its
    volume by ``s^3``, so ``s = cbrt(((M - W) / rho - V_other) / V_hull)``.

    Args:
        net_weight_kg: wanted net weight W [kg] (negative: the robot floats).
        total_mass_kg: robot mass M [kg].
        water_density: rho [kg/m^3].
        hull_volume_m3: the hull's current sealed volume [m^3].
        other_volume_m3: every other sealed volume [m^3].

    Raises:
        ValueError: W is not finite, or so large that the hull would need no volume.
    """
    if not math.isfinite(net_weight_kg):
        raise ValueError(f"net_weight_kg: {net_weight_kg!r} must be a finite number")
    target = (total_mass_kg - net_weight_kg) / water_density - other_volume_m3
    if target <= 0.0:
        raise ValueError(
            f"net_weight_kg: {net_weight_kg} kg leaves the hull no sealed volume "
            f"(the robot weighs {total_mass_kg} kg; at most "
            f"{total_mass_kg - water_density * other_volume_m3:.3f} kg)"
        )
    return (target / hull_volume_m3) ** (1.0 / 3.0)


def net_weight_scales(net_weight_kg: float, coeffs, params=None) -> dict[str, float]:
    """Coefficient scales that give the deflated robot ``net_weight_kg``.

    The water model takes the hull's buoyancy from ``body.sealed_semi_axes`` (the ellipsoid
    also sets the waterline); ``body.sealed_volume`` is its documented volume. Both are
    scaled (by s and s^3) so the coefficients file stays consistent.
    """
    params = params or DEFAULT_ROBOT
    volumes = build_elements(coeffs, params)["volume"]
    s = hull_scale_for_net_weight(
        net_weight_kg,
        params.total_mass,
        coeffs.water_density.value,
        float(volumes[0]),
        float(volumes[1:].sum()),
    )
    return {"body.sealed_semi_axes": s, "body.sealed_volume": s**3}


def _cached_coefficients(path: pathlib.Path):
    """load_coefficients, parsed once per file version (a sweep resolves hundreds of runs;
    the YAML parser takes ~40 ms a file). Callers get a copy from scale_coefficients."""
    path = pathlib.Path(path)
    stat = path.stat() if path.is_file() else None
    return _load_coefficients_once(str(path), stat.st_mtime_ns if stat else 0)


@functools.lru_cache(maxsize=8)
def _load_coefficients_once(path: str, mtime_ns: int):
    return load_coefficients(path)


def apply_net_weight(scenario: Scenario, net_weight_kg) -> None:
    """Adds the hull scales for ``net_weight_kg`` to the scenario's coefficient scales
    (after its other scales, e.g. of the servo volume). Raises ScenarioError."""
    check_number("net_weight_kg", net_weight_kg)
    if not scenario.water.enabled:
        raise ScenarioError("net_weight_kg: needs water.enabled: true")
    scales = dict(scenario.water.coefficient_scales)
    for key in ("body.sealed_semi_axes", "body.sealed_volume"):
        if key in scales:
            raise ScenarioError(f"net_weight_kg: sets the scale of {key}, which is also set")
    try:
        coeffs = scale_coefficients(
            _cached_coefficients(resolve_path(scenario.water.coefficients)), scales
        )
        scales.update(net_weight_scales(float(net_weight_kg), coeffs))
    except ValueError as e:
        raise ScenarioError(str(e)) from None
    scenario.water.coefficient_scales = scales
