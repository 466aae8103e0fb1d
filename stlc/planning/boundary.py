"""Boundary-safe verification: a plan whose optimum lies exactly on a predicate's boundary
(ρ = κ, e.g. a start on the workspace floor at κ = 0) is judged on its own numbers.

A backend re-simulates its plan from the inputs (``Solution.channels``: states by the
exact discrete model), so the written plan obeys the dynamics exactly; that re-simulation
rounds, and a state the solver put exactly on a face (z = 0) can come back as −9e-15 m.
The verdict must not turn on such a rounding, nor on the solver's feasibility tolerance
(a goal face reached at x = 7 − 5e-15 m where any point of the box would do).  When the
re-simulated plan falls short of κ, ``reconcile`` judges, in order, the backend's own state
samples (``Solution.solver_states``), then the plan with every position sample within
``DEFECT_TOL`` of a face of a predicate put on that face, then the solver's samples so
moved.  The first that reaches κ while differing from the re-simulated states by at most
``DEFECT_TOL`` (relative to the states' scale) is the plan — what is verified and written,
so ``stlc monitor`` on the written file agrees — and its dynamics defect is a note, not a
violation.  A larger defect, or candidates that miss κ too, leave the verdict to the
re-simulated plan.

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


def faces(formula) -> dict[str, np.ndarray]:
    """Signal → the constants it is compared with in the formula's predicates written as
    ``s − c`` or ``c − s`` (box faces, bounds)."""
    from stlc.semantics import ir

    out: dict[str, set] = {}
    for p in ir.predicates(formula):
        e = p.expr
        if isinstance(e, ir.Bin) and e.op == "-":
            if isinstance(e.left, ir.Sig) and isinstance(e.right, ir.Const):
                out.setdefault(e.left.name, set()).add(e.right.value)
            elif isinstance(e.left, ir.Const) and isinstance(e.right, ir.Sig):
                out.setdefault(e.right.name, set()).add(e.left.value)
        elif isinstance(e, ir.Sig):
            out.setdefault(e.name, set()).add(0.0)
    return {k: np.array(sorted(v), dtype=float) for k, v in out.items()}


def snapped(channels: dict, states, constants: dict[str, np.ndarray]) -> dict:
    """The state channels ``states`` of ``channels`` with every sample within
    ``DEFECT_TOL`` (relative) of a face constant of its signal put on it."""
    out = {}
    for c in states:
        v = np.array(channels[c], dtype=float)
        for k in constants.get(c, ()):
            if np.isfinite(k):
                near = np.abs(v - k) <= DEFECT_TOL * max(1.0, abs(k))
                v[near] = k
        out[c] = v
    return out


def reconcile(problem, sol, exact: float, kappa: float, recompute, robustness
              ) -> Reconciled | None:
    """The plan of ``sol`` judged on its own numbers, or None (see the module docstring).
    Candidates, in order: the solver's own samples; the re-simulated samples and the
    solver's with every position within the tolerance of a face it must not cross put on
    that face (the solver's feasibility tolerance leaves ±1e-15 there).  The first that
    reaches κ with a dynamics defect within the tolerance is the plan judged and written.
    ``recompute(problem, channels) -> (channels, events)`` re-derives the derived
    signals, ``robustness(channels) -> float`` is the exact monitor on the requirement."""
    from stlc.analysis import verdict

    if verdict.satisfied(exact, kappa) or not sol.feasible:
        return None
    states = dict(getattr(sol, "solver_states", None) or {})
    names = list(states) or [c for c in sol.channels if ".pos." in c]
    constants = faces(problem.requirement)
    tries = []
    if states:
        tries.append(("the solver's own samples", states))
    tries.append(("the plan with positions within the tolerance of a face put on it",
                  snapped(sol.channels, names, constants)))
    if states:
        tries.append(("the solver's samples with positions within the tolerance of a face "
                      "put on it", snapped({**sol.channels, **states}, names, constants)))
    for label, cand in tries:
        gap, scale = defect(sol.channels, cand)
        if not gap <= DEFECT_TOL * scale:
            continue
        ch = dict(sol.channels)
        ch.update({c: np.asarray(v, dtype=float) for c, v in cand.items()})
        ch, events = recompute(problem, ch)
        rho = float(robustness(ch)) + 0.0  # −0.0 (a max of −0.0 terms) reads as 0
        if not verdict.satisfied(rho, kappa):
            continue
        note = (f"the plan's robustness {rho:+.3g} is on the boundary κ = {kappa:g}: the "
                f"re-simulated plan gives {exact:+.3g}; {label} — a dynamics defect of "
                f"{gap:.1e} m at most (below the rounding tolerance {DEFECT_TOL:g} × "
                f"{scale:g}) — are the plan judged and written")
        return Reconciled(ch, events, rho, gap, note)
    return None
