"""Benchmark of the discrete team planner on a mission file (script style).

``main(path)`` loads the .stl with ``stlc.pipeline.load``, builds the team scenario of each
mission (install / refill times fall back to paper B's T_ins = 5 s, T_rs = 12 s when the
mission does not give them), and prints: the MILP CPU time (median of 3 solves), lazy-cut
rounds, objective, the seed's CPU time, per drone the route and the payload events derived
from the seed's positions by the payload rule, and the minimum payload.

    python -m stlc.bench.team specs/bird_diverter_2x7.stl

``scaling(paths, repeats)`` times the whole ``stlc compile`` (parse, assignment, seed,
refinement, verification, outputs) of each file in a child process, ``repeats`` times, and
prints per run and as medians: wall time, CPU time of the child (user + system, from
``resource.getrusage``; the machine is shared, so CPU is the steadier number), the
assignment method and time, IPOPT iterations and status, verdict and exact robustness:

    python -m stlc.bench.team --compile specs/bird_diverter_2x7.stl specs/bird_diverter_4x11.stl

``formulations(paths, repeats, budget)`` solves the assignment of each mission with every
formulation (``routes``: column generation, the default; ``arcs``: lazy cuts; ``trips``:
the trip model of ``stlc.team.partition``) within ``budget`` wall seconds, and prints per
instance and formulation the median wall and CPU time, the objective, the lower bound and
whether optimality was proved (else the gap):

    python -m stlc.bench.team --formulations tests/missions/bird_diverter_3x9.stl
"""

from __future__ import annotations

import json
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time

import numpy as np

from stlc import settings
from stlc.pipeline import load
from stlc.team.milp import assign
from stlc.team.payload import payload_team, uninstalled
from stlc.team.seed import scenario_from_program, seed_plan


def main(path: str, *, install_time: float = 5.0, refill_time: float = 12.0,
         repeats: int = 3) -> None:
    program = load(path).program
    for mission in program.missions.values():
        sc = scenario_from_program(program, mission, install_time=install_time,
                                   refill_time=refill_time)
        runs = [assign(sc) for _ in range(repeats)]
        routes, stats = runs[0]
        cpu = statistics.median(s.cpu_s for _, s in runs)
        wall = statistics.median(s.wall_s for _, s in runs)
        c0 = time.process_time()
        plan = seed_plan(sc, routes)
        seed_cpu = time.process_time() - c0
        payload, events = payload_team(plan.times, plan.pos, sc)
        print(f"mission {mission.name}: {len(sc.drones)} drones, {len(sc.targets)} targets, "
              f"{len(sc.stations)} stations, T_ins = {sc.install_time:g} s, "
              f"T_rs = {sc.refill_time:g} s, horizon {sc.horizon:g} s, step {sc.step:g} s")
        print(f"  MILP: median CPU {cpu:.3f} s (wall {wall:.3f} s) over {repeats} solves; "
              f"{stats.rounds} solve rounds ({stats.rounds - 1} lazy), {stats.cuts} cuts; "
              f"objective {stats.objective:.2f} s")
        print(f"  seed: CPU {seed_cpu:.3f} s, {len(plan.times)} samples per drone")
        for d in sc.drones:
            acc_ok = np.all(np.abs(plan.acc[d.name]) <= np.asarray(d.acc_max) + 1e-9)
            vel_ok = np.all(np.abs(plan.vel[d.name]) <= np.asarray(d.vel_max) + 1e-9)
            print(f"  {d.name} (capacity {d.capacity}, route time "
                  f"{stats.drone_time[d.name]:.2f} s, bounds ok: {bool(vel_ok and acc_ok)}): "
                  + " -> ".join(routes[d.name]))
            for e in events:
                if e.drone == d.name:
                    print(f"      {e.kind:7s} {e.region:6s} {e.start:7.2f} .. {e.end:7.2f} s")
            print(f"      min payload {int(payload[d.name].min())}, final "
                  f"{int(payload[d.name][-1])}")
        missing = uninstalled(events, sc)
        print(f"  installed {len(sc.targets) - len(missing)}/{len(sc.targets)} targets"
              + (f" (missing: {', '.join(missing)})" if missing else ""))


def compile_once(path: str) -> dict:
    """One ``stlc compile`` of ``path`` in a child process: timings and solver facts."""
    with tempfile.TemporaryDirectory() as out:
        r0 = resource.getrusage(resource.RUSAGE_CHILDREN)
        w0 = time.perf_counter()
        proc = subprocess.run([sys.executable, "-m", "stlc", "compile", "-q", "--no-risk",
                               "-o", out, path], capture_output=True, text=True,
                              env={**settings.environment(), "OMP_NUM_THREADS": "1"})
        wall = time.perf_counter() - w0
        r1 = resource.getrusage(resource.RUSAGE_CHILDREN)
        cpu = (r1.ru_utime - r0.ru_utime) + (r1.ru_stime - r0.ru_stime)
        row = {"file": path, "exit": proc.returncode, "wall_s": wall, "cpu_s": cpu}
        try:
            with open(os.path.join(out, "solution.json"), encoding="utf-8") as f:
                sol = json.load(f)
        except (OSError, ValueError):
            row["error"] = proc.stderr.strip()[-300:]
            return row
    solver, seed = sol.get("solver", {}), sol.get("solver", {}).get("seed", {})
    rob = sol.get("robustness")
    row.update(status=sol.get("status"),
               exact=rob.get("exact") if isinstance(rob, dict) else rob,
               iterations=solver.get("iterations"), ipopt=solver.get("ipopt_status"),
               assignment=seed.get("assignment"), milp_s=sol.get("timing", {}).get("milp_s"),
               solve_s=sol.get("timing", {}).get("solve_s"))
    return row


def scaling(paths: list[str], repeats: int = 3) -> list[dict]:
    rows = []
    for path in paths:
        runs = []
        for i in range(repeats):
            r = compile_once(path)
            runs.append(r)
            print(f"{path} run {i + 1}: " + ", ".join(
                f"{k} {v:.2f}" if isinstance(v, float) else f"{k} {v}"
                for k, v in r.items() if k != "file"), flush=True)
        med = {k: statistics.median(r[k] for r in runs if r.get(k) is not None)
               for k in ("wall_s", "cpu_s", "milp_s", "solve_s", "iterations")
               if any(r.get(k) is not None for r in runs)}
        print(f"{path}: median of {repeats}: " + ", ".join(f"{k} {v:.2f}" for k, v in
                                                          med.items()), flush=True)
        rows.append({"file": path, "runs": runs, "median": med})
    return rows


def _trips_model(sc, budget: float) -> dict:
    from stlc.team import partition
    from stlc.team.arcs import build_arcs, dwell_times

    w0, c0 = time.perf_counter(), time.process_time()
    arcs = build_arcs(sc)
    out = partition.solve(sc, arcs, sc.horizon - dwell_times(sc)[1],
                          max(budget - (time.perf_counter() - w0), 0.01))
    return {"wall": time.perf_counter() - w0, "cpu": time.process_time() - c0,
            "obj": out.objective, "bound": out.bound, "optimal": out.status == "optimal"}


def formulations(paths: list[str], repeats: int = 3, budget: float = 30.0,
                 which=("routes", "arcs", "trips")) -> list[dict]:
    rows = []
    for path in paths:
        program = load(path).program
        for mission in program.missions.values():
            sc = scenario_from_program(program, mission, separation=3.0)
            for form in which:
                runs = []
                for _ in range(repeats if form == "routes" else 1):
                    if form == "trips":
                        runs.append(_trips_model(sc, budget))
                        continue
                    _, st = assign(sc, formulation=form, budget_s=budget)
                    runs.append({"wall": st.wall_s, "cpu": st.cpu_s, "obj": st.objective,
                                 "bound": st.bound, "optimal": st.method == "milp"})
                r = runs[0]
                gap = (r["obj"] - r["bound"]) / r["obj"] if r["obj"] > 0 else 0.0
                row = {"mission": mission.name, "formulation": form, "runs": len(runs),
                       "wall": statistics.median(x["wall"] for x in runs),
                       "cpu": statistics.median(x["cpu"] for x in runs), "obj": r["obj"],
                       "bound": r["bound"], "optimal": all(x["optimal"] for x in runs),
                       "gap": gap}
                rows.append(row)
                print(f"| {row['mission']} | {form} | {row['wall']:.2f} | {row['cpu']:.2f} | "
                      f"{row['obj']:.2f} | {row['bound']:.2f} | "
                      + ("optimal" if row["optimal"] else f"gap {100 * gap:.1f} %")
                      + f" | {len(runs)} |", flush=True)
    return rows


if __name__ == "__main__":
    args = sys.argv[1:]
    if args and args[0] == "--compile":
        scaling(args[1:])
    elif args and args[0] == "--formulations":
        formulations(args[1:])
    else:
        for p in args:
            main(p)
