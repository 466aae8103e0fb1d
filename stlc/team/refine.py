"""Continuous team refinement of paper B: maximise the mission robustness from a seed.

Design (NLP_NOTES §4: a full 20 Hz grid is far too big for exact-Hessian IPOPT):

* **Variables**: position and velocity of every drone at knots every ``knot_dt`` ≈ 1 s, cubic
  Hermite between knots (``stlc.team.waypoints``), plus one margin variable r. Every dense
  sample (position, velocity, acceleration at T_s = 0.05 s) is a fixed sparse linear map of
  the knots, so the NLP has 6·K·D + 1 variables whatever the sampling step.
* **Hypograph form** of "maximise robustness": maximise r subject to every predicate of the
  safety/dwell part of eq. (2) being ≥ r — the *exact* min, not a log-sum-exp: workspace
  faces, hover points inside their target/station with margin r, pairwise distance
  ‖p_d − p_e‖ ≥ Γ_dis + r (as dist² ≥ (Γ + r)²), and outside every obstacle box. The box
  complement is a disjunction (max over six face distances); it is written with the *sound*
  lower bound of the max, LSE_λ(faces) − ln 6/λ ≤ max, so a feasible point is truly outside.
* **Assignment and order fixed** (paper B keeps the MILP's): ``stlc.team.retime`` stretches
  the seed's transits by a common factor and snaps each dwell to knots; during a dwell the
  knots hover (v = 0, one common position in the region with margin r), which by the cubic
  form keeps every sample of the dwell on that point.
* **Bounds exact on the dense grid by construction**: acceleration is linear in a segment,
  so |a| ≤ ā at both segment ends bounds every sample; velocity and workspace position are
  constrained at four check points per segment, tightened by the largest possible overshoot
  between check points (``waypoints.overshoot``).
* **Separation and obstacle rows by constraint generation**: only samples where the current
  trajectory comes close (seed within a buffer, then every dense sample found violating
  after a solve, with neighbours) get rows; each round re-solves warm-started and the dense
  trajectory is re-checked until no sample is below the optimised margin.
* **Energy** (paper B eq. 9, ``eta > 0``): a second solve, warm-started, maximises
  r − η Σ_k (1 − v_for,k / v*)² over the dense transit samples (``stlc.team.energy``) with
  r kept ≥ min(κ, r of the first solve); v* is clamped to the feasible forward speed.

The exact monitor on the dense plan is the judge; ``margins`` is its numpy shortcut for the
parts optimised here (the payload-dependent install/refill specs only need the dwells).
"""

from __future__ import annotations

import math
import time

import numpy as np

from stlc.team import Box, TeamPlan, TeamScenario
from stlc.team.energy import feasible_forward_speed
from stlc.team.nlp import TeamNLP
from stlc.team.retime import initial_knots, make_schedule


def _faces(p: np.ndarray, box: Box) -> np.ndarray:
    lo, hi = np.array(box.lo), np.array(box.hi)
    return np.concatenate([p - hi, lo - p], axis=-1)  # > 0 on the outer side of a face


def margins(scenario: TeamScenario, plan: TeamPlan) -> dict[str, float]:
    """Exact minimum margins on the dense grid (metres; bounds as max |·|/bound ratios)."""
    names = [d.name for d in scenario.drones]
    ws = scenario.workspace
    out = {"workspace": math.inf, "obstacles": math.inf, "separation": math.inf,
           "dwell": math.inf, "vel_ratio": 0.0, "acc_ratio": 0.0}
    for drone in scenario.drones:
        p = plan.pos[drone.name]
        out["workspace"] = min(out["workspace"], float(np.min(-_faces(p, ws))))
        for o in scenario.obstacles:
            out["obstacles"] = min(out["obstacles"], float(np.min(np.max(_faces(p, o), 1))))
        out["vel_ratio"] = max(out["vel_ratio"],
                               float(np.max(np.abs(plan.vel[drone.name]) / drone.vel_max)))
        out["acc_ratio"] = max(out["acc_ratio"],
                               float(np.max(np.abs(plan.acc[drone.name]) / drone.acc_max)))
    for i, a in enumerate(names):
        for b in names[i + 1:]:
            dist = np.linalg.norm(plan.pos[a] - plan.pos[b], axis=1)
            out["separation"] = min(out["separation"], float(np.min(dist)) - scenario.separation)
    boxes = {b.name: b for b in (*scenario.targets, *scenario.stations)}
    for v in plan.visits:
        sel = (plan.times >= v.start - 1e-9) & (plan.times <= v.end + 1e-9)
        inside = -_faces(plan.pos[v.drone][sel], boxes[v.region])
        out["dwell"] = min(out["dwell"], float(np.min(inside)))
    return out


def _close_samples(scenario, pos: dict[str, np.ndarray], limit_sep, limit_obs, stride):
    """(pair, sample) and (drone, obstacle, sample) index sets below the given margins."""
    names = [d.name for d in scenario.drones]
    n = len(next(iter(pos.values())))
    sep, obs = set(), set()
    for i, a in enumerate(names):
        for j in range(i + 1, len(names)):
            dist = np.linalg.norm(pos[a] - pos[names[j]], axis=1) - scenario.separation
            for k in np.flatnonzero(dist < limit_sep):
                if k % stride == 0 or dist[k] < limit_sep - 1.0:
                    sep.add((i, j, int(k)))
    for i, a in enumerate(names):
        for q, o in enumerate(scenario.obstacles):
            m = np.max(_faces(pos[a], o), 1)
            for k in np.flatnonzero(m < limit_obs):
                if k % stride == 0 or m[k] < limit_obs - 1.0:
                    obs.add((i, q, int(k)))
    return sep, obs, n


def _widen(found: set, n: int, width: int = 2) -> set:
    out = set()
    for key in found:
        for dk in range(-width, width + 1):
            if 0 <= key[-1] + dk < n:
                out.add((*key[:-1], key[-1] + dk))
    return out


def refine(scenario: TeamScenario, seed: TeamPlan, *, lam: float = 10.0, kappa: float = 0.2,
           eta: float = 0.0, v_star: float | dict[str, float] | None = None,
           knot_dt: float = 1.0,
           stretch_cap: float = 0.5, dwell_pad: float = 0.5, max_rounds: int = 6,
           buffer: float = 2.0, ipopt: dict | None = None) -> tuple[TeamPlan, dict]:
    """Refine a team seed (route fixed) into a dense plan; returns (plan, stats)."""
    if isinstance(v_star, dict):  # one v* per drone (paper B eq. 8 from each drone's data)
        v_star = {d.name: v_star[d.name] for d in scenario.drones}
    if eta > 0 and (v_star is None or min(_per_drone(v_star, scenario).values()) <= 0):
        raise ValueError("eta > 0 needs a positive v_star")
    wall0, cpu0 = time.perf_counter(), time.process_time()
    sched = make_schedule(scenario, seed, knot_dt, stretch_cap, dwell_pad)
    guess = initial_knots(scenario, seed, sched)
    times = np.asarray(seed.times, dtype=float)
    nlp = TeamNLP(scenario, sched, times, lam=lam)
    x = nlp.pack(guess)
    plan0 = nlp.plan(x, seed)
    m0 = margins(scenario, plan0)
    x[-1] = min(0.5, m0["dwell"], m0["separation"], m0["obstacles"], m0["workspace"])
    stride = max(1, round(0.25 / scenario.step))
    sep, obs, n = _close_samples(scenario, plan0.pos, buffer, buffer, stride)
    stats: dict = {"drones": len(scenario.drones), "knots": len(sched.knots),
                   "stretch": sched.stretch, "variables": nlp.nw, "rounds": [],
                   "build_cpu_s": 0.0, "solve_cpu_s": 0.0, "iterations": 0}
    status = "not solved"

    def solve(energy: dict | None, r_floor: float | None):
        nonlocal x, status
        t0 = time.process_time()
        solver, lbg, ubg, lbx, ubx, ncon = nlp.build(x, sep, obs, energy, r_floor, ipopt)
        t1 = time.process_time()
        res = solver(x0=x, lbg=lbg, ubg=ubg, lbx=lbx, ubx=ubx)
        t2 = time.process_time()
        st = solver.stats()
        x = np.array(res["x"]).ravel()
        status = st["return_status"]
        stats["build_cpu_s"] += t1 - t0
        stats["solve_cpu_s"] += t2 - t1
        stats["iterations"] += int(st["iter_count"])
        stats["rounds"].append({"constraints": ncon, "sep_rows": len(sep), "obs_rows": len(obs),
                                "iterations": int(st["iter_count"]), "status": status,
                                "r": float(x[-1]), "build_cpu_s": t1 - t0,
                                "solve_cpu_s": t2 - t1, "energy": energy is not None})

    def generate(energy: dict | None, r_floor: float | None) -> TeamPlan:
        for _ in range(max_rounds):
            solve(energy, r_floor)
            plan = nlp.plan(x, seed)
            target = min(float(x[-1]), kappa) - 1e-3
            s2, o2, _ = _close_samples(scenario, plan.pos, target, target, 1)
            s2, o2 = _widen(s2, n) - sep, _widen(o2, n) - obs
            if not s2 and not o2:
                return plan
            sep.update(s2)
            obs.update(o2)
        return plan

    plan = generate(None, None)
    r_std = float(x[-1])
    stats["standard"] = plan  # the plan without the forward-speed term (paper B Fig. 11)
    if eta > 0:
        vs = {d.name: feasible_forward_speed(v, d.vel_max)
              for d, v in zip(scenario.drones, _per_drone(v_star, scenario).values())}
        stats["v_star"] = vs
        # a little above κ: IPOPT meets the floor to its tolerance, the dense check must too
        plan = generate({"eta": eta, "v_star": vs}, min(kappa + 1e-3, r_std - 1e-3))
    stats.update(status=status, r=float(x[-1]), r_standard=r_std,
                 constraints=stats["rounds"][-1]["constraints"],
                 margins=margins(scenario, plan), forward_cost=nlp.forward_cost(plan, v_star),
                 cpu_s=time.process_time() - cpu0, wall_s=time.perf_counter() - wall0)
    return plan, stats


def _per_drone(v_star, scenario: TeamScenario) -> dict[str, float]:
    if isinstance(v_star, dict):
        return {d.name: float(v_star[d.name]) for d in scenario.drones}
    return {d.name: float(v_star) for d in scenario.drones}


def per_drone_csv(plan: TeamPlan, moving_speed: float = 0.05) -> dict[str, str]:
    """One CSV text per drone: ``t,x,y,z,vx,vy,vz,ax,ay,az,heading``.

    heading = atan2(vy, vx) (rad, world frame) while the horizontal speed is above
    ``moving_speed``; while hovering the last heading is held (before the first motion, the
    heading of the first motion; 0 for a drone that never moves).
    """
    out = {}
    for d, p in plan.pos.items():
        v, a = plan.vel[d], plan.acc[d]
        moving = np.hypot(v[:, 0], v[:, 1]) > moving_speed
        raw = np.arctan2(v[:, 1], v[:, 0])
        heading = np.zeros(len(p))
        idx = np.flatnonzero(moving)
        if len(idx):
            last = np.maximum.accumulate(np.where(moving, np.arange(len(p)), -1))
            heading = raw[np.where(last >= 0, last, idx[0])]
        rows = ["t,x,y,z,vx,vy,vz,ax,ay,az,heading"]
        for k in range(len(p)):
            vals = (plan.times[k], *p[k], *v[k], *a[k], heading[k])
            rows.append(",".join(f"{float(x):.4f}" for x in vals))
        out[d] = "\n".join(rows) + "\n"
    return out

