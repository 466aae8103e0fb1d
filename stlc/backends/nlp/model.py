"""The CasADi/IPOPT backend: a checked mission → a smooth-robustness trajectory NLP.

``build(problem)`` lowers a ``PlanningProblem`` into one NLP (paper A eq. 6) built once; it
reads the problem's typed fields only (team, grid, requirement, threshold, smoothing,
objective, integrator, end state, iteration limit, start states), never the mission as written:

* decision variables: every vehicle's states at the n samples and inputs on the N intervals
  (multiple shooting, RK4 by default), then the auxiliary variables of the lifted robustness;
* constraints: the discrete dynamics ``x_{k+1} = F(x_k, u_k)``, the fixed start state (as
  variable bounds), state/input bounds (rotor forces, per-axis velocity/acceleration), the
  lifted robustness constraints, and ``ρ̃ ≥ κ`` (switched on per solve through its lower bound);
* objective: ``w_E·E/n + w_F·F − w_ρ·ρ̃ + r·Σ‖u‖²`` (+ ``w_J·J``, the input change, for a
  team without energy or forward-speed terms: ``smoothing``) with the weights and λ as
  NLP *parameters*, so that a λ schedule and the energy stage re-solve the same NLP with warm
  starts instead of rebuilding it (a small input regularisation r keeps the optimum unique).
  E/n is the mean per-sample energy (1 at hover), O(1) like ρ̃: the summed E (≈ 170) made
  IPOPT crawl along the robustness constraint (263 → 123 iterations measured).
* ρ̃ is the smooth robustness of the *planner form* ``P_κ(f)`` of the requirement
  (``nlp.expr.planner_form``): margins with the sign of m − κ, in units of each
  predicate's own scale, without atan2/√ singularities at hover.  ρ̃(P_κ f) > 0 ⟹ ρ(f) > κ.

``solve_mission`` runs the schedule (see ``SCHEDULE``) and ``invert`` maps the raw result back
to a ``Solution`` in mission-level names, re-evaluated by the exact monitor.
"""

from __future__ import annotations

import sys
import time
from dataclasses import dataclass, field

import casadi as ca
import numpy as np

from stlc import deadline, settings, vehicles
from stlc.backends.nlp import choices
from stlc.backends.nlp import derivatives
from stlc.backends.nlp import flyable
from stlc.solvers import ipopt
from stlc.solvers.ipopt import MUMPS, STATUS_MAP  # noqa: F401 (the NLP family's names)
from stlc.backends.nlp.expr import planner_form
from stlc.backends.nlp.smooth import lower_robustness
from stlc.backends.nlp.windows import LoweredRobustness
from stlc.vehicles import dynamics
from stlc.vehicles.dynamics import substeps
from stlc.planning import words
from stlc.planning.problem import PlanningProblem
from stlc.semantics import ir, model
from stlc.semantics.timegrid import TimeGrid

INPUT_REG = 1e-4
#: the energy stage keeps the planner's smooth robustness ρ̃(P_κ(f)) >= PLAN_MARGIN (> 0, so
#: that ρ(f) >= κ holds with IPOPT's constraint tolerance to spare)
PLAN_MARGIN = 1e-3
#: the energy stage keeps the robust plan's branch of every disjunction of predicates
#: (``choices``): sound, and it removes the smooth max's negative curvature
FIX_CHOICES = True
FIX_WINDOWS = True  # and of every ``eventually``
FEASIBLE_DEFECT = 1e-6  # max dynamics defect of an iterate accepted as a plan
PROGRESS_EVERY_S = 3.0  # a progress line at least this often (or every 10 iterations)


def dynamics_defect(w: np.ndarray, inv: InverseData, integrator: str = "rk4") -> float:
    """Largest |x_{k+1} − F(x_k, u_k)| of a decision vector: 0 for a dynamically exact plan."""
    n = inv.grid.n
    worst = 0.0
    for L in inv.layouts:
        X = np.asarray(w[L.x_slice]).reshape(n, L.nx).T
        U = np.asarray(w[L.u_slice]).reshape(n - 1, L.nu).T
        v = L.vehicle
        F = dynamics.discrete_dynamics(vehicles.model_of(v).ode(v), inv.grid.dt, integrator,
                                       substeps(inv.grid.dt)).map(n - 1)
        worst = max(worst, float(np.max(np.abs(X[:, 1:] - np.asarray(F(X[:, :-1], U))))))
    return worst


IPOPT_DEFAULTS = {
    "ipopt.print_level": 0, "ipopt.sb": "yes", "print_time": False,
    # IPOPT's acceptable test also ends a stage whose objective has stopped moving
    # (relative change < 1e-4 for 5 iterations).  tol 1e-4 on the scaled KKT error: ρ̃ and
    # E/n are O(1), margins are in units of a box's half-width; with tol 1e-6 IPOPT ran two
    # more barrier phases (μ = 1e-7, 1e-9) in which the plan wandered without improving
    "ipopt.tol": 1e-4, "ipopt.acceptable_tol": 1e-2, "ipopt.acceptable_iter": 5,
    "ipopt.acceptable_obj_change_tol": 1e-4,
    # a plan must meet the dynamics to FEASIBLE_DEFECT, and IPOPT's own tests check exactly
    # that (1e-7 made the energy stage chase the last digit of the defect: 150 → 23 iterations)
    "ipopt.constr_viol_tol": FEASIBLE_DEFECT, "ipopt.acceptable_constr_viol_tol": FEASIBLE_DEFECT,
    # monotone μ from a small start: every stage is warm-started near a solution; adaptive μ
    # fell to 1e-11 at once and the energy stage wandered (252 vs 150 iterations measured)
    "ipopt.mu_strategy": "monotone", "ipopt.mu_init": 1e-4, "ipopt.linear_solver": "mumps",
    # the filter rejects trial points more infeasible than the start (default 1e4·θ₀): energy
    # stages took near-singular steps (‖d‖ ≈ 20) from a feasible plan to infeasibility 15 and
    # spent ~50 iterations at δ_w ≈ 1e11 coming back (4 handovers: 401 → 275 iterations)
    "ipopt.theta_max_fact": 1.0,
    # bound multipliers start at μ/slack (default: 1), consistent with the small μ_init of
    # a warm-started stage: 23 random and shipped handovers, NLP iterations median 82 → 65,
    # 2185 → 1625 in all (all satisfied with both; 18 took fewer, 5 more)
    "ipopt.bound_mult_init_method": "mu-based",
    **{f"ipopt.{k}": v for k, v in MUMPS.items()},
}


@dataclass
class Layout:
    """Where each vehicle's states and inputs sit in the decision vector."""

    vehicle: model.Vehicle
    x_slice: slice  # nx*n entries, column-major (sample by sample)
    u_slice: slice  # nu*N entries
    nx: int
    nu: int


@dataclass
class NlpProblem:
    solver: ca.Function
    lbx: np.ndarray
    ubx: np.ndarray
    lbg: np.ndarray
    ubg: np.ndarray
    kappa_row: int
    n_dyn: int  # the first n_dyn constraint rows are the dynamics defects
    n_vars: int
    n_cons: int
    root_fn: ca.Function  # w, p -> smooth robustness (lifted root)
    progress: Progress
    lowered: LoweredRobustness
    build_s: float
    inv: InverseData | None = None  # set by build: the choice parameters live there
    #: the objective has the input-change term w_jerk·Σ‖Δu/u_max‖²/(N−1) (``smoothing``)
    smoothable: bool = False
    jerk_fn: ca.Function | None = None  # w -> that input change J (``smoothing``)


@dataclass
class InverseData:
    grid: TimeGrid
    layouts: list[Layout]
    aux_slice: slice
    formula: ir.Formula  # the normalised requirement, as the user wrote it
    planned: ir.Formula | None = None  # what the NLP optimises: casadi_expr.planner_form
    choice_nodes: list = field(default_factory=list)  # choices.choice_form's disjunctions
    choice_values: dict = field(default_factory=dict)  # their parameter rows (choices.*)
    params: dict = field(default_factory=dict)  # NLP parameters after the choices, in order


@dataclass
class Stage:
    label: str
    lam: float
    iterations: int
    status: str
    smooth: float
    exact: float
    solve_s: float
    objective: float
    t_functions: float = 0.0  # IPOPT's function/derivative evaluations (t_wall_nlp_*)
    t_verify: float = 0.0  # exact-monitor checks of iterates in the callback
    converged: bool = False  # IPOPT's own test: Solve_Succeeded / Solved_To_Acceptable_Level
    planner: float = 0.0  # ρ̃ of the planner form (what the NLP maximises / constrains)
    regularizations: int = 0  # iterations where IPOPT regularised the KKT matrix
    #: the plan meets the dynamics to FEASIBLE_DEFECT (a stage stopped on its iteration
    #: limit with no feasible iterate returns its last one, which may not)
    feasible: bool = True

    def meets(self, kappa: float) -> bool:
        """The stage's plan is a plan (dynamically feasible) with exact ρ ≥ κ."""
        return self.feasible and self.exact >= kappa

    def score(self) -> float:
        """Exact ρ of a feasible plan, −∞ for one that does not meet the dynamics."""
        return self.exact if self.feasible else -np.inf


@dataclass
class RawResult:
    w: np.ndarray
    lam: float
    stages: list[Stage] = field(default_factory=list)
    comparisons: dict[str, np.ndarray] = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)  # for the solution's notes


# ---------------------------------------------------------------- building


def _channels(layouts: list[Layout], w: ca.SX, n: int) -> dict[str, ca.SX]:
    out: dict[str, ca.SX] = {}
    for L in layouts:
        X = ca.reshape(w[L.x_slice], L.nx, n)
        U = ca.reshape(w[L.u_slice], L.nu, n - 1)
        for i, name in enumerate(vehicles.model_of(L.vehicle).state_channels(L.vehicle)):
            out[name] = X[i, :]
        Up = ca.horzcat(U, U[:, -1])
        for i, name in enumerate(vehicles.model_of(L.vehicle).input_channels(L.vehicle)):
            out[name] = Up[i, :]
    return out


def build(problem: PlanningProblem, quiet: bool = True) -> tuple[NlpProblem, InverseData]:
    t0 = time.perf_counter()
    program, grid, integrator = problem.program, problem.grid, problem.integrator
    n, N = grid.n, grid.n_intervals
    layouts: list[Layout] = []
    off = 0
    for name in problem.team:
        v = program.vehicles[name]
        nx, nu = vehicles.model_of(v).state_size(v)
        layouts.append(Layout(v, slice(off, off + nx * n), slice(off + nx * n,
                                                               off + nx * n + nu * N), nx, nu))
        off += nx * n + nu * N
    n_traj = off
    wt = ca.SX.sym("w", n_traj)
    lam, w_rob, w_en, w_fwd, w_jerk = (ca.SX.sym(s) for s in ("lam", "w_rob", "w_en", "w_fwd",
                                                                "w_jerk"))
    p = ca.vertcat(lam, w_rob, w_en, w_fwd)

    formula = problem.requirement  # in negation normal form
    chans = _channels(layouts, wt, n)
    planned = planner_form(formula, problem.threshold, program.params)
    fixed, nodes = choices.choice_form(planned, FIX_WINDOWS) if FIX_CHOICES else (planned, [])
    extra = []
    for name in choices.signals(nodes) if nodes else []:
        extra.append(ca.SX.sym(name, 1 if name == choices.MIX else n))
        chans[name] = ca.repmat(extra[-1], 1, n) if name == choices.MIX else extra[-1].T
    psyms = {k: ca.SX.sym(k) for k in sorted(ir.params(fixed))}  # e.g. a human's pose
    p = ca.vertcat(p, *extra, *psyms.values(), w_jerk)  # w_jerk: ``smoothing``
    lowered = lower_robustness(fixed, grid, chans, {**program.params, **psyms}, lam,
                               method=problem.smoothing.method)
    aux = lowered.aux
    w = ca.vertcat(wt, aux)
    g_list, lbg, ubg = [], [], []
    lbx = np.full(w.numel(), -np.inf)
    ubx = np.full(w.numel(), np.inf)
    energy, fwd, reg, jerk = ca.SX(0), ca.SX(0), ca.SX(0), ca.SX(0)
    smoothable = True  # no energy or forward-speed term: the jerk term (``smoothing``)
    for L in layouts:
        v = L.vehicle
        vm = vehicles.model_of(v)
        X = ca.reshape(wt[L.x_slice], L.nx, n)
        U = ca.reshape(wt[L.u_slice], L.nu, N)
        # the dynamics rows stay a call of the one-step map in the MX NLP (not inlined into
        # the SX graph): ``derivatives.nlpsol_options`` assembles them
        g_list.append(ca.SX(L.nx * N, 1))
        lbg.append(np.zeros(L.nx * N))
        ubg.append(np.zeros(L.nx * N))
        b = vm.envelope(v, vm.bounds(v))
        lbx[L.x_slice] = np.tile(b.x_lo, n)
        ubx[L.x_slice] = np.tile(b.x_hi, n)
        lbx[L.u_slice] = np.tile(b.u_lo, N)
        ubx[L.u_slice] = np.tile(b.u_hi, N)
        x0 = problem.start_state(v.name)
        start = L.x_slice.start
        lbx[start:start + L.nx] = x0
        ubx[start:start + L.nx] = x0
        reg += ca.sumsqr(U) / N
        scale = np.maximum(np.abs(b.u_lo), np.abs(b.u_hi))  # Δu in units of its bound
        scale = np.where(np.isfinite(scale) & (scale > 0), scale, 1.0)
        jerk += ca.sumsqr((U[:, 1:] - U[:, :-1]) / ca.DM(scale)) / max(N - 1, 1)
        xs = ca.SX.sym("x", L.nx)
        e_x = vm.energy_terms(v, xs, grid.dt)  # None: the model has no energy
        if e_x is not None:
            e_fn = ca.Function("e", [xs], [e_x]).map(n)
            energy += ca.sum2(e_fn(X)) / n  # mean per sample: O(1), like ρ̃
            smoothable = False
        elif problem.objective.forward_speed:
            smoothable = False
            vstar = dynamics.forward_speed_target(v, problem.objective.forward_speed)
            fwd += ca.sum2(ca.reshape(dynamics.forward_speed_terms(X, vstar), 1, -1))
    n_dyn = sum(x.numel() for x in g_list)
    # the holdable end (when the problem asks for it) and the heading regulariser
    fly = flyable.add_rows(g_list, lbg, ubg, problem.hold_end, layouts, wt, n)
    cons, lb_r, ub_r = lowered.constraints()
    g_list.append(cons)
    lbg.append(lb_r)
    ubg.append(ub_r)
    g_list.append(lowered.root)
    kappa_row = sum(len(x) for x in lbg)
    lbg.append(np.array([-np.inf]))
    ubg.append(np.array([np.inf]))
    g = ca.vertcat(*g_list)
    obj = w_en * energy + w_fwd * fwd - w_rob * lowered.root + INPUT_REG * reg + fly
    if smoothable:
        obj += w_jerk * jerk
    opts = dict(IPOPT_DEFAULTS)
    opts.update(settings.ipopt_options())  # a developer's extra options (``STLC_IPOPT``)
    opts["ipopt.max_iter"] = int(problem.max_iter)
    root_fn = ca.Function("root", [w, p], [lowered.root])
    progress = Progress("progress", w.numel(), g.numel(), p.numel(), root_fn, quiet=quiet)
    opts["iteration_callback"] = progress
    nlp, derivs = derivatives.nlpsol_options(w, p, obj, g, layouts, grid.dt, integrator,
                                             substeps(grid.dt), n_dyn)
    opts.update(derivs)
    solver = ipopt.solver("stlc", nlp, opts)
    prob = NlpProblem(solver, lbx, ubx, np.concatenate(lbg), np.concatenate(ubg), kappa_row,
                      n_dyn, w.numel(), g.numel(), root_fn, progress, lowered,
                      time.perf_counter() - t0)
    inv = InverseData(grid, layouts, slice(n_traj, n_traj + aux.numel()), formula, planned,
                      nodes, choices.written(nodes, n) if nodes else {},
                      {k: program.params[k] for k in psyms})
    prob.inv = inv
    prob.smoothable = smoothable
    prob.jerk_fn = ca.Function("jerk", [w], [jerk])

    def verify(x: np.ndarray, gv: np.ndarray) -> float | None:
        if n_dyn and np.max(np.abs(gv[:n_dyn])) > FEASIBLE_DEFECT:
            return None
        return exact_robustness(formula, inv, x, inv.params)

    progress.verify = verify
    return prob, inv


# ---------------------------------------------------------------- evaluation helpers


def trajectory_channels(w: np.ndarray, inv: InverseData) -> dict[str, np.ndarray]:
    """Numeric channels (states, padded inputs) of a decision vector."""
    n = inv.grid.n
    out: dict[str, np.ndarray] = {}
    for L in inv.layouts:
        X = np.asarray(w[L.x_slice]).reshape(n, L.nx).T
        U = np.asarray(w[L.u_slice]).reshape(n - 1, L.nu).T
        for i, name in enumerate(vehicles.model_of(L.vehicle).state_channels(L.vehicle)):
            out[name] = X[i].copy()
        Up = np.hstack([U, U[:, -1:]])
        for i, name in enumerate(vehicles.model_of(L.vehicle).input_channels(L.vehicle)):
            out[name] = Up[i].copy()
    return out


def lowering_channels(w: np.ndarray, inv: InverseData) -> dict[str, np.ndarray]:
    """``trajectory_channels`` plus the current choice parameters (what the lowered
    robustness reads; never part of a plan's channels)."""
    return {**trajectory_channels(w, inv), **inv.choice_values}


def choice_params(inv: InverseData) -> list[float]:
    """The NLP parameters after (λ, w_ρ, w_E, w_F): mix, then the branch rows."""
    v = inv.choice_values
    if not v:
        return []
    return [float(v[choices.MIX][0])] + [x for name in choices.signals(inv.choice_nodes)[1:]
                                           for x in v[name].tolist()]


def state_matrix(w: np.ndarray, L: Layout, n: int) -> np.ndarray:
    return np.asarray(w[L.x_slice]).reshape(n, L.nx)


def exact_robustness(f: ir.Formula, inv: InverseData, w: np.ndarray,
                     params: dict[str, float]) -> float:
    from stlc.analysis import monitor

    return float(monitor.robustness(f, inv.grid.dt, trajectory_channels(w, inv), params))


def fill_aux(prob: NlpProblem, inv: InverseData, w: np.ndarray, params: dict[str, float],
             lam: float) -> np.ndarray:
    """Set the aux variables of ``w`` to the un-lifted smooth values of its trajectory."""
    w = np.array(w, dtype=float)
    aux, _ = prob.lowered.init_values(lowering_channels(w, inv), params, lam)
    w[inv.aux_slice] = np.asarray(aux).ravel()
    return w


class Progress(ca.Callback):
    """IPOPT iteration callback printing iteration, objective and smooth robustness."""

    def __init__(self, name: str, nx: int, ng: int, np_: int, root_fn: ca.Function,
                 label: str = "", every: int = 10, stream=None, quiet: bool = True):
        ca.Callback.__init__(self)
        self.nx, self.ng, self.np_ = nx, ng, np_
        self.root_fn, self.label, self.every, self.stream = root_fn, label, every, stream
        self.quiet, self.it = quiet, 0
        self.limit = 10**9  # stop the current solve after this many iterations
        self.p = np.zeros(np_)
        #: anytime tracking: ``verify(x, g)`` returns the exact robustness of a dynamically
        #: feasible iterate (None otherwise); the best one is kept, and a solve stops once
        #: it has a satisfying plan that has not improved for ``patience`` iterations
        self.verify = None
        self.patience = 10**9
        #: "robust": keep the feasible iterate with the best exact robustness; "objective":
        #: keep the satisfying feasible iterate with the lowest objective (energy stages)
        self.mode = "robust"
        self.kappa = 0.0  # the mission's threshold: a plan satisfies iff exact ρ >= κ
        self.reset()
        self.construct(name, {})

    def reset(self) -> None:
        self.it = 0
        self.best_x: np.ndarray | None = None
        self.best_exact = self.best_score = -np.inf
        self.best_it = 0
        self.t_verify, self.timed_out = 0.0, False
        self.printed = time.perf_counter()

    def get_n_in(self):
        return ca.nlpsol_n_out()

    def get_n_out(self):
        return 1

    def get_name_in(self, i):
        return ca.nlpsol_out(i)

    def get_name_out(self, i):
        return "ret"

    def get_sparsity_in(self, i):
        size = {"f": 1, "x": self.nx, "lam_x": self.nx, "g": self.ng, "lam_g": self.ng,
                "lam_p": self.np_}.get(ca.nlpsol_out(i))
        return ca.Sparsity(0, 0) if size is None else ca.Sparsity.dense(size)

    def eval(self, arg):
        exact = None
        t0 = time.perf_counter()
        if self.verify is not None:
            exact = self.verify(np.asarray(arg[0]).ravel(), np.asarray(arg[2]).ravel())
            if exact is not None:
                if self.mode == "robust":
                    score = exact
                else:
                    score = -float(arg[1]) if exact >= self.kappa else -np.inf
                if score > self.best_score + 1e-4 * max(1.0, abs(score)):
                    self.best_score, self.best_exact = score, exact
                    self.best_x, self.best_it = np.asarray(arg[0]).ravel(), self.it
        self.t_verify += time.perf_counter() - t0
        now = time.perf_counter()
        if not self.quiet and (self.it % self.every == 0
                               or now - self.printed >= PROGRESS_EVERY_S):
            self.printed = now
            rho = float(self.root_fn(arg[0], self.p))
            best = f", best verified {words.number(self.best_exact)}" \
                if self.best_x is not None else ""
            ex = words.iterate_exact(exact) + best + deadline.progress_note()
            print(f"  [{self.label}] iter {self.it:4d}  objective {float(arg[1]):+.5e}  "
                  f"planner ρ̃ {words.number(rho)}  exact ρ {ex}",
                  file=self.stream or sys.stderr, flush=True)
        self.it += 1
        stagnant = self.best_exact >= self.kappa and self.it - self.best_it > self.patience
        self.timed_out = deadline.solve_expired()  # the run's time limit (stlc.deadline)
        return [1 if self.it >= self.limit or stagnant or self.timed_out else 0]
