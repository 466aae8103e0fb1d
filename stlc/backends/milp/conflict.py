"""Infeasibility, proved and explained: no plan can satisfy the mission, and which named
specs conflict.

When the verdict on a plan is not ``satisfied``, ``explain_infeasible`` asks whether *any*
plan could be: it encodes the requirement (``milp.encode``) over a **relaxation** of the
vehicles and asks HiGHS for a plan whose robustness reaches κ.  The relaxation contains
every trajectory the real vehicles can fly on the mission grid, so "infeasible" there is a
proof:

* each vehicle becomes a double integrator in its position and velocity with *two*
  independent inputs per interval, ā for the position and a' for the velocity:
  p_{k+1} = p_k + Δt v_k + Δt²/2 ā_k,  v_{k+1} = v_k + Δt a'_k, both in the vehicle's sound
  acceleration box and v_k in its speed box (``VehicleModel.kinematic_envelope``).  Any
  flown trajectory with accelerations a(t) in the box has ā = (2/Δt²)∬a and a' = (1/Δt)∫a,
  weighted means of a(t) and so in the (convex) box; RK4's and Euler's sample-to-sample maps
  are such means of their stage accelerations too, so the real discrete models are inside;
* an upper bound on a norm of positions and velocities (a speed limit ‖v‖ ≤ c) becomes the
  box around its ball, |v_i| ≤ c (``seed_inner.inner_norms`` with ``outer``): each margin
  c − |v_i| is at least c − ‖v‖;
* every other predicate that reads anything but positions and velocities (attitude, rotor
  speed, payload, an input, a distance) is replaced by ``true``.  The formula is in negation
  normal form, hence monotone in its predicates, so both can only raise the robustness.

Linear vehicles planned with their zero-order-hold model (the point mass; the NLP's RK4 is
exact on it) need no relaxation: the proof uses their own discrete dynamics and every
predicate affine in their states and inputs.

Only HiGHS's own ``Infeasible`` counts as a proof (a time limit proves nothing: the verdict
stays what it was).  The conflict is then a minimal set of the named specs the mission
requires (a deletion filter: drop a spec, keep it out if the rest is still infeasible), with
the mission's `require` line added only when the specs alone can all hold.  The solution gets
``status = infeasible``, ``conflict`` and an STL504 diagnostic at the mission.
"""

from __future__ import annotations

import sys
import time
from dataclasses import dataclass, replace

import numpy as np

from stlc import deadline, vehicles
from stlc.backends.milp.backend import build
from stlc.backends.milp.encode import NotLinear
from stlc.backends.milp.seed_inner import inner_norms, norm_bounded
from stlc.solvers.highs import Highs
from stlc.diagnostics import Diagnostic
from stlc.semantics import ir

TOL = 1e-6  #: a plan within this of κ counts as reaching it (never call a feasible one infeasible)
SOLVE_LIMIT_S = 15.0
TOTAL_LIMIT_S = 40.0
MAX_CELLS = 400_000  #: samples × vehicles × formula size beyond which no proof is attempted
REQUIRE = "require"


def exact_model(problem) -> bool:
    """Every vehicle is linear and planned with its zero-order-hold model (the NLP's RK4 is
    exact on it): the proof may use the vehicles' own discrete dynamics, not a relaxation."""
    from stlc.backends.milp.backend import linear_model

    return (problem.integrator == "rk4"
            and all(linear_model(v) is not None for v in problem.vehicles()))


def relaxed_vehicle(problem):
    """The relaxation of each vehicle (see the module docstring), or None if a vehicle's
    model offers no kinematic envelope."""
    dt = problem.grid.dt

    def lins(v):
        vm = vehicles.model_of(v)
        vmax, alo, ahi = vm.kinematic_envelope(v)
        sc = vm.state_channels(v)
        x0 = problem.start_states.get(v.name, vm.initial_state(v))
        pos, vel = sc[vm.pos_index()], sc[vm.vel_index()]
        x0 = np.concatenate([np.asarray(x0)[vm.pos_index()], np.asarray(x0)[vm.vel_index()]])
        eye = np.eye(3)
        ad = np.block([[eye, dt * eye], [np.zeros((3, 3)), eye]])
        bd = np.block([[dt * dt / 2 * eye, np.zeros((3, 3))], [np.zeros((3, 3)), dt * eye]])

        class B:
            x_lo = np.concatenate([np.full(3, -np.inf), -np.asarray(vmax, float)])
            x_hi = np.concatenate([np.full(3, np.inf), np.asarray(vmax, float)])
            u_lo = np.concatenate([alo, alo])
            u_hi = np.concatenate([ahi, ahi])

        inputs = [f"__relax.{v.name}.{w}.{a}" for w in ("pbar", "vbar") for a in "xyz"]
        return list(pos) + list(vel), inputs, ad, bd, B, x0

    for v in problem.vehicles():
        if getattr(vehicles.model_of(v), "kinematic_envelope", None) is None:
            return None
    return lins


def kept_channels(problem) -> set[str]:
    out = set(problem.fixed_channels)
    for v in problem.vehicles():
        vm = vehicles.model_of(v)
        sc = vm.state_channels(v)
        out |= set(sc[vm.pos_index()]) | set(sc[vm.vel_index()])
    return out


def drop_nonlinear(f: ir.Formula, params, memo: dict) -> ir.Formula:
    """``f`` with every predicate that is not affine (a distance, a norm) made to read a
    signal no relaxation keeps, so that ``restrict`` replaces it by ``true`` (sound: the
    formula is in NNF)."""
    from stlc.backends.milp.encode import affine

    hit = memo.get(id(f))
    if hit is not None:
        return hit[1]
    if isinstance(f, ir.Pred):
        try:
            affine(f.expr, params, f)
            out = f
        except (NotLinear, ValueError):
            out = ir.Pred(ir.Sig("__nonlinear"), f.label, f.span)
    else:
        out = ir.map_children(f, lambda g: drop_nonlinear(g, params, memo))
    memo[id(f)] = (f, out)
    return out


def _ignored(problem, keep: set) -> list[str]:
    """The labels of the requirement's predicates that the relaxation replaces by true."""
    from stlc.backends.milp.encode import affine

    out: list[str] = []
    for f in ir.nodes(problem.requirement):
        if not isinstance(f, ir.Pred) or f.label in out:
            continue
        try:
            affine(f.expr, problem.params, f)
            linear = True
        except (NotLinear, ValueError):
            linear = False
        if not linear and norm_bounded(f, problem.params):
            linear = True  # kept as the box around its ball
        if not linear or not ir.signals(f) <= keep:
            out.append(f.label)
    return out


def required_specs(problem) -> list[str]:
    """The named specs the requirement requires (a conjunct of it, or all of a spec's
    conjuncts are conjuncts of it)."""
    req = problem.requirement
    parts = set(req.args) if isinstance(req, ir.And) else {req}
    out = []
    for name, s in problem.specs.items():
        f = s.normal
        if f in parts or f == req or (isinstance(f, ir.And) and set(f.args) <= parts):
            out.append(name)
    return out


class _Checker:
    """One model with a switchable row ``ρ(element) ≥ κ − TOL`` per element (the model is
    built once; each check only changes row bounds)."""

    def __init__(self, problem, formulas: dict[str, ir.Formula], lins):
        low = build(problem, formulas, lins)
        self.kappa = problem.threshold - TOL
        self.rows: dict[str, int | None] = {}
        self.const: dict[str, float] = {}
        for name, t in low.terms.items():
            self.const[name] = t.const
            self.rows[name] = (None if t.is_const else
                               low.milp.row(dict(t.coefs), -np.inf, np.inf))
        self.h = Highs(low.milp, {})

    def infeasible(self, names, limit: float) -> bool | None:
        """True: proved infeasible; False: feasible; None: not decided in time."""
        if any(self.rows[n] is None and self.const[n] < self.kappa for n in names):
            return True
        for n, r in self.rows.items():
            if r is not None:
                lo = self.kappa - self.const[n] if n in names else -np.inf
                self.h.set_row_bounds(r, lo, np.inf)
        self.h.set_time_limit(max(limit, 0.05))
        res = self.h.solve()
        if res.highs_status == "Infeasible":
            return True
        return False if res.x is not None else None


@dataclass(frozen=True)
class Proof:
    """No plan reaches κ: ``conflict`` lists named specs (and ``require``) that cannot hold
    together; ``minimal`` is False when a check of the deletion filter ran out of time."""

    conflict: tuple[str, ...]
    minimal: bool
    wall_s: float
    exact: bool  # proved on the vehicles' own linear model, not on the relaxation


def prove_infeasible(problem, why: list | None = None) -> Proof | None:
    """A proof that no plan satisfies ``problem`` with a minimal conflict, or None (no
    proof: feasible, undecided in time, or not encodable).  Without the holdable end
    (``hold_end``): the planners prefer a plan that ends at rest, but the verdict does not
    ask for one (a plan that does not is satisfied, with a note), so the proof must not
    either — with it, stlpy's RandomMultitarget (optimum +0.274 free, +0.0961 at rest) was
    called impossible at κ = 0.1.  ``why`` receives, without a proof, the reason in words."""
    say = why.append if why is not None else (lambda _: None)
    problem = replace(problem, hold_end=False)
    exact = exact_model(problem)
    lins = None if exact else relaxed_vehicle(problem)
    if lins is None and not exact:
        say("the vehicles have no linear relaxation to check the mission on")
        return None
    keep = kept_channels(problem)
    if exact:
        from stlc.backends.milp.backend import planned_channels

        keep |= planned_channels(problem)
    restrict = lambda f: ir.restrict(  # noqa: E731
        drop_nonlinear(inner_norms(f, problem.params, outer=True), problem.params, {}),
        lambda s: s in keep)
    req = restrict(problem.requirement)
    size = sum(1 for _ in ir.nodes(problem.requirement))
    if problem.grid.n * len(problem.team) * size > MAX_CELLS:
        say(f"the mission is too large to check ({problem.grid.n} samples × "
            f"{len(problem.team)} vehicles × {size} formula nodes > {MAX_CELLS:,})")
        return None
    specs = required_specs(problem)
    formulas = {REQUIRE: req, **{n: restrict(problem.specs[n].normal) for n in specs}}
    t0 = time.perf_counter()
    try:
        ck = _Checker(problem, formulas, lins)
    except (NotLinear, ValueError):
        say("the requirement could not be written as a MILP")
        return None
    left = lambda: min(TOTAL_LIMIT_S - (time.perf_counter() - t0),  # noqa: E731
                       deadline.solve_remaining())
    verdict = ck.infeasible([REQUIRE], min(SOLVE_LIMIT_S, left()))
    if verdict is not True:
        ignored = _ignored(problem, keep)
        model = "the vehicles' linear model" if exact else "a relaxation of the vehicles"
        say((f"the check ran out of time ({time.perf_counter() - t0:.1f} s)" if verdict is None
             else f"it was checked on {model}, where a plan reaching κ exists")
            + ("" if not ignored else
               "; that check ignores " + ", ".join(f"`{x}`" for x in ignored[:3])
               + (f" and {len(ignored) - 3} more" if len(ignored) > 3 else "")
               + " (not linear in position and velocity), which may be what cannot hold"))
        return None
    # a minimal conflict among the required specs (the `require` line only if needed)
    elements = list(specs)
    if not elements or ck.infeasible(elements, min(SOLVE_LIMIT_S, left())) is not True:
        elements = [*specs, REQUIRE]
    minimal = True
    for e in list(elements):
        rest = [x for x in elements if x != e]
        if not rest:
            continue
        verdict = ck.infeasible(rest, min(SOLVE_LIMIT_S, max(left(), 0.05)))
        if verdict is True:
            elements = rest
        elif verdict is None:
            minimal = False
    return Proof(tuple(elements), minimal, time.perf_counter() - t0, exact)


def explain_infeasible(problem, sol, quiet: bool = True) -> bool:
    """Prove that no plan satisfies ``problem`` and name a minimal conflict; on a proof,
    mark ``sol`` infeasible (status, conflict, STL504) and return True; without one, record
    why (``solver["infeasibility"]``: ``proved`` false and ``why``)."""
    why: list[str] = []
    proof = prove_infeasible(problem, why)
    if proof is None:
        sol.solver["infeasibility"] = {"proved": False,
                                       "why": why[0] if why else "no proof was found"}
        return False
    mark(problem, sol, proof, quiet)
    return True


def mark(problem, sol, proof: Proof, quiet: bool = True) -> None:
    """``sol`` marked infeasible by ``proof`` (status, conflict, notes, STL504)."""
    _mark(problem, sol, list(proof.conflict), proof.minimal, proof.wall_s, quiet, proof.exact)


def _mark(problem, sol, conflict: list[str], minimal: bool, wall: float, quiet: bool,
          exact: bool = False) -> None:
    m = problem.mission
    named = [f"`{c}`" for c in conflict if c != REQUIRE]
    kappa = problem.threshold
    margin = f" with margin κ = {kappa:g}" if kappa > 0 else ""
    if len(named) >= 2:
        what = f"specs {', '.join(named[:-1])} and {named[-1]} conflict"
    elif len(named) == 1:
        what = f"spec {named[0]} cannot hold{margin}"
    else:
        what = f"its requirement cannot hold{margin}"
    if named and REQUIRE in conflict:
        what += " under its `require`"
    sol.status = "infeasible"
    sol.conflict = list(conflict)
    sol.solver["infeasibility"] = {
        "proved": True, "conflict": list(conflict), "minimal": minimal, "wall_s": wall,
        "relaxation": ("none: the vehicles' own linear discrete dynamics (exact)" if exact else
                       "double integrator per vehicle with independent position and velocity "
                       "accelerations in the vehicle's acceleration box, speed box; "
                       "predicates on other signals replaced by true")}
    sol.notes.insert(0, f"no plan exists: {what} (proved by a MILP over a relaxation that "
                     "contains every trajectory the vehicles can fly)")
    fix = ("relax or drop one of the conflicting specs" if len(named) >= 2 else
           f"relax {named[0]} or the mission's threshold, or check where the vehicles "
           "start" if named else "relax the requirement or the mission's threshold")
    sol.diagnostics.append(Diagnostic(
        "STL504", f"no plan can satisfy mission `{m.name}`: {what}", m.span,
        fix + ("" if minimal else " (the set may not be minimal: a check ran out of "
                                  "time)")))
    if not quiet:
        print(f"{m.name}: impossibility proved ({wall:.1f} s)", file=sys.stderr)
