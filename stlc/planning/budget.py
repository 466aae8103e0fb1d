"""The size of a trajectory NLP, estimated from the planning problem before anything is
built, and the refusal (STL606) of a problem that cannot fit the memory budget.

The estimate counts, per sample, each vehicle's states and inputs (nx + nu) and the
predicate instances of the requirement in negation normal form (each lifted into
auxiliary variables and constraints of the smooth robustness):

* variables  ≈ n·(Σ(nx + nu) + P)
* Jacobian non-zeros ≈ n·(Σ nx·(nx + nu) + P·(nx + nu)) (dynamics defects, predicates)
* Hessian non-zeros  ≈ n·(Σ (nx + nu)² + P·(nx + nu)) (RK4 steps, lifted predicates)
* memory ≈ ``BASE`` + n·(``PER_DIM2``·Σ(nx + nu)² + ``PER_PREDICATE``·P)·``SOLVE_FACTOR``

The per-sample costs were measured on this machine with ``ru_maxrss`` after
``CasadiNlp.lower`` (the CasADi build, derivatives included), at 31 to 6,001 samples:
the build grows linearly in n (a point mass: 2 predicates, 9 states+inputs, ≈ 100 kB per
sample; the hexarotor climb: 12 predicates, 24, ≈ 0.65 MB; the handover: 69 predicates,
≈ 1.3 MB), fitted by ≈ 0.9 kB·(nx + nu)² + 11.4 kB·P.  ``SOLVE_FACTOR`` covers IPOPT's
own memory during the solve (1.1× measured at 1,500 samples of a point mass; 8.3 GB was
measured at 20,000 samples of one, ≈ 4× the build), so the estimate errs on the
large side.  A team mission is planned on waypoints (``stlc.team``) with its own budgets
and is not estimated here.
"""

from __future__ import annotations

from dataclasses import dataclass

from stlc import limits, vehicles
from stlc.diagnostics import Diagnostic, Span, StlcError
from stlc.semantics import ir

BASE = 120 << 20
PER_DIM2 = 1024
PER_PREDICATE = 12 * 1024
SOLVE_FACTOR = 4.0


@dataclass(frozen=True)
class NlpEstimate:
    samples: int
    variables: int
    jacobian_nnz: int
    hessian_nnz: int
    bytes: int

    def text(self) -> str:
        return (f"{self.samples:,} samples, ~{self.variables:,} variables, ~"
                f"{self.jacobian_nnz:,} Jacobian and ~{self.hessian_nnz:,} Hessian non-zeros, "
                f"~{limits.human(self.bytes)}")


def estimate(problem) -> NlpEstimate:
    """The estimated size of the NLP of ``problem`` (a ``PlanningProblem``)."""
    n = problem.grid.n
    dims = []
    for v in problem.vehicles():
        nx, nu = vehicles.model_of(v).state_size(v)
        dims.append((nx, nu))
    p = len(ir.predicates(problem.requirement))
    width = sum(nx + nu for nx, nu in dims)
    variables = n * (width + p)
    jac = n * (sum(nx * (nx + nu) for nx, nu in dims) + p * max(width, 1))
    hess = n * (sum((nx + nu) ** 2 for nx, nu in dims) + p * max(width, 1))
    per_sample = PER_DIM2 * sum((nx + nu) ** 2 for nx, nu in dims) + PER_PREDICATE * p
    return NlpEstimate(n, variables, jac, hess, int(BASE + n * per_sample * SOLVE_FACTOR))


def check_nlp(problem, span: Span) -> NlpEstimate:
    """Raise ``StlcError`` (STL606 at ``span``) when the NLP of ``problem`` would not fit
    the memory budget; returns the estimate otherwise."""
    est = estimate(problem)
    budget = limits.max_memory()
    if est.bytes > budget:
        n_fit = max(2, int((budget - BASE) / max(est.bytes - BASE, 1) * est.samples))
        step = problem.grid.horizon / max(n_fit - 1, 1)
        raise StlcError([Diagnostic(
            "STL606", f"mission `{problem.mission.name}` is too large to plan: {est.text()}, "
            f"over the memory budget of {limits.human(budget)}", span,
            f"use a coarser step (about {step:.3g} s or more fits: at most ~{n_fit:,} "
            "samples), a shorter horizon, fewer vehicles or specs, or raise the budget with "
            "`--max-memory`")])
    return est
