"""A binary program solved by HiGHS through cvxpy, with a time limit, a known assignment as
cutoff and fallback, and the dual bound when the limit stops the search.

``solve_binary`` is the one call the assignment MILP (``stlc.team.milp``) makes per lazy-cut
round.  The model is a cvxpy problem solved by HiGHS (``solver=cp.HIGHS``); on top of a
plain solve it

* takes a known feasible solution ``start`` (the heuristic routes of ``stlc.team.local``):
  its cost becomes HiGHS's ``objective_bound``, so branch and bound prunes every node that
  cannot beat it, and it is returned when the search finds nothing better in time (cvxpy
  has no MIP-start interface for HiGHS, so the start is a cutoff, not an incumbent);
* reads, when the time limit stops the search, the best solution found (cvxpy's
  ``user_limit`` keeps it) and HiGHS's dual bound (``solver_stats.extra_stats`` is HiGHS's
  ``HighsInfo``) — a valid lower bound of this round's model and so, the rounds being
  relaxations of the full problem, of the full problem too.

Presolve is off (on these small models it costs more than it saves; see
``milp.HIGHS_OPTIONS``).  HiGHS prints a banner when its first solver object is created;
``_quiet_banner`` creates that first object with stdout closed, so ``stlc -q`` stays quiet.
"""

from __future__ import annotations

import contextlib
import functools
import os
import sys
import warnings
from dataclasses import dataclass

import cvxpy as cp
import numpy as np
import scipy.sparse as sp

FEAS_TOL = 1e-6
MAX_TIME_S = 300.0  # the time limit of a HiGHS call that was given none (or an infinite one)


@dataclass
class Result:
    status: str  # "optimal" | "time" | "infeasible" | "error"
    x: np.ndarray | None  # best solution found (rounded), None if none
    objective: float
    bound: float  # dual bound (lower bound of the minimum); -inf if unknown


@functools.cache
def _quiet_banner() -> None:
    """Create HiGHS's first solver object (which prints the banner) with fd 1 on /dev/null."""
    import highspy

    sys.stdout.flush()
    saved = os.dup(1)
    try:
        with open(os.devnull, "w") as null:
            os.dup2(null.fileno(), 1)
            highspy.Highs()
    finally:
        os.dup2(saved, 1)
        os.close(saved)


def _feasible(x: np.ndarray, a_eq, b_eq, a_ub, b_ub) -> bool:
    ok = a_eq is None or a_eq.shape[0] == 0 or np.allclose(a_eq @ x, b_eq, atol=FEAS_TOL)
    return ok and (a_ub is None or a_ub.shape[0] == 0 or bool(np.all(a_ub @ x <= b_ub + FEAS_TOL)))


def solve_binary(cost: np.ndarray, integer: np.ndarray, a_eq: sp.csr_matrix, b_eq: np.ndarray,
                 a_ub: sp.csr_matrix | None, b_ub: np.ndarray | None, *,
                 time_limit: float | None = None, start: np.ndarray | None = None,
                 options: dict | None = None) -> Result:
    """Minimise ``cost·x`` over ``x ∈ [0, 1]`` (``integer`` marks the binaries; the other
    columns are continuous in [0, ∞)) subject to ``a_eq x = b_eq`` and ``a_ub x ≤ b_ub``.
    No solve runs without a time limit: ``None`` or an infinite one is ``MAX_TIME_S``."""
    if time_limit is None or not np.isfinite(time_limit):
        time_limit = MAX_TIME_S
    _quiet_banner()
    n = len(cost)
    cost = np.asarray(cost, dtype=float)
    integer = np.asarray(integer, dtype=bool)
    nb = int(integer.sum())
    xb = cp.Variable(nb, boolean=True) if nb else None
    xc = cp.Variable(n - nb, nonneg=True) if n - nb else None
    perm = np.concatenate([np.flatnonzero(integer), np.flatnonzero(~integer)])
    place = sp.csr_matrix((np.ones(n), (perm, np.arange(n))), shape=(n, n))  # x = P [xb; xc]
    x = place @ cp.hstack([v for v in (xb, xc) if v is not None])
    cons = []
    if a_eq is not None and a_eq.shape[0]:
        cons.append(sp.csr_matrix(a_eq) @ x == np.asarray(b_eq, dtype=float))
    if a_ub is not None and a_ub.shape[0]:
        cons.append(sp.csr_matrix(a_ub) @ x <= np.asarray(b_ub, dtype=float))
    opts = dict(options or {})
    if time_limit is not None:
        opts["time_limit"] = max(float(time_limit), 1e-3)
    known = None
    if start is not None:
        s = np.round(np.asarray(start, dtype=float))
        if _feasible(s, a_eq, b_eq, a_ub, b_ub):
            known = (s.astype(int), float(cost @ s))
            opts["objective_bound"] = known[1] + 1e-6
    prob = cp.Problem(cp.Minimize(cost @ x), cons)
    with warnings.catch_warnings(), contextlib.suppress(cp.error.SolverError):
        warnings.simplefilter("ignore", UserWarning)  # a time-limited solve is judged below
        prob.solve(solver=cp.HIGHS, **opts)
    info = prob.solver_stats.extra_stats if prob.solver_stats is not None else None
    dual = float(getattr(info, "mip_dual_bound", -np.inf))
    bound = dual if np.isfinite(dual) else -np.inf
    found = x.value is not None and prob.status in (cp.OPTIMAL, cp.OPTIMAL_INACCURATE,
                                                    cp.USER_LIMIT)
    xv = np.round(np.asarray(x.value)).astype(int) if found else None
    obj = float(cost @ xv) if xv is not None else np.inf
    if known is not None and (xv is None or known[1] <= obj):
        xv, obj = known  # nothing better than the known assignment was found
    if prob.status == cp.OPTIMAL:
        return Result("optimal", xv, obj, obj)
    if prob.status in (cp.INFEASIBLE, cp.INFEASIBLE_INACCURATE):
        if known is not None:  # pruned by the cutoff: the known assignment is optimal
            return Result("optimal", known[0], known[1], known[1])
        return Result("infeasible", None, np.inf, np.inf)
    if prob.status == cp.USER_LIMIT or (time_limit is not None and xv is not None):
        return Result("time", xv, obj, bound)
    return Result("error", xv, obj, bound)


def solve_mip(cost: np.ndarray, integer: np.ndarray, upper: np.ndarray, a: sp.csc_matrix,
              row_lo: np.ndarray, row_hi: np.ndarray, *, time_limit: float,
              start: np.ndarray | None = None, options: dict | None = None) -> Result:
    """Minimise ``cost·x`` over ``0 ≤ x ≤ upper`` (``integer`` marks the integer columns),
    ``row_lo ≤ a x ≤ row_hi``, with HiGHS through ``highspy`` directly (no cvxpy): a model of
    ~10⁵ columns is passed as one CSC matrix (cvxpy's canonicalisation of it took longer
    than the solve), ``start`` is a real MIP start (``setSolution``: HiGHS keeps it as its
    first incumbent, which cvxpy cannot pass), and the time limit, the incumbent and the dual
    bound come from HiGHS's own status and info.  ``time_limit`` is mandatory."""
    import highspy

    _quiet_banner()
    h = highspy.Highs()
    h.setOptionValue("output_flag", False)
    h.setOptionValue("time_limit", min(max(float(time_limit), 1e-3), MAX_TIME_S))
    h.setOptionValue("mip_rel_gap", 1e-6)
    h.setOptionValue("threads", 1)
    for k, v in (options or {}).items():
        h.setOptionValue(k, v)
    a = sp.csc_matrix(a)
    lp = highspy.HighsLp()
    lp.num_col_, lp.num_row_ = a.shape[1], a.shape[0]
    lp.col_cost_ = np.asarray(cost, dtype=float)
    lp.col_lower_ = np.zeros(a.shape[1])
    lp.col_upper_ = np.asarray(upper, dtype=float)
    lp.row_lower_ = np.asarray(row_lo, dtype=float)
    lp.row_upper_ = np.asarray(row_hi, dtype=float)
    lp.a_matrix_.format_ = highspy.MatrixFormat.kColwise
    lp.a_matrix_.start_ = a.indptr.astype(np.int32)
    lp.a_matrix_.index_ = a.indices.astype(np.int32)
    lp.a_matrix_.value_ = a.data.astype(float)
    lp.a_matrix_.num_col_, lp.a_matrix_.num_row_ = a.shape[1], a.shape[0]
    lp.integrality_ = [highspy.HighsVarType.kInteger if i else highspy.HighsVarType.kContinuous
                       for i in np.asarray(integer, dtype=bool)]
    h.passModel(lp)
    if start is not None:
        sol = highspy.HighsSolution()
        sol.col_value = list(np.asarray(start, dtype=float))
        sol.value_valid = True
        h.setSolution(sol)
    h.run()
    status = h.getModelStatus()
    info = h.getInfo()
    ms = highspy.HighsModelStatus
    has_x = info.primal_solution_status == 2  # kSolutionStatusFeasible
    x = np.asarray(h.getSolution().col_value) if has_x else None
    obj = float(cost @ x) if x is not None else np.inf
    bound = float(info.mip_dual_bound) if np.isfinite(info.mip_dual_bound) else -np.inf
    if status == ms.kOptimal:
        return Result("optimal", x, obj, obj)
    if status == ms.kInfeasible:
        return Result("infeasible", None, np.inf, np.inf)
    if status in (ms.kTimeLimit, ms.kInterrupt, ms.kSolutionLimit, ms.kIterationLimit):
        return Result("time", x, obj, bound)
    return Result("error", x, obj, bound)
