"""The smoothest of the robust plans of a team without an energy objective (a point mass).

A point mass has no energy term, so the NLP minimises ``−w_ρ·ρ̃ + r·Σ‖u‖²/N`` with a tiny
``r`` (``model.INPUT_REG``): its accelerations sit at their bounds and switch often
(bang-bang), which no tracker follows.  The exact MILP's plan has the same defect and the
same fix (``milp/jerk.py``: an LP keeping its choices and ρ̂).  Here, after the schedule's
plan (planner robustness ρ̃*, exact ρ*), ``stage`` re-solves the same NLP — not rebuilt: the
input-change weight ``w_J`` is one of its parameters (``model.build``) — warm-started from
the plan, with the plan's branch of every disjunction and sample of every window
(``choices.choose``, as the energy stage), with ``w_ρ = 0, w_J = 1``, i.e. minimising

    J = Σ_k ‖(u_{k+1} − u_k) / u_max‖² / (N − 1)

(O(1): one full switch of one axis adds 4/(N − 1)) subject to ρ̃ ≥ ρ̃* − δ on the κ row
(the mechanism the constrained energy stage uses for ρ̃ ≥ ``PLAN_MARGIN``), with
δ = ``GIVE``·(ρ̃* − PLAN_MARGIN): the bound stays above PLAN_MARGIN, so ρ ≥ κ still holds
by construction, and the robustness given away is a small share of the margin.  Without
any give the start sits on the bound, where an interior-point method starts badly.

The smoothed plan replaces the schedule's only if the exact monitor says it meets κ and its
exact ρ is at least ρ* − ``RHO_TOL``·(ρ* − κ); otherwise the schedule's plan stays and the
solution's notes say why.  The stage runs within the run's time limit (``stlc.deadline``:
none starts once the solvers' share is spent, and IPOPT's callback stops one that runs
past it) and at most ``ITER`` iterations.  ``SMOOTH`` switches it off.
"""

from __future__ import annotations

import numpy as np

from stlc import deadline
from stlc.backends.nlp import choices
from stlc.backends.nlp.model import (
    PLAN_MARGIN,
    InverseData,
    NlpProblem,
    RawResult,
    exact_robustness,
    fill_aux,
    lowering_channels,
    trajectory_channels,
)
from stlc.planning import words

SMOOTH = True  #: smooth the plans of NLPs without energy or forward-speed terms
GIVE = 0.05  #: share of ρ̃* − PLAN_MARGIN the smoothing may give away on the κ row
RHO_TOL = 0.1  #: the smoothed plan's exact ρ may be this share of ρ* − κ below ρ*
ITER = 100  #: iteration limit of the stage
LABEL = "smooth"


def input_change(prob: NlpProblem, inv: InverseData, w: np.ndarray) -> float:
    """J of ``w`` (module doc): the squared input change in units of each input's bound,
    per interval, summed over the team — the term the stage minimises."""
    total = 0.0
    for L in inv.layouts:
        nu, N = L.nu, inv.grid.n_intervals
        U = np.asarray(w[L.u_slice]).reshape(N, nu)
        scale = np.maximum(np.abs(prob.lbx[L.u_slice][:nu]), np.abs(prob.ubx[L.u_slice][:nu]))
        scale = np.where(np.isfinite(scale) & (scale > 0), scale, 1.0)
        total += float(np.sum((np.diff(U, axis=0) / scale) ** 2)) / max(N - 1, 1)
    return total


def applies(prob: NlpProblem) -> bool:
    return SMOOTH and prob.smoothable


def stage(prob: NlpProblem, inv: InverseData, problem, result: RawResult, solve,
          record) -> None:
    """The smoothing stage on ``result`` (module doc), in place: ``solve`` and ``record``
    are the schedule's one-solve function and stage recorder."""
    if not applies(prob) or deadline.solve_expired():
        return
    params, kappa, lam = problem.params, problem.threshold, result.lam
    w = result.w
    rho = exact_robustness(inv.formula, inv, w, params)
    if not rho >= kappa:
        return  # nothing to keep: the schedule's plan misses κ
    least = rho - RHO_TOL * (rho - kappa)
    if inv.choice_nodes:
        inv.choice_values = choices.choose(inv.choice_nodes, trajectory_channels(w, inv),
                                           params, inv.grid.n, inv.planned, inv.grid.dt)
    # the solve keeps its last iterate if it has ρ ≥ least, else the verified iterate
    # with ρ ≥ least and the least objective (``model.Progress``, mode "objective")
    kept, prob.progress.kappa = prob.progress.kappa, least
    try:
        w0 = fill_aux(prob, inv, w, params, lam)
        planner = float(prob.lowered.init_values(lowering_channels(w0, inv), params, lam)[1])
        floor = planner - GIVE * max(planner - PLAN_MARGIN, 0.0)
        w_s, stats, f_, dt_ = solve(prob, w0, [lam, 0.0, 0.0, 0.0], floor, LABEL, ITER,
                                    most_robust=False, jerk=1.0)
        st = record(LABEL, lam, w_s, stats, f_, dt_)
    finally:
        prob.progress.kappa = kept
        if inv.choice_nodes:
            inv.choice_values = choices.written(inv.choice_nodes, inv.grid.n)
    j0, j1 = input_change(prob, inv, w), input_change(prob, inv, w_s)
    if st.feasible and st.exact >= kappa and st.exact >= least and j1 < j0:
        result.w = w_s
        return
    why = ("it does not meet the dynamics" if not st.feasible else
           f"its exact ρ {words.number(st.exact)} is below "
           + (f"κ = {kappa:g}" if st.exact < kappa else
              f"{words.number(least)} (ρ = {words.number(rho)} less {RHO_TOL:g}·(ρ − κ))")
           if st.exact < least else "no iterate that keeps ρ changes the inputs less")
    result.notes.append(f"the smoothed plan (least input change, `{LABEL}` stage) was not "
                        f"kept: {why}; the plan is the schedule's (input change {j0:.3g}, "
                        f"smoothed {j1:.3g})")
