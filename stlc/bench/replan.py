"""Benchmark of disturbance replanning: ``python -m stlc.bench.replan``.

Plans ``handover_left_tb`` (``specs/handover.stl``) once — or loads the plan cached by an
earlier run, or a ``trajectory.csv`` given with ``--trajectory`` — then

1. runs ``--runs`` (default 24) simulations with one randomised push each (seeded):
   magnitude uniform in [1.05, 1.3] m, horizontal direction uniform, time uniform in
   [0.5 s, T_N − 3 s].  A push that lands the vehicle in a region its kept specs forbid
   (checked on the pushed nominal path until the latest replan start) is a collision, not a
   replanning problem: it is redrawn, and the number of redraws is printed;
2. runs the two-disturbance demo of paper A Fig. 12 (two pushes of ~1.1 m at 3 s and 9 s);

and prints one row per triggered replan and a summary: median, p95 and worst solve time
(wall and CPU), IPOPT iterations, status counts, triggered/accepted counts, the kept-spec
robustness on the segments and the named specs on the executed trajectory.  Wall times on a
shared machine are inflated by load: the load average is printed beside them.
"""

from __future__ import annotations

import argparse
import math
import os
import tempfile
import time
from collections import Counter

import numpy as np

from stlc.analysis import monitor
from stlc.planning.solution import Solution
from stlc.planning.problem import from_mission
from stlc.backends.replan.segment import SegmentBackend
from stlc.replan.disturb import simulate_disturbances
from stlc.planning.kept import kept_clauses
from stlc.semantics import model


def load_plan(path: str, mission: str, trajectory: str | None, cache: str | None):
    """(program, mission, problem, Solution): from a trajectory CSV, a cached plan, or a
    fresh compile (then cached)."""
    from stlc import pipeline

    program = pipeline.load(path).program
    m = program.missions[mission]
    problem = from_mission(program, m)
    if trajectory:
        from stlc.analysis.trace import read_trace

        tr = read_trace(trajectory)
        return program, m, problem, Solution(m.name, "satisfied", 0.0, 0.0, {}, 0.0,
                                             tr.times, tr.channels)
    cache = cache or os.path.join(tempfile.gettempdir(), f"stlc-replan-{mission}.npz")
    if os.path.exists(cache):
        z = np.load(cache)
        ch = {k: z[k] for k in z.files if k != "__t"}
        print(f"plan: loaded {cache}")
        return program, m, problem, Solution(m.name, "satisfied", 0.0, 0.0, {}, 0.0,
                                             z["__t"], ch)
    t0 = time.perf_counter()
    problem, sol = pipeline.plan(program, m)
    print(f"plan: compiled {mission} in {time.perf_counter() - t0:.1f} s ({sol.status}, "
          f"exact {sol.robustness_exact:+.4f}); cached in {cache}")
    np.savez(cache, __t=sol.times, **sol.channels)
    return program, m, problem, sol


def _pushed_safe(problem, plan, cfg, t: float, disp: np.ndarray, vehicle) -> bool:
    """The kept specs' bodies hold on the nominal path shifted by ``disp`` from t until
    the latest replan start (t + T_e + t_c)."""
    dt = problem.grid.dt
    a = int(math.ceil(t / dt - 1e-9))
    b = min(problem.grid.n - 1, int(math.ceil((t + cfg.event_period + cfg.compute_budget)
                                              / dt)))
    ch = {k: np.asarray(v, float).copy() for k, v in plan.channels.items()}
    for i, ax in enumerate("xyz"):
        ch[f"{vehicle.name}.pos.{ax}"][a:] += disp[i]
    for cl in kept_clauses(problem, cfg.specs, vehicle):
        sig = monitor.robustness_signal(cl.body, dt, ch, problem.params)
        if np.min(sig[a:b + 1]) < problem.threshold:
            return False
    return True


def random_pushes(problem, plan, cfg, runs: int, seed: int):
    rng = np.random.default_rng(seed)
    v = problem.vehicles()[0]
    out, redraws = [], 0
    T = problem.grid.horizon
    while len(out) < runs:
        mag = rng.uniform(1.05, 1.3)
        ang = rng.uniform(0.0, 2 * math.pi)
        t = round(float(rng.uniform(0.5, T - 3.0)), 2)
        disp = np.array([mag * math.cos(ang), mag * math.sin(ang), 0.0])
        if not _pushed_safe(problem, plan, cfg, t, disp, v):
            redraws += 1
            continue
        out.append(model.Disturbance(v.name, t, tuple(float(x) for x in disp)))
    return out, redraws


def _row(label: str, e) -> str:
    d = e.detail
    kept = ", ".join(f"{k} {r:+.3f}" for k, r in e.kept.items())
    return (f"{label:>10} {e.time:6.1f} {e.deviation:6.3f} {e.solve_s or 0:8.3f} "
            f"{d.get('cpu_s', 0):7.3f} {d.get('iterations', 0):5d} {e.status:>10} "
            f"{str(e.accepted):>6}  {kept}")


HEADER = (f"{'run':>10} {'t_e':>6} {'dev m':>6} {'solve s':>8} {'cpu s':>7} {'iter':>5} "
          f"{'status':>10} {'flown':>6}  kept (exact, segment)")


def summary(events, results, budget: float) -> list[str]:
    trig = [e for e in events if e.triggered]
    wall = np.array([e.solve_s for e in trig if e.solve_s is not None])
    cpu = np.array([e.detail.get("cpu_s", np.nan) for e in trig if e.solve_s is not None])
    its = np.array([e.detail.get("iterations", 0) for e in trig if e.solve_s is not None])
    kept = [r for e in trig for r in e.kept.values()]
    lines = [f"triggered {len(trig)}, flown {sum(bool(e.accepted) for e in trig)}, "
             f"statuses {dict(Counter(e.status for e in trig))}"]
    if wall.size:
        lines.append(f"solve wall s: median {np.median(wall):.3f}  p95 "
                     f"{np.percentile(wall, 95):.3f}  worst {wall.max():.3f}  "
                     f"(budget t_c {budget:g} s; within it {int(np.sum(wall <= budget))}"
                     f"/{wall.size})")
        lines.append(f"solve CPU s:  median {np.nanmedian(cpu):.3f}  p95 "
                     f"{np.nanpercentile(cpu, 95):.3f}  worst {np.nanmax(cpu):.3f}")
        lines.append(f"iterations:   median {np.median(its):.0f}  worst {its.max()}")
    if kept:
        lines.append(f"kept specs on the segments: min exact robustness {min(kept):+.4f}")
    for key in sorted({k for r in results for k in r.executed_robustness}):
        vals = [r.executed_robustness[key] for r in results]
        ok = sum(v >= results[0].threshold for v in vals)
        lines.append(f"executed {key:>12}: min {min(vals):+.4f}  satisfied {ok}/{len(vals)}")
    return lines


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m stlc.bench.replan", description=__doc__)
    ap.add_argument("--file", default="specs/handover.stl")
    ap.add_argument("--mission", default="handover_left_tb")
    ap.add_argument("--trajectory", help="a trajectory.csv to fly instead of compiling")
    ap.add_argument("--cache", help="where the compiled plan is cached (npz)")
    ap.add_argument("--runs", type=int, default=24)
    ap.add_argument("--seed", type=int, default=1)
    args = ap.parse_args(argv)
    _, m, problem, plan = load_plan(args.file, args.mission, args.trajectory, args.cache)
    cfg = m.replan or model.ReplanConfig(specs=("safety",))
    print(f"replan: ζ = {cfg.threshold:g} m, T_e = {cfg.event_period:g} s, T_g = "
          f"{cfg.waypoint_period:g} s, t_c = {cfg.compute_budget:g} s, keep "
          f"{list(cfg.specs)}; load average {os.getloadavg()[0]:.2f} (2 cores)")
    pushes, redraws = random_pushes(problem, plan, cfg, args.runs, args.seed)
    print(f"\n{args.runs} randomised pushes (seed {args.seed}; {redraws} redrawn: they "
          "landed in a forbidden region)")
    print(HEADER)
    results, events, builds = [], [], []
    c0, w0 = time.process_time(), time.perf_counter()
    for i, d in enumerate(pushes):
        r = simulate_disturbances(problem, plan, [d], cfg, segment=SegmentBackend)
        results.append(r)
        for e in r.triggered:
            events.append(e)
            builds += [e.detail["build_s"]] if "build_s" in e.detail else []
            print(_row(f"#{i} {np.hypot(*d.displacement[:2]):.2f}m", e))
    print(f"\n{len(pushes)} simulations in {time.perf_counter() - w0:.1f} s wall, "
          f"{time.process_time() - c0:.1f} s CPU; NLP build median "
          f"{np.median(builds) if builds else float('nan'):.2f} s (once per simulation, "
          "not in the solve times)")
    for line in summary(events, results, cfg.compute_budget):
        print("  " + line)
    demo = [model.Disturbance(problem.team[0], 3.0, (0.0, 1.1, 0.0)),
            model.Disturbance(problem.team[0], 9.0, (0.78, -0.78, 0.0))]
    print("\ntwo-disturbance demo (paper A Fig. 12): pushes of 1.1 m at 3 s (+y) and "
          "9 s (+x−y)")
    print(HEADER)
    r = simulate_disturbances(problem, plan, demo, cfg, segment=SegmentBackend)
    for e in r.triggered:
        print(_row("demo", e))
    for line in summary(r.triggered, [r], cfg.compute_budget):
        print("  " + line)
    print(f"load average now {os.getloadavg()[0]:.2f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
