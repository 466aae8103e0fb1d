"""Lazy cuts of the task-assignment MILP (paper B eq. 7e), found in an incumbent.

``cuts_for`` decomposes one drone's chosen arcs (``stlc.team.milp.Arc``: tail, head, drone,
cost) into components and depot/station-to-station segments and returns the sub-tour,
connectivity and capacity cuts the incumbent violates (see ``stlc.team.milp``'s docstring
for their form); ``station_shared`` tells when two drones use one station, so that the
one-drone-per-station rows are added.  The model argument is ``milp._Model`` (its arcs,
scenario, inner arcs and the set of windows already cut).
"""

from __future__ import annotations

import math

import numpy as np

Node = tuple[str, int]  # ("D", drone) | ("T", target) | ("S", station) | ("E", 0)


def _components(chosen: list) -> dict:
    parent: dict = {}

    def find(v: Node) -> Node:
        parent.setdefault(v, v)
        while parent[v] != v:
            parent[v] = parent[parent[v]]
            v = parent[v]
        return v

    for a in chosen:
        parent[find(a.tail)] = find(a.head)
    return {v: find(v) for v in list(parent)}


def segments(chosen: list) -> list[tuple]:
    """(start node, targets in order, end node) for every run that leaves the depot or a
    station (targets have one successor each, so the runs are unique)."""
    succ = {a.tail: a.head for a in chosen if a.tail[0] == "T"}
    out = []
    for a in chosen:
        if a.tail[0] in "DS":
            seq, v = [], a.head
            while v[0] == "T" and len(seq) <= len(succ):
                seq.append(v[1])
                v = succ[v]
            out.append((a.tail, seq, v))
    return out


def cuts_for(model, d: int, chosen: list) -> list[tuple[dict[int, float], float]]:
    """Violated lazy cuts (rows ``a·x ≤ b``) for drone ``d``'s arcs."""
    arcs, cap = model.arcs, model.sc.drones[d].capacity
    comp = _components(chosen)
    main = comp.get(("D", d))
    cuts: list[tuple[dict[int, float], float]] = []
    groups: dict[Node, set[Node]] = {}
    for v, r in comp.items():
        groups.setdefault(r, set()).add(v)
    for root, nodes in groups.items():
        if root == main:
            continue
        targets = {v[1] for v in nodes if v[0] == "T"}
        has_station = any(v[0] == "S" for v in nodes)
        entering = {k: -1.0 for k, a in enumerate(arcs)
                    if a.drone == d and a.head in nodes and a.tail not in nodes}
        for j in targets:
            row = dict(entering)
            for k, a in enumerate(arcs):
                if a.drone == d and a.head == ("T", j):
                    row[k] = row.get(k, 0.0) + 1.0
            cuts.append((row, 0.0))
        if not has_station:
            cuts.append(({k: 1.0 for k, a in enumerate(arcs) if a.tail[0] == "T"
                          and a.head[0] == "T" and a.tail[1] in targets
                          and a.head[1] in targets}, len(targets) - 1.0))
    for _, seq, _ in segments([a for a in chosen if comp[a.tail] == main]):
        if len(seq) > cap:
            cuts += _capacity_cuts(model, seq, cap)
    return cuts


def _capacity_cuts(model, seq: list[int], cap: int) -> list[tuple[dict[int, float], float]]:
    """Capacity cuts for every window of an over-long run ``seq`` (length > ``cap``): per
    drone ``e`` with ``c̄_e < |W|``, ``Σ_{i≠j∈W} x_eij ≤ |W| − ⌈|W|/c̄_e⌉``, and the team-wide
    ``Σ_e Σ_{i≠j∈W} x_eij ≤ |W| − ⌈|W|/max_e c̄_e⌉`` (each valid for every feasible route, so
    the solver cannot move the violation to another drone)."""
    caps = [dr.capacity for dr in model.sc.drones]
    cmax = max(caps)
    cuts: list[tuple[dict[int, float], float]] = []
    for lo in range(len(seq)):
        for hi in range(lo + cap + 1, len(seq) + 1):
            w = set(seq[lo:hi])
            if frozenset(w) in model.seen:
                continue
            model.seen.add(frozenset(w))
            inner = [k for k in model.inner_arcs if model.arcs[k].tail[1] in w
                     and model.arcs[k].head[1] in w]
            for e, c in enumerate(caps):
                if 0 < c < len(w):
                    row = {k: 1.0 for k in inner if model.arcs[k].drone == e}
                    cuts.append((dict(row), len(w) - math.ceil(len(w) / c)))
                    # fractional capacity cut: runs of e in W >= (targets of e in W) / c
                    for k, a in enumerate(model.arcs):
                        if a.drone == e and a.head[0] == "T" and a.head[1] in w:
                            row[k] = row.get(k, 0.0) - (1.0 - 1.0 / c)
                    cuts.append((row, 0.0))
            if cmax < len(w):
                cuts.append(({k: 1.0 for k in inner}, len(w) - math.ceil(len(w) / cmax)))
    return cuts


def station_shared(arcs: list, xv: np.ndarray) -> bool:
    """Does the incumbent send two drones into one station?"""
    users: dict[int, set[int]] = {}
    for k, a in enumerate(arcs):
        if xv[k] and a.head[0] == "S":
            users.setdefault(a.head[1], set()).add(a.drone)
    return any(len(u) > 1 for u in users.values())
