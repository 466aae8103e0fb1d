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
δ = ``GIVES[0]``·max(ρ̃* − PLAN_MARGIN, 0): a bound above PLAN_MARGIN keeps ρ ≥ κ by
construction, and the robustness given away is a small share of the margin (without any
give the start sits on the bound, where an interior-point method starts badly).  A plan
with ρ̃* below PLAN_MARGIN (its ρ ≥ κ is the exact monitor's, at a λ whose smoothing gap
exceeds the margins) keeps ρ̃ ≥ ρ̃*: the monitor's check below is then what holds κ.

The planner form's margins are scaled per predicate, so ρ̃ ≥ ρ̃* − δ does not hold the exact
ρ: a plan whose ρ̃* is pinned by one scaled margin (a start near a wall of a large workspace)
may give away exact robustness elsewhere.  So of the solve's verified iterates the one kept
is the last if its exact ρ is at least ρ* − ``RHO_TOL``·(ρ* − κ), else the one with the
least objective among those that are (``model.Progress``, mode "objective"); it replaces
the schedule's plan only if it meets κ, keeps that ρ and changes the inputs less —
otherwise, if it fell below that ρ, the stage solves once more with the smaller δ of
``GIVES[1]`` (``tests/missions/survey_sphere.stl``, ρ* = 0.346: δ 0.05 → 0.02 gives ρ
0.329 → 0.337 and Σ|Δa| 46 → 55 m/s², against 73 unsmoothed), and if that fails too the schedule's plan
stays and the solution's notes say why.  A plan without input
changes (J ≤ ``STILL``) gets no stage.  The stage runs within the run's time limit
(``stlc.deadline``: none starts once the solvers' share is spent, and IPOPT's callback
stops one that runs past it) and at most ``ITER`` iterations.  ``SMOOTH`` switches it off.

Measured (2-core machine, load ≈ 2): ``specs/tower_inspection.stl`` 17 iterations, 0.03 s,
Σ|Δa| 32.1 → 14.5 m/s², ρ 0.399 → 0.397; a 60 s point-mass patrol with a speed bound
(the ``knots`` chain, 121 knots) 36 iterations, 2 s, max |Δa| 0.21 → 0.06 m/s².
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
#: shares of ρ̃* − PLAN_MARGIN the smoothing may give away on the κ row: the second only
#: if the first one's plan gives away too much exact robustness
GIVES = (0.05, 0.02)
RHO_TOL = 0.05  #: the smoothed plan's exact ρ may be this share of ρ* − κ below ρ*
ITER = 100  #: iteration limit of the stage
LABEL = "smooth"
STILL = 1e-9  #: a plan whose input change J is at most this is left as it is


def input_change(prob: NlpProblem, w: np.ndarray) -> float:
    """J of ``w`` (module doc): the squared input change in units of each input's bound,
    per interval, summed over the team — the term the stage minimises (``model.build``'s
    own expression of it)."""
    return float(prob.jerk_fn(w))


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
    j0 = input_change(prob, w)
    if not rho >= kappa or j0 <= STILL:
        return  # nothing to keep (the plan misses κ) or nothing to smooth
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
        for i, give in enumerate(GIVES):  # a tighter bound only if the looser one fails
            if i and deadline.solve_expired():
                break
            label = LABEL if i == 0 else f"{LABEL} (δ × {give / GIVES[0]:g})"
            floor = planner - give * max(planner - PLAN_MARGIN, 0.0)
            w_s, stats, f_, dt_ = solve(prob, w0, [lam, 0.0, 0.0, 0.0], floor, label, ITER,
                                        most_robust=False, jerk=1.0)
            st = record(label, lam, w_s, stats, f_, dt_)
            j1 = input_change(prob, w_s)
            if st.feasible and st.exact >= kappa and st.exact >= least and j1 < j0:
                result.w = w_s
                return
            if not st.exact < least:
                break  # it kept ρ but not smoother: a tighter bound would not be either
    finally:
        prob.progress.kappa = kept
        if inv.choice_nodes:
            inv.choice_values = choices.written(inv.choice_nodes, inv.grid.n)
    why = ("it does not meet the dynamics" if not st.feasible else
           f"its exact ρ {words.number(st.exact)} is below "
           + (f"κ = {kappa:g}" if st.exact < kappa else
              f"{words.number(least)} (ρ = {words.number(rho)} less {RHO_TOL:g}·(ρ − κ))")
           if st.exact < least else "no iterate that keeps ρ changes the inputs less")
    result.notes.append(f"the smoothed plan (least input change, `{LABEL}` stage) was not "
                        f"kept: {why}; the plan is the schedule's (input change {j0:.3g}, "
                        f"smoothed {j1:.3g})")
