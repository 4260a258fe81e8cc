"""The robot's bill of materials: each part's mass and displaced volume, summing to Table 1.

``models/bill_of_materials.yaml`` names the parts (the 16 servos, the fin plates, the hull's
shell and what the hull holds) with their sources; :func:`load_bill_of_materials` reads and
checks it and :func:`parts` turns it, with the robot's geometry, into the list of
:class:`Part` the model is built from:

* **Servos**: one per joint, each case on the link its joint hangs from, at the joint's
  axis: a leg's yaw servo on the hull at the leg's mount, its roll1 servo on link 1, its
  pitch servo on link 2, its roll2 servo on link 3 at the roll2 axis (Table 2's chain; the
  paper does not say where the cases are). Each displaces its case's envelope.
* **Fin plates**: links 3 and 4, a NACA0012 section of thickness t over chord c and span s:
  volume A s with A = 0.68508 t c (:func:`naca_section_area`), mass density x volume.
* **Hull shell**: density x thickness x the fairing ellipsoid's surface
  (:func:`ellipsoid_surface_area`, exact); inside the hull's sealed volume, like every
  ``hull_parts`` entry, so it displaces no water of its own.
* **Residual**: Table 1's total less every part above, on the hull (ballast, fasteners,
  brackets, cabling, seals: what the list does not account for), centred at
  ``residual_position`` (the ballast's trim). A list heavier than the total is refused.

:func:`carried_masses` sums the parts per carrier: the hull body's mass and each leg link's
(``RobotParams.body_mass``, ``link_masses``).
"""

import dataclasses as dc
import functools
import math
import pathlib

import numpy as np
from pydrake.common.yaml import yaml_load_typed
from scipy.special import ellipeinc, ellipkinc

from manta_drake.config_io import ScenarioError, check_keys, load_yaml_mapping
from manta_drake.model import MODELS_DIR
from manta_drake.model.sourced import Number, Numbers, sourced_entries

DEFAULT_BILL_OF_MATERIALS_FILE = MODELS_DIR / "bill_of_materials.yaml"

# The area of a NACA 4-digit symmetric section over thickness x chord: twice the integral of
# its half-thickness y_t / t = 5 (0.2969 sqrt(x) - 0.1260 x - 0.3516 x^2 + 0.2843 x^3
# - 0.1015 x^4) over the chord x in [0, 1] (Abbott and von Doenhoff 1959, eq. 6.2):
# 10 (0.2969 2/3 - 0.1260/2 - 0.3516/3 + 0.2843/4 - 0.1015/5).
NACA4_SECTION_AREA = 10 * (0.2969 * 2 / 3 - 0.1260 / 2 - 0.3516 / 3 + 0.2843 / 4 - 0.1015 / 5)

NUM_LEGS = 4
# The carrier of each joint's servo (the link its joint hangs from), in joint order.
SERVO_CARRIERS = (("yaw", "hull"), ("roll1", "link1"), ("pitch", "link2"), ("roll2", "link3"))
CARRIERS = ("hull", "link1", "link2", "link3", "link4")


@dc.dataclass
class ServoEntry:
    count: Number = dc.field(default_factory=Number)
    mass: Number = dc.field(default_factory=Number)  # kg each
    size: Numbers = dc.field(default_factory=Numbers)  # m, the case's envelope


@dc.dataclass
class PlateEntry:
    density: Number = dc.field(default_factory=Number)  # kg/m^3


@dc.dataclass
class ShellEntry:
    density: Number = dc.field(default_factory=Number)  # kg/m^3
    thickness: Number = dc.field(default_factory=Number)  # m


@dc.dataclass
class HullPart:
    """A part inside the hull's sealed volume."""

    count: int = 0
    mass: float = 0.0  # kg each
    source: str = ""


@dc.dataclass
class BillOfMaterials:
    total_mass: Number = dc.field(default_factory=Number)  # kg, Table 1
    servo: ServoEntry = dc.field(default_factory=ServoEntry)
    fin_plates: PlateEntry = dc.field(default_factory=PlateEntry)
    hull_shell: ShellEntry = dc.field(default_factory=ShellEntry)
    residual_position: Numbers = dc.field(default_factory=Numbers)  # m, body frame
    hull_parts: dict[str, HullPart] = dc.field(default_factory=dict)


@dc.dataclass(frozen=True)
class Geometry:
    """The robot's dimensions the parts' masses and volumes follow [m]."""

    body_semi_axes: tuple
    fin_thickness: float
    proximal_chord: float
    proximal_span: float
    distal_chord: float
    distal_span: float


@dc.dataclass(frozen=True)
class Part:
    """One line of the bill: ``count`` parts of ``mass`` [kg] each, each displacing
    ``volume`` [m^3] of water outside the sealed hull (0 inside it), on ``carrier``
    (``hull``, or a leg's ``link1`` .. ``link4``, one per leg), centred at ``position``
    [m] (the hull's parts in the body frame; None: spread over the carrier's solid)."""

    name: str
    count: int
    mass: float
    volume: float
    carrier: str
    source: str
    position: tuple | None = None

    @property
    def total_mass(self) -> float:
        return self.count * self.mass


# --- the closed forms ------------------------------------------------------------------------


def naca_section_area(thickness: float, chord: float) -> float:
    """The area [m^2] of a NACA 4-digit symmetric section of ``thickness`` and ``chord``."""
    return NACA4_SECTION_AREA * thickness * chord


def ellipsoid_surface_area(a: float, b: float, c: float) -> float:
    """The surface [m^2] of an ellipsoid with semi-axes a, b, c (any order), exact:
    S = 2 pi c^2 + 2 pi a b (E(phi, m) sin^2 phi + F(phi, m) cos^2 phi) / sin phi with
    a >= b >= c, cos phi = c / a, m = a^2 (b^2 - c^2) / (b^2 (a^2 - c^2)) (Legendre's form;
    DLMF 19.33.2)."""
    a, b, c = sorted((float(a), float(b), float(c)), reverse=True)
    if a == c:  # a sphere
        return 4.0 * math.pi * a * a
    phi = math.acos(c / a)
    m = a * a * (b * b - c * c) / (b * b * (a * a - c * c))
    s = math.sin(phi)
    return 2 * math.pi * c * c + 2 * math.pi * a * b / s * (
        ellipeinc(phi, m) * s * s + ellipkinc(phi, m) * math.cos(phi) ** 2
    )


# --- loading and checks ----------------------------------------------------------------------


def check_bill_of_materials(bom: BillOfMaterials, where: str) -> None:
    """Raises ScenarioError naming the first entry with no source or a value out of range."""
    position = bom.residual_position
    if not position.source.strip():
        raise ScenarioError(f"{where}: residual_position has no source")
    if (
        len(position.value) != 3
        or not np.all(np.isfinite(position.value))
        or np.max(np.abs(position.value)) > 0.05
    ):
        raise ScenarioError(
            f"{where}: residual_position = {position.value!r} needs 3 finite "
            "coordinates within 0.05 m of the body origin"
        )
    for name, entry in sourced_entries(bom):
        if name == "residual_position":  # signed, checked above
            continue
        if not entry.source.strip():
            raise ScenarioError(f"{where}: {name} has no source")
        values = np.atleast_1d(np.asarray(entry.value, dtype=float))
        if values.size == 0 or not np.all(np.isfinite(values)) or np.any(values <= 0):
            raise ScenarioError(f"{where}: {name} = {entry.value!r} must be finite and > 0")
    joints = NUM_LEGS * len(SERVO_CARRIERS)
    if bom.servo.count.value != joints:
        raise ScenarioError(
            f"{where}: servo.count = {bom.servo.count.value!r} must be {joints} (one servo a joint)"
        )
    if len(bom.servo.size.value) != 3:
        raise ScenarioError(f"{where}: servo.size = {bom.servo.size.value!r} needs 3 lengths")
    for name, part in bom.hull_parts.items():
        if not part.source.strip():
            raise ScenarioError(f"{where}: hull_parts.{name} has no source")
        if part.count < 1:
            raise ScenarioError(f"{where}: hull_parts.{name}.count = {part.count} must be >= 1")
        if not (math.isfinite(part.mass) and part.mass > 0):
            raise ScenarioError(
                f"{where}: hull_parts.{name}.mass = {part.mass!r} must be finite and > 0"
            )
        if name == "residual":
            raise ScenarioError(
                f"{where}: hull_parts.residual is the name of the computed "
                "remainder; call the part something else"
            )


def load_bill_of_materials(path=DEFAULT_BILL_OF_MATERIALS_FILE) -> BillOfMaterials:
    """Loads and checks a bill of materials; errors are one line naming the file and the
    entry."""
    path = pathlib.Path(path)
    try:
        data, text = load_yaml_mapping(path, "bill of materials")
        check_keys(data, BillOfMaterials, path.name)
        bom = yaml_load_typed(schema=BillOfMaterials, data=text)
        check_bill_of_materials(bom, str(path))
    except (RuntimeError, TypeError) as e:  # yaml_load_typed's own errors
        raise ScenarioError(f"{path}: {' '.join(str(e).split())}") from None
    except ValueError as e:
        message = str(e)
        raise ScenarioError(
            message if message.startswith(str(path)) else f"{path}: {message}"
        ) from None
    return bom


@functools.lru_cache(maxsize=4)
def _cached(path: str, mtime_ns: int) -> BillOfMaterials:
    return load_bill_of_materials(path)


def shipped_bill_of_materials() -> BillOfMaterials:
    """The shipped file, parsed once per version (RobotParams reads it for its defaults)."""
    path = DEFAULT_BILL_OF_MATERIALS_FILE
    return _cached(str(path), path.stat().st_mtime_ns)


# --- the parts and what each carrier carries -------------------------------------------------


def parts(bom: BillOfMaterials, geometry: Geometry) -> list[Part]:
    """Every line of the bill, the residual last (see the module docstring)."""
    g, servo = geometry, bom.servo
    case = float(np.prod(servo.size.value))
    rows = [
        Part(f"{joint} servo", NUM_LEGS, servo.mass.value, case, carrier, servo.mass.source)
        for joint, carrier in SERVO_CARRIERS
    ]
    rho = bom.fin_plates.density.value
    for name, carrier, chord, span in (
        ("proximal fin plate", "link3", g.proximal_chord, g.proximal_span),
        ("distal fin plate", "link4", g.distal_chord, g.distal_span),
    ):
        volume = naca_section_area(g.fin_thickness, chord) * span
        rows.append(
            Part(name, NUM_LEGS, rho * volume, volume, carrier, bom.fin_plates.density.source)
        )
    shell = bom.hull_shell
    area = ellipsoid_surface_area(*g.body_semi_axes)
    rows.append(
        Part(
            "hull shell",
            1,
            shell.density.value * shell.thickness.value * area,
            0.0,
            "hull",
            shell.thickness.source,
        )
    )
    rows += [
        Part(name.replace("_", " "), p.count, p.mass, 0.0, "hull", p.source)
        for name, p in bom.hull_parts.items()
    ]
    listed = sum(r.total_mass for r in rows)
    residual = bom.total_mass.value - listed
    if residual < 0:
        raise ScenarioError(
            f"bill of materials: the parts weigh {listed:.3f} kg, more than "
            f"total_mass = {bom.total_mass.value} kg"
        )
    rows.append(
        Part(
            "residual",
            1,
            residual,
            0.0,
            "hull",
            "total_mass less every part above: ballast, fasteners, brackets, "
            "cabling and seals, which the list does not account for",
            tuple(bom.residual_position.value),
        )
    )
    return rows


def carried_masses(rows: list[Part]) -> tuple[float, tuple[float, ...]]:
    """(the hull body's mass, each leg's link 1-4 masses) [kg] of the parts ``rows``."""
    mass = {c: sum(r.total_mass for r in rows if r.carrier == c) for c in CARRIERS}
    return mass["hull"], tuple(mass[f"link{i}"] / NUM_LEGS for i in range(1, 5))
