"""Assignment MILP against an independent brute force, and its typed errors.

The brute force enumerates, for every drone and subset of targets, every visiting order,
every choice of refill (no station or one of the stations) between consecutive targets
and every home station, keeps the runs within the capacity, and takes the best
combination over all assignments of targets to drones and of home stations (distinct when
there are at least as many stations as drones).  Leg times are recomputed here
from the closed-form trapezoid / triangle formulas (rounded up to whole steps).
"""

from __future__ import annotations

import itertools
import math
import random

import numpy as np
import pytest

from stlc.team import AssignmentError, Box, Drone, TeamScenario
from stlc.team.milp import assign, route_time

STEP = 0.1


def leg(p, q, v, a):
    t = 0.0
    for d in np.abs(np.asarray(q, float) - np.asarray(p, float)):
        if d > 0:
            t = max(t, d / v + v / a if d >= v * v / a else 2 * math.sqrt(d / a))
    return STEP * math.ceil(t / STEP - 1e-9)


def cube(name, c, h=0.5):
    return Box(name, tuple(x - h for x in c), tuple(x + h for x in c))


def brute(sc: TeamScenario) -> float:
    ins = STEP * (math.ceil(sc.install_time / STEP - 1e-9) + 1)
    rs = STEP * (math.ceil(sc.refill_time / STEP - 1e-9) + 1)
    tc = [np.add(t.lo, t.hi) / 2 for t in sc.targets]
    scn = [np.add(s.lo, s.hi) / 2 for s in sc.stations]
    limit = sc.horizon - rs
    nt = len(tc)
    best: list[dict[tuple[frozenset, int], float]] = []  # (targets, home) -> best time
    for dr in sc.drones:
        v, a = dr.vel_max[0], dr.acc_max[0]
        table: dict[tuple[frozenset, int], float] = {}
        for size in range(nt + 1):
            for subset in itertools.combinations(range(nt), size):
                top = [math.inf] * len(scn)
                key = frozenset(subset)
                if not size:
                    top = [leg(dr.start, s, v, a) for s in scn]
                if not size or dr.capacity == 0:
                    table.update({(key, h): top[h] for h in range(len(scn))})
                    continue
                for order in itertools.permutations(subset):
                    for gaps in itertools.product([None, *range(len(scn))], repeat=size - 1):
                        run, ok = 1, True
                        time = leg(dr.start, tc[order[0]], v, a) + ins
                        for i, g in enumerate(gaps):
                            p, q = tc[order[i]], tc[order[i + 1]]
                            if g is None:
                                run += 1
                                time += leg(p, q, v, a) + ins
                            else:
                                run = 1
                                time += leg(p, scn[g], v, a) + rs + leg(scn[g], q, v, a) + ins
                            ok = ok and run <= dr.capacity
                        if ok:
                            for h, s in enumerate(scn):
                                top[h] = min(top[h], time + leg(tc[order[-1]], s, v, a))
                table.update({(key, h): top[h] for h in range(len(scn))})
        best.append(table)
    nd = len(sc.drones)
    out = math.inf
    for owner in itertools.product(range(nd), repeat=nt):
        sets = [frozenset(j for j in range(nt) if owner[j] == d) for d in range(nd)]
        for homes in itertools.product(range(len(scn)), repeat=nd):
            if len(scn) >= nd and len(set(homes)) < nd:
                continue  # distinct home stations when there are enough of them
            times = [best[d][(sets[d], homes[d])] for d in range(nd)]
            if all(t <= limit + 1e-9 for t in times):
                out = min(out, sum(times))
    return out


def instance(seed: int, nd: int, nt: int, ns: int, horizon: float = 200.0) -> TeamScenario:
    rng = random.Random(seed)

    def pt(z):
        return (rng.uniform(-10, 10), rng.uniform(-5, 5), z)

    drones = tuple(Drone(f"u{i}", pt(0.5), (2.0,) * 3, (1.5,) * 3, rng.randint(1, 3))
                   for i in range(nd))
    return TeamScenario(drones, tuple(cube(f"t{i}", pt(rng.uniform(4, 8))) for i in range(nt)),
                        tuple(cube(f"s{i}", pt(1.0), 1.0) for i in range(ns)), (),
                        Box("ws", (-50.0,) * 3, (50.0,) * 3), install_time=2.0,
                        refill_time=3.0, horizon=horizon, step=STEP, separation=0.0)


def check_routes(sc: TeamScenario, routes: dict[str, list[str]]) -> None:
    names = {t.name for t in sc.targets}
    served = [r for rt in routes.values() for r in rt if r in names]
    assert sorted(served) == sorted(names)
    homes = [routes[dr.name][-1] for dr in sc.drones]
    if len(sc.stations) >= len(sc.drones):
        assert len(set(homes)) == len(homes)
    for dr in sc.drones:
        rt = routes[dr.name]
        assert rt and rt[-1] in {s.name for s in sc.stations}
        run = 0
        for r in rt:
            run = run + 1 if r in names else 0
            assert run <= dr.capacity


@pytest.mark.parametrize("seed,nd,nt,ns", [
    (1, 1, 4, 1), (2, 1, 5, 2), (3, 2, 4, 1), (4, 2, 5, 2), (5, 2, 5, 1), (6, 2, 3, 2),
])
def test_milp_matches_brute_force(seed, nd, nt, ns):
    sc = instance(seed, nd, nt, ns)
    routes, stats = assign(sc)
    check_routes(sc, routes)
    want = brute(sc)
    assert stats.objective == pytest.approx(want, abs=1e-6)
    total = sum(route_time(sc, d, routes[dr.name]) for d, dr in enumerate(sc.drones))
    assert total == pytest.approx(want, abs=1e-6)


def test_refill_needed_single_drone():
    sc = instance(7, 1, 4, 1)
    sc = TeamScenario(tuple(Drone(d.name, d.start, d.vel_max, d.acc_max, 2) for d in sc.drones),
                      *[getattr(sc, f) for f in ("targets", "stations", "obstacles",
                                                   "workspace", "install_time", "refill_time",
                                                   "horizon", "step", "separation")])
    routes, stats = assign(sc)
    rt = routes["u0"]
    assert rt.count("s0") == 2  # one refill, then home
    assert stats.objective == pytest.approx(brute(sc), abs=1e-6)


def test_horizon_forces_the_second_drone():
    free = instance(3, 2, 4, 1)
    routes, stats = assign(free)
    longest = max(stats.drone_time.values())
    tight = TeamScenario(free.drones, free.targets, free.stations, (), free.workspace, 2.0,
                         3.0, horizon=longest + 3.1 + 1e-6, step=STEP, separation=0.0)
    _, s2 = assign(tight)
    assert s2.objective == pytest.approx(brute(tight), abs=1e-6)
    very_tight = TeamScenario(free.drones, free.targets, free.stations, (), free.workspace,
                              2.0, 3.0, horizon=10.0, step=STEP, separation=0.0)
    with pytest.raises(AssignmentError) as err:
        assign(very_tight)
    assert err.value.reason == "horizon" and "horizon of 10 s" in err.value.message


def test_no_station_and_too_few_diverters():
    base = instance(4, 2, 5, 0)
    caps = sum(d.capacity for d in base.drones)
    if caps >= 5:
        base = TeamScenario(tuple(Drone(d.name, d.start, d.vel_max, d.acc_max, 1)
                                  for d in base.drones), base.targets, (), (), base.workspace,
                            2.0, 3.0, 200.0, STEP, 0.0)
    with pytest.raises(AssignmentError) as err:
        assign(base)
    assert err.value.reason == "no-station" and "no refilling station" in err.value.message


def test_no_station_enough_capacity_ends_at_last_target():
    d = Drone("u0", (0.0, 0.0, 0.0), (2.0,) * 3, (1.5,) * 3, 2)
    sc = TeamScenario((d,), (cube("t0", (3, 0, 0)), cube("t1", (6, 0, 0))), (), (),
                      Box("ws", (-50.0,) * 3, (50.0,) * 3), 2.0, 3.0, 100.0, STEP, 0.0)
    routes, stats = assign(sc)
    assert routes == {"u0": ["t0", "t1"]}
    assert stats.objective == pytest.approx(leg((0, 0, 0), (3, 0, 0), 2, 1.5) * 2 + 2 * 2.1)


def test_unreachable_station_and_zero_capacity():
    stuck = Drone("u0", (0.0, 0.0, 0.0), (2.0, 2.0, 0.0), (1.5,) * 3, 2)
    sc = TeamScenario((stuck,), (cube("t0", (3, 0, 0)),), (cube("s0", (0, 0, 5)),), (),
                      Box("ws", (-50.0,) * 3, (50.0,) * 3), 2.0, 3.0, 100.0, STEP, 0.0)
    with pytest.raises(AssignmentError) as err:
        assign(sc)
    assert err.value.reason == "unreachable" and err.value.subject == "u0"
    empty = Drone("u0", (0.0, 0.0, 0.0), (2.0,) * 3, (1.5,) * 3, 0)
    sc0 = TeamScenario((empty,), sc.targets, sc.stations, (), sc.workspace, 2.0, 3.0, 100.0,
                       STEP, 0.0)
    with pytest.raises(AssignmentError) as err:
        assign(sc0)
    assert err.value.reason == "capacity"


def test_time_budget_falls_back_to_a_feasible_greedy_assignment():
    """With no time for the MILP the routes come from the greedy rule: every target once,
    capacities and refills respected (the seed installs everything by the payload rule),
    and the stats say the MILP did not converge."""
    from pathlib import Path

    from stlc.pipeline import load
    from stlc.team.payload import payload_team
    from stlc.team.seed import scenario_from_program, seed_plan

    path = Path(__file__).parent / "missions" / "team_small.stl"
    program = load(str(path)).program
    sc = scenario_from_program(program, program.missions["team_small"], separation=2.0)
    routes, stats = assign(sc, budget_s=0.0)
    assert stats.method == "greedy"
    served = [r for rs in routes.values() for r in rs if r.startswith("t")]
    assert sorted(served) == ["ta", "tb", "tc"]
    homes = [rs[-1] for rs in routes.values()]
    assert len(set(homes)) == len(homes)  # as many stations as drones: one home each
    plan = seed_plan(sc, routes)
    payload, events = payload_team(plan.times, plan.pos, sc)
    assert sorted(e.region for e in events if e.kind == "install") == ["ta", "tb", "tc"]
    assert all(c.min() >= 0 for c in payload.values())
    exact, _ = assign(sc)
    assert stats.objective >= sum(route_time(sc, i, exact[d.name])
                                  for i, d in enumerate(sc.drones)) - 1e-9
