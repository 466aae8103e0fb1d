"""Heuristic assignment (stlc.team.local): the refill placement against a brute force, and
the rules a fallback plan must keep (every target once, capacity, own stations, horizon).

The brute force tries every subset of the gaps between consecutive targets as refill
points (and every station when a drone may use several), keeps the runs within the
capacity, and prices the route with the closed-form leg times of this file.
"""

from __future__ import annotations

import itertools
import math
import random
from pathlib import Path

import numpy as np
import pytest

from stlc.team import Box, Drone, TeamScenario
from stlc.team.local import Costs, homes, local_routes, split

STEP = 0.1


def leg(p, q, d):
    t = 0.0
    for x, v, a in zip(np.abs(np.asarray(q, float) - np.asarray(p, float)), d.vel_max,
                       d.acc_max, strict=True):
        if x > 0:
            t = max(t, x / v + v / a if x >= v * v / a else 2 * math.sqrt(x / a))
    return STEP * math.ceil(t / STEP - 1e-9)


def cube(name, c, h=0.5):
    return Box(name, tuple(x - h for x in c), tuple(x + h for x in c))


def random_scenario(rng: random.Random, nd: int, nt: int, ns: int) -> TeamScenario:
    def pt():
        return (rng.uniform(-10, 10), rng.uniform(-10, 10), rng.uniform(1, 8))

    drones = tuple(Drone(f"u{i}", pt(), (2.0,) * 3, (1.5,) * 3, rng.randint(1, 3))
                   for i in range(nd))
    return TeamScenario(drones, tuple(cube(f"t{j}", pt()) for j in range(nt)),
                        tuple(cube(f"s{j}", pt(), 1.0) for j in range(ns)), (),
                        Box("ws", (-50,) * 3, (50,) * 3), 2.0, 3.0, 400.0, STEP, 0.0)


def brute_split(sc, d, seq, stations, ins, rs):
    dr = sc.drones[d]
    tc = [np.add(b.lo, b.hi) / 2 for b in sc.targets]
    sp = [np.add(b.lo, b.hi) / 2 for b in sc.stations]
    best = math.inf
    n = len(seq)
    for gaps in itertools.product([None, *stations], repeat=max(n - 1, 0)):
        run, ok = 1, True
        for g in gaps:
            run = 1 if g is not None else run + 1
            ok &= run <= dr.capacity
        if not ok:
            continue
        for home in stations:
            p, t = dr.start, 0.0
            for i, j in enumerate(seq):
                if i and gaps[i - 1] is not None:
                    t += leg(p, sp[gaps[i - 1]], dr) + rs
                    p = sp[gaps[i - 1]]
                t += leg(p, tc[j], dr) + ins
                p = tc[j]
            best = min(best, t + leg(p, sp[home], dr))
    return best


@pytest.mark.parametrize("seed", range(6))
def test_split_places_refills_optimally(seed):
    rng = random.Random(seed)
    sc = random_scenario(rng, 1, 5, 2)
    costs = Costs(sc, leg)
    seq = list(range(5))
    rng.shuffle(seq)
    for stations in ([0], [1], [0, 1]):
        got, route = split(costs, 0, seq, sc.drones[0].capacity, stations, 2.1, 3.1)
        assert got == pytest.approx(brute_split(sc, 0, seq, stations, 2.1, 3.1))
        assert [i for k, i in route if k == "T"] == seq and route[-1][0] == "S"


def test_heuristic_routes_keep_the_rules():
    rng = random.Random(7)
    sc = random_scenario(rng, 3, 8, 4)
    costs = Costs(sc, leg)
    own = homes(sc, costs)
    assert sorted(s for h in own for s in h) == sorted(set(s for h in own for s in h))
    routes = local_routes(sc, leg, (2.1, 3.1), 300.0, {"u0": [f"t{j}" for j in range(8)]})
    served = sorted(r for rt in routes.values() for r in rt if r.startswith("t"))
    assert served == [f"t{j}" for j in range(8)]
    used = {}
    for d, dr in enumerate(sc.drones):
        rt = routes[dr.name]
        assert rt[-1].startswith("s")
        run = 0
        for r in rt:
            run = run + 1 if r.startswith("t") else 0
            assert run <= dr.capacity
        for r in rt:
            if r.startswith("s"):
                used.setdefault(r, set()).add(dr.name)
                assert int(r[1:]) in own[d]
    assert all(len(u) == 1 for u in used.values())  # no station shared between drones


def test_large_mission_seed_is_separated_and_clear():
    """The 6 × 16 case with the heuristic (the MILP given no time): every target installed
    by the payload rule, the seed keeps Γ_dis between drones and clears the towers."""
    from stlc.pipeline import load
    from stlc.team.milp import assign
    from stlc.team.payload import payload_team, uninstalled
    from stlc.team.seed import scenario_from_program, seed_plan

    path = Path(__file__).parent / "missions" / "bird_diverter_6x16.stl"
    program = load(str(path)).program
    sc = scenario_from_program(program, program.missions["bird_diverter_6x16"],
                               separation=3.0)
    routes, stats = assign(sc, budget_s=0.0)
    assert stats.method == "greedy"  # the heuristic fallback: not optimal
    plan = seed_plan(sc, routes)
    _, events = payload_team(plan.times, plan.pos, sc)
    assert uninstalled(events, sc) == []
    names = list(plan.pos)
    for i, a in enumerate(names):
        for b in names[i + 1:]:
            assert np.min(np.linalg.norm(plan.pos[a] - plan.pos[b], axis=1)) >= 3.0
    for p in plan.pos.values():
        for o in sc.obstacles:
            lo, hi = np.array(o.lo), np.array(o.hi)
            assert np.max(np.concatenate([p - hi, lo - p], axis=1), axis=1).min() > 0.0


def test_highs_binary_program_against_brute_force():
    """solve_binary (the MILP's HiGHS call) on small random covering programs, with and
    without a feasible warm start: the optimum equals the enumerated one."""
    import scipy.sparse as sp

    from stlc.solvers.highs import solve_binary

    rng = np.random.default_rng(3)
    for _ in range(5):
        n, m = 8, 5
        cost = rng.integers(1, 9, n).astype(float)
        a = (rng.random((m, n)) < 0.4).astype(float)
        a[np.arange(m), rng.integers(0, n, m)] = 1.0  # every row coverable
        eq = sp.csr_matrix((1, n))  # one empty equality row 0 = 0
        best = min(cost @ np.array(x) for x in itertools.product([0, 1], repeat=n)
                   if np.all(a @ np.array(x) >= 1))
        for start in (None, np.ones(n)):
            res = solve_binary(cost, np.ones(n, bool), eq, np.zeros(1), sp.csr_matrix(-a),
                               -np.ones(m), start=start)
            assert res.status == "optimal" and res.objective == pytest.approx(best)
            assert np.all(a @ res.x >= 1) and res.bound == pytest.approx(best)


def test_budget_fallback_reports_where_the_routes_come_from():
    from stlc.pipeline import load
    from stlc.team.milp import assign
    from stlc.team.seed import scenario_from_program

    path = Path(__file__).parent / "missions" / "team_small.stl"
    program = load(str(path)).program
    sc = scenario_from_program(program, program.missions["team_small"], separation=2.0)
    _, stats = assign(sc, budget_s=0.0)
    assert stats.method == "greedy" and stats.incumbent == "heuristic"
    exact_routes, exact = assign(sc)
    assert exact.method == "milp" and exact.bound == exact.objective
    assert stats.objective >= exact.objective - 1e-9
