"""Exact pricing of the route formulation (``stlc.team.colgen``): labels over trips.

Per drone, a label ``(S, q, U)`` is a route prefix — the targets ``S`` it served, the
station ``q`` it is at, the stations ``U`` it entered — with the cheapest cost found for
that key (at a fixed key cheaper is better in time and in reduced cost alike, so one label
per key is exact).  Every label is also a complete route (the drone may end where it is).
A label is extended by every trip from ``q`` disjoint from ``S`` that keeps the route within
the horizon, in layers (one trip per layer), vectorised over frontier × trips with numpy.

Reduced cost of a route: ``cost − π(S) − σ_d − μ(U) − γ·(station trips)``, with the
master's duals for targets (π), the drone (σ), stations (μ ≤ 0) and the refill row (γ ≥ 0).
A label is dropped when its reduced cost plus a completion bound cannot go below the
threshold: ``Σ_{j ∉ S} min(0, ρ_j)``, ``ρ_j`` the least reduced cost per target of any station
trip holding ``j`` (every later trip is a station trip, each target in one of them).  With a
label cap (the cheap first rounds of column generation) only the most promising labels are
kept and the result is marked incomplete — no bound may be claimed from such a round.
"""

from __future__ import annotations

import time

import numpy as np

from stlc.team.trips import Trips

#: labels per drone at which exact pricing / enumeration gives up
EXACT_LABELS = 400_000


class DroneTrips:
    """The trips of one drone, grouped for labelling."""

    def __init__(self, trips: Trips, d: int, masks: np.ndarray, member: np.ndarray):
        mine = np.flatnonzero(trips.drone == d)
        self.idx = mine
        self.start = trips.start[mine]
        self.end = trips.end[mine]
        self.mask = masks[mine]
        self.cost = trips.cost[mine]
        self.member = member[mine]  # (m_d, nt) 0/1
        self.size = self.member.sum(axis=1)
        self.dep = np.flatnonzero(self.start < 0)
        self.by_q = {int(q): np.flatnonzero(self.start == q) for q in np.unique(self.start)
                     if q >= 0}


class Labels:
    """Labels of one drone in arrays (see ``_labels``); ``best`` maps a key to its index."""

    def __init__(self) -> None:
        self.s, self.q, self.u, self.cost, self.rc, self.parent, self.trip = ([] for _ in
                                                                               range(7))
        self.best: dict[tuple[int, int, int], int] = {}

    def add(self, s, q, u, cost, rc, parent, trip) -> np.ndarray:
        """Append the candidates that improve on their key (cheapest first); their indices."""
        order = np.lexsort((cost, u, q, s))
        s, q, u, cost, rc, parent, trip = (x[order] for x in (s, q, u, cost, rc, parent,
                                                                trip))
        first = np.ones(len(s), dtype=bool)
        first[1:] = (s[1:] != s[:-1]) | (q[1:] != q[:-1]) | (u[1:] != u[:-1])
        added = []
        n = sum(len(x) for x in self.s)
        for i in np.flatnonzero(first):
            key = (int(s[i]), int(q[i]), int(u[i]))
            old = self.best.get(key)
            if old is not None and self._cost(old) <= cost[i] + 1e-9:
                continue
            self.best[key] = n + len(added)
            added.append(i)
        added = np.asarray(added, dtype=int)
        for lst, x in zip((self.s, self.q, self.u, self.cost, self.rc, self.parent,
                           self.trip), (s, q, u, cost, rc, parent, trip), strict=True):
            lst.append(x[added])
        self._flat = None
        return np.arange(n, n + len(added))

    def _cost(self, i: int) -> float:
        return float(self.arrays()[3][i])

    def arrays(self):
        if getattr(self, "_flat", None) is None:
            self._flat = [np.concatenate(x) if x else np.zeros(0) for x in
                          (self.s, self.q, self.u, self.cost, self.rc, self.parent, self.trip)]
        return self._flat


def labels(dr: DroneTrips, pi: np.ndarray, mu: np.ndarray, gamma: float, sigma: float,
            limit: float,
            thr: float, cap: int, deadline: float, exclusive: bool, single: bool):
    """Labels of one drone whose completed routes could have reduced cost < ``thr``, as
    ``(Labels, complete)`` — ``complete`` is False when the search stopped at ``cap``
    labels; raises ``TimeoutError`` past ``deadline``.  With ``single`` a route uses one
    station only (its home: every station is some drone's home and used by it alone)."""
    nt = len(pi)
    r = dr.cost - dr.member @ pi - gamma * (dr.start >= 0)  # γ: dual of the refill row
    rho = np.zeros(nt)
    st = (dr.size > 0) & (dr.start >= 0)
    if st.any():
        per = np.where(dr.member[st] > 0, (r[st] / dr.size[st])[:, None], np.inf)
        rho = np.minimum(0.0, per.min(axis=0))
    rho_t = dr.member @ rho
    rho_all = float(rho.sum())
    bits = np.int64(1) << np.arange(nt, dtype=np.int64)
    mu = np.asarray(mu, dtype=float)
    lab = Labels()
    dep = dr.dep
    ends = dr.end[dep]
    u0 = np.where(ends >= 0, np.int64(1) << np.maximum(ends, 0), 0) if exclusive else \
        np.zeros(len(dep), dtype=np.int64)
    rc0 = r[dep] - (np.where(ends >= 0, mu[np.maximum(ends, 0)], 0.0) if exclusive else 0.0)
    keep = rc0 + rho_all - rho_t[dep] - sigma < thr
    front = lab.add(dr.mask[dep][keep], ends[keep], u0[keep], dr.cost[dep][keep], rc0[keep],
                    np.full(keep.sum(), -1), dep[keep])
    while len(front):
        if time.perf_counter() > deadline:
            raise TimeoutError
        if cap < EXACT_LABELS and len(front) > cap // 4:  # heuristic round: the best only
            fs0, frc0 = lab.arrays()[0][front], lab.arrays()[4][front]
            front = front[np.argsort(frc0 - ((fs0[:, None] & bits) != 0) @ rho)[:cap // 4]]
        fs, fq, fu, fc, frc = (x[front] for x in lab.arrays()[:5])
        base = frc + rho_all - ((fs[:, None] & bits) != 0) @ rho - sigma
        new = []
        for q in np.unique(fq):
            cand = dr.by_q.get(int(q))
            if cand is None:
                continue
            if single:
                cand = cand[dr.end[cand] == q]
            rows = np.flatnonzero(fq == q)
            chunk = max(1, 2_000_000 // max(len(cand), 1))
            for lo in range(0, len(rows), chunk):
                rr = rows[lo:lo + chunk]
                ok = (fs[rr, None] & dr.mask[cand][None, :]) == 0
                ok &= fc[rr, None] + dr.cost[cand][None, :] <= limit + 1e-9
                val = base[rr, None] + (r[cand] - rho_t[cand])[None, :]
                pen = np.zeros((len(rr), len(cand)))
                if exclusive:
                    e = dr.end[cand]
                    pen = np.where((fu[rr, None] >> e[None, :]) & 1, 0.0, -mu[e][None, :])
                ok &= val + pen < thr
                i, k = np.nonzero(ok)
                if len(i):
                    e = dr.end[cand[k]]
                    new.append((fs[rr[i]] | dr.mask[cand[k]], e,
                                (fu[rr[i]] | (np.int64(1) << e)) if exclusive else fu[rr[i]],
                                fc[rr[i]] + dr.cost[cand[k]],
                                frc[rr[i]] + r[cand[k]] + pen[i, k], front[rr[i]], cand[k]))
        if not new:
            break
        cols = [np.concatenate(x) for x in zip(*new, strict=True)]
        cut = len(cols[0]) + len(lab.best) > cap
        if cut:  # keep the most promising candidates (lowest reduced cost) up to the cap
            room = max(cap - len(lab.best), 1)
            best = np.argsort(cols[4] - ((cols[0][:, None] & bits) != 0) @ rho)[:room]
            cols = [x[best] for x in cols]
        front = lab.add(*cols)
        if cut:
            return lab, False
    return lab, True


def chain(lab: Labels, i: int, dr: DroneTrips) -> tuple[int, ...]:
    parent, trip = lab.arrays()[5], lab.arrays()[6]
    out = []
    while i >= 0:
        out.append(int(dr.idx[int(trip[i])]))
        i = int(parent[i])
    return tuple(out[::-1])
