"""Benchmark of the discrete team planner on a mission file (script style).

``main(path)`` loads the .stl with ``stlc.pipeline.load``, builds the team scenario of each
mission (install / refill times fall back to paper B's T_ins = 5 s, T_rs = 12 s when the
mission does not give them), and prints: the MILP CPU time (median of 3 solves), lazy-cut
rounds, objective, the seed's CPU time, per drone the route and the payload events derived
from the seed's positions by the payload rule, and the minimum payload.

    python -m stlc.team.bench specs/bird_diverter_2x7.stl
"""

from __future__ import annotations

import statistics
import sys
import time

import numpy as np

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


if __name__ == "__main__":
    for p in sys.argv[1:]:
        main(p)
