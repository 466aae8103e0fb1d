"""The checked program: vehicles, scenario and missions in SI units, formulas as IR.

This is what ``check`` produces from the AST and what every backend, the risk analysis and
the report consume.  Nothing here refers to the surface syntax except spans (for pointing
back into the source) and the source text itself (for the report).

Conventions
-----------
* lengths m, times s, angles rad, masses kg, forces N, frequencies Hz.
* Euler angles ``att = (roll, pitch, yaw)``, rotation R = Rz(yaw) Ry(pitch) Rx(roll)
  (body → world).
* A region attached to a human is a box in that human's frame: a world point p is inside
  when ``R(att_h)^T (p - pos_h)`` lies in the box.  In formulas the human pose enters as
  ``Param`` leaves named ``"<human>.pos.x"`` … ``"<human>.att.z"``; ``Program.params`` holds
  their nominal values.
* Signal channels of a vehicle ``v`` (names used by traces, the monitor and the backends):
  ``v.pos.{x,y,z}``, ``v.vel.{x,y,z}``, ``v.att.{x,y,z}``, ``v.rate.{x,y,z}``,
  ``v.force.{1..n}`` (multirotor rotor forces ξ), ``v.dforce.{1..n}`` (inputs ξ̇),
  ``v.acc.{x,y,z}`` (point-mass input), ``v.payload`` (point-mass diverters on board).
"""

from __future__ import annotations

from dataclasses import dataclass, field

from stlc.diagnostics import Span
from stlc.semantics.ir import Formula
from stlc.semantics.shapes import Round
from stlc.semantics.teamform import TeamForm
from stlc.vehicles.declared import AXES, Multirotor, PointMass, Rotor, Vehicle

__all__ = ["AXES", "Multirotor", "PointMass", "Rotor", "Vehicle"]  # re-exported: declared in stlc.vehicles

Vec3 = tuple[float, float, float]
NO_SPAN = Span.none()

@dataclass(frozen=True, slots=True)
class Box:
    """Axis-aligned box ``lo <= p <= hi``; ``frame`` names a human when the box is in that
    human's frame (else world frame).  ``placed`` names a world box whose centre is a
    parameter of the formulas (``Param`` leaves ``<placed>.center.{x,y,z}``, set with
    ``--set``; ``lo``/``hi`` are its current corners).  ``shape``: a round region (cylinder,
    sphere, capsule; ``stlc.semantics.shapes``) whose bounding box ``lo``/``hi`` are."""

    lo: Vec3
    hi: Vec3
    frame: str | None = None
    placed: str | None = None
    shape: Round | None = None


@dataclass(frozen=True, slots=True)
class Region:
    name: str
    kind: str  # workspace | obstacle | region | target | station | home
    box: Box
    span: Span = field(default=NO_SPAN, compare=False)


@dataclass(frozen=True, slots=True)
class Normal:
    """A Gaussian over the named parameters (e.g. operator.pos.x, .y, .z)."""

    params: tuple[str, ...]
    mean: tuple[float, ...]
    cov: tuple[tuple[float, ...], ...]
    span: Span = field(default=NO_SPAN, compare=False)


@dataclass(frozen=True, slots=True)
class Human:
    name: str
    pos: Vec3
    att: Vec3
    uncertain: tuple[Normal, ...] = ()
    span: Span = field(default=NO_SPAN, compare=False)


@dataclass(frozen=True, slots=True)
class Scenario:
    regions: tuple[Region, ...] = ()
    humans: tuple[Human, ...] = ()

    def by_kind(self, kind: str) -> tuple[Region, ...]:
        return tuple(r for r in self.regions if r.kind == kind)

    def region(self, name: str) -> Region | None:
        return next((r for r in self.regions if r.name == name), None)


@dataclass(frozen=True, slots=True)
class Smoothing:
    method: str = "gkl"  # gkl (Gilpin–Kurtz–Lin) | lse (log-sum-exp)
    lam: float = 10.0


@dataclass(frozen=True, slots=True)
class Objective:
    """minimise  energy_weight·E + forward_weight·Σ(1 − v_for/v*)² − robustness_weight·ρ̃"""

    robustness_weight: float = 1.0
    energy_weight: float = 0.0
    forward_weight: float = 0.0
    forward_speed: float | None = None  # v*


@dataclass(frozen=True, slots=True)
class RiskCase:
    name: str
    distributions: tuple[Normal, ...]  # override / add uncertain parameters for this case
    span: Span = field(default=NO_SPAN, compare=False)


@dataclass(frozen=True, slots=True)
class RiskLevel:
    """``require cvar(0.9) >= 0.02 m`` in a ``risk`` block: a level the distribution of the
    robustness must meet.  ``measure``: ``var`` | ``cvar`` (at ``beta``, in robustness
    terms: the level kept with probability β / the mean of the worst 1 − β) or
    ``p_violation`` (P(ρ ≤ 0), judged by its Clopper–Pearson upper bound); ``op``:
    ``>=`` ``>`` ``<=`` ``<``."""

    measure: str
    beta: float | None
    op: str
    bound: float
    text: str = ""  # as written, for messages
    span: Span = field(default=NO_SPAN, compare=False)


@dataclass(frozen=True, slots=True)
class RiskConfig:
    cases: tuple[RiskCase, ...]
    K: int = 15000
    betas: tuple[float, ...] = (0.7, 0.8, 0.9)
    delta: float = 0.01
    seed: int = 0
    levels: tuple[RiskLevel, ...] = ()


@dataclass(frozen=True, slots=True)
class ReplanConfig:
    threshold: float = 1.0  # ζ, m
    event_period: float = 0.5  # T_e, s
    waypoint_period: float = 1.0  # T_g, s
    compute_budget: float = 0.4  # t_c, s
    specs: tuple[str, ...] = ()  # named specs kept when replanning
    takeover_delay: float = 10.0  # T_rep, s: a backup drone starts at t_fail + T_rep
    #: the fields the mission wrote (the others are defaults; T_g's comes from the
    #: vehicle's limits, ``stlc.replan.explain.default_waypoint_period``)
    given: frozenset[str] = field(default=frozenset(), compare=False)


@dataclass(frozen=True, slots=True)
class Disturbance:
    """A push on a vehicle at ``time``: its position jumps by ``displacement`` (m) and its
    velocity by ``velocity`` (m/s) (``stlc simulate``)."""

    vehicle: str
    time: float
    displacement: tuple[float, float, float] = (0.0, 0.0, 0.0)
    velocity: tuple[float, float, float] = (0.0, 0.0, 0.0)
    span: Span = field(default=NO_SPAN, compare=False)


@dataclass(frozen=True, slots=True)
class Failure:
    """``vehicle`` fails at ``time``; the declared ``backup`` takes over its pending
    targets from ``time + T_rep`` (paper B §IV-C)."""

    vehicle: str
    time: float
    backup: str
    span: Span = field(default=NO_SPAN, compare=False)


@dataclass(frozen=True, slots=True)
class HumanMove:
    """``move operator { time = 8 s; pos = (...) m; att = (...) deg }``: the human's pose
    becomes ``pos`` (m) / ``att`` (rad) at ``time`` (paper A §6); None keeps that part."""

    human: str
    time: float
    pos: tuple[float, float, float] | None = None
    att: tuple[float, float, float] | None = None
    span: Span = field(default=NO_SPAN, compare=False)


@dataclass(frozen=True, slots=True)
class FlightWind:
    """``wind { velocity = (3, 0, 0) m/s; turbulence = light }``: the air ``stlc fly``
    flies through — a steady wind (m/s, ENU) and a Dryden turbulence level."""

    velocity: tuple[float, float, float] = (0.0, 0.0, 0.0)
    turbulence: str = "none"
    span: Span = field(default=NO_SPAN, compare=False)


@dataclass(frozen=True, slots=True)
class SensorNoise:
    """``noise { pos = 0.02 m; vel = 0.05 m/s }``: standard deviations of the position and
    velocity errors the tracking controller of ``stlc fly`` sees."""

    pos: float = 0.0
    vel: float = 0.0
    span: Span = field(default=NO_SPAN, compare=False)


@dataclass(frozen=True, slots=True)
class SimulateConfig:
    """A mission's ``simulate { ... }`` block: the events of ``stlc simulate`` (and
    ``stlc fly``'s pushes), and the wind and sensor noise of ``stlc fly``."""

    disturbances: tuple[Disturbance, ...] = ()
    failures: tuple[Failure, ...] = ()
    moves: tuple[HumanMove, ...] = ()
    wind: FlightWind | None = None
    noise: SensorNoise | None = None


@dataclass(frozen=True, slots=True)
class Mission:
    name: str
    vehicles: tuple[str, ...]
    horizon: float
    step: float
    specs: dict[str, Formula]  # named specs, each self-contained (references inlined)
    requirement: Formula
    objective: Objective = Objective()
    threshold: float = 0.0  # κ: required smooth robustness
    smoothing: Smoothing = Smoothing()
    risk: RiskConfig | None = None
    replan: ReplanConfig | None = None
    simulate: SimulateConfig | None = None
    options: dict[str, float | str] = field(default_factory=dict)
    span: Span = field(default=NO_SPAN, compare=False)
    spec_spans: dict[str, Span] = field(default_factory=dict, compare=False)
    #: paper B's payload rule: dwell to install one item / to refill (s), if given
    install_time: float | None = None
    refill_time: float | None = None
    #: the quantifiers over ``vehicles`` kept, to re-instantiate the requirement and named
    #: specs for another team (``stlc.semantics.teamform.for_team``); None: there are none
    team_form: TeamForm | None = field(default=None, compare=False, repr=False)


@dataclass(frozen=True, slots=True)
class Program:
    file: str
    source: str
    signals: tuple[str, ...] = ()  # declared `signal` names (monitoring files)
    specs: dict[str, Formula] = field(default_factory=dict)  # top-level specs
    spec_spans: dict[str, Span] = field(default_factory=dict, compare=False)
    vehicles: dict[str, Vehicle] = field(default_factory=dict)
    scenario: Scenario = Scenario()
    missions: dict[str, Mission] = field(default_factory=dict)
    params: dict[str, float] = field(default_factory=dict)  # nominal value of every Param
