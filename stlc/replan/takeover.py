"""Backup-drone takeover after a drone failure (paper B §IV-C).

``simulate_failure(problem, plan, failure, cfg)`` simulates a compiled team plan in which
``failure.vehicle`` fails at ``t_fail = failure.time`` and the declared ``failure.backup``
takes over its pending targets from ``t0 = t_fail + T_rep`` (``cfg.takeover_delay``).

Semantics (the decisions the paper leaves open):

* **Grid.** ``k_f`` is the last mission sample at or before t_fail; t0 is rounded *up* to the
  mission grid (the backup never starts earlier than T_rep after the failure).
* **The failed drone** flies its plan up to sample ``k_f`` and is out of the mission from the
  next sample on. It cannot be dropped from the team's quantifiers (its installs before the
  failure count), so from ``k_f + 1`` it is *parked*: its position is the centre of a
  refilling station, velocity and acceleration 0 (a jump: the channels after t_fail are a
  bookkeeping device for the monitor, not a flight; draw the failed drone up to t_fail).
  Parked in a station it installs nothing (it is in no target) and every per-drone spec
  holds for it trivially (safety, refill, home); the station is its own planned home when
  every other drone (and the waiting backup) stays ≥ Γ_dis + 0.5 m from it after the
  failure, otherwise the station with the largest such clearance; the backup neither uses
  that station nor comes within Γ_dis of it (the parked drone is one of its fixed drones).
* **Pending targets** are the failed drone's targets (its planned installs, and targets of
  its route that the plan left uninstalled) that the payload rule (``stlc.team.payload``),
  run on the positions of the team with the failed drone parked from ``k_f + 1``, does not
  count as installed. A stay that had lasted T_ins by ``k_f`` counts (its install completes
  at t_fail, when the drone leaves the target); one in progress (shorter) does not, and its
  target is pending.
* **The backup** waits at its start, at rest, until t0, carrying its full capacity; on
  [t0, T_N] it flies the plan of the takeover backend (``stlc.backends.replan.takeover``: the team
  MILP, seed and refinement), run through ``run_chain`` on the takeover's
  ``PlanningProblem``: the backup alone, the window [t0, T_N], the other drones' plans and
  the parked failed drone as fixed channels (in the separation rows), the pending targets
  and the free stations.
* **Judgement.** The executed trajectory (the other drones' plans, the failed drone then
  parked, the backup) is verified like a plan (``stlc.planning.verify``: derived signals and
  the payload recomputed from the positions) against the checked mission re-instantiated
  with the backup in its team (``stlc.semantics.teamform.for_team``: the quantifiers over
  the team that the checker kept, no source text and no checker), so ``forall d in team``
  and ``exists d in team`` range over the backup, with the ``--set`` values of the run.
  ``executed_robustness`` holds ``mission`` (the requirement) and every named spec; the
  event's ``kept`` holds the specs of the mission's ``replan { keep = [...] }``, or every
  named spec when it names none.
* **Accepted** when the replan converged (MILP optimal, IPOPT optimal/acceptable), took at
  most T_rep (the time the paper reserves for it) and every kept spec is ≥ κ on the
  executed trajectory. ``within_budget`` compares the replan time with the 2 s goal
  (``GOAL_S``, paper B: "approximately 2 s"). A plan that is not accepted is still flown in
  the executed trajectory, so that its robustness shows what it would do; when the MILP or
  the seed finds no plan (no time left, no assignment fits) the backup stays at its start.
* **Nothing pending** (the failed drone had finished its installs) is no error: the event is
  not triggered, the backup is not sent and the executed team is the mission's own.

Bad inputs raise ``TakeoverError`` (a ``ValueError``) naming the culprit in ``subject``.
"""

from __future__ import annotations

import math
import time

import numpy as np

from stlc.analysis import verdict
from stlc.backends.base import SolverStatus, run_chain
from stlc.planning.takeover import BackupPlan, Fixed
from stlc.replan.result import ReplanEvent, SimulationResult
from stlc.semantics import model
from stlc.team import Drone, TeamScenario, centre

GOAL_S = 2.0  # s: paper B reports about 2 s per replan
TARGET_S = 1.0  # s: our goal
PARK_MARGIN = 0.5  # m above Γ_dis for the failed drone's own home to be its parking place


class TakeoverError(ValueError):
    """A takeover that cannot be simulated as given; ``subject`` names the vehicle (or "")."""

    def __init__(self, message: str, subject: str = "") -> None:
        super().__init__(message)
        self.message = message
        self.subject = subject


def validate(problem, plan, failure: model.Failure, cfg: model.ReplanConfig) -> Drone:
    """Check the failure against the mission; returns the backup as a team ``Drone``."""
    from stlc import vehicles
    from stlc.semantics.teamform import TeamFormError, for_team

    m, prog = problem.mission, problem.program
    f, b = failure.vehicle, failure.backup
    if not plan.routes:
        raise TakeoverError(f"mission `{m.name}` is not a team mission (no routes): "
                            "a takeover needs a payload mission", m.name)
    if f not in problem.team:
        raise TakeoverError(f"`{f}` is not in the team of mission `{m.name}` "
                            f"({', '.join(problem.team)})", f)
    if b not in prog.vehicles:
        raise TakeoverError(f"backup `{b}` is not a declared vehicle", b)
    if b in problem.team:
        raise TakeoverError(f"backup `{b}` is already in the team of mission `{m.name}`", b)
    v = prog.vehicles[b]
    if not vehicles.model_of(v).carries_payload(v):
        raise TakeoverError(f"backup `{b}` is a {vehicles.model_of(v).kind}; the takeover "
                            "plans point-mass drones", b)
    if v.capacity is None or v.capacity < 1:
        raise TakeoverError(f"backup `{b}` has no capacity (it can carry no diverter)", b)
    try:  # the mission over the executed team (judged at the end) must exist
        for_team(m, (*problem.team, b))
    except TeamFormError as e:
        raise TakeoverError(f"backup `{b}` cannot join mission `{m.name}`: {e}", b) from None
    horizon = float(m.horizon)
    if not (0.0 <= failure.time < horizon) or math.isnan(failure.time):
        raise TakeoverError(f"failure time {failure.time:g} s is outside the mission "
                            f"[0, {horizon:g}) s", f)
    if not cfg.takeover_delay >= 0:
        raise TakeoverError(f"takeover delay T_rep = {cfg.takeover_delay:g} s must be ≥ 0", b)
    return Drone(b, tuple(map(float, v.start_pos)), tuple(map(float, v.vel_max)),
                 tuple(map(float, v.acc_max)), int(v.capacity))


def _pos(ch: dict, d: str) -> np.ndarray:
    return np.stack([np.asarray(ch[f"{d}.pos.{a}"], dtype=float) for a in "xyz"], axis=1)


def _kin(ch: dict, d: str) -> dict[str, np.ndarray]:
    """Position, velocity and acceleration channels of drone d (copies)."""
    return {f"{d}.{f}.{a}": np.array(ch[f"{d}.{f}.{a}"], dtype=float)
            for f in ("pos", "vel", "acc") for a in "xyz"}


def _set(ch: dict, d: str, sl: slice, pos, vel=0.0, acc=0.0) -> None:
    for j, a in enumerate("xyz"):
        for f, val in (("pos", pos), ("vel", vel), ("acc", acc)):
            v = np.asarray(val, dtype=float)
            ch[f"{d}.{f}.{a}"][sl] = v[..., j] if v.ndim else v


def failed_targets(plan, drone: str, targets: set[str]) -> list[str]:
    """The failed drone's targets: its planned installs, then targets of its route that no
    planned event installs (in route order)."""
    mine = [e.region for e in plan.events if e.drone == drone and e.kind == "install"]
    done = {e.region for e in plan.events if e.kind == "install"}
    rest = [r for r in plan.routes.get(drone, []) if r in targets and r not in done]
    return list(dict.fromkeys(mine + rest))


def parking_station(sc: TeamScenario, home: str | None, others: dict[str, np.ndarray],
                    k_from: int, backup_start) -> tuple[str | None, float]:
    """Where the failed drone is parked (see the module docstring) and its clearance (m)."""
    best, best_c = None, -math.inf
    clearance = {}
    for s in sc.stations:
        c = centre(s)
        d = [float(np.linalg.norm(np.asarray(backup_start) - c))]
        d += [float(np.min(np.linalg.norm(p[k_from:] - c, axis=1))) for p in others.values()
              if len(p) > k_from]
        clearance[s.name] = min(d)
        if clearance[s.name] > best_c:
            best, best_c = s.name, clearance[s.name]
    if home in clearance and clearance[home] >= sc.separation + PARK_MARGIN:
        return home, clearance[home]
    return best, best_c


def retire(problem, plan, failure: model.Failure, backup_start) -> dict:
    """The team's kinematic channels with the failed drone parked from the sample after
    t_fail, where it is parked, and its pending and installed targets (module docstring)."""
    from stlc.planning.bounds import stated_bounds
    from stlc.planning.verify import recompute_derived
    from stlc.team.seed import scenario_from_program

    f, dt = failure.vehicle, problem.grid.dt
    n = len(plan.times)
    # the scenario the team chain planned on (it was built once already: no error here)
    base = scenario_from_program(problem.program, problem.mission, separation=float(
        stated_bounds(problem.requirement).get("distance_min", 0.0)))
    k_f = min(n - 1, int(math.floor(failure.time / dt + 1e-9)))
    raw: dict[str, np.ndarray] = {}
    for d in problem.team:
        raw.update(_kin(plan.channels, d))
    others = {d: _pos(plan.channels, d) for d in problem.team if d != f}
    stations = {s.name: s for s in base.stations}
    home = next((r for r in reversed(plan.routes.get(f, [])) if r in stations), None)
    park, clear = parking_station(base, home, others, k_f + 1, backup_start)
    if park is None:
        raise TakeoverError(f"mission `{problem.mission.name}` has no refilling station to "
                            f"park the failed `{f}` in", f)
    _set(raw, f, slice(k_f + 1, None), centre(stations[park]))
    _, events = recompute_derived(problem, raw)
    installed = {e.region for e in events if e.kind == "install"}
    targets = failed_targets(plan, f, {t.name for t in base.targets})
    return {"base": base, "raw": raw, "others": others, "park": park, "clearance": clear,
            "k_f": k_f, "pending": [t for t in targets if t not in installed],
            "installed": [t for t in targets if t in installed]}


def free_stations(sc: TeamScenario, exclude: str, fixed: list[Fixed]) -> list[str]:
    """Stations the backup may refill and end in: not the parking one, and none that a
    fixed drone comes within Γ_dis + PARK_MARGIN of (its centre) on the segment; all but
    the parking one when no station is free."""
    rest = [s for s in sc.stations if s.name != exclude]
    free = [s.name for s in rest
            if all(float(np.min(np.linalg.norm(fx.pos - centre(s), axis=1)))
                   >= sc.separation + PARK_MARGIN for fx in fixed)]
    return free or [s.name for s in rest]


def simulate_failure(problem, plan, failure: model.Failure,
                     cfg: model.ReplanConfig | None = None, *, planner,
                     energy: bool = False) -> SimulationResult:
    """Simulate ``failure`` on the team ``plan`` of ``problem`` (``stlc.pipeline.plan``).

    ``energy`` adds the mission's forward-speed term (eq. 9) to the backup's refinement; off
    by default: that second IPOPT solve roughly doubles the replan time for a cost term,
    not a spec.  ``planner`` is the backend that plans the backup
    (``stlc.backends.replan.takeover.TakeoverBackend``, given by the pipeline)."""
    cfg = cfg if cfg is not None else model.ReplanConfig()
    backup = validate(problem, plan, failure, cfg)
    f, b = failure.vehicle, backup.name
    times = np.asarray(plan.times, dtype=float)
    dt, n = problem.grid.dt, len(times)
    k0 = int(math.ceil((failure.time + cfg.takeover_delay) / dt - 1e-9))
    notes: list[str] = []
    out = retire(problem, plan, failure, backup.start)
    base, raw, others, park = out["base"], out["raw"], out["others"], out["park"]
    pending, done = out["pending"], out["installed"]
    park_box = next(s for s in base.stations if s.name == park)
    if out["clearance"] < base.separation:
        notes.append(f"the failed {f} is parked in {park}, {out['clearance']:.2f} m from "
                     f"another drone (< Γ_dis = {base.separation:g} m): no station is clear")

    # -------------------------------------------------- the backup's replan
    t0 = float(k0 * dt)
    event = ReplanEvent(time=float(failure.time), vehicle=f, deviation=0.0,
                        triggered=bool(pending), kind="failure",
                        detail={"pending": pending, "installed_before_failure": done,
                                "backup": b, "parked_in": park})
    if pending:  # the backup joins the executed team, waiting at its start until t0
        for c in ("pos", "vel", "acc"):
            for a in "xyz":
                raw[f"{b}.{c}.{a}"] = np.zeros(n)
        _set(raw, b, slice(None), np.asarray(backup.start))
    if not pending:
        notes.append(f"{f} had installed all its targets by {failure.time:g} s: no replan "
                     "needed")
    elif k0 >= n - 1:
        event.status = str(SolverStatus.INFEASIBLE)
        event.solve_s, event.within_budget, event.accepted = 0.0, True, False
        event.detail["message"] = (f"t_fail + T_rep = {failure.time + cfg.takeover_delay:g} "
                                   f"s leaves no time before T_N = {times[-1]:g} s")
        notes.append(f"the backup {b} cannot take over: {event.detail['message']}")
    else:
        fixed = [Fixed(dr, others[dr.name][k0:],
                       np.stack([plan.channels[f"{dr.name}.vel.{a}"][k0:] for a in "xyz"], 1),
                       np.stack([plan.channels[f"{dr.name}.acc.{a}"][k0:] for a in "xyz"], 1))
                 for dr in base.drones if dr.name != f]
        fdr = next(dr for dr in base.drones if dr.name == f)
        zero = np.zeros((n - k0, 3))
        fixed.append(Fixed(fdr, np.tile(centre(park_box), (n - k0, 1)), zero, zero))
        w0, c0 = time.perf_counter(), time.process_time()
        stations = free_stations(base, park, fixed)
        event.detail["stations"] = stations
        sub = takeover_problem(problem, backup.name, fixed, k0, (t0, float(times[-1])),
                               pending, stations, energy, max(cfg.takeover_delay, 1.0))
        bp = backup_plan(run_chain(sub, [planner])[0], backup.name)
        event.solve_s = time.perf_counter() - w0
        event.detail.update(cpu_s=time.process_time() - c0, **_detail(bp, backup))
        event.status = str(bp.status)
        event.within_budget = event.solve_s <= GOAL_S
        event.segment = (t0, float(times[-1]))
        if bp.pos is not None:
            _set(raw, b, slice(k0, None), bp.pos, bp.vel, bp.acc)
            event.times = times[k0:].copy()
            event.channels = {k: v[k0:].copy() for k, v in raw.items() if k.startswith(b + ".")}
        else:
            notes.append(f"the backup {b} has no plan: {bp.message}")

    # -------------------------------------------------- judge the executed trajectory
    executed, rob = judge(problem, b if pending else None, raw)
    kept_names = list(cfg.specs) or [k for k in rob if k != "mission"]
    event.kept = {k: rob[k] for k in kept_names if k in rob}
    if event.triggered and event.accepted is None:
        event.accepted = bool(SolverStatus(event.status).converged
                              and event.solve_s <= cfg.takeover_delay
                              and all(verdict.satisfied(v, problem.threshold)
                                      for v in event.kept.values()))
    return SimulationResult(
        mission=problem.mission.name, times=times, nominal=dict(plan.channels),
        executed=executed, events=[event], budget=GOAL_S, executed_robustness=rob,
        threshold=problem.threshold, failures=[failure], notes=notes)


def takeover_problem(problem, backup: str, fixed: list[Fixed], k0: int,
                     window: tuple[float, float], pending: list[str], stations: list[str],
                     energy: bool, budget_s: float):
    """The backup's planning problem: the backup alone on ``window``, the ``fixed`` drones'
    trajectories (from sample ``k0``) as fixed channels on the mission grid, in order, the
    pending targets and free stations; the forward-speed term only with ``energy``."""
    from dataclasses import replace
    from types import MappingProxyType

    n = problem.grid.n
    chans: dict[str, np.ndarray] = {}
    for fx in fixed:
        for f, arr in (("pos", fx.pos), ("vel", fx.vel), ("acc", fx.acc)):
            for j, a in enumerate("xyz"):
                full = np.zeros(n)
                full[k0:k0 + len(arr)] = arr[:, j]
                chans[f"{fx.drone.name}.{f}.{a}"] = full
    obj = problem.objective if energy else replace(problem.objective, forward_weight=0.0)
    return replace(problem, team=(backup,), window=window, seed=None,
                   fixed_channels=MappingProxyType(chans), targets=tuple(pending),
                   stations=tuple(stations), objective=obj, time_limit=float(budget_s))


def backup_plan(sol, backup: str) -> BackupPlan:
    """The ``BackupPlan`` of the takeover backend's ``Solution`` (channels on the window)."""
    stack = None
    if f"{backup}.pos.x" in sol.channels:
        def stack(f):
            return np.stack([np.asarray(sol.channels[f"{backup}.{f}.{a}"]) for a in "xyz"], 1)
    return BackupPlan(SolverStatus(sol.solver["status"]), list(sol.routes.get(backup, [])),
                      *((stack("pos"), stack("vel"), stack("acc")) if stack else (None,) * 3),
                      stats=dict(sol.solver.get("stats", {})),
                      message=str(sol.solver.get("message", "")))


def _detail(bp: BackupPlan, backup: Drone) -> dict:
    out = {"backup_route": list(bp.route), **{k: v for k, v in bp.stats.items()}}
    if bp.message:
        out["message"] = bp.message
    if bp.vel is not None:
        out["vel_ratio"] = float(np.max(np.abs(bp.vel) / np.asarray(backup.vel_max)))
        out["acc_ratio"] = float(np.max(np.abs(bp.acc) / np.asarray(backup.acc_max)))
    return out


def judge(problem, backup: str | None, raw: dict[str, np.ndarray]
          ) -> tuple[dict[str, np.ndarray], dict[str, float]]:
    """The executed channels with derived signals and payload recomputed, and the exact
    robustness of the mission (over the team with the backup, if it was sent) and of each
    named spec."""
    from stlc.analysis import monitor
    from stlc.planning.problem import from_mission
    from stlc.planning.verify import recompute_derived
    from stlc.semantics.teamform import for_team

    m = problem.mission
    p_exec = problem
    if backup is not None:  # the checked mission re-instantiated: no source, no checker
        m_exec = for_team(m, (*problem.team, backup))
        p_exec = from_mission(problem.program, m_exec, step=m.step, horizon=m.horizon,
                              values=problem.values)
    ch, _ = recompute_derived(p_exec, raw)
    dt, params = p_exec.grid.dt, p_exec.params
    rob = {"mission": float(monitor.robustness(p_exec.requirement, dt, ch, params))}
    for name, spec in p_exec.specs.items():
        rob[name] = float(monitor.robustness(spec.normal, dt, ch, params))
    return ch, rob
