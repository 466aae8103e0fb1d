"""The HiGHS adapter: every use of ``highspy`` (and of cvxpy's HiGHS interface).

* ``STATUS_MAP``: HiGHS's model status strings → the shared ``SolverStatus``;
* ``Result``: what every HiGHS run returns — the shared status, HiGHS's own status string,
  the incumbent, its objective, the dual bound, gap, nodes and wall time;
* ``Highs``: one model of a MILP built column by column (``stlc.backends.milp.model``),
  solved again after changing bounds, with a MIP start and the feasibility-only options;
* ``IncrementalLp``: an LP grown by rows and columns, re-solved warm (column generation's
  restricted master, ``stlc.team.colgen``);
* ``solve_mip``: one MILP given as a CSC matrix, with a time limit and a MIP start
  (``stlc.team.partition``, ``stlc.team.colgen``);
* ``solve_binary``: a binary program solved by HiGHS through cvxpy, with a known assignment
  as cutoff and fallback (``stlc.team.lazy``): its cost becomes HiGHS's ``objective_bound``,
  so branch and bound prunes every node that cannot beat it, and it is returned when the
  search finds nothing better in time (cvxpy has no MIP-start interface for HiGHS); when the
  time limit stops the search, cvxpy's ``user_limit`` keeps the best solution found and
  ``solver_stats.extra_stats`` (HiGHS's ``HighsInfo``) gives the dual bound.

No run is without a time limit: ``None`` or an infinite one is ``MAX_TIME_S``.  HiGHS
prints a banner when its first solver object is created; ``quiet_banner`` creates that
first object with stdout closed, so ``stlc -q`` (and a user's pipe) stays clean.
"""

from __future__ import annotations

import contextlib
import functools
import os
import sys
import time
import warnings
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from stlc.solvers.status import SolverStatus

FEAS_TOL = 1e-6
MAX_TIME_S = 300.0  # the time limit of a HiGHS call that was given none (or an infinite one)

#: HiGHS's model status (``modelStatusToString``) → the shared status
STATUS_MAP = {
    "Optimal": SolverStatus.OPTIMAL,
    "Time limit reached": SolverStatus.MAX_TIME,
    "Iteration limit reached": SolverStatus.MAX_ITER,
    "Infeasible": SolverStatus.INFEASIBLE,
    "Primal infeasible or unbounded": SolverStatus.INFEASIBLE,
    "Interrupted by user": SolverStatus.INTERRUPTED,
    "Solve error": SolverStatus.FAILED,
    "Unbounded": SolverStatus.FAILED,
}


@dataclass
class Result:
    status: SolverStatus  # the shared status
    x: np.ndarray | None  # the incumbent (None: none found)
    objective: float  # of the incumbent, in the model's (minimisation) sense
    bound: float  # dual bound (a lower bound of the minimum); -inf if unknown
    gap: float = float("nan")
    nodes: int = 0
    wall_s: float = 0.0
    highs_status: str = ""  # HiGHS's own model status, e.g. "Infeasible", "Time limit reached"


@contextlib.contextmanager
def stdout_closed():
    """HiGHS prints its banner on its first object; keep stdout (a user's pipe) clean."""
    sys.stdout.flush()
    saved = os.dup(1)
    try:
        with open(os.devnull, "w") as null:
            os.dup2(null.fileno(), 1)
            yield
    finally:
        sys.stdout.flush()
        os.dup2(saved, 1)
        os.close(saved)


@functools.cache
def quiet_banner() -> None:
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


#: HiGHS options for a MILP that only looks for a feasible point (the MILP seed's first
#: phase): no RINS/RENS sub-MIPs and no restart.  Measured on 20 handovers' seeds:
#: 28.7 → 16.6 s in all, the slowest 5.7 → 1.4 s; the sub-MIPs took two thirds of the
#: time and the point was found by the tree search (under another random seed: 19.9 → 15.3 s)
FEASIBILITY_OPTIONS = {"mip_heuristic_run_rins": False, "mip_heuristic_run_rens": False,
                       "mip_allow_restart": False}


class Highs:
    """One HiGHS model of a ``Milp`` (``stlc.backends.milp.model``: ``n_cols``, ``lo``, ``hi``,
    ``integer``, ``rows``, ``matrix()``) with the objective ``cost``; ``solve`` may be called
    again after ``set_row_bounds`` (the model is not rebuilt).  ``feasibility``: the
    ``FEASIBILITY_OPTIONS`` (a search for one feasible point)."""

    def __init__(self, m, cost: dict[int, float], *, time_limit: float | None = None,
                 rel_gap: float = 1e-9, abs_gap: float = 1e-9, feasibility: bool = False):
        import highspy

        with stdout_closed():
            self.h = h = highspy.Highs()
        h.setOptionValue("output_flag", False)
        h.setOptionValue("threads", 1)
        h.setOptionValue("mip_rel_gap", rel_gap)
        h.setOptionValue("mip_abs_gap", abs_gap)
        h.setOptionValue("mip_feasibility_tolerance", 1e-9)
        h.setOptionValue("primal_feasibility_tolerance", 1e-9)
        if time_limit is not None:
            h.setOptionValue("time_limit", float(max(time_limit, 0.01)))
        for k, v in (FEASIBILITY_OPTIONS.items() if feasibility else ()):
            h.setOptionValue(k, v)
        lp = highspy.HighsLp()
        n = m.n_cols
        lp.num_col_, lp.num_row_ = n, len(m.rows)
        c = np.zeros(n)
        for j, v in cost.items():
            c[j] += v
        lp.col_cost_ = c
        lp.col_lower_ = np.asarray(m.lo, dtype=float)
        lp.col_upper_ = np.asarray(m.hi, dtype=float)
        lp.row_lower_ = np.asarray([r[1] for r in m.rows], dtype=float)
        lp.row_upper_ = np.asarray([r[2] for r in m.rows], dtype=float)
        a = m.matrix()
        lp.a_matrix_.format_ = highspy.MatrixFormat.kColwise
        lp.a_matrix_.start_ = a.indptr
        lp.a_matrix_.index_ = a.indices
        lp.a_matrix_.value_ = a.data
        lp.a_matrix_.num_col_, lp.a_matrix_.num_row_ = n, len(m.rows)
        lp.integrality_ = [highspy.HighsVarType.kInteger if b else
                           highspy.HighsVarType.kContinuous for b in m.integer]
        h.passModel(lp)
        self.n = n
        self.integers = np.flatnonzero(m.integer)

    def set_row_bounds(self, row: int, lo: float, hi: float) -> None:
        self.h.changeRowBounds(row, lo, hi)

    def set_time_limit(self, seconds: float) -> None:
        self.h.setOptionValue("time_limit", float(seconds))

    def set_col_bounds(self, col: int, lo: float, hi: float) -> None:
        self.h.changeColBounds(col, lo, hi)

    def relax(self, col: int) -> None:
        """An integer column made continuous (within its bounds)."""
        import highspy

        self.h.changeColIntegrality(int(col), highspy.HighsVarType.kContinuous)

    def fix_integers(self, x: np.ndarray) -> None:
        """Every integer column fixed at its (rounded) value in ``x``: the discrete choices
        of a point kept, the rest an LP."""
        for j in self.integers:
            v = float(round(x[j]))
            self.h.changeColBounds(int(j), v, v)

    def start(self, x: np.ndarray) -> None:
        """A MIP start (HiGHS completes or repairs it)."""
        import highspy

        sol = highspy.HighsSolution()
        sol.col_value = list(np.asarray(x, dtype=float))
        sol.value_valid = True
        self.h.setSolution(sol)

    def solve(self) -> Result:
        t0 = time.perf_counter()
        self.h.run()
        wall = time.perf_counter() - t0
        status = self.h.modelStatusToString(self.h.getModelStatus())
        info = self.h.getInfo()
        x = None
        if info.primal_solution_status >= 2:  # feasible
            x = np.asarray(self.h.getSolution().col_value, dtype=float)
        return Result(STATUS_MAP.get(status, SolverStatus.FAILED), x,
                      float(info.objective_function_value), float(info.mip_dual_bound),
                      float(info.mip_gap), int(info.mip_node_count), wall, status)


class IncrementalLp:
    """An LP grown in place (rows first, then columns) and re-solved warm by the simplex."""

    def __init__(self, row_lo: np.ndarray, row_hi: np.ndarray):
        import highspy

        quiet_banner()
        self.h = highspy.Highs()
        self.h.setOptionValue("output_flag", False)
        self.h.setOptionValue("threads", 1)
        self.h.addRows(len(row_lo), row_lo, row_hi, 0, np.array([], dtype=np.int32),
                       np.array([], dtype=np.int32), np.array([]))

    def add_cols(self, cost, lo, hi, starts, index, values) -> None:
        """Columns in CSC form (``starts`` into ``index``/``values``, row indices)."""
        self.h.addCols(len(cost), np.asarray(cost, dtype=float), np.asarray(lo, dtype=float),
                       np.asarray(hi, dtype=float), len(index),
                       np.asarray(starts, dtype=np.int32), np.asarray(index, dtype=np.int32),
                       np.asarray(values, dtype=float))

    def solve(self, time_limit: float) -> tuple[bool, float, np.ndarray]:
        """(optimal?, objective, row duals) within ``time_limit`` seconds."""
        import highspy

        self.h.setOptionValue("time_limit", min(max(time_limit, 1e-3), MAX_TIME_S))
        self.h.run()
        sol = self.h.getSolution()
        ok = self.h.getModelStatus() == highspy.HighsModelStatus.kOptimal
        return ok, self.h.getInfo().objective_function_value, np.asarray(sol.row_dual)


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
    import cvxpy as cp

    if time_limit is None or not np.isfinite(time_limit):
        time_limit = MAX_TIME_S
    quiet_banner()
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
        return Result(SolverStatus.OPTIMAL, xv, obj, obj)
    if prob.status in (cp.INFEASIBLE, cp.INFEASIBLE_INACCURATE):
        if known is not None:  # pruned by the cutoff: the known assignment is optimal
            return Result(SolverStatus.OPTIMAL, known[0], known[1], known[1])
        return Result(SolverStatus.INFEASIBLE, None, np.inf, np.inf)
    if prob.status == cp.USER_LIMIT or (time_limit is not None and xv is not None):
        return Result(SolverStatus.MAX_TIME, xv, obj, bound)
    return Result(SolverStatus.FAILED, xv, obj, bound)


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

    quiet_banner()
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
        return Result(SolverStatus.OPTIMAL, x, obj, obj)
    if status == ms.kInfeasible:
        return Result(SolverStatus.INFEASIBLE, None, np.inf, np.inf)
    if status in (ms.kTimeLimit, ms.kInterrupt, ms.kSolutionLimit, ms.kIterationLimit):
        return Result(SolverStatus.MAX_TIME, x, obj, bound)
    return Result(SolverStatus.FAILED, x, obj, bound)
