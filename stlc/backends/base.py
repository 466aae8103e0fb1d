"""The backend interface and the backend chain (modelled on cvxpy's ``Solver``/``Reduction``).

A backend turns a ``PlanningProblem`` into a ``Solution`` in four steps:

* ``accepts(problem)`` — capability check *before any work*: a list of STL401 diagnostics,
  each at the span of the construct the backend cannot handle (empty = accepted);
* ``lower(problem) -> (lowered, inverse)`` — build the solver's problem and keep what is
  needed to map results back;
* ``solve(lowered, problem) -> raw`` — run the solver;
* ``invert(raw, inverse, problem) -> Solution`` — mission-level channel names only.

Solver objects never leave a backend: a chain ``[seed, refine]`` hands each backend's
``Solution`` to the next one as ``problem.seed`` (by channel name).  Every backend maps its
solver's own return codes to the shared ``SolverStatus`` through its ``STATUS_MAP``.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, ClassVar

from stlc.diagnostics import Diagnostic, StlcError
from stlc.semantics import ir
from stlc.solvers.status import SolverStatus

if TYPE_CHECKING:
    from stlc.planning.solution import Solution
    from stlc.planning.problem import PlanningProblem


@dataclass(frozen=True, slots=True)
class Capabilities:
    """What a backend can plan: vehicle model kinds, IR node types, expression functions,
    and whether it handles several vehicles, payload signals and human parameters."""

    vehicle_models: frozenset[str]
    nodes: frozenset[type]
    functions: frozenset[str]
    team: bool = True
    derived_signals: frozenset[str] = frozenset()  # e.g. {"payload"}: channels not planned
    #: plans only vehicles whose model offers a linear model ``(A, B)`` (any kind)
    linear_dynamics_only: bool = False
    #: has integer decision variables (discrete choices decided globally: a MILP)
    integer_variables: bool = False
    #: plans only problems whose requirement reads one of these signal fields (a team
    #: chain: ``payload``); empty = any problem
    needs_signals: frozenset[str] = frozenset()
    #: plans a part of the grid (``problem.window``) from given start states; a backend
    #: without it plans the whole horizon and refuses a windowed problem
    windows: bool = False

    def describe(self) -> str:
        return (f"vehicles {sorted(self.vehicle_models)}"
                f"{' (any with linear dynamics)' if self.linear_dynamics_only else ''}, "
                f"{len(self.nodes)} formula nodes, functions {sorted(self.functions)}"
                f"{', integer variables' if self.integer_variables else ''}")


#: every formula node of the IR after normalisation, and every expression function: what a
#: backend that lowers the whole smooth semantics supports
ALL_NODES = frozenset({ir.Pred, ir.TrueF, ir.FalseF, ir.And, ir.Or, ir.Always, ir.Eventually,
                       ir.Until, ir.Release, ir.Next})
ALL_FUNCTIONS = frozenset({"abs", "sqrt", "norm", "min", "max", "sin", "cos", "exp", "log",
                           "atan2", "angdiff", "sd_box", "sd_cylinder", "sd_capsule"})


class Backend:
    """Base class: subclasses set ``name``, ``capabilities``, ``STATUS_MAP`` and implement
    ``lower``/``solve``/``invert``; ``accepts`` checks the capabilities."""

    name: ClassVar[str] = "backend"
    capabilities: ClassVar[Capabilities]
    STATUS_MAP: ClassVar[dict[str, SolverStatus]] = {}

    def status(self, code: str) -> SolverStatus:
        return self.STATUS_MAP.get(code, SolverStatus.FAILED)

    def accepts(self, problem: PlanningProblem) -> list[Diagnostic]:
        return unsupported(self, problem)

    def lower(self, problem: PlanningProblem) -> tuple[Any, Any]:
        raise NotImplementedError

    def solve(self, lowered: Any, problem: PlanningProblem) -> Any:
        raise NotImplementedError

    #: does ``lower`` read ``problem.seed``?  If not, ``run_chain`` lowers this backend while
    #: the one before it solves (``start``)
    lower_needs_seed: ClassVar[bool] = True

    def start(self, lowered: Any, problem: PlanningProblem) -> Callable[[], Any]:
        """Begin ``solve``; the returned function waits for its result.  By default the solve
        runs now; a backend that can solve apart (``stlc.apart``) overrides this."""
        raw = self.solve(lowered, problem)
        return lambda: raw

    def invert(self, raw: Any, inverse: Any, problem: PlanningProblem) -> Solution:
        raise NotImplementedError


def unsupported(backend: Backend, problem: PlanningProblem) -> list[Diagnostic]:
    """STL401 for every construct of the problem outside ``backend.capabilities``, at the
    construct's own span (the vehicle declaration, the formula node or the predicate)."""
    from stlc import vehicles

    cap = backend.capabilities
    out: list[Diagnostic] = []
    who = f"the {backend.name} backend"
    for v in problem.vehicles():
        vm = vehicles.model_of(v)
        kind = vm.kind
        linear = getattr(vm, "linear_model", None)
        if cap.linear_dynamics_only and (linear is None or linear(v) is None):
            out.append(Diagnostic("STL401", f"{who} cannot plan a `{kind}` vehicle "
                                  f"(`{v.name}`): its dynamics are not linear", v.span,
                                  "vehicles with linear dynamics: point_mass"))
        elif not cap.linear_dynamics_only and kind not in cap.vehicle_models:
            out.append(Diagnostic("STL401", f"{who} cannot plan a `{kind}` vehicle "
                                  f"(`{v.name}`)", v.span,
                                  "supported models: " + ", ".join(sorted(cap.vehicle_models))))
    if problem.window is not None and not cap.windows:
        out.append(Diagnostic("STL401", f"{who} plans the whole horizon, not the window "
                              f"[{problem.window[0]:g}, {problem.window[1]:g}] s",
                              problem.mission.span))
    if not cap.team and len(problem.team) > 1:
        out.append(Diagnostic("STL401", f"{who} plans one vehicle, the mission has "
                              f"{len(problem.team)}", problem.mission.span))
    planned = {c for v in problem.vehicles() for c in vehicles.model_of(v).all_channels(v)}
    seen: set[tuple[str, int, int]] = set()
    for g in ir.nodes(problem.requirement):
        if type(g) not in cap.nodes:
            out.append(Diagnostic("STL401", f"{who} does not support "
                                  f"`{type(g).__name__.lower()}`", g.span))
            continue
        if not isinstance(g, ir.Pred):
            continue
        for e in ir.expr_nodes(g.expr):
            msg = None
            if isinstance(e, ir.Call) and e.fn not in cap.functions:
                msg = f"{who} does not support " + (
                    "distances to regions (`dist`, a round region)" if e.fn.startswith("sd_")
                    else f"the function `{e.fn}`")
            elif isinstance(e, ir.Sig) and e.name not in planned \
                    and e.name not in problem.fixed_channels:
                field = e.name.split(".")[1] if "." in e.name else e.name
                if field in cap.derived_signals:
                    continue
                msg = f"{who} has no channel for signal `{e.name}`"
            if msg is not None:
                key = (msg, g.span.line, g.span.col)
                if key not in seen:
                    seen.add(key)
                    out.append(Diagnostic("STL401", msg, g.span,
                                          "plan this mission with a backend that supports it, "
                                          "or rewrite the predicate"))
    return out


def run_chain(problem: PlanningProblem, chain: Sequence[Backend]) -> tuple[Solution, list]:
    """Run ``chain`` in order, each backend seeded with the previous ``Solution``.  Every
    backend's ``accepts`` runs before any work; a backend whose lowering needs no seed is
    lowered while the previous one solves.  A backend whose Solution is ``infeasible`` (a
    proof that no plan exists: a seed's MILP over a relaxation) ends the chain there.
    Returns the last Solution and all of them."""
    diags = [d for b in chain for d in b.accepts(problem)]
    if diags:
        raise StlcError(diags)
    sols: list[Solution] = []
    p = problem
    early: dict[int, tuple[Any, Any]] = {}
    for i, b in enumerate(chain):
        lowered, inverse = early.pop(i) if i in early else b.lower(p)
        wait = b.start(lowered, p)
        if i + 1 < len(chain) and not chain[i + 1].lower_needs_seed:
            try:
                early[i + 1] = chain[i + 1].lower(p)  # while ``b`` solves apart
            except BaseException:  # a lowering error or Ctrl-C: stop the solve apart too
                getattr(wait, "cancel", lambda: None)()
                raise
        from stlc.planning.effort import heartbeat

        with heartbeat(f"{b.name} running (no verified plan yet)" if i == 0 else
                       f"{b.name} running",  # a backend that runs apart (a seed)
                       getattr(b, "quiet", True) or not hasattr(wait, "cancel")):
            raw = wait()
        sol = b.invert(raw, inverse, p)
        sols.append(sol)
        if sol.status == "infeasible":
            break
        p = p.with_seed(sol)
    return sols[-1], sols
