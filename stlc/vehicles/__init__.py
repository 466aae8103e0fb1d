"""Vehicle models behind one protocol, registered once.

Every pass that needs to know what a vehicle *is* — its state layout, dynamics, bounds,
start state, derived signals, energy, the fields a formula may read, the kinematic limits
of an initial guess — asks the registry: ``model_of(vehicle)`` returns the ``VehicleModel``
registered for the vehicle's class.  Adding a vehicle model is one module here plus one
``register`` call (see docs/extending.md, "Adding a vehicle model"); no other module tests the
class of a vehicle.
"""

from __future__ import annotations

from typing import Protocol

from stlc.lazy import lazy

ca = lazy("casadi")  # CasADi runs only when a plan is built (``stlc.lazy``)
import numpy as np

from stlc.vehicles import declared as model
from stlc.vehicles.declared import FormulaField
from stlc.vehicles.dynamics import Bounds


class VehicleModel(Protocol):
    """What a pass may ask of a vehicle model.  Beyond the state layout, dynamics and
    derived signals: ``formula_fields`` (the fields a formula may read beyond pos, vel,
    speed, horizontal_speed, course), ``envelope`` (the planner's flight envelope added to
    ``bounds``), ``fit_guess_inputs`` (a kinematic guess's inputs made to fit the
    planner's input bounds), ``has_rotor_energy`` (an energy model exists),
    ``carries_payload`` (a team drone with a recomputed payload), ``axis_limits``
    (per-axis limits drawn by the report, e.g. {"vel": v_max, "acc": a_max}),
    ``guess`` (a state/input guess along a kinematic path; ``needed(channel)``, when given,
    is the boolean mask of samples at which the requirement reads that channel,
    ``stlc.semantics.reads``), ``energy_profile`` (J per sample; a point mass reads its
    accelerations from ``U`` when given), ``rotor_forces`` ((force_min, force_max, c_f) of
    rotors, or None) and ``linear_model`` (``(A, B)`` of linear dynamics: continuous time
    ẋ = A x + B u without ``dt``, the exact zero-order-hold discretisation x+ = A x + B u
    with ``dt``; ``None`` for a nonlinear model)."""

    kind: str  # the name written after `vehicle NAME :` in a file

    def state_size(self, v) -> tuple[int, int]: ...
    def state_channels(self, v) -> list[str]: ...
    def input_channels(self, v) -> list[str]: ...
    def derived_names(self, v) -> list[str]: ...
    def all_channels(self, v) -> list[str]: ...
    def pos_index(self) -> slice: ...
    def vel_index(self) -> slice: ...
    def ode(self, v) -> ca.Function: ...
    def bounds(self, v): ...
    def initial_state(self, v) -> np.ndarray: ...
    def derived_channels(self, v, X: np.ndarray) -> dict[str, np.ndarray]: ...
    def derived_channels_sx(self, v, x: ca.SX, eps: float = 0.0) -> dict[str, ca.SX]: ...
    def energy_terms(self, v, x: ca.SX, dt: float) -> ca.SX | None: ...
    def energy_profile(self, v, X: np.ndarray, dt: float, U: np.ndarray | None = None
                       ) -> np.ndarray: ...
    def kinematic_limits(self, v) -> tuple[np.ndarray, np.ndarray]: ...
    def guess(self, v, P: np.ndarray, V: np.ndarray, A: np.ndarray, dt: float,
              needed=None) -> tuple[np.ndarray, np.ndarray]: ...
    def plot_bounds(self, v) -> dict[str, list[float]]: ...
    # asked instead of comparing the kind:
    def formula_fields(self, v) -> dict[str, FormulaField]: ...
    def envelope(self, v, b: Bounds) -> Bounds: ...
    def fit_guess_inputs(self, v, U: np.ndarray, lo: np.ndarray, hi: np.ndarray
                         ) -> np.ndarray: ...
    def has_rotor_energy(self, v) -> bool: ...
    def carries_payload(self, v) -> bool: ...
    def axis_limits(self, v) -> dict[str, tuple[float, ...]]: ...
    def rotor_forces(self, v) -> tuple[float, float, float] | None: ...
    def linear_model(self, v, dt: float | None = None
                     ) -> tuple[np.ndarray, np.ndarray] | None: ...
    def knot_step(self, v) -> float: ...  # the coarsest knots a long plan may use (s)


_REGISTRY: dict[type, VehicleModel] = {}


def register(cls: type, vm: VehicleModel) -> None:
    _REGISTRY[cls] = vm


def model_of(v: model.Vehicle) -> VehicleModel:
    try:
        return _REGISTRY[type(v)]
    except KeyError:
        raise TypeError(f"no vehicle model registered for {type(v).__name__}") from None


def takes(method, name: str) -> bool:
    """Does a model's method accept the optional parameter ``name``?  (A model written
    before ``guess(…, needed)`` or ``energy_profile(…, U)`` existed does not.)"""
    import inspect

    try:
        return name in inspect.signature(method).parameters
    except (TypeError, ValueError):
        return False


def kinds() -> list[str]:
    return sorted(vm.kind for vm in _REGISTRY.values())


def state_matrix(v: model.Vehicle, channels: dict[str, np.ndarray]) -> np.ndarray:
    """States of ``v`` as an (n, nx) matrix from its named channels."""
    return np.stack([np.asarray(channels[c], dtype=float)
                     for c in model_of(v).state_channels(v)], axis=1)


from stlc.vehicles import multirotor as _mr  # noqa: E402
from stlc.vehicles import point_mass as _pm  # noqa: E402

register(model.Multirotor, _mr.MultirotorModel())
register(model.PointMass, _pm.PointMassModel())
