"""How a solver run ended: the status every solver adapter maps its library's codes to, and
every backend reports (``stlc.backends.base`` re-exports it)."""

from __future__ import annotations

import enum


class SolverStatus(enum.StrEnum):
    """How a solver run ended (shared by every backend)."""

    OPTIMAL = "optimal"  # the solver's own convergence test
    ACCEPTABLE = "acceptable"  # the solver's relaxed convergence test
    STOPPED = "stopped"  # our stagnation rule stopped it (not converged)
    MAX_ITER = "max_iter"  # iteration limit (not converged)
    MAX_TIME = "max_time"  # time limit (not converged)
    INFEASIBLE = "infeasible"
    FAILED = "failed"
    INTERRUPTED = "interrupted"
    NOT_RUN = "not_run"

    @property
    def converged(self) -> bool:
        return self in (SolverStatus.OPTIMAL, SolverStatus.ACCEPTABLE)


__all__ = ["SolverStatus"]
