"""The declared data of each vehicle model (SI units): what the checker reads from a
``vehicle NAME : kind { ... }`` block.  ``stlc.semantics.model`` re-exports these types so
a checked ``Program`` holds them; the behaviour of each model is in its own module of this
package (``multirotor``, ``point_mass``) behind the ``VehicleModel`` protocol.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from stlc.diagnostics import Span

Vec3 = tuple[float, float, float]
NO_SPAN = Span.none()

AXES = ("x", "y", "z")


@dataclass(frozen=True, slots=True)
class Rotor:
    position: Vec3  # in the body frame, m
    axis: Vec3  # unit thrust direction in the body frame
    spin: int  # +1 counter-clockwise seen from above (reaction torque -z), -1 clockwise


@dataclass(frozen=True, slots=True)
class Multirotor:
    name: str
    mass: float
    inertia: tuple[Vec3, Vec3, Vec3]
    c_f: float  # rotor force = c_f * Omega, Omega = (rotor speed in Hz)^2
    c_tau: float  # drag torque = c_tau * Omega
    force_min: float
    force_max: float
    rotors: tuple[Rotor, ...]
    start_pos: Vec3
    start_att: Vec3 = (0.0, 0.0, 0.0)
    start_vel: Vec3 = (0.0, 0.0, 0.0)
    start_rate: Vec3 = (0.0, 0.0, 0.0)
    dforce_max: float | None = None  # bound on |ξ̇| (N/s), optional
    gravity: float = 9.81
    span: Span = field(default=NO_SPAN, compare=False)
    #: the body's radius (m): `pos not in R` keeps this clearance (R inflated by it)
    radius: float = 0.0
    #: the top speed per axis (m/s), optional: a bound of every plan and the guess's speed
    vel_max: Vec3 | None = None

    kind = "multirotor"

    def channels(self) -> list[str]:
        n = len(self.rotors)
        out = [f"{self.name}.{f}.{a}" for f in ("pos", "att", "vel", "rate") for a in AXES]
        out += [f"{self.name}.force.{i + 1}" for i in range(n)]
        return out

    def input_channels(self) -> list[str]:
        return [f"{self.name}.dforce.{i + 1}" for i in range(len(self.rotors))]


@dataclass(frozen=True, slots=True)
class PointMass:
    name: str
    vel_max: Vec3
    acc_max: Vec3
    start_pos: Vec3
    start_vel: Vec3 = (0.0, 0.0, 0.0)
    capacity: int | None = None
    mass: float | None = None
    #: paper B eq. 8 data for the energy-aware forward speed v*: (rotors, rotor disk area m²,
    #: equivalent flat-plate area m², induced-power factor, air density kg/m³), or None
    aero: tuple[int, float, float, float, float] | None = None
    span: Span = field(default=NO_SPAN, compare=False)
    radius: float = 0.0  # as Multirotor.radius

    kind = "point_mass"

    def channels(self) -> list[str]:
        return [f"{self.name}.{f}.{a}" for f in ("pos", "vel") for a in AXES]

    def input_channels(self) -> list[str]:
        return [f"{self.name}.acc.{a}" for a in AXES]


Vehicle = Multirotor | PointMass


@dataclass(frozen=True, slots=True)
class FormulaField:
    """A field of a vehicle that a formula may read beyond the common ``pos``, ``vel``,
    ``speed``, ``horizontal_speed`` and ``course`` (asked of the model, see
    ``VehicleModel.formula_fields``).

    Each component reads the channel ``channels[i]``, or ``sqrt(channel / sqrt_of_ratio)``
    when ``sqrt_of_ratio`` is set (a rotor speed from its force); ``labels`` are the names
    the component has in traces and messages; ``dim`` is the unit's exponents over
    (length, mass, time, angle), ``None`` for a count."""

    dim: tuple[int, int, int, int] | None
    channels: tuple[str, ...]
    labels: tuple[str, ...]
    vector: bool
    sqrt_of_ratio: float | None = None
