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

from dataclasses import dataclass

import numpy as np

from stlc import vehicles
from stlc.analysis import monitor, smooth
from stlc.planning.solution import Solution, SpecResult, Verdict
from stlc.planning.bounds import plot_bounds, spec_windows
from stlc.planning.problem import PlanningProblem
from stlc.semantics.specs import reads_payload


def recompute_derived(problem: PlanningProblem, channels: dict) -> tuple[dict, list]:
    """The plan's channels with every derived signal recomputed from its states, and the
    payload events (team missions: the payload follows from the positions alone)."""
    ch = {k: v for k, v in channels.items() if not k.endswith(".payload")}
    for v in problem.vehicles():
        vm = vehicles.model_of(v)
        if all(c in ch for c in vm.state_channels(v)):
            ch.update(vm.derived_channels(v, vehicles.state_matrix(v, ch)))
    events: list = []
    if reads_payload(problem.requirement):
        from stlc.team.payload import payload_team
        from stlc.team.seed import scenario_from_program

        sc = scenario_from_program(problem.program, problem.mission)
        pos = {d: np.stack([ch[f"{d}.pos.{a}"] for a in "xyz"], axis=1)
               for d in problem.team}
        payload, events = payload_team(problem.grid.times(), pos, sc)
        for d, c in payload.items():
            ch[f"{d}.payload"] = np.asarray(c, dtype=float)
    return ch, events


@dataclass
class ComparisonVerdict:
    """The exact monitor on one comparison plan."""

    channels: dict  # derived signals recomputed
    robustness_exact: float
    specs: dict[str, float]
    peak_speed: float
    peak_rotor_speed: float


@dataclass
class Verification:
    """What the exact monitor says of a plan (``judge``): nothing here comes from the
    planner.  ``apply`` writes it onto the ``Solution`` for the outputs."""

    channels: dict  # the plan's channels with every derived signal recomputed
    events: list  # payload events (team missions)
    robustness_exact: float
    specs: dict[str, SpecResult]
    status: str  # Verdict
    notes: list[str]
    comparisons: list[ComparisonVerdict]
    bounds: dict
    windows: list

    def apply(self, sol: Solution) -> Solution:
        sol.channels, sol.events = self.channels, self.events
        sol.robustness_exact = self.robustness_exact
        sol.specs.update(self.specs)
        sol.status = self.status
        sol.notes.extend(self.notes)
        for c, v in zip(sol.comparisons, self.comparisons):
            c.channels, c.robustness_exact, c.specs = v.channels, v.robustness_exact, v.specs
            c.peak_speed, c.peak_rotor_speed = v.peak_speed, v.peak_rotor_speed
        sol.bounds = self.bounds
        sol.windows = self.windows
        return sol


def judge(problem: PlanningProblem, sol: Solution) -> Verification:
    """The exact robustness, per-spec results, verdict and report data of the plan ``sol``
    (``sol`` is not changed)."""
    dt = problem.grid.dt
    params = problem.params
    kappa = problem.threshold
    lam = float(sol.smoothing.get("lambda_final", problem.smoothing.lam))
    method = problem.smoothing.method
    ch, events = recompute_derived(problem, sol.channels)
    exact = float(monitor.robustness(problem.requirement, dt, ch, params))
    specs = {}
    for name, spec in problem.specs.items():
        r, k, pred = monitor.binding(spec.normal, dt, ch, params)
        specs[name] = SpecResult(
            robustness=float(r),
            smooth=float(smooth.smooth_robustness(spec.normal, dt, ch, params, lam, method)),
            satisfied=bool(r >= kappa),
            tightest_time=None if k is None else float(k * dt),
            binding_predicate=pred.label if pred is not None else "",
            line=spec.span.line,
            binding_line=pred.span.line if pred is not None and pred.span.known else 0,
            binding_origin=pred.origin if pred is not None else None)
    status = sol.status
    if status != Verdict.SOLVER_FAILED:
        status = Verdict.SATISFIED if exact >= kappa and sol.feasible else Verdict.VIOLATED
    notes = []
    if 0 <= exact < kappa:
        notes.append(f"exact robustness {exact:.6f} is below the threshold κ = "
                     f"{kappa:g}: the margin fell short")
    comparisons = []
    for c in sol.comparisons:
        cch, _ = recompute_derived(problem, c.channels)
        comparisons.append(ComparisonVerdict(
            cch, float(monitor.robustness(problem.requirement, dt, cch, params)),
            {name: float(monitor.robustness(s.normal, dt, cch, params))
             for name, s in problem.specs.items()},
            _peak(cch, ".speed"), _peak(cch, ".rotor_speed.")))
    return Verification(ch, events, exact, specs, status, notes, comparisons,
                        plot_bounds(problem), spec_windows(problem))


def verify(problem: PlanningProblem, sol: Solution) -> Solution:
    """``judge`` the plan and write the verdict onto ``sol`` (returned); then whether the
    vehicles can hold its final state (``stlc.planning.holdable``), and energy "not
    computed" (NaN → null) when no vehicle has an energy model (never a made-up 0.0 J)."""
    from stlc.planning.holdable import end_state, flag

    sol = judge(problem, sol).apply(sol)
    sol.end_state = end_state(problem.vehicles(), sol.channels)
    if not any(vehicles.model_of(v).has_rotor_energy(v) for v in problem.vehicles()):
        sol.energy, sol.energy_profile = float("nan"), None
    sol.notes.extend(flag(problem.hold_end, sol.end_state))
    return sol


def _peak(ch: dict, key: str) -> float:
    vals = [float(max(v)) for k, v in ch.items() if key in k]
    return max(vals) if vals else float("nan")
