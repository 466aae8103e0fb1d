"""A binary program solved by HiGHS (``highspy``) with a warm start and a time limit.

``solve_binary`` is the one call the assignment MILP (``stlc.team.milp``) makes per lazy-cut
round.  Compared with going through cvxpy it can (a) hand HiGHS a known feasible solution
before the search (``start``: the heuristic routes of ``stlc.team.local``), so that branch
and bound prunes against a good incumbent from the first node, and (b) read, when the time
limit stops the search, both the best solution found and HiGHS's dual bound — a valid
lower bound of this round's model and so, the rounds being relaxations of the full
problem, of the full problem too.  Presolve is off (on these small models it costs more
than it saves; see ``milp.HIGHS_OPTIONS``).
"""

from __future__ import annotations

from dataclasses import dataclass

import highspy
import numpy as np
import scipy.sparse as sp


@dataclass
class Result:
    status: str  # "optimal" | "time" | "infeasible" | "error"
    x: np.ndarray | None  # best solution found (rounded), None if none
    objective: float
    bound: float  # dual bound (lower bound of the minimum); -inf if unknown


def solve_binary(cost: np.ndarray, integer: np.ndarray, a_eq: sp.csr_matrix, b_eq: np.ndarray,
                 a_ub: sp.csr_matrix | None, b_ub: np.ndarray | None, *,
                 time_limit: float | None = None, start: np.ndarray | None = None,
                 options: dict | None = None) -> Result:
    """Minimise ``cost·x`` over ``x ∈ [0, 1]`` (``integer`` marks the binaries; the other
    columns are continuous in [0, ∞)) subject to ``a_eq x = b_eq`` and ``a_ub x ≤ b_ub``."""
    n = len(cost)
    h = highspy.Highs()
    h.setOptionValue("output_flag", False)
    for k, v in (options or {}).items():
        h.setOptionValue(k, v)
    if time_limit is not None:
        h.setOptionValue("time_limit", max(float(time_limit), 1e-3))
    inf = highspy.kHighsInf
    ub = np.where(integer, 1.0, inf)
    h.addVars(n, np.zeros(n), ub)
    idx = np.arange(n, dtype=np.int32)
    h.changeColsCost(n, idx, np.asarray(cost, dtype=float))
    bin_idx = np.flatnonzero(integer).astype(np.int32)
    h.changeColsIntegrality(len(bin_idx), bin_idx,
                            np.array([highspy.HighsVarType.kInteger] * len(bin_idx)))
    for a, lo, hi in ((a_eq, b_eq, b_eq), (a_ub, None, b_ub)):
        if a is None or a.shape[0] == 0:
            continue
        a = sp.csr_matrix(a)
        lower = np.full(a.shape[0], -inf) if lo is None else np.asarray(lo, dtype=float)
        h.addRows(a.shape[0], lower, np.asarray(hi, dtype=float), a.nnz,
                  a.indptr[:-1].astype(np.int32), a.indices.astype(np.int32),
                  a.data.astype(float))
    if start is not None:
        sol = highspy.HighsSolution()
        sol.col_value = [float(v) for v in start]
        sol.value_valid = True
        h.setSolution(sol)
    h.run()
    status = h.getModelStatus()
    info = h.getInfo()
    found = info.primal_solution_status == 2  # kSolutionStatusFeasible
    x = np.round(np.asarray(h.getSolution().col_value)).astype(int) if found else None
    bound = float(info.mip_dual_bound) if np.isfinite(info.mip_dual_bound) else -np.inf
    obj = float(info.objective_function_value) if found else np.inf
    if status == highspy.HighsModelStatus.kOptimal:
        return Result("optimal", x, obj, obj)
    if status == highspy.HighsModelStatus.kInfeasible:
        return Result("infeasible", None, np.inf, np.inf)
    if status == highspy.HighsModelStatus.kTimeLimit:
        return Result("time", x, obj, bound)
    return Result("error", x, obj, bound)
