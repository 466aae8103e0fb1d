"""Disturbance recovery by event-triggered replanning (paper A §4.4): ``stlc simulate``.

``simulate_disturbances(problem, plan, disturbances, cfg)`` flies a compiled plan through
the vehicle model, pushes it with the given disturbances, and replans whenever it has
drifted more than ζ from the trajectory it is following.  Semantics (what the papers leave
open is decided here):

* **Flight.**  Every vehicle flies its *reference* — the plan, spliced with every accepted
  replan — by applying the reference's inputs **open loop** through the same discrete model
  the plan was made with (``model_of(v).ode(v)``, the mission's integrator and sub-steps).
  There is no tracking controller: a deviation below ζ persists (a pure displacement stays
  constant, a velocity kick grows linearly), until an event triggers a replan.  A plan that
  is not an exact solution of the discrete model (a team plan sampled from motion
  primitives; the full-dynamics NLP plan has defects ~1e-10) would drift away from itself
  when flown open loop (metres, on a 40 s team plan), so each step adds the reference's own
  one-step defect ``x_{k+1} − F(x_k, u_k)``: undisturbed, the vehicle flies exactly its
  plan; disturbed, the deviation evolves through the model.  Replanned segments are exact
  (defect 0).  A note reports a plan's defects above 1 µm.
* **Disturbances** act on the actual state at the first mission sample at or after their
  time: ``displacement`` is added to the position and ``velocity`` to the velocity.
* **Events** are the samples at or after k·T_e (k = 0, 1, …) within the horizon.  At each,
  for every vehicle, the deviation ‖p̃ − p_ref‖ from its current reference is compared with
  ζ; an event triggers when it is larger.
* **A replan** starts at s = the first sample at or after t_e + t_c.  Its start state is
  predicted by integrating the current reference's inputs from the actual state at t_e (a
  disturbance between t_e and t_s is not foreseen: the vehicle then flies the replan's
  inputs from a different state, and a later event catches it).  Its goal is the reference's
  **full state** at the first waypoint of the T_g grid (samples at or after j·T_g) that lies
  at least T_g after s, so the segment lasts between T_g and 2T_g (less only at the end of
  the horizon, where the goal is the last sample; an event with no sample left after s is
  reported as not run).  A deviation (position and velocity) too large to null in T_g at
  the acceleration bound of the vehicle model (``explain.min_time``, per axis) moves the
  goal to the first waypoint at least that long after s (``detail.lengthened``), and the
  segment NLP is rebuilt for the longer segment.  The segment backend
  (``stlc.backends.replan.segment``, passed in as ``segment``) keeps the specs of
  ``cfg.specs`` on the segment's samples after s with margin κ, obeys the dynamics and
  bounds and minimises input effort and distance from the reference.
* **Acceptance.**  A replan is flown iff IPOPT converged (optimal or acceptable), its wall
  time is within t_c (IPOPT also stops at ``max_wall_time`` = t_c), its inputs flown from the
  predicted start end within ``REJOIN_TOL`` of the goal, and every kept spec's exact
  robustness on the segment is ≥ κ — or, for a **recovery** (a predicted start that
  already breaks a kept spec, e.g. pushed into a clearance band: no segment can keep it
  there), every kept spec is ≥ κ from some sample of the segment to its end: the segment
  backend takes the shortest way back (``recover``), and the event's ``detail.recovery``
  says which specs were broken at the start and when the vehicle was back.  Otherwise the
  event is reported (status, time,
  ``accepted = False``) and nothing changes: the vehicle keeps its inputs and the next event
  tries again.  On acceptance the reference becomes the prediction on [t_e, t_s] and the
  replanned states (flown from the predicted start) on [t_s, t_g]; its inputs the replan's on
  [t_s, t_g).
* **Kept robustness of an event** (``ReplanEvent.kept``): the exact robustness of each kept
  spec's ``always`` body at every sample of (t_s, t_g] within its window, of the reference
  with the segment spliced in (the states the replan's inputs produce from the predicted
  start), the minimum over those samples (+inf if the window misses the segment).  The sample
  at t_s itself is the predicted start, fixed before the replan: a kept spec already broken
  there is not the replan's doing, and shows in the executed robustness.
* **After the run** the executed channels (states, applied inputs, derived signals
  recomputed as ``planning.verify`` does) are on the mission grid, and the exact robustness
  of the requirement (``"mission"``) and of every named spec is evaluated on them.

Errors: ``DisturbanceError`` (unknown vehicle, time outside the horizon, not finite),
``ValueError`` (a non-positive period, threshold or budget) and
``segment.KeptSpecError`` (a kept spec that a segment cannot keep), both ``ValueError``s
carrying the offending object for a diagnostic.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from dataclasses import replace
from types import MappingProxyType

from stlc import vehicles
from stlc.analysis import monitor, verdict
from stlc.backends.base import Backend, SolverStatus
from stlc.planning.kept import Clause, KeptSpecError, kept_clauses
from stlc.planning.solution import Solution, Verdict
from stlc.planning.verify import recompute_derived
from stlc.replan import explain
from stlc.replan.result import ReplanEvent, SimulationResult
from stlc.semantics import model
from stlc.semantics.timegrid import is_aligned, steps_ceil
from stlc.vehicles import dynamics

#: largest |state − goal| (any component, SI units) at the end of a flown replan
REJOIN_TOL = 1e-4
#: a plan whose one-step position defect exceeds this (m) is not an exact solution of the
#: model: the simulation carries its defects along, and a note says so
DEFECT_NOTE = 1e-6

__all__ = ["DisturbanceError", "KeptSpecError", "simulate_disturbances"]


MAX_PUSH_M = 1e3  #: per axis: a larger displacement is no disturbance but a teleport
MAX_KICK = 1e2  #: m/s per axis


class DisturbanceError(ValueError):
    """A disturbance that cannot be applied (unknown vehicle, time outside the horizon, a
    value that is not finite)."""

    def __init__(self, disturbance: model.Disturbance, message: str):
        super().__init__(message)
        self.disturbance = disturbance


@dataclass
class _Track:
    """One vehicle: its reference (states n×nx, inputs (n−1)×nu), what it actually flies,
    its kept clauses, its segment backend and (once lowered) its replanning NLP."""

    vehicle: model.Vehicle
    ref_X: np.ndarray
    ref_U: np.ndarray
    X: np.ndarray
    U: np.ndarray
    clauses: list[Clause]
    step: object  # the discrete dynamics (casadi Function)
    D: np.ndarray  # (n−1, nx) the reference's one-step defects x_{k+1} − F(x_k, u_k)
    backend: Backend | None = None
    make: object = None  # steps → a segment backend for segments of up to that many steps
    segment: object = None  # the segment problem (one vehicle, kept specs, others fixed)
    nlp: object = None  # the backend's lowered problem, built at the first event
    pos: slice = field(default_factory=lambda: slice(0, 3))

    def fly(self, x: np.ndarray, k: int) -> np.ndarray:
        """The state after step k from ``x``, flying the reference's input."""
        return np.asarray(self.step(x, self.ref_U[k])).ravel() + self.D[k]


def _inputs(v: model.Vehicle, channels: dict, n: int) -> np.ndarray:
    names = vehicles.model_of(v).input_channels(v)
    missing = [c for c in names if c not in channels]
    if missing:
        raise ValueError(f"the plan has no input channel `{missing[0]}`: it cannot be flown")
    return np.stack([np.asarray(channels[c], float)[:n - 1] for c in names], axis=1)


def _check(problem, disturbances: list[model.Disturbance], cfg: model.ReplanConfig) -> None:
    for what, x in (("event_period", cfg.event_period), ("waypoint_period",
                    cfg.waypoint_period), ("threshold", cfg.threshold),
                    ("budget", cfg.compute_budget)):
        if not (math.isfinite(x) and x > 0):
            raise ValueError(f"replan {what} must be a positive number, got {x:g}")
    team = set(problem.team)
    T = problem.grid.horizon
    for d in disturbances:
        if not all(math.isfinite(x) for x in (*d.displacement, *d.velocity)):
            raise DisturbanceError(d, f"disturbance of `{d.vehicle}` at {d.time:g} s is not "
                                   "finite")
        if max(map(abs, d.displacement)) > MAX_PUSH_M or max(map(abs, d.velocity)) > MAX_KICK:
            # a "push" of 1e300 m made every replan NaN and the event loop run on (fuzz)
            raise DisturbanceError(d, f"disturbance of `{d.vehicle}` at {d.time:g} s is "
                                   f"beyond {MAX_PUSH_M:g} m or {MAX_KICK:g} m/s per axis: "
                                   "not a push the vehicle can recover from")
        if d.vehicle not in team:
            raise DisturbanceError(d, f"disturbance of `{d.vehicle}`, which is not in mission "
                                   f"`{problem.mission.name}` ({', '.join(problem.team)})")
        if not (0.0 <= d.time <= T + 1e-9):
            raise DisturbanceError(d, f"disturbance at {d.time:g} s is outside the horizon "
                                   f"[0, {T:g}] s of mission `{problem.mission.name}`")


def _waypoint_goal(s: int, G: int, Tg: float, dt: float, last: int) -> int:
    """The first waypoint sample (ceil(j·T_g/dt)) at least G samples after s, capped at
    the last sample."""
    if s + G >= last:
        return last
    j = max(0, math.floor((s + G) * dt / Tg) - 1)
    for _ in range(4):  # j is within one or two of the answer: a bounded search
        if steps_ceil(j * Tg, dt) >= s + G:
            break
        j += 1
    else:  # pragma: no cover - rounding beyond the grid (T_g / dt past 2^52)
        return last
    return min(steps_ceil(j * Tg, dt), last)


def _event_samples(period: float, horizon: float, dt: float, n: int) -> set[int]:
    """The samples of the event instants k·T_e: at most one per sample (a period below the
    step, which the checker refuses, is clamped to every sample), never a loop over more
    instants than the mission has samples."""
    if period <= dt:
        return set(range(n))
    n_events = min(int(math.floor(horizon / period + 1e-9)) + 1, n)
    return {min(steps_ceil(k * period, dt), n - 1) for k in range(n_events)}


def simulate_disturbances(problem, plan, disturbances: list[model.Disturbance],
                          cfg: model.ReplanConfig, *, segment: type[Backend]
                          ) -> SimulationResult:
    """Fly ``plan`` under ``disturbances`` with event-triggered replanning (module doc).
    ``segment`` is the replanning backend, built as ``segment(steps=M, budget=t_c,
    integrator=...)`` once per vehicle (``stlc.backends.replan.segment.SegmentBackend``)."""
    grid = problem.grid
    dt, n = grid.dt, grid.n
    disturbances = sorted(disturbances, key=lambda d: d.time)
    _check(problem, disturbances, cfg)
    integrator = problem.integrator
    tracks: dict[str, _Track] = {}
    for v in problem.vehicles():
        vm = vehicles.model_of(v)
        ref_X = vehicles.state_matrix(v, plan.channels)[:n].copy()
        ref_U = _inputs(v, plan.channels, n)
        step = dynamics.discrete_dynamics(vm.ode(v), dt, integrator, dynamics.substeps(dt))
        D = (ref_X[1:] - np.asarray(step.map(n - 1)(ref_X[:-1].T, ref_U.T)).T if n > 1
             else np.zeros((0, ref_X.shape[1])))
        tracks[v.name] = _Track(v, ref_X, ref_U, np.zeros_like(ref_X), ref_U.copy(),
                                kept_clauses(problem, cfg.specs, v), step, D,
                                pos=vm.pos_index())
    notes = [f"replan {what} = {x:g} s is not a multiple of the step {dt:g} s: rounded up "
             "to the next sample" for what, x in (("event_period", cfg.event_period),
                                                  ("waypoint_period", cfg.waypoint_period),
                                                  ("budget", cfg.compute_budget))
             if not is_aligned(x, dt)]
    # bounded by the mission's samples: a waypoint period longer than the horizon gives
    # one segment to the end, never an NLP sized by the period
    G = min(max(1, steps_ceil(cfg.waypoint_period, dt)), max(1, n - 1))
    M = min(2 * G - 1, max(1, n - 1))
    for tr in tracks.values():
        tr.make = lambda steps: segment(steps=steps, budget=cfg.compute_budget,
                                        integrator=integrator)
        tr.backend = tr.make(M)
        tr.segment = _segment_problem(problem, plan, tr.vehicle, cfg)
    kicks: dict[int, list[model.Disturbance]] = {}
    for d in disturbances:
        kicks.setdefault(min(steps_ceil(d.time, dt), n - 1), []).append(d)
    event_at = _event_samples(cfg.event_period, grid.horizon, dt, n)
    events: list[ReplanEvent] = []
    for tr in tracks.values():
        tr.X[0] = tr.ref_X[0]
    _defect_note(tracks, notes)
    for k in range(n):
        for d in kicks.get(k, []):
            tr = tracks[d.vehicle]
            vm = vehicles.model_of(tr.vehicle)
            tr.X[k, vm.pos_index()] += np.asarray(d.displacement, float)
            tr.X[k, vm.vel_index()] += np.asarray(d.velocity, float)
        if k in event_at:
            for tr in tracks.values():
                dev = float(np.linalg.norm(tr.X[k, tr.pos] - tr.ref_X[k, tr.pos]))
                ev = ReplanEvent(time=k * dt, vehicle=tr.vehicle.name, deviation=dev,
                                 triggered=dev > cfg.threshold)
                if ev.triggered:
                    _replan(problem, tr, ev, k, cfg, G)
                events.append(ev)
        if k < n - 1:
            for tr in tracks.values():
                tr.U[k] = tr.ref_U[k]
                tr.X[k + 1] = tr.fly(tr.X[k], k)
    executed = _executed(problem, tracks, n)
    params = problem.params
    rob = {"mission": float(monitor.robustness(problem.requirement, dt, executed, params))}
    for name, spec in problem.specs.items():
        rob[name] = float(monitor.robustness(spec.normal, dt, executed, params))
    return SimulationResult(
        mission=problem.mission.name, times=grid.times(), nominal=dict(plan.channels),
        executed=executed, events=events, budget=cfg.compute_budget,
        executed_robustness=rob, threshold=problem.threshold,
        disturbances=list(disturbances), notes=notes)


def _defect_note(tracks: dict[str, _Track], notes: list[str]) -> None:
    """Say so when the plan is not an exact solution of the discrete model (e.g. a team
    plan sampled from motion primitives): its defects are flown along (module doc)."""
    for tr in tracks.values():
        worst = float(np.max(np.linalg.norm(tr.D[:, tr.pos], axis=1), initial=0.0))
        if worst > DEFECT_NOTE:
            notes.append(f"{tr.vehicle.name}: the plan is not an exact solution of the "
                         f"vehicle model (one-step position defects up to {worst:.3g} m); "
                         "the simulation adds them to every step so that the undisturbed "
                         "flight reproduces the plan")


def _segment_problem(problem, plan, v: model.Vehicle, cfg: model.ReplanConfig):
    """The problem a vehicle's segments share: that vehicle alone, the kept specs, the
    other vehicles' plans held fixed."""
    own = set(vehicles.model_of(v).all_channels(v))
    others = {c: a for c, a in plan.channels.items()
              if c.split(".")[0] in problem.team and c not in own}
    specs = {name: problem.specs[name] for name in cfg.specs if name in problem.specs}
    return replace(problem, team=(v.name,), specs=MappingProxyType(specs),
                   fixed_channels=MappingProxyType(others), seed=None)


def _reference(problem, tr: _Track) -> Solution:
    """The vehicle's current reference (the plan with every accepted replan) as a plan."""
    vm = vehicles.model_of(tr.vehicle)
    ch = {c: tr.ref_X[:, i] for i, c in enumerate(vm.state_channels(tr.vehicle))}
    ch.update({c: tr.ref_U[:, i] for i, c in enumerate(vm.input_channels(tr.vehicle))})
    return Solution(mission=problem.mission.name, status=Verdict.VIOLATED,
                    robustness_exact=float("nan"), robustness_smooth=float("nan"), specs={},
                    energy=0.0, times=problem.grid.times(), channels=ch)


def _integrate(tr: _Track, x_start: np.ndarray, U: np.ndarray) -> np.ndarray:
    """States (L + 1, nx) from flying the inputs ``U`` (L, nu) open loop."""
    X = [np.asarray(x_start, dtype=float)]
    for u in U:
        X.append(np.asarray(tr.step(X[-1], u)).ravel())
    return np.array(X)


def _replan(problem, tr: _Track, ev: ReplanEvent, k: int, cfg: model.ReplanConfig,
            G: int) -> None:
    """Trigger at sample k: predict, solve, check, and splice if accepted (module doc)."""
    grid = problem.grid
    dt, n = grid.dt, grid.n
    s = steps_ceil(k * dt + cfg.compute_budget, dt)
    ev.within_budget, ev.accepted = False, False
    if s >= n - 1:
        ev.status = str(SolverStatus.NOT_RUN)
        ev.detail = {"reason": "no sample left after t_e + t_c"}
        return
    pred = [tr.X[k]]
    for j in range(k, s):
        pred.append(tr.fly(pred[-1], j))
    x_start = pred[-1]
    need = _needed_steps(tr, x_start, s, dt)
    g = _waypoint_goal(s, max(G, need), cfg.waypoint_period, dt, n - 1)
    L = g - s
    ev.segment = (s * dt, g * dt)
    if need > G:  # a segment of the waypoint rule's length could not rejoin (module doc)
        ev.detail["lengthened"] = {"steps": L, "needed_steps": need}
    first = tr.nlp is None
    if L > tr.backend.steps:  # the NLP is built for the longest segment asked so far
        tr.backend = tr.make(L)
        first = True
    if first:
        tr.nlp, _ = tr.backend.lower(tr.segment)
    kappa = problem.threshold
    cand = tr.ref_X.copy()
    cand[k:s + 1] = np.array(pred)
    broken = {c: r for c, r in _kept(problem, tr, cand, s, s).items()
              if not verdict.satisfied(r, kappa)}  # at the start: a recovery (module doc)
    event = replace(tr.segment, start_states=MappingProxyType({tr.vehicle.name: x_start}),
                    window=(s * dt, g * dt), seed=_reference(problem, tr),
                    recover=bool(broken))
    res = tr.backend.invert(tr.backend.solve(tr.nlp, event), tr.nlp, event)
    status = SolverStatus(res.solver["status"])
    vm = vehicles.model_of(tr.vehicle)
    U = np.stack([res.channels[c][:L] for c in vm.input_channels(tr.vehicle)], axis=1)
    ev.solve_s, ev.status = res.timing["solve_s"], str(status)
    ev.within_budget = ev.solve_s <= cfg.compute_budget
    flown = _integrate(tr, x_start, U)
    rejoin = float(np.max(np.abs(flown[-1] - tr.ref_X[g])))
    cand[s:g + 1] = flown
    ev.kept = _kept(problem, tr, cand, s + 1, g)
    kept_ok = all(verdict.satisfied(r, kappa) for r in ev.kept.values())
    if broken:  # a recovery keeps the specs from the sample it is back on
        back = _back(problem, tr, cand, s + 1, g)
        kept_ok = back is not None
        ev.detail["recovery"] = {"broken_at_start": broken,
                                 "back_at": None if back is None else back * dt}
    ev.accepted = bool(status.converged and ev.within_budget and rejoin <= REJOIN_TOL
                       and kept_ok)
    ev.detail = {**ev.detail, "iterations": res.solver["iterations"], "cpu_s": res.solver["cpu_s"],
                 "return_status": res.solver["return_status"], "start_sample": s,
                 "goal_sample": g, "steps": L, "rejoin_error": rejoin,
                 "objective": res.solver["objective"],
                 "start_deviation": float(np.linalg.norm(x_start[tr.pos] - tr.ref_X[s, tr.pos])),
                 "variables": res.problem_size["variables"],
                 "constraints": res.problem_size["constraints"],
                 **({"outside_bounds": res.solver["outside_bounds"]}
                    if "outside_bounds" in res.solver else {})}
    if first:
        ev.detail["build_s"] = res.timing["build_s"]
    if not ev.accepted:  # say why (stlc.replan.explain)
        ev.detail["reason"] = explain.reason(
            converged=status.converged, status=str(status), within_budget=ev.within_budget,
            solve_s=ev.solve_s, budget=cfg.compute_budget, rejoin=rejoin,
            rejoin_tol=REJOIN_TOL, kept={} if broken and kept_ok else ev.kept,
            kappa=kappa, deviation=x_start[tr.pos] - tr.ref_X[s, tr.pos], segment_s=L * dt,
            acc_max=vm.kinematic_limits(tr.vehicle)[1])
    if status.converged:
        ev.times = grid.times()[s:g + 1]
        for i, c in enumerate(vm.state_channels(tr.vehicle)):
            ev.channels[c] = flown[:, i].copy()
        Up = np.vstack([U, U[-1:]])
        for i, c in enumerate(vm.input_channels(tr.vehicle)):
            ev.channels[c] = Up[:, i].copy()
    if ev.accepted:
        tr.ref_X = cand
        tr.ref_U = tr.ref_U.copy()
        tr.ref_U[s:g] = U
        tr.D = tr.D.copy()
        tr.D[s:g] = 0.0  # the segment is an exact solution of the model


def _clause_signals(problem, tr: _Track, X: np.ndarray) -> list[tuple[Clause, np.ndarray]]:
    """Each kept clause with the exact robustness signal of its body on the states X."""
    v = tr.vehicle
    ch = {c: X[:, i] for i, c in enumerate(vehicles.model_of(v).state_channels(v))}
    return [(cl, monitor.robustness_signal(cl.body, problem.grid.dt, ch, problem.params))
            for cl in tr.clauses]


def _kept(problem, tr: _Track, X: np.ndarray, first: int, last: int) -> dict[str, float]:
    """Exact robustness of each kept spec's clauses on samples first..last of X (doc)."""
    out: dict[str, float] = {}
    for cl, sig in _clause_signals(problem, tr, X):
        a, b = max(first, cl.first), min(last, cl.last)
        r = float(np.min(sig[a:b + 1])) if a <= b else math.inf
        out[cl.spec] = min(out.get(cl.spec, math.inf), r)
    return out


def _needed_steps(tr: _Track, x_start: np.ndarray, s: int, dt: float) -> int:
    """The fewest steps in which the vehicle can possibly null its position and velocity
    deviation from the reference at sample s — per axis, the minimum time of a double
    integrator under the sound acceleration bound of its model (``kinematic_envelope``;
    ``explain.min_time``) — plus one: a shorter segment cannot rejoin."""
    vm = vehicles.model_of(tr.vehicle)
    _, lo, hi = vm.kinematic_envelope(tr.vehicle)
    a = np.maximum(np.abs(lo), np.abs(hi))
    e = x_start[tr.pos] - tr.ref_X[s, tr.pos]
    de = x_start[vm.vel_index()] - tr.ref_X[s, vm.vel_index()]
    t = max(explain.min_time(float(x), float(v), float(ai)) for x, v, ai in zip(e, de, a))
    return steps_ceil(t, dt) + 1 if math.isfinite(t) else 1


def _back(problem, tr: _Track, X: np.ndarray, first: int, last: int) -> int | None:
    """The first sample r of first..last from which every kept clause is ≥ κ up to
    ``last`` (a recovery is back on its kept specs there); None if none is."""
    ok = np.ones(last - first + 1, bool)
    for cl, sig in _clause_signals(problem, tr, X):  # a clause holds outside its window
        for r in range(max(first, cl.first), min(last, cl.last) + 1):
            ok[r - first] &= verdict.satisfied(float(sig[r]), problem.threshold)
    bad = np.flatnonzero(~ok)
    r = first if bad.size == 0 else int(bad[-1]) + 1 + first
    return r if r <= last else None


def _executed(problem, tracks: dict[str, _Track], n: int) -> dict[str, np.ndarray]:
    """Executed states and applied inputs (padded to n) by name, derived signals recomputed."""
    ch: dict[str, np.ndarray] = {}
    for tr in tracks.values():
        v = tr.vehicle
        vm = vehicles.model_of(v)
        for i, c in enumerate(vm.state_channels(v)):
            ch[c] = tr.X[:, i].copy()
        Up = np.vstack([tr.U, tr.U[-1:]]) if n > 1 else tr.U
        for i, c in enumerate(vm.input_channels(v)):
            ch[c] = Up[:, i].copy()
    ch, _ = recompute_derived(problem, ch)
    return ch
