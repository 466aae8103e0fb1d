"""Initial guess and solve schedule for the CasADi backend.

**Initial guess from the mission itself.**  A small kinematic problem is solved first: every
vehicle as a double integrator (position, velocity, acceleration; modest bounds) maximising
the smooth robustness of the part of the requirement that only reads positions and
velocities (``ir.restrict``).  It is cheap (≈ 9 variables per sample) and finds a path
through the regions the requirement visits *and around* the regions it forbids.  Its start
is the hover at the start position bent slightly sideways: a straight line through a
forbidden box lies on the box's symmetry plane, where the smooth robustness has no
sideways gradient, and the optimiser would stay inside (NLP_NOTES §3).  The full state guess
is then position and velocity from this path, level attitude, zero rates, hover forces.

**What is optimised.**  The NLP maximises the smooth robustness of the *planner form*
``P_κ(f)`` (``casadi_expr.planner_form``): each predicate margin m becomes a smooth margin
with the sign of m − κ, divided by its own scale (a box's half-width, a bound's value), so
that ρ̃(P_κ f) > 0 certifies ρ(f) > κ for the formula as written (the exact monitor still
judges that).  λ acts on these dimensionless margins.

**The smoothing gap and the λ schedule.**  A smooth min over n operands under-estimates by
up to ln(n)/λ.  The schedule solves at the mission's λ first and, while the exact monitor
says ρ < κ, multiplies λ by ``LAM_FACTOR`` and re-solves from the previous plan (the NLP
has λ as a parameter, nothing is rebuilt), up to ``LAM_MAX``.  The first stage keeps the
seed's disjunction branches and window samples (``SEED_CHOICES``).  Every stage runs until
IPOPT's own convergence test (or the iteration limit); every dynamically feasible iterate
is checked by the exact monitor and the best one kept.  Then, if the objective has energy
terms, one more solve minimises ``w·E/n − ρ̃(P_κ)`` at the smallest λ where the robust plan
has ρ̃(P_κ) ≥ ``PLAN_MARGIN``; only if its plan misses κ, a second one adds the constraint
ρ̃(P_κ) ≥ ``PLAN_MARGIN`` (paper A eq. 6).
"""

from __future__ import annotations

import os
import sys
import time

import casadi as ca
import numpy as np

from stlc import deadline, interrupt, vehicles
from stlc.backends import choices
from stlc.backends.derivatives import derivative_options
from stlc.backends.base import SolverStatus
from stlc.backends.casadi_nlp import (
    MUMPS,
    PLAN_MARGIN,
    STATUS_MAP,
    InverseData,
    NlpProblem,
    RawResult,
    Stage,
    choice_params,
    exact_robustness,
    fill_aux,
    lowering_channels,
    trajectory_channels,
)
from stlc.backends.smooth_casadi import lower_robustness
from stlc.planning.problem import PlanningProblem
from stlc.semantics import ir, model, reads
from stlc.semantics.timegrid import TimeGrid

LAM_FACTOR = 3.0
LAM_MAX = 300.0
GUESS_LAM = 30.0
#: the guess is a seed: IPOPT's acceptable test ends it once its objective has stopped
#: moving (relative change < 1e-5 for 5 iterations) with the path consistent to 1e-2.  Its
#: tight test never ended on plateaus where steps of ~1e-2 left second-order residuals of
#: ~1e-3 (handover_above: iterations 114–192 at the same objective to 7 digits)
GUESS_ACCEPTABLE = {"ipopt.acceptable_tol": 1e-2, "ipopt.acceptable_iter": 5,
                    "ipopt.acceptable_constr_viol_tol": 1e-2,
                    "ipopt.acceptable_obj_change_tol": 1e-5}
FIRST_STAGE_ITER = 200
STAGE_ITER = 300
PATIENCE = 10**9  # stages end on IPOPT's own tests (or the iteration limit), not on ours
MAX_LAM_STAGES = 4
#: the robustness stage first keeps the seed's choices (``choices``: the branch of every
#: disjunction and the sample of every window, from the full guess), then — only if that
#: plan misses κ — solves the formula as written from it.  Fixed choices take the smooth
#: max's negative curvature out of the Hessian: robustness stages of four handovers
#: 61/56/113/89 → 65/27/32/47 iterations, with fewer regularised ones (~50 vs ~70 ms each)
SEED_CHOICES = os.environ.get("STLC_SEED_CHOICES", "1") == "1"


def _start_kinematics(problem: PlanningProblem, name: str) -> tuple[np.ndarray, np.ndarray]:
    """(position, velocity) of the vehicle's start state (the problem's ``start_state``)."""
    v = problem.program.vehicles[name]
    x0 = problem.start_state(name)
    chans = vehicles.model_of(v).state_channels(v)

    def part(field: str, default) -> np.ndarray:
        idx = [chans.index(f"{name}.{field}.{a}") if f"{name}.{field}.{a}" in chans else None
               for a in "xyz"]
        if None in idx:
            return np.array(default, dtype=float)
        return np.array([x0[i] for i in idx], dtype=float)

    return part("pos", v.start_pos), part("vel", (0.0, 0.0, 0.0))


def kinematic_guess(problem: PlanningProblem, path: dict | None = None
                    ) -> dict[str, tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """Per vehicle of the problem's team: positions (3×n), velocities (3×n), accelerations
    (3×N) of the double-integrator path maximising the smooth robustness of the position and
    velocity part of ``problem.requirement`` from the problem's start states.  ``path`` (per
    vehicle (P, V, A): a MILP seed's path) is where IPOPT starts, and its discrete choices
    are kept (``choices``: the branch of every disjunction and the sample of every window
    fixed from the start path), so this local NLP smooths the path without leaving the
    homotopy class the MILP chose."""
    program, grid = problem.program, problem.grid
    n, N, dt = grid.n, grid.n_intervals, grid.dt
    names = list(problem.team)
    keep = {f"{v}.{f}.{a}" for v in names for f in ("pos", "vel") for a in "xyz"}
    f0 = f = ir.restrict(problem.requirement, lambda s: s in keep)
    f, fixed = _start_choices(f, path, program.params, grid) if path else (f, {})
    syms, chans, g, lbx, ubx, x0 = [], {}, [], [], [], []
    rest = []  # (bound index, v_max) of each vehicle's last velocity held at rest
    obj = ca.SX(0)
    for k, name in enumerate(names):
        v = program.vehicles[name]
        P, V, A = ca.SX.sym(f"P{k}", 3, n), ca.SX.sym(f"V{k}", 3, n), ca.SX.sym(f"A{k}", 3, N)
        for i, a in enumerate("xyz"):
            chans[f"{name}.pos.{a}"] = P[i, :]
            chans[f"{name}.vel.{a}"] = V[i, :]
        chans.update({c: ca.SX(ca.DM(row.reshape(1, -1))) for c, row in fixed.items()})
        g.append(ca.vec(P[:, 1:] - P[:, :-1] - dt * V[:, :-1] - 0.5 * dt * dt * A))
        g.append(ca.vec(V[:, 1:] - V[:, :-1] - dt * A))
        vmax, amax = vehicles.model_of(v).kinematic_limits(v)
        start, vel0 = _start_kinematics(problem, name)
        plo, phi_ = np.tile(start, (n, 1)).T.copy(), np.tile(start, (n, 1)).T.copy()
        plo[:, 1:], phi_[:, 1:] = -np.inf, np.inf
        vlo, vhi = np.tile(-vmax, (n, 1)).T.copy(), np.tile(vmax, (n, 1)).T.copy()
        vlo[:, 0] = vhi[:, 0] = vel0
        if problem.hold_end:  # a holdable end (flyable.py)
            vlo[:, -1] = vhi[:, -1] = 0.0
            rest.append((len(lbx) + 1, vmax))
        syms += [ca.vec(P), ca.vec(V), ca.vec(A)]
        lbx += [plo.T.ravel(), vlo.T.ravel(), np.tile(-amax, N)]
        ubx += [phi_.T.ravel(), vhi.T.ravel(), np.tile(amax, N)]
        # start: hover at the start, bent sideways (breaks symmetric traps), vehicle-specific
        s = np.sin(np.pi * np.arange(n) / max(N, 1))
        P0 = np.tile(start, (n, 1)) + np.outer(s, [0.0, 0.15 * (1 if k % 2 == 0 else -1), 0.05])
        if path is not None and name in path:
            Ps, Vs, As = path[name]
            x0 += [Ps.T.ravel(), Vs.T.ravel(), As[:, :N].T.ravel()]
        else:
            x0 += [P0.ravel(), np.zeros(3 * n), np.zeros(3 * N)]
        obj += 1e-2 * ca.sumsqr(A) / N
    w = ca.vertcat(*syms)
    wx0 = np.concatenate(x0)
    if isinstance(f, ir.TrueF):
        sol_w = wx0
    else:
        low = lower_robustness(f, grid, chans, program.params, GUESS_LAM,
                               method=problem.smoothing.method)
        cons, lb_r, ub_r = low.constraints()
        W = ca.vertcat(w, low.aux)
        G = ca.vertcat(*g, cons)
        lbg = np.concatenate([np.zeros(sum(x.numel() for x in g)), lb_r])
        ubg = np.concatenate([np.zeros(sum(x.numel() for x in g)), ub_r])
        solver = ca.nlpsol("guess", "ipopt", {"x": W, "f": obj - low.root, "g": G},
                           {**derivative_options(W, obj - low.root, G),
                            "ipopt.print_level": 0, "ipopt.sb": "yes", "print_time": False,
                            "ipopt.max_iter": 300, "ipopt.tol": 1e-4,
                            "ipopt.mu_strategy": "adaptive", **GUESS_ACCEPTABLE,
                            **{f"ipopt.{k}": v for k, v in MUMPS.items()},
                            **deadline.ipopt_options()})  # the run's time limit, if any
        num_ch = path_channels(_unpack(wx0, names, n, N)) | fixed
        aux0, _ = low.init_values(num_ch, program.params, GUESS_LAM)

        def run(lo, hi):
            sol = solver(x0=np.concatenate([wx0, np.asarray(aux0).ravel()]),
                         lbx=np.concatenate(lo + [np.full(low.aux.numel(), -np.inf)]),
                         ubx=np.concatenate(hi + [np.full(low.aux.numel(), np.inf)]),
                         lbg=lbg, ubg=ubg)
            interrupt.check()  # CasADi swallows Ctrl-C inside a solve: re-raise it here
            x = np.asarray(sol["x"]).ravel()[: w.numel()]
            return x, _kinematic_rho(f0, x, names, grid, program.params)

        sol_w, rho = run(lbx, ubx)
        if rest and rho < 0 and not deadline.solve_expired():
            # the end at rest is a preference of the seed (the NLP's rows make the plan
            # holdable): a path that misses the position part is solved again without it
            # (handover_low: −0.41 with it, +0.125 without; the NLP then ends it holdable)
            lo, hi = [a.copy() for a in lbx], [a.copy() for a in ubx]
            for i, vmax in rest:
                lo[i][-3:], hi[i][-3:] = -vmax, vmax
            free_w, free_rho = run(lo, hi)
            if free_rho > rho:
                sol_w = free_w
    return _unpack(sol_w, names, n, N)


def _start_choices(f: ir.Formula, start: dict, params, grid: TimeGrid
                   ) -> tuple[ir.Formula, dict[str, np.ndarray]]:
    """``f`` in choice form and its choice rows (``choices.choose``) on the start paths: the
    parameter signals that fix its disjunctions and windows as the start path has them
    (``f`` itself and no rows when it has nothing to choose)."""
    if isinstance(f, (ir.TrueF, ir.FalseF)):
        return f, {}
    fixed_form, nodes = choices.choice_form(f, windows=True)
    if not nodes:
        return f, {}
    return fixed_form, {k: np.asarray(v, float) for k, v in choices.choose(
        nodes, path_channels(start), params, grid.n, f, grid.dt).items()}


def _kinematic_rho(f: ir.Formula, w: np.ndarray, names: list[str], grid: TimeGrid,
                   params: dict) -> float:
    """Exact robustness of the position/velocity part ``f`` on a kinematic vector."""
    from stlc.analysis import monitor

    ch = path_channels(_unpack(w, names, grid.n, grid.n_intervals))
    return float(monitor.robustness(f, grid.dt, ch, params))


def path_channels(paths: dict) -> dict[str, np.ndarray]:
    """Position and velocity channels of per-vehicle (P 3×n, V 3×n, A) paths."""
    return {f"{name}.{fld}.{a}": X[i] for name, (P, V, _) in paths.items()
            for fld, X in (("pos", P), ("vel", V)) for i, a in enumerate("xyz")}


def _unpack(w: np.ndarray, names: list[str], n: int, N: int
            ) -> dict[str, tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """Per vehicle (positions 3×n, velocities 3×n, accelerations 3×N) of a kinematic vector."""
    out, off = {}, 0
    for name in names:
        P = w[off:off + 3 * n].reshape(n, 3).T
        V = w[off + 3 * n: off + 6 * n].reshape(n, 3).T
        A = w[off + 6 * n: off + 6 * n + 3 * N].reshape(N, 3).T
        out[name] = (P, V, A)
        off += 6 * n + 3 * N
    return out


def full_guess(program: model.Program, prob: NlpProblem, inv: InverseData,
               kin: dict[str, tuple[np.ndarray, np.ndarray, np.ndarray]], lam: float
               ) -> np.ndarray:
    """Decision vector from the kinematic path (see the vehicle model's ``guess``)."""
    w = np.zeros(prob.n_vars)
    needed = reads.reader(inv.formula, inv.grid.dt, inv.grid.n)  # where a channel is read
    for L in inv.layouts:
        v = L.vehicle
        P, V, A = kin[v.name]
        vm = vehicles.model_of(v)
        X, U = (vm.guess(v, P, V, A, inv.grid.dt, needed) if vehicles.takes(vm.guess, "needed")
                else vm.guess(v, P, V, A, inv.grid.dt))
        U = vm.fit_guess_inputs(v, U, prob.lbx[L.u_slice][: L.nu], prob.ubx[L.u_slice][: L.nu])
        w[L.x_slice] = X.T.ravel()
        w[L.u_slice] = U.T.ravel()
    return fill_aux(prob, inv, w, program.params, lam)


def param_values(inv: InverseData) -> list[float]:
    """The NLP parameters after the choice rows: the values of the scenario parameters the
    formula reads (a human's pose), so that one build serves every value."""
    return [float(x) for x in inv.params.values()]


def _solve(prob: NlpProblem, w0: np.ndarray, p: list[float], kappa: float | None,
           label: str, limit: int, patience: int = 10**9, most_robust: bool = True
           ) -> tuple[np.ndarray, dict, float, float]:
    """One IPOPT solve.  With ``most_robust`` the result is the dynamically feasible iterate
    with the best exact robustness (IPOPT's last iterate when that is as good); otherwise
    the last iterate if it is feasible and satisfying, else the best one."""
    lbg = prob.lbg.copy()
    if kappa is not None:
        lbg[prob.kappa_row] = kappa
    p = list(p) + choice_params(prob.inv) + param_values(prob.inv)
    progress = prob.progress
    progress.p = np.array(p)
    progress.reset()
    progress.label = label
    progress.limit = limit
    progress.patience = patience
    progress.mode = "robust" if most_robust else "objective"
    t0 = time.perf_counter()
    sol = prob.solver(x0=w0, p=p, lbx=prob.lbx, ubx=prob.ubx, lbg=lbg, ubg=prob.ubg)
    interrupt.check()  # CasADi swallows Ctrl-C inside a solve: re-raise it here
    dt = time.perf_counter() - t0
    x = np.asarray(sol["x"]).ravel()
    stats = dict(prob.solver.stats())
    # IPOPT's last iterate may be worse than (or infeasible unlike) the best verified one
    ok = stats.get("return_status") in ("Solve_Succeeded", "Solved_To_Acceptable_Level")
    if progress.best_x is not None and (not ok or progress.best_exact >= progress.kappa):
        last = progress.verify(x, np.asarray(sol["g"]).ravel()) if progress.verify else None
        if most_robust:
            keep_last = last is not None and last >= progress.best_exact
        else:
            keep_last = last is not None and last >= progress.kappa and ok
        if not keep_last:
            x = progress.best_x
            stats["best_iterate"] = progress.best_it
    return x, stats, float(sol["f"]), dt


def _regularizations(stats: dict) -> int:
    """Iterations in which IPOPT regularised the KKT matrix (lg(rg) printed, δ_w > 0)."""
    its = stats.get("iterations") or {}
    return int(sum(1 for r in its.get("regularization_size", []) if r > 0))


def _planner_smooth(prob: NlpProblem, inv: InverseData, w: np.ndarray,
                    params: dict[str, float], lam: float) -> float:
    """Un-lifted smooth robustness of the planner form (what the NLP sees) at ``w``."""
    return prob.lowered.init_values(lowering_channels(w, inv), params, lam)[1]


def solve_mission(problem: PlanningProblem, prob: NlpProblem, inv: InverseData,
                  w0: np.ndarray, quiet: bool = True, warm: bool = False) -> RawResult:
    """The λ/energy schedule (module doc) on the built NLP, with the problem's objective,
    threshold, smoothing and comparison variants; ``warm``: ``w0`` is a neighbour's solved
    plan (a sweep's library), see ``_warm_energy``."""
    from stlc.analysis import smooth

    deadline.disarm()  # from here every solve and stage checks the time limit itself
    params = problem.params
    obj = problem.objective
    kappa = problem.threshold
    lam = problem.smoothing.lam
    method = problem.smoothing.method
    stages: list[Stage] = []
    prob.progress.kappa = kappa

    def record(label, lam_, w_, stats, f_, dt_):
        ch = trajectory_channels(w_, inv)
        exact = exact_robustness(inv.formula, inv, w_, params)
        sm = float(smooth.smooth_robustness(inv.formula, inv.grid.dt, ch, params, lam_, method))
        ret = stats.get("return_status", "")
        status = STATUS_MAP.get(ret, SolverStatus.FAILED)
        if status == SolverStatus.MAX_ITER and "best_iterate" in stats:
            status = SolverStatus.STOPPED
        if prob.progress.timed_out:  # stopped by the run's time limit (stlc.deadline)
            status = SolverStatus.MAX_TIME
        t_fn = sum(v for k, v in stats.items() if k.startswith("t_wall_nlp_"))
        st = Stage(label, lam_, int(stats.get("iter_count", 0)), status, sm, exact, dt_, f_,
                   t_fn, prob.progress.t_verify,
                   converged=status.converged,
                   planner=_planner_smooth(prob, inv, w_, params, lam_),
                   regularizations=_regularizations(stats))
        stages.append(st)
        if not quiet:
            print(f"  {label}: λ = {lam_:g}, {st.iterations} iterations, {st.status}"
                  f"{' (converged)' if st.converged else ''}, planner ρ̃ {st.planner:+.4f}, "
                  f"exact {exact:+.4f} ({dt_:.2f} s)", file=sys.stderr)
        return st

    if warm and (obj.energy_weight > 0 or obj.forward_weight > 0):
        done = _warm_energy(prob, inv, w0, params, problem, record)
        if done is not None:  # (no robust plan was solved: no `compare` plans either)
            return RawResult(done[0], done[1], stages)
    # 1. robustness: maximise ρ̃ of the planner form P_κ (margins relative to κ, in units
    #    of each predicate's own scale) until IPOPT converges; raise λ while the exact
    #    monitor says ρ < κ
    w, best, best_st = w0, w0, None
    seeded = bool(inv.choice_nodes) and SEED_CHOICES
    if seeded:  # first with the seed's branches and window samples (sound, see choices)
        inv.choice_values = choices.choose(inv.choice_nodes, trajectory_channels(w0, inv),
                                           params, inv.grid.n, inv.planned, inv.grid.dt)
        w = fill_aux(prob, inv, w0, params, lam)
    for k in range(MAX_LAM_STAGES + (1 if seeded else 0)):
        limit = FIRST_STAGE_ITER if k == 0 else STAGE_ITER
        w, stats, f_, dt_ = _solve(prob, w, [lam, max(obj.robustness_weight, 1.0), 0, 0],
                                   None, f"robustness λ={lam:g}", limit, PATIENCE)
        st = record("robustness:seeded" if seeded else "robustness", lam, w,
                    stats, f_, dt_)
        if best_st is None or st.exact > best_st.exact:
            best, best_st = w, st
        if st.exact >= kappa or lam * LAM_FACTOR > LAM_MAX or deadline.solve_expired():
            break
        if seeded:  # the guess's choices do not reach κ: solve the formula as written
            seeded = False
            inv.choice_values = choices.written(inv.choice_nodes, inv.grid.n)
            w = fill_aux(prob, inv, w, params, lam)
            continue
        lam *= LAM_FACTOR
        w = fill_aux(prob, inv, w, params, lam)
    if inv.choice_nodes:
        inv.choice_values = choices.written(inv.choice_nodes, inv.grid.n)
    lam = best_st.lam
    result = RawResult(best, lam, stages)
    robust_w = best
    if (obj.energy_weight > 0 or obj.forward_weight > 0) and best_st.exact >= kappa \
            and not deadline.solve_expired():
        # 2. paper A eq. 6 on the planner form: minimise w·E − ρ̃(P_κ), at the smallest λ of
        #    the schedule where the robust plan has ρ̃(P_κ) ≥ PLAN_MARGIN.  First without the
        #    constraint (−ρ̃ in the objective already keeps the plan away from ρ̃ < 0, and IPOPT
        #    converges; with it active, the Hessian needs heavy regularisation), then, only if
        #    the exact monitor finds ρ < κ, with ρ̃(P_κ) ≥ PLAN_MARGIN from the robust plan
        lam_e = _energy_lambda(prob, inv, best, params, lam)
        w_e, st = _energy(prob, inv, best, params, obj, kappa, lam_e, record)
        if st.exact >= kappa:
            result.w, result.lam = w_e, lam_e
    for name, variant in problem.comparisons:
        if variant is None or deadline.solve_expired():
            continue
        if variant.energy_weight == 0 and variant.forward_weight == 0:
            result.comparisons[name] = robust_w
            continue
        w_c, stats, f_, dt_ = _solve(
            prob, fill_aux(prob, inv, robust_w, params, lam),
            [lam, variant.robustness_weight, variant.energy_weight, variant.forward_weight],
            None, f"compare {name}", STAGE_ITER, PATIENCE, most_robust=False)
        record(f"compare {name}", lam, w_c, stats, f_, dt_)
        result.comparisons[name] = w_c
    return result


def _energy_lambda(prob: NlpProblem, inv: InverseData, w: np.ndarray, params: dict,
                   lam: float) -> float:
    """The smallest λ of the schedule from ``lam`` where ``w`` has ρ̃(P_κ) ≥ PLAN_MARGIN."""
    while lam * LAM_FACTOR <= LAM_MAX and \
            _planner_smooth(prob, inv, w, params, lam) < PLAN_MARGIN:
        lam *= LAM_FACTOR
    return lam


def _energy(prob: NlpProblem, inv: InverseData, w: np.ndarray, params: dict, obj, kappa: float,
            lam_e: float, record, limit: int = STAGE_ITER) -> tuple[np.ndarray, Stage]:
    """Paper A eq. 6 from ``w`` at λ = ``lam_e`` with ``w``'s branches: unconstrained, then
    with ρ̃(P_κ) ≥ PLAN_MARGIN only if that misses κ."""
    p_e = [lam_e, obj.robustness_weight, obj.energy_weight, obj.forward_weight]
    if inv.choice_nodes:
        inv.choice_values = choices.choose(inv.choice_nodes, trajectory_channels(w, inv),
                                           params, inv.grid.n, inv.planned, inv.grid.dt)
    w_e, stats, f_, dt_ = _solve(prob, fill_aux(prob, inv, w, params, lam_e), p_e, None,
                                 f"energy λ={lam_e:g}", limit, PATIENCE, most_robust=False)
    st = record("energy", lam_e, w_e, stats, f_, dt_)
    if st.exact < kappa and not deadline.solve_expired():
        w_e, stats, f_, dt_ = _solve(prob, fill_aux(prob, inv, w, params, lam_e), p_e,
                                     PLAN_MARGIN, f"energy ρ̃ ≥ {PLAN_MARGIN:g}",
                                     limit, PATIENCE, most_robust=False)
        st = record("energy (constrained)", lam_e, w_e, stats, f_, dt_)
    inv.choice_values = choices.written(inv.choice_nodes, inv.grid.n) if inv.choice_nodes else {}
    return w_e, st


def _warm_energy(prob: NlpProblem, inv: InverseData, w0: np.ndarray, params: dict, problem,
                 record) -> tuple[np.ndarray, float] | None:
    """Energy stage first (≤ 100 iterations) from a neighbour's plan: (plan, λ), None < κ."""
    lam = problem.smoothing.lam
    lam_e = _energy_lambda(prob, inv, w0, params, lam)
    if _planner_smooth(prob, inv, w0, params, lam_e) < PLAN_MARGIN:
        lam_e = min(lam * LAM_FACTOR, LAM_MAX)
    w_e, st = _energy(prob, inv, w0, params, problem.objective, problem.threshold, lam_e, record,
                      100)
    return (w_e, lam_e) if st.exact >= problem.threshold else None
