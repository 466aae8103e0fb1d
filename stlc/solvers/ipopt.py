"""The IPOPT adapter: every ``casadi.nlpsol`` of stlc, IPOPT's status map and its linear
solver's options.

``solver(name, nlp, options)`` creates an IPOPT solver of a CasADi NLP (``{"x", "p", "f",
"g"}`` or expressions with derivative options); ``STATUS_MAP`` maps IPOPT's return status
(``solver.stats()["return_status"]``) to the shared ``SolverStatus``; ``MUMPS`` holds the
options of its sparse linear solver that every IPOPT run of stlc uses.
"""

from __future__ import annotations

import casadi as ca

from stlc.solvers.status import SolverStatus

#: MUMPS: AMD ordering, no matrix scaling.  Its default (automatic ordering, scaling
#: recomputed at every factorisation) cost 120 ms per iteration on the handover's ~10 k KKT
#: system; this costs 75 ms (40 iterations of the λ = 10 stage: 4.8 s -> 3.0 s CPU, the
#: same iterates to 3 digits)
#: mumps_mem_percent 100 (default 1000): MUMPS no longer maps ~10× its estimated workspace at
#: every factorisation, which cost 20 % of the search direction in system time (same iterates)
MUMPS = {"mumps_pivot_order": 0, "mumps_scaling": 0, "mumps_permuting_scaling": 0,
         "mumps_mem_percent": 100}
#: IPOPT's return statuses → the shared ``SolverStatus`` (every backend that runs IPOPT uses
#: this map; the only user stop is the schedule's iteration limit, hence MAX_ITER)
STATUS_MAP = {
    "Solve_Succeeded": SolverStatus.OPTIMAL,
    "Solved_To_Acceptable_Level": SolverStatus.ACCEPTABLE,
    "Maximum_Iterations_Exceeded": SolverStatus.MAX_ITER,
    "Infeasible_Problem_Detected": SolverStatus.INFEASIBLE,
    "Restoration_Failed": SolverStatus.FAILED,
    "Error_In_Step_Computation": SolverStatus.FAILED,
    "Maximum_CpuTime_Exceeded": SolverStatus.MAX_TIME,
    "Maximum_WallTime_Exceeded": SolverStatus.MAX_TIME,
    "Search_Direction_Becomes_Too_Small": SolverStatus.STOPPED,  # no convergence test
    "Invalid_Number_Detected": SolverStatus.FAILED,
    "User_Requested_Stop": SolverStatus.MAX_ITER,
}


def solver(name: str, nlp, options: dict) -> ca.Function:
    """An IPOPT solver of ``nlp`` (CasADi's ``nlpsol``) with ``options``."""
    return ca.nlpsol(name, "ipopt", nlp, options)


def return_status(solver: ca.Function) -> str:
    """IPOPT's return status of the solver's last run."""
    return str(solver.stats().get("return_status", ""))


def status(code: str) -> SolverStatus:
    """The shared status of an IPOPT return status (unknown codes: ``FAILED``)."""
    return STATUS_MAP.get(code, SolverStatus.FAILED)
