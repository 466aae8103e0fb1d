"""Solve schedule for the CasADi backend (the initial guess: ``kinematic``).

**What is optimised.**  The NLP maximises the smooth robustness of the *planner form*
``P_κ(f)`` (``nlp.expr.planner_form``): each predicate margin m becomes a smooth margin
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
ρ̃(P_κ) ≥ ``PLAN_MARGIN`` (paper A eq. 6).  Without energy or forward-speed terms (a point
mass), a last stage smooths the plan's inputs at the robustness it has (``smoothing``).

**Energy first.**  With an energy (or forward-speed) objective, that energy solve runs first,
straight from the seed's guess with the seed's choices, at the smallest λ where the guess
has ρ̃(P_κ) ≥ ``PLAN_MARGIN`` (``ENERGY_FIRST``); the robustness schedule above runs only if
its plan misses κ, from the same guess.  The seed is global (``milp.seed``) and already
inside the class the robustness stage used to find, so that stage mostly re-did the seed's
work.  A robustness-only ``compare`` plan is solved as the robustness stage's first solve
would have been (from the guess, with its choices: ``_compare``) — in a forked child while
the energy stage runs (``COMPARE_APART``), since it does not depend on the energy plan.
A sweep's instance started from a neighbour's plan (``warm``) whose energy stage misses κ
stops there: the pipeline plans it again from its own MILP seed
(``library.LibrarySeed.next_seed``), as its compile would.
"""

from __future__ import annotations

import sys
import time

import numpy as np

from stlc import deadline, interrupt, vehicles
from stlc.backends.nlp import choices, smoothing
from stlc.planning import words
from stlc.backends.base import SolverStatus
from stlc.backends.nlp.model import (
    FEASIBLE_DEFECT,
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
from stlc.backends.nlp.kinematic import kinematic_guess, path_channels  # noqa: F401 (re-exported)
from stlc.planning.problem import PlanningProblem
from stlc.semantics import model, reads

LAM_FACTOR = 3.0
LAM_MAX = 300.0
FIRST_STAGE_ITER = 200
STAGE_ITER = 300
PATIENCE = 10**9  # stages end on IPOPT's own tests (or the iteration limit), not on ours
MAX_LAM_STAGES = 4
#: the robustness stage first keeps the seed's choices (``choices``: the branch of every
#: disjunction and the sample of every window, from the full guess), then — only if that
#: plan misses κ — solves the formula as written from it.  Fixed choices take the smooth
#: max's negative curvature out of the Hessian: robustness stages of four handovers
#: 61/56/113/89 → 65/27/32/47 iterations, with fewer regularised ones (~50 vs ~70 ms each)
SEED_CHOICES = True
#: a mission with an energy objective goes to the energy stage (paper A eq. 6) straight from
#: the seed, with the seed's choices; the robustness schedule runs only if that plan misses
#: κ.  On 14 handovers (3 shipped, 8 random, 3 unseen): all satisfied, NLP iterations median
#: 65 → 32, energy equal or lower (−0.3 % median)
ENERGY_FIRST = True
#: an energy-first mission's robustness-only ``compare`` plans start from the seed's guess,
#: not from the energy plan, so they are solved in a forked child (``apart``, one core)
#: while the energy stage runs on the other, and recorded after it (the shipped handovers:
#: 19–35 iterations, 1.5–3 s, off the critical path)
COMPARE_APART = True


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
           label: str, limit: int, patience: int = 10**9, most_robust: bool = True,
           jerk: float = 0.0) -> tuple[np.ndarray, dict, float, float]:
    """One IPOPT solve.  With ``most_robust`` the result is the dynamically feasible iterate
    with the best exact robustness (IPOPT's last iterate when that is as good); otherwise
    the last iterate if it is feasible and satisfying, else the best one.  ``p``: (λ, w_ρ,
    w_E, w_F); ``jerk``: the input-change weight (``smoothing``), the last parameter."""
    lbg = prob.lbg.copy()
    if kappa is not None:
        lbg[prob.kappa_row] = kappa
    p = list(p) + choice_params(prob.inv) + param_values(prob.inv) + [jerk]
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
    # a kept iterate was verified feasible; IPOPT's last one is only if its dynamics rows are
    g = np.asarray(sol["g"]).ravel()[:prob.n_dyn]
    stats["feasible"] = bool("best_iterate" in stats or not g.size
                             or np.max(np.abs(g)) <= FEASIBLE_DEFECT)
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

    def record(label, lam_, w_, stats, f_, dt_, ran=None):
        # ``ran``: (verify seconds, timed out) of a solve that ran apart (else this process's)
        t_verify, timed_out = ran or (prob.progress.t_verify, prob.progress.timed_out)
        ch = trajectory_channels(w_, inv)
        exact = exact_robustness(inv.formula, inv, w_, params)
        sm = float(smooth.smooth_robustness(inv.formula, inv.grid.dt, ch, params, lam_, method))
        ret = stats.get("return_status", "")
        status = STATUS_MAP.get(ret, SolverStatus.FAILED)
        if status == SolverStatus.MAX_ITER and "best_iterate" in stats:
            status = SolverStatus.STOPPED
        if timed_out:  # stopped by the run's time limit (stlc.deadline)
            status = SolverStatus.MAX_TIME
        t_fn = sum(v for k, v in stats.items() if k.startswith("t_wall_nlp_"))
        st = Stage(label, lam_, int(stats.get("iter_count", 0)), status, sm, exact, dt_, f_,
                   t_fn, t_verify,
                   converged=status.converged,
                   planner=_planner_smooth(prob, inv, w_, params, lam_),
                   regularizations=_regularizations(stats),
                   feasible=bool(stats.get("feasible", True)))
        stages.append(st)
        if not quiet:
            print(f"  {label}: λ = {lam_:g}, {st.iterations} iterations, {st.status}"
                  f"{' (converged)' if st.converged else ''}, planner ρ̃ {words.number(st.planner)}, "
                  f"exact ρ {words.number(exact)} ({dt_:.2f} s)", file=sys.stderr)
        return st

    if (warm or ENERGY_FIRST) and (obj.energy_weight > 0 or obj.forward_weight > 0):
        ahead = None  # the robustness-only compare plans, solved apart from the guess
        if not warm and COMPARE_APART and any(
                v is not None and _only_rho(v) for _, v in problem.comparisons):
            from stlc import apart

            ahead = apart.start(_guess_compares, prob, inv, problem, w0)
        try:
            done = _warm_energy(prob, inv, w0, params, problem, record, retry=not warm)
        except BaseException:
            if ahead is not None:
                ahead.cancel()
            raise
        w_e, lam_e, met = done
        if met:
            result = RawResult(w_e, lam_e, stages)
            smoothing.stage(prob, inv, problem, result, _solve, record)
            if not warm:  # (a sweep's instance has no `compare` plans)
                _compare(prob, inv, problem, result, w_e, lam_e, record, guess=w0,
                         ahead=ahead()[0] if ahead is not None else None)
            return result
        if warm:  # a neighbour's plan, in the class another instance's seed chose: not
            # the robustness schedule from it (up to 675 iterations on unseen sweep
            # instances, two ending violated) but this instance's own seed
            # (``LibrarySeed.next_seed``)
            return RawResult(w_e, lam_e, stages)
        if ahead is not None:  # the robustness schedule below solves those plans itself
            ahead.cancel()
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
        if best_st is None or st.score() > best_st.score():
            best, best_st = w, st
        if st.meets(kappa) or lam * LAM_FACTOR > LAM_MAX or deadline.solve_expired():
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
    if (obj.energy_weight > 0 or obj.forward_weight > 0) and best_st.meets(kappa) \
            and not deadline.solve_expired():
        # 2. paper A eq. 6 on the planner form: minimise w·E − ρ̃(P_κ), at the smallest λ of
        #    the schedule where the robust plan has ρ̃(P_κ) ≥ PLAN_MARGIN.  First without the
        #    constraint (−ρ̃ in the objective already keeps the plan away from ρ̃ < 0, and IPOPT
        #    converges; with it active, the Hessian needs heavy regularisation), then, only if
        #    the exact monitor finds ρ < κ, with ρ̃(P_κ) ≥ PLAN_MARGIN from the robust plan
        lam_e = _energy_lambda(prob, inv, best, params, lam)
        w_e, st = _energy(prob, inv, best, params, obj, kappa, lam_e, record)
        if st.meets(kappa):
            result.w, result.lam = w_e, lam_e
    if best_st.meets(kappa):
        smoothing.stage(prob, inv, problem, result, _solve, record)
    _compare(prob, inv, problem, result, robust_w, lam, record, robust=robust_w)
    return result


def _compare(prob: NlpProblem, inv: InverseData, problem, result: RawResult, start: np.ndarray,
             lam: float, record, robust: np.ndarray | None = None,
             guess: np.ndarray | None = None, ahead: dict | None = None) -> None:
    """The mission's ``compare`` plans, each solved from ``start`` at λ with the variant's
    weights.  A robustness-only variant is ``robust`` (the robustness stage's plan) when the
    schedule solved one; else it is solved as that stage's first solve would have: from the
    seed's ``guess`` with its choices, at the mission's λ (handover_left_tb: 19 iterations;
    from the energy plan without them, 69) — or taken from ``ahead``, where
    ``_guess_compares`` solved it the same way in a child while the energy stage ran."""
    for name, variant in problem.comparisons:
        if variant is None:
            continue
        if _only_rho(variant) and robust is not None:
            result.comparisons[name] = robust
            continue
        if ahead and name in ahead:
            lam_c, w_c, stats, f_, dt_, ran = ahead[name]
            record(f"compare {name}", lam_c, w_c, stats, f_, dt_, ran)
            result.comparisons[name] = w_c
            continue
        if deadline.solve_expired():
            continue
        lam_c, w_c, stats, f_, dt_ = _compare_one(prob, inv, problem, name, variant, start,
                                                  lam, guess)
        record(f"compare {name}", lam_c, w_c, stats, f_, dt_)
        result.comparisons[name] = w_c


def _only_rho(variant) -> bool:
    return variant.energy_weight == 0 and variant.forward_weight == 0


def _compare_one(prob: NlpProblem, inv: InverseData, problem, name: str, variant,
                 start: np.ndarray, lam: float, guess: np.ndarray | None):
    """One ``compare`` solve (see ``_compare``): (λ, plan, IPOPT stats, objective, s)."""
    only_rho = _only_rho(variant)
    w, lam_c = start, lam
    if only_rho:
        w, lam_c = guess, problem.smoothing.lam
        if inv.choice_nodes and SEED_CHOICES:
            inv.choice_values = choices.choose(inv.choice_nodes, trajectory_channels(w, inv),
                                               problem.params, inv.grid.n, inv.planned,
                                               inv.grid.dt)
    weights = [max(variant.robustness_weight, 1.0) if only_rho else
               variant.robustness_weight, variant.energy_weight, variant.forward_weight]
    w_c, stats, f_, dt_ = _solve(prob, fill_aux(prob, inv, w, problem.params, lam_c),
                                 [lam_c, *weights], None, f"compare {name}", STAGE_ITER,
                                 PATIENCE, most_robust=only_rho)
    if inv.choice_nodes:
        inv.choice_values = choices.written(inv.choice_nodes, inv.grid.n)
    return lam_c, w_c, stats, f_, dt_


def _guess_compares(prob: NlpProblem, inv: InverseData, problem, guess: np.ndarray) -> dict:
    """The robustness-only ``compare`` plans from the seed's ``guess`` (``_compare_one``), as
    a forked child runs them beside the energy stage (``COMPARE_APART``): per name (λ, plan,
    IPOPT stats, objective, s, (verify s, timed out)).  Quiet: the parent prints each one's
    line when it records it."""
    quiet, prob.progress.quiet = prob.progress.quiet, True
    out = {}
    try:
        for name, variant in problem.comparisons:
            if variant is None or not _only_rho(variant) or deadline.solve_expired():
                continue
            lam_c, w_c, stats, f_, dt_ = _compare_one(prob, inv, problem, name, variant,
                                                      guess, problem.smoothing.lam, guess)
            out[name] = (lam_c, w_c, stats, f_, dt_,
                         (prob.progress.t_verify, prob.progress.timed_out))
    finally:
        prob.progress.quiet = quiet
    return out


def _energy_lambda(prob: NlpProblem, inv: InverseData, w: np.ndarray, params: dict,
                   lam: float) -> float:
    """The smallest λ of the schedule from ``lam`` where ``w`` has ρ̃(P_κ) ≥ PLAN_MARGIN."""
    while lam * LAM_FACTOR <= LAM_MAX and \
            _planner_smooth(prob, inv, w, params, lam) < PLAN_MARGIN:
        lam *= LAM_FACTOR
    return lam


def _energy(prob: NlpProblem, inv: InverseData, w: np.ndarray, params: dict, obj, kappa: float,
            lam_e: float, record, limit: int = STAGE_ITER, retry: bool = True
            ) -> tuple[np.ndarray, Stage]:
    """Paper A eq. 6 from ``w`` at λ = ``lam_e`` with ``w``'s branches: unconstrained, then
    (``retry``) with ρ̃(P_κ) ≥ PLAN_MARGIN only if that misses κ."""
    p_e = [lam_e, obj.robustness_weight, obj.energy_weight, obj.forward_weight]
    if inv.choice_nodes:
        inv.choice_values = choices.choose(inv.choice_nodes, trajectory_channels(w, inv),
                                           params, inv.grid.n, inv.planned, inv.grid.dt)
    w_e, stats, f_, dt_ = _solve(prob, fill_aux(prob, inv, w, params, lam_e), p_e, None,
                                 f"energy λ={lam_e:g}", limit, PATIENCE, most_robust=False)
    st = record("energy", lam_e, w_e, stats, f_, dt_)
    if retry and not st.meets(kappa) and not deadline.solve_expired():
        w_e, stats, f_, dt_ = _solve(prob, fill_aux(prob, inv, w, params, lam_e), p_e,
                                     PLAN_MARGIN, f"energy ρ̃ ≥ {PLAN_MARGIN:g}",
                                     limit, PATIENCE, most_robust=False)
        st = record("energy (constrained)", lam_e, w_e, stats, f_, dt_)
    inv.choice_values = choices.written(inv.choice_nodes, inv.grid.n) if inv.choice_nodes else {}
    return w_e, st


def _warm_energy(prob: NlpProblem, inv: InverseData, w0: np.ndarray, params: dict, problem,
                 record, retry: bool = True) -> tuple[np.ndarray, float, bool]:
    """Energy stage first (≤ 100 iterations) from ``w0`` — a neighbour's plan (a sweep) or the
    seed's guess (``ENERGY_FIRST``): (plan, λ, whether it meets κ).  ``retry``: then
    the constrained energy stage from ``w0`` too — not from a neighbour's plan, whose class
    is the MILP seed's choice for *another* instance (a sweep instance of `handover_left_tb`:
    the constrained stage ran 90 iterations to its limit with no feasible iterate); that
    instance is planned from its own seed instead (``solve_mission``)."""
    lam = problem.smoothing.lam
    lam_e = _energy_lambda(prob, inv, w0, params, lam)
    if _planner_smooth(prob, inv, w0, params, lam_e) < PLAN_MARGIN:
        lam_e = min(lam * LAM_FACTOR, LAM_MAX)
    w_e, st = _energy(prob, inv, w0, params, problem.objective, problem.threshold, lam_e, record,
                      100, retry)
    return w_e, lam_e, st.meets(problem.threshold)
