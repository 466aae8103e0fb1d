"""Verification pass: the exact monitor judges every plan (``Solution``) of a problem.

Derived signals are recomputed from the plan's states by the vehicle models (and the
payload from positions, for team missions), never taken from the planner; then the exact
robustness of the requirement, of every named spec (with its tightest time and binding
predicate) and of every comparison plan is computed on the dense trajectory at the
mission's step, and the verdict is set.  The contract: ``satisfied`` ⟺ the exact robustness of the
requirement as written is ≥ the mission's threshold κ and the plan obeys the dynamics; a
plan with 0 ≤ ρ < κ is ``violated`` (its margin fell short), and so is every named spec
whose robustness is below κ.
"""

from __future__ import annotations

import numpy as np

from stlc import vehicles
from stlc.analysis import monitor, smooth
from stlc.planning.solution import Solution, SpecResult, Verdict
from stlc.planning.bounds import plot_bounds, spec_windows
from stlc.planning.problem import PlanningProblem
from stlc.semantics import ir


def recompute_derived(problem: PlanningProblem, channels: dict) -> tuple[dict, list]:
    """The plan's channels with every derived signal recomputed from its states, and the
    payload events (team missions: the payload follows from the positions alone)."""
    ch = {k: v for k, v in channels.items() if not k.endswith(".payload")}
    for v in problem.vehicles():
        vm = vehicles.model_of(v)
        if all(c in ch for c in vm.state_channels(v)):
            ch.update(vm.derived_channels(v, vehicles.state_matrix(v, ch)))
    events: list = []
    if any(s.endswith(".payload") for s in ir.signals(problem.requirement)):
        from stlc.team.payload import payload_team
        from stlc.team.seed import scenario_from_program

        sc = scenario_from_program(problem.program, problem.mission)
        pos = {d: np.stack([ch[f"{d}.pos.{a}"] for a in "xyz"], axis=1)
               for d in problem.team}
        payload, events = payload_team(problem.grid.times(), pos, sc)
        for d, c in payload.items():
            ch[f"{d}.payload"] = np.asarray(c, dtype=float)
    return ch, events


def verify(problem: PlanningProblem, sol: Solution) -> Solution:
    """Set the exact robustness, per-spec results, verdict and report data of ``sol``."""
    dt = problem.grid.dt
    params = problem.params
    kappa = problem.threshold
    lam = float(sol.smoothing.get("lambda_final", problem.smoothing.lam))
    method = problem.smoothing.method
    ch, sol.events = recompute_derived(problem, sol.channels)
    sol.channels = ch
    exact = float(monitor.robustness(problem.requirement, dt, ch, params))
    sol.robustness_exact = exact
    for name, spec in problem.specs.items():
        r, k, pred = monitor.binding(spec.normal, dt, ch, params)
        sol.specs[name] = SpecResult(
            robustness=float(r),
            smooth=float(smooth.smooth_robustness(spec.normal, dt, ch, params, lam, method)),
            satisfied=bool(r >= kappa),
            tightest_time=None if k is None else float(k * dt),
            binding_predicate=pred.label if pred is not None else "",
            line=spec.span.line)
    if sol.status != Verdict.SOLVER_FAILED:
        sol.status = (Verdict.SATISFIED if exact >= kappa and sol.feasible
                      else Verdict.VIOLATED)
    if 0 <= exact < kappa:
        sol.notes.append(f"exact robustness {exact:.6f} is below the threshold κ = "
                         f"{kappa:g}: the margin fell short")
    for c in sol.comparisons:
        c.channels, _ = recompute_derived(problem, c.channels)
        c.robustness_exact = float(monitor.robustness(problem.requirement, dt, c.channels,
                                                      params))
        c.specs = {name: float(monitor.robustness(s.normal, dt, c.channels, params))
                   for name, s in problem.specs.items()}
        c.peak_speed = _peak(c.channels, ".speed")
        c.peak_rotor_speed = _peak(c.channels, ".rotor_speed.")
    sol.bounds = plot_bounds(problem)
    sol.windows = spec_windows(problem)
    return sol


def _peak(ch: dict, key: str) -> float:
    vals = [float(max(v)) for k, v in ch.items() if key in k]
    return max(vals) if vals else float("nan")
