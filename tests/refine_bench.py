"""Benchmark of the whole team pipeline on paper B's missions (script, not a test).

parse → MILP (stlc.team.milp) → seed (stlc.team.seed) → refine → exact monitor of every
named spec (``stlc.analysis.monitor.robustness`` on the checked IR, payload from
``stlc.team.payload``) on the dense 20 Hz plan. Needs the `team` helper's modules.

    python tests/refine_bench.py specs/bird_diverter_2x7.stl specs/bird_diverter_4x11.stl
"""

from __future__ import annotations

import sys
import time

from stlc.analysis import monitor
from stlc.pipeline import load
from stlc.semantics import nnf
from stlc.team.milp import assign
from stlc.team.payload import payload_team
from stlc.team.refine import refine
from stlc.team.seed import scenario_from_program, seed_plan


def main(path: str, eta: float = 0.0, own_seed: bool = False) -> None:
    w0, c0 = time.perf_counter(), time.process_time()
    program = load(path).program
    for mission in program.missions.values():
        sc = scenario_from_program(program, mission, install_time=5.0, refill_time=12.0,
                                   separation=3.0)
        if own_seed:  # stand-in seed: contiguous target blocks, straight quintic moves
            from refine_cases import chunk_routes, straight_seed

            r = chunk_routes(sc)
            seed = straight_seed(sc, r)
            routes = seed.route
        else:
            routes, _ = assign(sc)
            seed = seed_plan(sc, routes)
        c1 = time.process_time()
        plan, st = refine(sc, seed, lam=mission.smoothing.lam, kappa=mission.threshold,
                          eta=eta, v_star=mission.objective.forward_speed)
        c2 = time.process_time()
        payload, _ = payload_team(plan.times, plan.pos, sc)
        ch = {}
        for d in plan.pos:
            for j, a in enumerate("xyz"):
                ch[f"{d}.pos.{a}"] = plan.pos[d][:, j]
                ch[f"{d}.vel.{a}"] = plan.vel[d][:, j]
            ch[f"{d}.payload"] = payload[d].astype(float)
        rho = {n: float(monitor.robustness(nnf.normalize(f), sc.step, ch, program.params))
               for n, f in mission.specs.items()}
        rho["ALL"] = float(monitor.robustness(nnf.normalize(mission.requirement), sc.step, ch,
                                              program.params))
        print(f"{mission.name} eta={eta}: refine cpu {c2 - c1:.2f} s (build "
              f"{st['build_cpu_s']:.2f}, solve {st['solve_cpu_s']:.2f}), "
              f"{st['variables']} vars, {st['constraints']} cons, {st['iterations']} it, "
              f"{len(st['rounds'])} rounds, {st['status']}, r = {st['r']:.3f}, "
              f"stretch {st['stretch']:.2f}")
        print(f"  pipeline cpu {time.process_time() - c0:.2f} s, wall "
              f"{time.perf_counter() - w0:.2f} s; exact robustness "
              + ", ".join(f"{k} {v:.3f}" for k, v in rho.items()))
        m = st["margins"]
        print("  margins: " + ", ".join(f"{k} {v:.3f}" for k, v in m.items())
              + (f"; forward cost {st['forward_cost']:.1f}" if st["forward_cost"] else ""))
        print("  routes: " + "; ".join(f"{d}: {' '.join(r)}" for d, r in routes.items()))


if __name__ == "__main__":
    eta = float(sys.argv[1]) if sys.argv[1].replace(".", "").isdigit() else 0.0
    for p in sys.argv[1:]:
        if p.endswith(".stl"):
            main(p, eta, "--own-seed" in sys.argv)
