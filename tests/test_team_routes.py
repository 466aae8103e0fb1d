"""The assignment's formulations against each other and an independent brute force.

* the route formulation (column generation, ``stlc.team.colgen``, the default of
  ``assign``), the arc formulation with lazy cuts (``formulation="arcs"``) and the trip
  model (``stlc.team.partition``) reach the brute force's optimum (``test_team_milp.brute``,
  which enumerates every order, refill choice and home station) on small random instances;
* station exclusivity (as many stations as drones: a station serves one drone) is checked
  by a brute force of its own over the same enumeration;
* a horizon too short is answered at once from lower bounds of the route times (12 targets,
  2 drones of capacity 2, 10 s; 30 targets, 45 s), or, when the bounds fit, by the model
  proved infeasible — in both cases without any unbudgeted solve;
* the 3-drone × 9-target mission that needs a refill (tests/missions) is proved optimal.
"""

from __future__ import annotations

import dataclasses
import itertools
import math
import time
from pathlib import Path

import numpy as np
import pytest
from test_team_milp import STEP, brute, check_routes, cube, instance, leg

from stlc.team import AssignmentError, Box, Drone, TeamScenario
from stlc.team.arcs import build_arcs, dwell_times
from stlc.team.horizon import route_bounds
from stlc.team.milp import assign, route_time

MISSIONS = Path(__file__).parent / "missions"


def total(sc, routes):
    return sum(route_time(sc, d, routes[dr.name]) for d, dr in enumerate(sc.drones))


@pytest.mark.parametrize("seed,nd,nt,ns", [
    (11, 1, 5, 1), (12, 2, 5, 1), (13, 3, 4, 2), (14, 2, 5, 2), (15, 1, 5, 2),
])
def test_routes_match_brute_force(seed, nd, nt, ns):
    sc = instance(seed, nd, nt, ns)
    routes, stats = assign(sc, formulation="routes")
    check_routes(sc, routes)
    want = brute(sc)
    assert stats.method == "milp" and stats.formulation == "routes"
    assert stats.objective == pytest.approx(want, abs=1e-6)
    assert stats.bound == pytest.approx(want, abs=1e-6)
    assert total(sc, routes) == pytest.approx(want, abs=1e-6)


@pytest.mark.parametrize("seed", [21, 22, 23])
def test_routes_and_arcs_agree(seed):
    sc = instance(seed, 2, 5, 1)
    _, a = assign(sc, formulation="arcs")
    _, r = assign(sc, formulation="routes")
    assert a.formulation == "arcs" and r.formulation == "routes"
    assert r.objective == pytest.approx(a.objective, abs=1e-6)


@pytest.mark.parametrize("seed,nd,nt,ns", [(31, 1, 4, 1), (32, 2, 4, 1), (33, 2, 4, 2)])
def test_trip_model_matches_brute_force(seed, nd, nt, ns):
    from stlc.team import partition

    sc = instance(seed, nd, nt, ns)
    arcs = build_arcs(sc)
    out = partition.solve(sc, arcs, sc.horizon - dwell_times(sc)[1], 60.0)
    assert out.status == "optimal"
    assert out.objective == pytest.approx(brute(sc), abs=1e-6)
    assert total(sc, out.routes) == pytest.approx(out.objective, abs=1e-6)


def exclusive_brute(sc: TeamScenario) -> float:
    """Every drone on one station only (as many stations as drones: each station is one
    drone's home and no other drone may enter it), by enumeration."""
    ins = STEP * (math.ceil(sc.install_time / STEP - 1e-9) + 1)
    rs = STEP * (math.ceil(sc.refill_time / STEP - 1e-9) + 1)
    tc = [np.add(t.lo, t.hi) / 2 for t in sc.targets]
    scn = [np.add(s.lo, s.hi) / 2 for s in sc.stations]
    limit, nt, nd = sc.horizon - rs, len(tc), len(sc.drones)

    def best(d, subset, h):
        dr = sc.drones[d]
        v, a = dr.vel_max[0], dr.acc_max[0]
        if not subset:
            return leg(dr.start, scn[h], v, a)
        out = math.inf
        for order in itertools.permutations(subset):
            for cuts in itertools.product([False, True], repeat=len(order) - 1):
                run, t, ok = 1, leg(dr.start, tc[order[0]], v, a) + ins, True
                for i, cut in enumerate(cuts):
                    p, q = tc[order[i]], tc[order[i + 1]]
                    if cut:
                        run, t = 1, t + leg(p, scn[h], v, a) + rs + leg(scn[h], q, v, a) + ins
                    else:
                        run, t = run + 1, t + leg(p, q, v, a) + ins
                    ok = ok and run <= dr.capacity
                if ok and dr.capacity > 0:
                    out = min(out, t + leg(tc[order[-1]], scn[h], v, a))
        return out

    out = math.inf
    for owner in itertools.product(range(nd), repeat=nt):
        for homes in itertools.permutations(range(len(scn)), nd):
            times = [best(d, tuple(j for j in range(nt) if owner[j] == d), homes[d])
                     for d in range(nd)]
            if all(t <= limit + 1e-9 for t in times):
                out = min(out, sum(times))
    return out


@pytest.mark.parametrize("seed", [41, 42])
def test_station_exclusivity_matches_brute_force(seed):
    sc = instance(seed, 2, 4, 2)
    sc = dataclasses.replace(sc, drones=tuple(dataclasses.replace(d, capacity=1)
                                              for d in sc.drones))
    routes, stats = assign(sc)
    used = [{r for r in routes[d.name] if r.startswith("s")} for d in sc.drones]
    assert not used[0] & used[1]  # no station shared
    assert stats.objective == pytest.approx(exclusive_brute(sc), abs=1e-6)


def line(nt: int, nd: int, cap: int, horizon: float) -> TeamScenario:
    drones = tuple(Drone(f"u{i}", (3.0 * i, -3.0, 0.5), (3.1,) * 3, (3.1,) * 3, cap)
                   for i in range(nd))
    targets = tuple(cube(f"t{j}", (4.0 * j, 2.5 * (-1) ** j, 12.0)) for j in range(nt))
    stations = tuple(cube(f"s{i}", (6.0 * i, -7.0, 1.0), 1.0) for i in range(2))
    return TeamScenario(drones, targets, stations, (), Box("ws", (-10, -10, 0),
                                                           (4.0 * nt + 10, 10, 15)),
                        5.0, 12.0, horizon, 0.05, 3.0)


@pytest.mark.parametrize("nt,nd,cap,horizon", [(12, 2, 2, 10.0), (30, 2, 2, 45.0)])
def test_short_horizon_is_answered_from_a_bound(nt, nd, cap, horizon):
    sc = line(nt, nd, cap, horizon)
    t0 = time.perf_counter()
    with pytest.raises(AssignmentError) as err:
        assign(sc, budget_s=5.0)
    assert time.perf_counter() - t0 < 30.0  # the bound, not a solve (was > 300 s)
    assert err.value.reason == "horizon"
    assert f"horizon of {horizon:g} s" in err.value.message
    lb = float(err.value.message.split("at least ")[1].split(" s")[0])
    tail = dwell_times(sc)[1]
    assert lb == pytest.approx(max(route_bounds(sc, build_arcs(sc), tail)), abs=0.05)
    assert lb > horizon


def test_large_team_answers_within_its_budget():
    """30 targets, 3 drones of capacity 4 (too many trips for the route model: the arc
    model, then the heuristic): an answer within the budget plus the heuristic's time."""
    sc = line(30, 3, 4, 600.0)
    t0 = time.perf_counter()
    routes, stats = assign(sc, budget_s=3.0)
    assert time.perf_counter() - t0 < 3.0 + 2.0 + 10.0  # budget, heuristic, load margin
    check_routes(sc, routes)
    assert stats.method == "greedy" and stats.objective == pytest.approx(total(sc, routes))


def test_bounds_hold_for_the_optimum():
    """Both lower bounds are below the longest route of a brute-force optimum's
    assignment (each is a bound for every assignment)."""
    for seed in (51, 52, 53):
        sc = instance(seed, 2, 4, 1)
        routes, stats = assign(sc)
        tail = dwell_times(sc)[1]
        reach, work = route_bounds(sc, build_arcs(sc), tail)
        longest = max(stats.drone_time.values()) + tail
        assert reach <= longest + 1e-9 and work <= longest + 1e-9


def test_infeasible_horizon_within_the_bounds_is_proved():
    sc = instance(1, 2, 4, 1)
    sc = dataclasses.replace(sc, horizon=22.6)  # brute force: no assignment fits
    assert max(route_bounds(sc, build_arcs(sc), dwell_times(sc)[1])) <= sc.horizon
    assert brute(sc) == math.inf
    with pytest.raises(AssignmentError) as err:
        assign(sc, budget_s=20.0)
    assert err.value.reason == "horizon" and "infeasible" in err.value.message


def test_budget_ends_with_a_feasible_assignment():
    """The 6 × 16 mission with a 1 s budget: a feasible assignment, reported as not
    optimal with a lower bound below it."""
    from stlc.pipeline import load
    from stlc.team.seed import scenario_from_program

    program = load(str(MISSIONS / "bird_diverter_6x16.stl")).program
    sc = scenario_from_program(program, program.missions["bird_diverter_6x16"],
                               separation=3.0)
    routes, stats = assign(sc, budget_s=1.0)
    check_routes(sc, routes)
    assert stats.method == "greedy"
    assert stats.objective == pytest.approx(total(sc, routes), abs=1e-6)
    assert not stats.bound > stats.objective + 1e-9


def test_three_by_nine_with_a_refill_is_proved_optimal():
    from stlc.pipeline import load
    from stlc.team.seed import scenario_from_program

    program = load(str(MISSIONS / "bird_diverter_3x9.stl")).program
    sc = scenario_from_program(program, program.missions["bird_diverter_3x9"],
                               separation=3.0)
    assert sum(d.capacity for d in sc.drones) < len(sc.targets)  # a refill is needed
    routes, stats = assign(sc)
    check_routes(sc, routes)
    assert stats.method == "milp" and stats.bound == pytest.approx(stats.objective)
    assert total(sc, routes) == pytest.approx(stats.objective, abs=1e-6)
    stations = {s.name for s in sc.stations}
    assert any(sum(r in stations for r in rt) >= 2 for rt in routes.values())  # refill
