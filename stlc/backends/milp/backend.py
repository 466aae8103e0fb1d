"""The exact backend for linear vehicles: the requirement's STL→MILP encoding
(``milp.encode``) over the vehicles' exact discrete dynamics (``milp.model``) on the
mission grid, solved to its global optimum by HiGHS.

``lower`` builds the model once: every vehicle offering a linear model ``(A, B)``
(``VehicleModel.linear_model``) gets state and input columns and its zero-order-hold
dynamics rows; the requirement (NNF) is encoded at sample 0 and its term bounds the
epigraph column ρ̂, which is maximised.  ``solve`` runs HiGHS with the user's time limit
(mission option ``time_limit``, else the backend's): ``Optimal`` means ρ̂ is the maximum
robustness over every plan on the grid; ``Time limit reached`` gives the incumbent with
HiGHS's dual bound — *not converged*, the gap is reported.  ``invert`` re-simulates the
states from the inputs through the same discrete model (the plan obeys the dynamics to
rounding) and returns mission-level channels; the exact monitor then judges the plan, and
its robustness equals ρ̂ to the MIP gap (1e-9) and the solver tolerances.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field, replace

import numpy as np

from stlc import vehicles
from stlc.backends.base import ALL_NODES, Backend, Capabilities, SolverStatus, unsupported
from stlc.backends.milp.encode import ONE_HOT_MAX, Encoder, NotLinear, Term, affine
from stlc.backends.milp.model import INF, LinearVehicle, Milp, linear_vehicle
from stlc.solvers.highs import STATUS_MAP as HIGHS_STATUS_MAP
from stlc.solvers.highs import Highs
from stlc.diagnostics import Diagnostic
from stlc.planning.solution import Solution, Verdict
from stlc import deadline
from stlc.backends.nlp.flyable import HOLD_TOL
from stlc.planning.problem import PlanningProblem
from stlc.semantics import ir

TIME_LIMIT_S = 60.0  #: default wall-time limit of one MILP solve (a mission may set its own); an
#: unconverged unforced solve then falls back to the `nlp` chain (``strategy._fallback``)

KAPPA_MARGIN = 1e-6  #: the feasibility phase asks ρ̂ ≥ κ + this
#: past this many binaries the default limit is LARGE_LIMIT_S: the 60 s patrol at 0.2 s (≈ 12k
#: binaries) found no incumbent in 120 s, while the `nlp` fallback planned it in 48 s
LARGE_BINARIES = 3000
LARGE_LIMIT_S = 20.0
#: LP rounds of the start's local search (the 60 s patrol at 0.2 s: ρ̂ 0.121 after one,
#: 0.129 after six, 0.15 s each)
ROUNDS = 3


def linear_model(v):
    """``(A, B)`` of a vehicle whose model offers one, else None."""
    fn = getattr(vehicles.model_of(v), "linear_model", None)
    return None if fn is None else fn(v)


@dataclass
class Lowered:
    milp: Milp
    vehicles: list[LinearVehicle]
    top: int  # the epigraph column ρ̂ (maximised)
    encoder: Encoder
    build_s: float
    terms: dict[str, Term] = field(default_factory=dict)
    box: dict = field(default_factory=dict)
    spans: dict[str, tuple[int, int]] = field(default_factory=dict)


def planned_channels(problem: PlanningProblem, relaxed: bool = False) -> set[str]:
    out: set[str] = set()
    for v in problem.vehicles():
        vm = vehicles.model_of(v)
        out |= set(vm.state_channels(v)) | set(vm.input_channels(v))
    return out


def invariant_box(problem: PlanningProblem) -> dict[str, tuple[float, float]]:
    """Channel → [lo, hi] that every plan with robustness ≥ 0 keeps at every sample: the
    bounds of a top-level conjunct ``always[0, T] (s ≥ c and …)`` over the whole grid.  A
    plan outside has a negative robustness, so restricting to the box loses no plan that
    could beat a non-negative optimum (``ExactMilp`` solves again without it otherwise)."""
    req = problem.requirement
    parts = req.args if isinstance(req, ir.And) else (req,)
    out: dict[str, tuple[float, float]] = {}
    for g in parts:
        if not (isinstance(g, ir.Always) and g.lo == 0
                and problem.grid.window(g.lo, g.hi)[1] >= problem.grid.n - 1):
            continue
        body = g.arg.args if isinstance(g.arg, ir.And) else (g.arg,)
        for p in body:
            if not isinstance(p, ir.Pred):
                continue
            try:
                coefs, c = affine(p.expr, problem.params, p)
            except NotLinear:
                continue
            if len(coefs) != 1:
                continue
            (sig, a), = coefs.items()
            lo, hi = out.get(sig, (-INF, INF))
            if a > 0:
                lo = max(lo, -c / a)
            elif a < 0:
                hi = min(hi, -c / a)
            out[sig] = (lo, hi)
    return out


def build(problem: PlanningProblem, formulas: dict[str, ir.Formula], lins=None,
          box: dict[str, tuple[float, float]] | None = None,
          top_of: str | None = None, one_hot: int = ONE_HOT_MAX) -> Lowered:
    """The MILP of ``problem``'s vehicles with each formula of ``formulas`` encoded at
    sample 0 (``terms``; ``spans``: the columns each one added), and the epigraph column
    ρ̂ of formula ``top_of`` (default: the only formula); ``lins`` maps a vehicle to its
    (states, inputs, A, B, bounds, x0) (default: the vehicle's own linear model)."""
    t0 = time.perf_counter()
    m = Milp()
    grid = problem.grid
    lvs: list[LinearVehicle] = []
    for v in problem.vehicles():
        vm = vehicles.model_of(v)
        discrete = lins is not None
        if discrete:
            states, inputs, a, b, bounds, x0 = lins(v)
        else:
            a, b = linear_model(v)
            states, inputs = vm.state_channels(v), vm.input_channels(v)
            bounds, x0 = vm.bounds(v), problem.start_states.get(v.name, vm.initial_state(v))
        if box:
            lo_, hi_ = np.array(bounds.x_lo, float), np.array(bounds.x_hi, float)
            for i, c in enumerate(states):
                if c in box and box[c][0] <= x0[i] <= box[c][1]:
                    lo_[i], hi_[i] = max(lo_[i], box[c][0]), min(hi_[i], box[c][1])
            bounds = replace(bounds, x_lo=lo_, x_hi=hi_)
        lvs.append(linear_vehicle(m, v.name, states, inputs, a, b, bounds, x0, grid.dt,
                                  grid.n, discrete))
    if lins is None and problem.hold_end:  # the NLP's holdable end, as rows
        for lv, v in zip(lvs, problem.vehicles()):
            ac, _ = linear_model(v)  # continuous: f(x, 0) = A x
            for row in np.atleast_2d(np.asarray(ac, float)):
                coefs = {int(c): float(a) for c, a in zip(lv.x[-1], row) if a != 0.0}
                if coefs:
                    m.row(coefs, -HOLD_TOL, HOLD_TOL)
    index = {}
    for lv in lvs:
        for c in lv.states + lv.inputs:
            index[c] = lv

    def channel(name: str, k: int):
        lv = index.get(name)
        return None if lv is None else lv.channel(name, k)

    def fixed(name: str):
        f = problem.fixed_channels.get(name)
        return None if f is None else np.asarray(f, dtype=float)

    enc = Encoder(m, grid, dict(problem.params), channel, fixed, one_hot)
    terms, spans = {}, {}
    for name, f in formulas.items():  # in order: later formulas reuse earlier terms (memo)
        c0 = m.n_cols
        terms[name] = enc.at(f, 0)
        spans[name] = (c0, m.n_cols)
    top = -1
    if top_of is None and len(formulas) == 1:
        top_of = next(iter(formulas))
    if top_of is not None:
        t = terms[top_of]
        if not t.is_const:
            top = m.var(t.lo, t.hi)
            enc._le(top, t)
    return Lowered(m, lvs, top, enc, time.perf_counter() - t0, terms, spans=spans)


def nonlinear_predicates(problem: PlanningProblem, formula: ir.Formula) -> list[Diagnostic]:
    """STL401 at every predicate that is not affine in the planned states and inputs."""
    planned = planned_channels(problem)
    out = []
    for p in ir.predicates(formula):
        try:
            coefs, _ = affine(p.expr, problem.params, p)
            missing = [s for s in coefs if s not in planned and s not in problem.fixed_channels]
            if missing:
                raise NotLinear(p, f"`{missing[0]}` is not a state or input of a linear "
                                "vehicle")
        except NotLinear as e:
            out.append(Diagnostic("STL401", f"the exact MILP backend needs predicates linear "
                                  f"in the state: {e}", p.span,
                                  "plan this mission with `--backend nlp`, or write the "
                                  "predicate with boxes, half-spaces and bounds"))
    return out


class ExactMilp(Backend):
    name = "exact MILP (HiGHS)"
    capabilities = Capabilities(vehicle_models=frozenset({"point_mass"}), nodes=ALL_NODES,
                                functions=frozenset(), linear_dynamics_only=True,
                                integer_variables=True)
    STATUS_MAP = HIGHS_STATUS_MAP
    lower_needs_seed = False  # built while a coarse start (``milp.start``) solves apart

    def __init__(self, quiet: bool = True, time_limit: float | None = None,
                 one_hot: int = ONE_HOT_MAX):
        self.quiet = quiet
        self.time_limit = time_limit
        #: disjunctions of at most this many operands get one binary each, wider ones the
        #: logarithmic encoding (the default: always one-hot, measured faster with HiGHS)
        self.one_hot = one_hot

    def accepts(self, problem: PlanningProblem) -> list[Diagnostic]:
        out = unsupported(self, problem)
        if any(d.message.startswith(f"the {self.name} backend cannot plan") for d in out):
            return out
        return out + nonlinear_predicates(problem, problem.requirement)

    def lower(self, problem: PlanningProblem):
        box = invariant_box(problem)
        low = build(problem, {"requirement": problem.requirement}, box=box,
                    one_hot=self.one_hot)
        low.box = box
        return low, low

    def _limit(self, problem: PlanningProblem, low: Lowered) -> float:
        t = problem.time_limit
        if t is None and self.time_limit is not None:
            t = self.time_limit
        if t is None:  # a large model gets less before the `nlp` fallback (MILP seed + NLP)
            t = TIME_LIMIT_S if low.milp.n_binaries <= LARGE_BINARIES else LARGE_LIMIT_S
        return float(min(float(t), max(deadline.solve_remaining(), 0.01)))

    def solve(self, low: Lowered, problem: PlanningProblem):
        """Two phases on one model: a plan with ρ̂ ≥ κ first (a feasibility MILP, usually
        far faster than the optimisation; ``Infeasible`` here proves no plan reaches κ),
        then ρ̂ maximised from it as a MIP start.  Inside the invariant box a negative
        optimum proves nothing, so then the whole problem is solved again.  The holdable
        end (``hold_end``, rows at the last sample) is a preference, not the verdict's:
        when no plan ending at rest reaches κ, the problem is solved again without it and
        the better plan kept (its end is then noted as not holdable)."""
        t0 = time.perf_counter()
        limit = self._limit(problem, low)
        self.phases = []
        res = self._solve(low, problem, limit)
        self.among = AT_REST if problem.hold_end else ALL_PLANS  # what an optimum is over
        if problem.hold_end and not self._reaches(res, low, problem):
            free_problem = replace(problem, hold_end=False)
            free = build(free_problem, {"requirement": problem.requirement},
                         box=low.box or None, one_hot=self.one_hot)
            free.box = low.box
            self.phases.append(("no plan at rest reaches κ: without the holdable end",
                                "started", 0.0))
            res2 = self._solve(free, free_problem, max(limit - (time.perf_counter() - t0), 1.0),
                               only_above_kappa=True)
            wall = res.wall_s + res2.wall_s
            if res2.x is not None and (res.x is None or -res2.objective > -res.objective):
                low.milp, low.vehicles, low.top = free.milp, free.vehicles, free.top
                res, self.among = res2, ALL_PLANS
            elif res2.highs_status not in ("Optimal", "Infeasible"):  # the retry was cut short
                self.among = (f"{AT_REST}; the re-solve without the rest end stopped "
                              f"({res2.highs_status}, {res2.wall_s:.1f} s): a better plan that "
                              "does not end at rest may exist")
            res.wall_s = wall
        from stlc.backends.milp.jerk import least_jerk

        return least_jerk(low, res, self.phases)  # the same ρ̂ and choices, least jerk

    @staticmethod
    def _reaches(res, low: Lowered, problem: PlanningProblem) -> bool:
        """A plan with ρ̂ ≥ κ (a mission without a requirement term: any plan)."""
        if res.x is None:
            return False
        return low.top < 0 or -res.objective >= problem.threshold + KAPPA_MARGIN

    def _solve(self, low: Lowered, problem: PlanningProblem, limit: float,
               only_above_kappa: bool = False):
        """``only_above_kappa``: stop when HiGHS proves no plan reaches κ (no optimisation
        below κ: the caller keeps the plan it has) — inside the invariant box only for
        κ ≥ 0, since the box keeps just the plans with ρ ≥ 0."""
        t0 = time.perf_counter()
        start = self._seed_start(low, problem, limit)
        proof = only_above_kappa and (not low.box or problem.threshold >= 0)
        res = self._two_phase(low, problem, limit - (time.perf_counter() - t0), start, proof)
        if proof and res.x is None and res.highs_status == "Infeasible":
            return res
        if low.box and not (res.x is not None and -res.objective >= 0):
            full = build(problem, {"requirement": problem.requirement}, one_hot=self.one_hot)
            left = limit - (time.perf_counter() - t0)
            res2 = self._two_phase(full, problem, max(left, 1.0))
            low.milp, low.vehicles, low.top = full.milp, full.vehicles, full.top
            res2.wall_s += res.wall_s
            return res2
        return res

    def _seed_start(self, low: Lowered, problem: PlanningProblem, limit: float):
        """A start for HiGHS from the seed's inputs (a coarse start's path), or None.  The
        inputs give the states (the exact discrete model) and ``Encoder.complete`` every
        term and choice on that trajectory — each choice the best branch, no search; then,
        with those choices fixed and the inputs free, the LP maximising ρ̂: the most robust
        plan of that homotopy class on this grid (the coarse path may clip a region
        between its samples, which the LP repairs where the class allows), repeated from the
        best choices on the LP's path for up to ``ROUNDS`` LPs while ρ̂ grows.  Only a
        start: the optimisation that follows frees the choices too."""
        seed = problem.seed
        if seed is None or not seed.channels or low.top < 0:
            return None
        t0 = time.perf_counter()
        x = np.zeros(low.milp.n_cols)
        lo, hi = np.asarray(low.milp.lo), np.asarray(low.milp.hi)
        for lv in low.vehicles:
            for j, name in enumerate(lv.inputs):
                vals = seed.channels.get(name)
                if vals is None or len(vals) < len(lv.u):
                    return None
                x[lv.u[:, j]] = np.asarray(vals, float)[: len(lv.u)]
            x[lv.x[0]] = lo[lv.x[0]]
            xs, uu = lv.simulate(x)
            x[lv.x], x[lv.u] = xs, uu
        low.encoder.complete(x)
        x[low.top] = min(max(low.encoder.value(low.terms["requirement"], x), lo[low.top]),
                         hi[low.top])
        inside = bool(np.all((x >= lo - 1e-7) & (x <= hi + 1e-7)))
        self.phases.append(("coarse start (its path)", "within bounds" if inside else
                            "outside the bounds", time.perf_counter() - t0))
        best = None
        for _ in range(ROUNDS):  # choices fixed → LP → the best choices on its path → …
            h = Highs(low.milp, {low.top: -1.0},
                      time_limit=max(min(limit / 4, limit - 1) - (time.perf_counter() - t0),
                                     0.1))
            h.fix_integers(x)
            pol = h.solve()
            self.phases.append(("coarse start (choices fixed)", pol.highs_status, pol.wall_s))
            if pol.x is None or (best is not None and
                                 pol.x[low.top] <= best.x[low.top] + 1e-6):
                break
            best = pol
            x = pol.x.copy()
            low.encoder.complete(x)
        return best

    def _two_phase(self, low: Lowered, problem: PlanningProblem, limit: float, start=None,
                   only_above_kappa: bool = False):
        if low.top < 0:
            return Highs(low.milp, {}, time_limit=limit).solve()
        t0 = time.perf_counter()
        # κ plus a margin above the monitor's rounding (MILP and monitor agree to ~1e-9): a
        # plan at exactly κ could be judged a hair below it (seen on the 60 s patrol)
        kappa_lo = min(max(low.milp.lo[low.top], problem.threshold + KAPPA_MARGIN),
                       low.milp.hi[low.top])
        if start is not None and start.x[low.top] >= kappa_lo:
            first = start  # the start already reaches κ: no feasibility phase
        else:
            h = Highs(low.milp, {}, time_limit=limit)
            h.set_col_bounds(low.top, kappa_lo, low.milp.hi[low.top])
            if start is not None:
                h.start(start.x)
            first = h.solve()
            self.phases.append(("feasibility", first.highs_status, first.wall_s))
            if only_above_kappa and first.highs_status == "Infeasible":
                return first
            if first.x is None and start is not None:
                first.x = start.x
        h = Highs(low.milp, {low.top: -1.0},
                  time_limit=max(limit - (time.perf_counter() - t0), 1.0))
        if first.x is not None:
            h.start(first.x)
        res = h.solve()
        if res.x is not None and abs(res.x[low.top] + res.objective) > 1e-6 * (
                1 + abs(res.objective)):
            # HiGHS (1.x) can return the MIP start's point beside another point's objective
            # (seen when presolve ends the search): never trust one without the other
            self.phases.append(("optimisation (inconsistent point)", res.highs_status, res.wall_s))
            h = Highs(low.milp, {low.top: -1.0},
                      time_limit=max(limit - (time.perf_counter() - t0), 1.0))
            wall = res.wall_s
            res = h.solve()
            res.wall_s += wall
        self.phases.append(("optimisation", res.highs_status, res.wall_s))
        res.wall_s += first.wall_s
        if res.x is None and first.x is not None:
            res.x, res.objective = first.x, -float(first.x[low.top])
        return res

    def invert(self, res, low: Lowered, problem: PlanningProblem) -> Solution:
        n = problem.grid.n
        status = self.status(res.highs_status)
        x = res.x
        if x is None:  # no incumbent: hold the inputs at zero (a dynamically feasible plan)
            x = np.zeros(low.milp.n_cols)
            for lv in low.vehicles:
                x[lv.x[0]] = np.asarray(low.milp.lo)[lv.x[0]]
        ch: dict[str, np.ndarray] = {}
        solver_states: dict[str, np.ndarray] = {}
        dev = 0.0
        for lv, v in zip(low.vehicles, problem.vehicles()):
            xs, uu = lv.simulate(x)
            dev = max(dev, float(np.max(np.abs(xs - x[lv.x]))) if res.x is not None else 0.0)
            for i, c in enumerate(lv.states):
                ch[c] = xs[:, i]
                if res.x is not None:
                    solver_states[c] = np.array(x[lv.x][:, i], dtype=float)
            for j, c in enumerate(lv.inputs):
                ch[c] = np.concatenate([uu[:, j], uu[-1:, j]]) if n > 1 else uu[:1, j]
            vm = vehicles.model_of(v)
            ch.update(vm.derived_channels(v, vehicles.state_matrix(v, ch)))
        rho = -res.objective if low.top >= 0 and res.x is not None else float("nan")
        bound = -res.bound if low.top >= 0 else float("nan")
        failed = res.x is None
        sol = Solution(
            mission=problem.mission.name,
            status=Verdict.SOLVER_FAILED if failed else Verdict.VIOLATED,
            robustness_exact=float("nan"), robustness_smooth=rho, specs={}, energy=0.0,
            times=problem.grid.times(), channels=ch,
            timing={"build_s": low.build_s, "solve_s": res.wall_s},
            solver={"name": "HiGHS MILP (highspy)", "return_status": str(status),
                    "highs_status": res.highs_status, "converged": status.converged,
                    "objective": rho, "bound": bound,
                    "gap": None if status.converged else _gap(rho, bound),
                    "nodes": res.nodes, "iterations": res.nodes,
                    "phases": [{"phase": p, "status": st, "wall_s": w}
                               for p, st, w in getattr(self, "phases", [])],
                    "max_state_deviation": dev},
            smoothing={"method": "exact (MILP)", "lambda": problem.smoothing.lam,
                       "lambda_final": problem.smoothing.lam,
                       "threshold": problem.threshold},
            problem_size={"samples": n, "variables": low.milp.n_cols,
                          "constraints": len(low.milp.rows),
                          "binaries": low.milp.n_binaries},
            feasible=not failed and dev <= 1e-5, solver_states=solver_states)
        sol.solver["optimal_among"] = getattr(self, "among", ALL_PLANS)
        if status.converged and sol.solver["optimal_among"] not in (AT_REST, ALL_PLANS):
            sol.notes.append(f"optimal among {sol.solver['optimal_among']}")
        if status == SolverStatus.MAX_TIME:
            sol.notes.append(f"the MILP stopped on its time limit (not converged): best plan "
                             f"ρ̂ = {rho:.6g}, bound {bound:.6g}")
        return sol


#: what a MILP optimum is optimal among (``solver["optimal_among"]``)
AT_REST = "plans that end at rest (the holdable end, a preference of the mission)"
ALL_PLANS = "all plans on the mission's grid"


def _gap(obj: float, bound: float) -> float | None:
    if not (np.isfinite(obj) and np.isfinite(bound)):
        return None
    return float(max(0.0, bound - obj))


__all__ = ["ExactMilp", "build", "linear_model", "INF"]
