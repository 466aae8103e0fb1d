"""Obstacle-aware legs of the seed: detours through via points around the obstacle boxes.

The seed (``stlc.team.seed``) and the assignment's cost model (``stlc.team.milp``) fly every
leg between two regions with a rest-to-rest motion primitive.  A leg whose synchronised
primitive keeps a clearance of ``margin`` from every obstacle box (sampled every 0.1 s and
at the chord's box intersections) is flown as before: one primitive, nothing changes for
missions whose direct legs are clear.  Otherwise the leg becomes a path ``p0 → v_1 → … →
p1`` through via points, each sub-leg flown on its chord (``rest_to_rest(straight=True)``,
the drone stops at every via point):

* candidate via points are the corners of every obstacle box inflated by ``node_margin``
  (> ``margin``), clamped into the workspace shrunk by ``node_margin`` — so a tower that
  reaches the top of the workspace yields corners beside it at the top and bottom of the
  free space; candidates inside another inflated obstacle are dropped;
* a segment is free when it misses every obstacle inflated by ``margin`` (slab test),
  except the obstacles that already contain one of its end points (a region touching an
  obstacle's inflated shell must stay reachable);
* the path is the shortest in *time* (Dijkstra, edge cost = the drone's minimum chord
  time) over the free segments among ``p0``, ``p1`` and the candidates.

When no free path exists the direct leg is kept (the refinement then has to find one).
``Router`` caches the visibility among candidates once per scenario and the path per
(end points, bounds); ``router_for(scenario)`` keeps one router per scenario.
"""

from __future__ import annotations

import heapq
import math
from functools import lru_cache

import numpy as np

from stlc.team import Box, TeamScenario
from stlc.team.primitives import min_duration, rest_to_rest

MARGIN = 0.5  # m, clearance from obstacle boxes demanded of a seed leg
NODE_MARGIN = 0.8  # m, inflation of the boxes whose corners are via-point candidates


def _grow(box: Box, m: float) -> tuple[np.ndarray, np.ndarray]:
    return np.asarray(box.lo, dtype=float) - m, np.asarray(box.hi, dtype=float) + m


def _hits_boxes(p0: np.ndarray, p1: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """Does the closed segment p0-p1 meet each open box ``(lo[k], hi[k])`` ((k, 3) each)?
    Points and boxes broadcast over the leading axes (the last holds x, y, z): segments
    ``(s, 1, 3)`` against boxes ``(1, k, 3)`` give an ``(s, k)`` answer."""
    d = p1 - p0
    flat = np.abs(d) < 1e-12
    with np.errstate(divide="ignore", invalid="ignore"):
        a = np.where(flat, -np.inf, (lo - p0) / d)
        b = np.where(flat, np.inf, (hi - p0) / d)
    t0 = np.maximum(np.max(np.minimum(a, b), axis=-1), 0.0)
    t1 = np.minimum(np.min(np.maximum(a, b), axis=-1), 1.0)
    inside_flat = np.all(~flat | ((lo < p0) & (p0 < hi)), axis=-1)
    return inside_flat & (t0 < t1)


def _free_from(p: np.ndarray, qs: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """For segments ``p-qs[i]``: clear of every box ``(lo[k], hi[k])`` that contains
    neither end point?  (bool per segment; ``_hits_boxes`` for many segments at once)"""
    if len(lo) == 0 or len(qs) == 0:
        return np.ones(len(qs), dtype=bool)
    d = qs[:, None, :] - p  # (n, 1, 3)
    flat = np.abs(d) < 1e-12
    with np.errstate(divide="ignore", invalid="ignore"):
        a = np.where(flat, -np.inf, (lo[None] - p) / d)  # (n, k, 3)
        b = np.where(flat, np.inf, (hi[None] - p) / d)
    t0 = np.maximum(np.max(np.minimum(a, b), axis=2), 0.0)
    t1 = np.minimum(np.min(np.maximum(a, b), axis=2), 1.0)
    inside_flat = np.all(~flat | ((lo[None] < p) & (p < hi[None])), axis=2)
    hit = inside_flat & (t0 < t1)  # (n, k)
    skip = np.all((p > lo) & (p < hi), axis=1)[None, :] | np.all(
        (qs[:, None, :] > lo[None]) & (qs[:, None, :] < hi[None]), axis=2)
    return ~np.any(hit & ~skip, axis=1)


class Router:
    """Via-point paths around the obstacles of one scenario (see the module docstring)."""

    def __init__(self, scenario: TeamScenario, margin: float = MARGIN,
                 node_margin: float = NODE_MARGIN) -> None:
        self.sc = scenario
        self.boxes = [_grow(o, margin) for o in scenario.obstacles]
        self.lo = np.array([b[0] for b in self.boxes]).reshape(-1, 3)
        self.hi = np.array([b[1] for b in self.boxes]).reshape(-1, 3)
        ws_lo = np.asarray(scenario.workspace.lo, dtype=float) + node_margin
        ws_hi = np.asarray(scenario.workspace.hi, dtype=float) - node_margin
        nodes: list[np.ndarray] = []
        for o in scenario.obstacles:
            lo, hi = _grow(o, node_margin)
            for cx in (lo[0], hi[0]):
                for cy in (lo[1], hi[1]):
                    for cz in (lo[2], hi[2]):
                        c = np.clip(np.array([cx, cy, cz]), ws_lo, ws_hi)
                        if not any(np.all((c > bl) & (c < bh)) for bl, bh in self.boxes):
                            if not any(np.allclose(c, q) for q in nodes):
                                nodes.append(c)
        self.nodes = nodes
        n = len(nodes)
        self.vis = np.zeros((n, n), dtype=bool)
        for i in range(n):
            for j in range(i + 1, n):
                self.vis[i, j] = self.vis[j, i] = self.free(nodes[i], nodes[j])
        self._cache: dict = {}
        self._edges: dict = {}  # (v̄, ā) -> {(i, j): chord time between via points}

    def _inside(self, *pts) -> np.ndarray:
        """Which inflated obstacles contain one of the points (bool per box)."""
        out = np.zeros(len(self.boxes), dtype=bool)
        for p in pts:
            out |= np.all((np.asarray(p, dtype=float) > self.lo)
                          & (np.asarray(p, dtype=float) < self.hi), axis=1)
        return out

    def _exempt(self, *pts) -> set[int]:
        return set(np.flatnonzero(self._inside(*pts)).tolist())

    def free(self, p0, p1, exempt: set[int] | None = None) -> bool:
        """Is the segment clear of every inflated obstacle not containing an end point
        (or, if ``exempt`` is given, of every obstacle not in it)?"""
        if not self.boxes:
            return True
        p0, p1 = np.asarray(p0, dtype=float), np.asarray(p1, dtype=float)
        if exempt is None:
            skip = self._inside(p0, p1)
        else:
            skip = np.zeros(len(self.boxes), dtype=bool)
            skip[list(exempt)] = True
        return not bool(np.any(_hits_boxes(p0, p1, self.lo, self.hi) & ~skip))

    def _direct_clear(self, p0, p1, vel_max, acc_max) -> bool:
        if not self.boxes:
            return True
        skip = self._inside(p0, p1)
        prim = rest_to_rest(p0, p1, vel_max, acc_max)
        t = np.linspace(0.0, prim.duration, max(2, int(prim.duration / 0.1) + 2))
        pts = prim.sample(t)[0]
        a0, a1 = pts[:-1, None, :], pts[1:, None, :]  # segments x boxes
        lo, hi = self.lo[None][:, ~skip], self.hi[None][:, ~skip]
        if lo.shape[1] == 0:
            return True
        return not bool(np.any(_hits_boxes(a0, a1, lo, hi)))

    def path(self, p0, p1, vel_max, acc_max) -> list[np.ndarray]:
        """``[p0, p1]`` when the direct primitive is clear, else the via-point path."""
        key = (tuple(map(float, p0)), tuple(map(float, p1)), tuple(vel_max), tuple(acc_max))
        if key not in self._cache:
            self._cache[key] = self._path(np.asarray(p0, dtype=float),
                                          np.asarray(p1, dtype=float), vel_max, acc_max)
        return self._cache[key]

    def _path(self, p0, p1, vel_max, acc_max) -> list[np.ndarray]:
        if np.allclose(p0, p1) or self._direct_clear(p0, p1, vel_max, acc_max):
            return [p0, p1]
        n = len(self.nodes)
        pts = [*self.nodes, p0, p1]
        s, g = n, n + 1

        table = self._edges.setdefault((tuple(vel_max), tuple(acc_max)), {})

        def cost(i: int, j: int) -> float:
            if i < n and j < n:  # node-node chord times are shared by every path
                if (i, j) not in table:
                    table[i, j] = min_duration(pts[i], pts[j], vel_max, acc_max, straight=True)
                return table[i, j]
            return min_duration(pts[i], pts[j], vel_max, acc_max, straight=True)

        nodes = np.array(self.nodes).reshape(-1, 3)
        adj_end = _free_from(p1, nodes, self.lo, self.hi)
        adj_start = _free_from(p0, nodes, self.lo, self.hi)
        dist = {s: 0.0}
        prev: dict[int, int] = {}
        heap = [(0.0, s)]
        done: set[int] = set()
        while heap:
            du, u = heapq.heappop(heap)
            if u in done:
                continue
            done.add(u)
            if u == g:
                break
            if u == s:
                nbrs = [(j, bool(adj_start[j])) for j in range(n)]
                nbrs.append((g, self.free(p0, p1)))
            else:
                nbrs = [(j, bool(self.vis[u, j])) for j in range(n) if j != u]
                nbrs.append((g, bool(adj_end[u])))
            for v, ok in nbrs:
                if not ok or v in done:
                    continue
                dv = du + cost(u, v)
                if dv < dist.get(v, math.inf):
                    dist[v], prev[v] = dv, u
                    heapq.heappush(heap, (dv, v))
        if g not in prev:
            return [p0, p1]
        out, v = [p1], g
        while v != s:
            v = prev[v]
            out.append(pts[v])
        return out[::-1]


def leg_steps(path: list[np.ndarray], vel_max, acc_max, step: float) -> list[int]:
    """Whole steps of every sub-leg of a path (a direct leg uses the synchronised primitive,
    a detour's sub-legs the chord primitive)."""
    from stlc.team import samples_for

    straight = len(path) > 2
    out = []
    for a, b in zip(path[:-1], path[1:], strict=True):
        t = min_duration(a, b, vel_max, acc_max, straight)
        out.append(math.inf if math.isinf(t) else samples_for(t, step))
    return out


@lru_cache(maxsize=8)
def router_for(scenario: TeamScenario) -> Router:
    """One router per scenario (the scenario is frozen and hashable)."""
    return Router(scenario)
