"""Boundary-safe verification: a plan whose optimum lies exactly on a predicate's boundary
(ρ = κ, e.g. a start on the workspace floor at κ = 0) is judged on its own numbers.

A backend re-simulates its plan from the inputs (``Solution.channels``: states by the
exact discrete model), so the written plan obeys the dynamics exactly; that re-simulation
rounds, and a state the solver put exactly on a face (z = 0) can come back as −9e-15 m.
The verdict must not turn on such a rounding.  When the re-simulated plan falls short of
κ and the backend kept its own state samples (``Solution.solver_states``), ``reconcile``
judges the solver's samples too: if they reach κ and they differ from the re-simulated
states by at most ``DEFECT_TOL`` (relative to the states' scale) the solver's samples are
the plan — they are what is verified and written — and the dynamics defect is a note,
not a violation.  A larger defect, or solver samples that miss κ too, leave the verdict
to the re-simulated plan.

``DEFECT_TOL`` = 1e-9 relative: far below any physical effect (1 nm on a 1 m scale, 5 mm
at a UTM northing of 5.4e6 m in absolute numbers, where ``stlc.planning.frame`` plans in
a local frame anyway) and far above float64 rounding of a re-simulation (1e-16 relative
per step).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: largest re-simulation defect accepted as rounding, relative to max(1, |state|)
DEFECT_TOL = 1e-9


@dataclass(frozen=True)
class Reconciled:
    """The solver's own samples, judged instead of the re-simulated ones."""

    channels: dict  # the plan's channels with the solver's states (derived recomputed)
    events: list
    robustness: float
    defect: float  # max |solver state − re-simulated state|
    note: str


def defect(channels: dict, solver_states: dict) -> tuple[float, float]:
    """(max absolute difference, state scale) between the re-simulated and the solver's
    state samples (only the channels both have)."""
    worst, scale = 0.0, 1.0
    for c, s in solver_states.items():
        r = channels.get(c)
        if r is None or len(r) != len(s):
            return float("inf"), 1.0
        s, r = np.asarray(s, dtype=float), np.asarray(r, dtype=float)
        if s.size:
            worst = max(worst, float(np.max(np.abs(s - r))))
            scale = max(scale, float(np.max(np.abs(r))))
    return worst, scale


def reconcile(problem, sol, exact: float, kappa: float, recompute, robustness
              ) -> Reconciled | None:
    """The solver's samples of ``sol`` as the plan, or None (see the module docstring).
    ``recompute(problem, channels) -> (channels, events)`` re-derives the derived signals,
    ``robustness(channels) -> float`` is the exact monitor on the requirement."""
    from stlc.analysis import verdict

    states = getattr(sol, "solver_states", None) or {}
    if not states or verdict.satisfied(exact, kappa) or not sol.feasible:
        return None
    gap, scale = defect(sol.channels, states)
    if not gap <= DEFECT_TOL * scale:
        return None
    ch = dict(sol.channels)
    ch.update({c: np.asarray(v, dtype=float) for c, v in states.items()})
    ch, events = recompute(problem, ch)
    rho = float(robustness(ch)) + 0.0  # −0.0 (a max of −0.0 terms) reads as 0
    if not verdict.satisfied(rho, kappa):
        return None
    note = (f"the plan's robustness {rho:+.3g} is on the boundary κ = {kappa:g}: the "
            f"re-simulation of its inputs rounds to {exact:+.3g}, a dynamics defect of "
            f"{gap:.1e} (below the rounding tolerance {DEFECT_TOL:g} × {scale:g}); the "
            "solver's own samples are the plan judged and written")
    return Reconciled(ch, events, rho, gap, note)
