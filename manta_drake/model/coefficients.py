"""Hydrodynamic coefficients: the formulas, and ``models/hydrodynamics.yaml``.

Sign convention: the YAML and this module store *magnitudes* (added mass
m_a >= 0, damping d >= 0). In Fossen's notation X_udot = -m_a and
X_u = -d_lin, X_u|u| = -d_quad, so the damping force on axis i is
``-(d_lin_i + d_quad_i |nu_i|) nu_i``.

Axes are the robot's Drake body frame (x forward, y left, z up), in the order
(surge, sway, heave, roll, pitch, yaw).

Formulas:

* Body added mass by strip theory (Newman, Marine Hydrodynamics, 2018, ch. 4):
  the hull is an ellipsoid with semi-axes (a, b, c); every transverse section is
  an ellipse with half-width b(x) = b sqrt(1 - x^2/a^2) and half-height
  c(x) = c sqrt(1 - x^2/a^2), whose 2-D added mass for motion along one axis is
  rho pi (half-length of the *other* axis)^2. Heave and sway integrate transverse
  sections along x; surge and roll integrate longitudinal sections along y
  (half-length a(y), half-height c(y)), as the paper does ("both a longitudinal
  and transverse section").
* Fin added mass as flat plates (Lewis, Principles of Naval Architecture,
  SNAME 1989): a plate strip of chord c moving normal to itself has 2-D added
  mass rho pi c^2 / 4 per unit span; rotating about its mid-chord line,
  rho pi c^4 / 128 per unit span.
* Damping by the least-squares fit of Eq. (4): F = d_lin u + d_quad u|u|.
"""

import dataclasses as dc
import pathlib

import numpy as np
from pydrake.common.yaml import yaml_load_typed

from manta_drake.config_io import ScenarioError, check_keys, parse_yaml, read_text_file
from manta_drake.model import MODELS_DIR
from manta_drake.model.robot_params import RobotParams
from manta_drake.model.sourced import Number, Numbers, sourced_entries

DEFAULT_COEFFICIENTS_FILE = MODELS_DIR / "hydrodynamics.yaml"
AXES = ("surge", "sway", "heave", "roll", "pitch", "yaw")


# --- formulas ----------------------------------------------------------------------------


def body_added_mass_strip_theory(semi_axes, rho: float) -> dict:
    """Added mass [kg] and added inertia [kg m^2] of an ellipsoidal hull by strip theory.

    Args:
        semi_axes: (a, b, c) along x (length), y (width), z (height) [m].
        rho: water density [kg/m^3].

    Returns:
        dict with ``mass`` (surge, sway, heave) and ``inertia`` (roll, pitch, yaw).
    """
    a, b, c = semi_axes
    # int_{-a}^{a} (1 - x^2/a^2) dx = 4a/3;  int x^2 (1 - x^2/a^2) dx = 4a^3/15.
    surge = rho * np.pi * c**2 * 4 * b / 3  # longitudinal sections along y
    sway = rho * np.pi * c**2 * 4 * a / 3
    heave = rho * np.pi * b**2 * 4 * a / 3
    roll = rho * np.pi * a**2 * 4 * b**3 / 15  # heave of longitudinal sections, lever y
    pitch = rho * np.pi * b**2 * 4 * a**3 / 15  # heave of transverse sections, lever x
    yaw = rho * np.pi * c**2 * 4 * a**3 / 15  # sway of transverse sections, lever x
    return {"mass": np.array([surge, sway, heave]), "inertia": np.array([roll, pitch, yaw])}


def plate_added_mass_per_span(chord: float, rho: float) -> float:
    """Lewis: 2-D added mass of a flat plate strip moving normal to itself [kg/m]."""
    return rho * np.pi * chord**2 / 4.0


def plate_added_inertia_per_span(chord: float, rho: float) -> float:
    """Lewis: 2-D added inertia of a flat plate strip rotating about mid-chord [kg m^2/m]."""
    return rho * np.pi * chord**4 / 128.0


def fin_hinge_added_inertia(params: RobotParams, rho: float) -> np.ndarray:
    """Added inertia of the fin plates about each hinge at the zero pose [kg m^2].

    Order (yaw, roll1, pitch, roll2). roll1 swings both plates (proximal on
    [0, d3], distal on [d3, d3 + dE] along the span); roll2 swings the distal
    plate on [0, dE]; pitch turns both plates about their span line; yaw moves
    them edgewise (no added inertia from a thin plate).
    """
    cp, cd, d3, dE = params.proximal_chord, params.distal_chord, params.d3, params.dE
    mp, md = plate_added_mass_per_span(cp, rho), plate_added_mass_per_span(cd, rho)
    roll1 = mp * d3**3 / 3 + md * ((d3 + dE) ** 3 - d3**3) / 3
    roll2 = md * dE**3 / 3
    pitch = plate_added_inertia_per_span(cp, rho) * d3 + plate_added_inertia_per_span(cd, rho) * dE
    return np.array([0.0, roll1, pitch, roll2])


def fit_damping(velocity, force, relative: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """Least-squares fit of Eq. (4): force = d_lin * u + d_quad * u|u|.

    Args:
        velocity: samples u (n,).
        force: resisting force magnitudes X (n,), same sign as u.
        relative: minimise the relative residuals (A h - b) / b instead of the absolute
            ones (rows weighted by 1 / |b|): for samples spanning decades of force, where
            the absolute fit serves the largest forces only.

    Returns:
        (h, residuals): h = [d_lin, d_quad] = (A^T W A)^-1 A^T W b, residuals = A h - b.
    """
    u = np.asarray(velocity, dtype=float)
    b = np.asarray(force, dtype=float)
    if u.shape != b.shape or u.ndim != 1 or len(u) < 2:
        raise ValueError("fit_damping: need two equally long 1-D arrays of at least 2 samples")
    A = np.column_stack([u, u * np.abs(u)])
    wt = 1.0 / np.abs(b) if relative else np.ones_like(b)
    h, *_ = np.linalg.lstsq(A * wt[:, None], b * wt, rcond=None)
    return h, A @ h - b


@dc.dataclass
class BodyHydro:
    sealed_volume: Number = dc.field(default_factory=Number)  # m^3, displaced when submerged
    sealed_semi_axes: Numbers = dc.field(default_factory=Numbers)  # m
    center_of_buoyancy: Numbers = dc.field(default_factory=Numbers)  # m, in the body frame
    added_mass: Numbers = dc.field(default_factory=Numbers)  # kg (surge, sway, heave)
    added_inertia: Numbers = dc.field(default_factory=Numbers)  # kg m^2 (roll, pitch, yaw)
    linear_damping: Numbers = dc.field(default_factory=Numbers)  # 6, N s/m | N m s
    quadratic_damping: Numbers = dc.field(default_factory=Numbers)  # 6, N s^2/m^2 | N m s^2
    # 4, body lift Y_uv, Z_uw (N s^2/m^2), M_uw, N_uv (N s^2/m): water.body_lift
    body_lift: Numbers = dc.field(default_factory=Numbers)


@dc.dataclass
class LinkHydro:
    linear_damping: Numbers = dc.field(default_factory=Numbers)  # 6, per link
    quadratic_damping: Numbers = dc.field(default_factory=Numbers)  # 6, per link


@dc.dataclass
class FinHydro:
    normal_force_coefficient: Number = dc.field(default_factory=Number)
    skin_friction_coefficient: Number = dc.field(default_factory=Number)
    strips_per_plate: Number = dc.field(default_factory=Number)
    passive_pitch_max_deg: Number = dc.field(default_factory=Number)
    passive_pitch_reference_pressure: Number = dc.field(default_factory=Number)  # Pa
    hinge_added_inertia: Numbers = dc.field(default_factory=Numbers)  # (yaw, roll1, pitch, roll2)
    added_mass_factor: Numbers = dc.field(default_factory=Numbers)  # 3-D K (proximal, distal)
    hull_interaction_added_mass: Number = dc.field(default_factory=Number)  # kg, heave
    lift_slope: Number = dc.field(default_factory=Number)  # 1/rad, attached flow
    suction_efficiency: Number = dc.field(default_factory=Number)  # leading-edge suction share
    stall_angle_deg: Number = dc.field(default_factory=Number)  # attached -> separated
    stall_width_deg: Number = dc.field(default_factory=Number)  # width of that blend
    separation_lag: Number = dc.field(default_factory=Number)  # T_f, semichords


@dc.dataclass
class BalloonHydro:
    max_volume: Number = dc.field(default_factory=Number)  # m^3
    mount_point: Numbers = dc.field(default_factory=Numbers)  # m, body frame
    pump_rate: Number = dc.field(default_factory=Number)  # m^3/s


@dc.dataclass
class HydroCoefficients:
    """Contents of ``models/hydrodynamics.yaml``: every number with its source."""

    water_density: Number = dc.field(default_factory=Number)
    gravity: Number = dc.field(default_factory=Number)
    body: BodyHydro = dc.field(default_factory=BodyHydro)
    links: LinkHydro = dc.field(default_factory=LinkHydro)
    fins: FinHydro = dc.field(default_factory=FinHydro)
    balloon: BalloonHydro = dc.field(default_factory=BalloonHydro)

    def entries(self) -> list:
        """(dotted name, Number | Numbers) for every coefficient."""
        return list(sourced_entries(self))


def scale_coefficients(coeffs: HydroCoefficients, scales: dict) -> HydroCoefficients:
    """A copy of ``coeffs`` with named entries multiplied, e.g. ``{"body.linear_damping":
    1.3}``; each scaled entry's ``source`` says so. Unknown names and non-finite or
    negative factors raise ValueError naming the entry."""
    import copy

    result = copy.deepcopy(coeffs)
    entries = dict(result.entries())
    for name, factor in (scales or {}).items():
        if name not in entries:
            raise ValueError(
                f"coefficient_scales.{name}: unknown coefficient; allowed: "
                f"{', '.join(sorted(entries))}"
            )
        if not (isinstance(factor, (int, float)) and np.isfinite(factor) and factor >= 0):
            raise ValueError(f"coefficient_scales.{name}: {factor!r} must be a finite number >= 0")
        entry = entries[name]
        if isinstance(entry.value, list):
            entry.value = [float(v) * factor for v in entry.value]
        else:
            entry.value = float(entry.value) * factor
        entry.source = f"x{factor:g} of: {entry.source}"
    # The scaled set must pass the same checks as a file (a whole number of strips,
    # positive volumes and densities): a scale is refused, never silently truncated.
    check_coefficients(result, "coefficient_scales")
    return result


# Entries that must be > 0 (a zero volume or density divides by zero at t = 0), and
# entries that must be whole numbers.
POSITIVE = (
    "water_density",
    "gravity",
    "body.sealed_volume",
    "body.sealed_semi_axes",
    "fins.strips_per_plate",
    "fins.normal_force_coefficient",
    "fins.passive_pitch_reference_pressure",
    "balloon.max_volume",
    "balloon.pump_rate",
    "fins.added_mass_factor",
    "fins.lift_slope",
    "fins.stall_width_deg",
)
INTEGER = ("fins.strips_per_plate",)
SEALED_VOLUME_TOLERANCE = 0.01  # relative: body.sealed_volume against 4/3 pi abc
# Physical ranges of the constants: a pool of water on Earth. Fresh water is 997 kg/m^3 at
# 25 C, sea water about 1025, brines up to about 1200; beyond these the contact solver and
# the buoyancy are asked for something no pool holds. g on Earth's surface: 9.78-9.83.
RANGES = {"water_density": (900.0, 1300.0, "kg/m^3"), "gravity": (9.7, 9.9, "m/s^2")}
SIZES = {
    "body.sealed_semi_axes": 3,
    "body.center_of_buoyancy": 3,
    "body.added_mass": 3,
    "body.added_inertia": 3,
    "body.linear_damping": 6,
    "body.quadratic_damping": 6,
    "body.body_lift": 4,
    "links.linear_damping": 6,
    "links.quadratic_damping": 6,
    "fins.hinge_added_inertia": 4,
    "fins.added_mass_factor": 2,
    "balloon.mount_point": 3,
}


def check_coefficients(coeffs: HydroCoefficients, where: str = "coefficients") -> None:
    """Raises ScenarioError naming the first entry with a missing source, a wrong size, a
    non-finite, negative (or zero where it must be positive) or non-integer value."""
    for name, entry in coeffs.entries():
        if not entry.source.strip():
            raise ScenarioError(f"{where}: {name} has no source")
        values = np.atleast_1d(np.asarray(entry.value, dtype=float))
        if name in SIZES and len(values) != SIZES[name]:
            raise ScenarioError(f"{where}: {name} needs {SIZES[name]} values, got {len(values)}")
        if not np.all(np.isfinite(values)):
            raise ScenarioError(f"{where}: {name} = {entry.value!r} has non-finite values")
        signed = name in ("body.center_of_buoyancy", "balloon.mount_point", "body.body_lift")
        if not signed and np.any(values < 0):
            raise ScenarioError(f"{where}: {name} = {entry.value!r} must be >= 0 (magnitudes)")
        if name in POSITIVE and np.any(values <= 0):
            raise ScenarioError(f"{where}: {name} = {entry.value!r} must be > 0")
        if name in INTEGER and np.any(values != np.round(values)):
            raise ScenarioError(f"{where}: {name} = {entry.value!r} must be a whole number")
        if name in RANGES:
            lo, hi, unit = RANGES[name]
            if not np.all((lo <= values) & (values <= hi)):
                raise ScenarioError(
                    f"{where}: {name} = {entry.value!r} is outside the allowed "
                    f"range [{lo:g}, {hi:g}] {unit}"
                )
    # The water model integrates the hull's buoyancy over body.sealed_semi_axes; the volume
    # is its documented value. One changed without the other would change nothing (or
    # something else than meant) without a word, so they must agree.
    body = coeffs.body
    implied = 4.0 / 3.0 * np.pi * float(np.prod(body.sealed_semi_axes.value))
    volume = float(body.sealed_volume.value)
    if abs(implied - volume) > SEALED_VOLUME_TOLERANCE * volume:
        raise ScenarioError(
            f"{where}: body.sealed_volume = {volume:g} m^3 disagrees with body.sealed_semi_axes "
            f"(4/3 pi abc = {implied:g} m^3, more than {SEALED_VOLUME_TOLERANCE:.0%} apart); "
            "the buoyancy comes from the semi-axes: change both together (a sweep's "
            "net_weight_kg does)"
        )


def load_coefficients(
    path=DEFAULT_COEFFICIENTS_FILE, field: str | None = None
) -> HydroCoefficients:
    """Loads and checks ``hydrodynamics.yaml`` (unknown and duplicate keys, sizes, signs,
    sources); errors are one line naming the file (and ``field``, the scenario field that
    named it)."""
    path = pathlib.Path(path)
    where = f"{field} = {path}" if field else str(path)
    try:
        text = read_text_file(path, what="coefficients")
        data = parse_yaml(text)
        if not isinstance(data, dict):
            raise ScenarioError(
                "must be a mapping of coefficient sections (water_density, "
                f"gravity, body, links, fins, balloon), got {type(data).__name__}"
            )
        check_keys(data, HydroCoefficients, path.name)
        coeffs = yaml_load_typed(schema=HydroCoefficients, data=text)
        check_coefficients(coeffs, path.name)
    except ScenarioError as e:
        message = str(e)
        prefix = f"{path}: "
        if message.startswith(prefix):
            message = message[len(prefix) :]
        raise ScenarioError(f"{where}: {message}") from None
    return coeffs
