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
from stlc.analysis import monitor, smooth, verdict
from stlc.planning.solution import Solution, SpecResult, Verdict
from stlc.planning.boundary import reconcile
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
    notes = []
    on_face = reconcile(problem, sol, exact, kappa, recompute_derived,
                        lambda c: monitor.robustness(problem.requirement, dt, c, params))
    if on_face is not None:  # rounding of the re-simulation, not of the plan
        ch, events, exact = on_face.channels, on_face.events, on_face.robustness
        notes.append(on_face.note)
    specs = {}
    for name, spec in problem.specs.items():
        r, k, pred = monitor.binding(spec.normal, dt, ch, params)
        specs[name] = SpecResult(
            robustness=float(r),
            smooth=float(smooth.smooth_robustness(spec.normal, dt, ch, params, lam, method)),
            satisfied=verdict.satisfied(r, kappa),
            tightest_time=None if k is None else float(k * dt),
            binding_predicate=pred.label if pred is not None else "",
            line=spec.span.line,
            binding_line=pred.span.line if pred is not None and pred.span.known else 0,
            binding_origin=pred.origin if pred is not None else None)
    status = sol.status
    satisfied = verdict.satisfied(exact, kappa) and sol.feasible
    if status == Verdict.INFEASIBLE and not satisfied:
        pass  # proved before any plan (``milp.conflict``): the plan shown cannot change that
    elif status != Verdict.SOLVER_FAILED:
        status = Verdict.SATISFIED if satisfied else Verdict.VIOLATED
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
    vehicles can hold its final state (``stlc.planning.holdable``), and its energy."""
    from stlc.planning.holdable import end_state, flag

    sol = judge(problem, sol).apply(sol)
    sol.smoothing.setdefault("threshold", problem.threshold)  # κ, named beside every verdict
    sol.end_state = end_state(problem.vehicles(), sol.channels)
    plan_energy(problem, sol)
    sol.notes.extend(flag(problem.hold_end, sol.end_state))
    sol.notes.extend(corner_cuts(problem, sol.channels, sol.times))
    return sol


def corner_cuts(problem: PlanningProblem, channels: dict, times) -> list[str]:
    """Notes for the vehicles whose straight path between two samples comes closer to a
    world-frame obstacle than the vehicle's radius (or touches it), although the samples
    themselves are what the monitor judges (``stlc.analysis.clearance``: exact segment-box
    distance)."""
    from stlc.analysis.clearance import segment_region_distance

    obstacles = [r for r in problem.program.scenario.by_kind("obstacle") if r.box.frame is None]
    notes = []
    for v in problem.vehicles() if obstacles else []:
        cols = [channels.get(f"{v.name}.pos.{a}") for a in "xyz"]
        if any(c is None for c in cols) or len(cols[0]) < 2:
            continue
        P = np.stack([np.asarray(c, dtype=float) for c in cols], axis=1)
        r = float(getattr(v, "radius", 0.0))
        worst = None
        for ob in obstacles:
            d = segment_region_distance(P[:-1], P[1:], ob.box)
            k = int(np.argmin(d))
            if (d[k] < r - 1e-9 or d[k] <= 1e-12) and (worst is None or d[k] < worst[0]):
                worst = (float(d[k]), k, ob.name)
        if worst is not None:
            d, k, name = worst
            t = np.asarray(times, dtype=float)
            notes.append(f"{v.name} cuts the corner of obstacle `{name}` between samples: the "
                         f"straight segment from t = {t[k]:g} s to {t[k + 1]:g} s comes "
                         f"{d:.3f} m from it (radius {r:g} m), although the samples keep it; "
                         "the monitor judges samples only: a finer `step` or a larger "
                         "`radius` keeps the segments clear")
    return notes


def plan_energy(problem: PlanningProblem, sol: Solution) -> None:
    """Each vehicle's energy recomputed from the plan's states by its model (a multirotor:
    paper A eq. 5; a point mass that declares its aerodynamic data: paper B's power model,
    ``stlc.vehicles.power``) into ``sol.energy_by_vehicle``; the total and its profile only
    when every vehicle has a model, else "not computed" (NaN → null, never a made-up 0.0 J)."""
    dt, profiles = problem.grid.dt, {}
    for v in problem.vehicles():
        vm = vehicles.model_of(v)
        if vm.has_rotor_energy(v) and all(c in sol.channels for c in vm.state_channels(v)):
            ins = vm.input_channels(v)
            U = (np.stack([np.asarray(sol.channels[c], dtype=float) for c in ins], axis=1)
                 if ins and all(c in sol.channels for c in ins) else None)
            X = vehicles.state_matrix(v, sol.channels)
            profiles[v.name] = np.asarray(vm.energy_profile(v, X, dt, U)
                                          if vehicles.takes(vm.energy_profile, "U")
                                          else vm.energy_profile(v, X, dt), dtype=float)
    sol.energy_by_vehicle = {k: float(p.sum()) for k, p in profiles.items()}
    if profiles and len(profiles) == len(problem.vehicles()):
        sol.energy_profile = np.sum(list(profiles.values()), axis=0)
        sol.energy = float(sol.energy_profile.sum())
    else:
        sol.energy, sol.energy_profile = float("nan"), None


def _peak(ch: dict, key: str) -> float:
    vals = [float(max(v)) for k, v in ch.items() if key in k]
    return max(vals) if vals else float("nan")
