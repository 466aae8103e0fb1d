"""The refinement NLP over waypoint knots (CasADi SX + IPOPT, exact Hessian).

Layout of the decision vector w: for drone d and axis j, the block
``[p_0 … p_{K−1}, v_0 … v_{K−1}]`` starts at ``(3d + j)·2K``; the margin r is the last entry.
Every sampled quantity is a sparse linear row of w (``_rows``), so the linear constraints
(velocity, acceleration, workspace, dwell) are one constant sparse matrix, and the only
nonlinear rows are the separation and obstacle rows chosen by constraint generation plus
the optional energy term. See ``stlc.team.refine`` for the formulation.
"""

from __future__ import annotations

import math

import casadi as ca
import numpy as np
import scipy.sparse as sp

from stlc.team import TeamPlan, TeamScenario, Visit
from stlc.team.retime import Schedule
from stlc.team.waypoints import _locate, check_times, hermite_weights, overshoot

_IPOPT = {"ipopt.print_level": 0, "print_time": False, "ipopt.sb": "yes",
          "ipopt.max_iter": 400, "ipopt.tol": 1e-6, "ipopt.mu_strategy": "adaptive"}


class TeamNLP:
    def __init__(self, scenario: TeamScenario, sched: Schedule, times: np.ndarray,
                 lam: float = 10.0):
        self.sc, self.sched, self.times, self.lam = scenario, sched, times, lam
        self.names = [d.name for d in scenario.drones]
        self.D, self.K = len(self.names), len(sched.knots)
        self.nw = 6 * self.D * self.K + 1
        self.h = float(sched.knots[1] - sched.knots[0])
        self.w = ca.SX.sym("w", self.nw)
        self._linear()

    # ------------------------------------------------------------------ linear rows
    def _rows(self, d: int, j: int, seg: np.ndarray, s: np.ndarray, order: int) -> sp.csr_matrix:
        k, base = self.K, (3 * d + j) * 2 * self.K
        w = hermite_weights(s, self.h, order)
        cols = np.stack([seg, k + seg, seg + 1, k + seg + 1], axis=1) + base
        rows = np.repeat(np.arange(len(seg)), 4)
        return sp.csr_matrix((np.stack(w, 1).ravel(), (rows, cols.ravel())),
                             shape=(len(seg), self.nw))

    def _at(self, d: int, j: int, t: np.ndarray, order: int) -> sp.csr_matrix:
        seg, s, _ = _locate(self.sched.knots, np.asarray(t, dtype=float))
        return self._rows(d, j, seg, s, order)

    def _col(self, d: int, j: int, part: int, k: int) -> int:
        return (3 * d + j) * 2 * self.K + part * self.K + k

    def _linear(self) -> None:
        sc, K, h = self.sc, self.K, self.h
        per = max(1, math.ceil(h / 0.25 - 1e-9))
        tchk = check_times(self.sched.knots, per)
        nseg = K - 1
        blocks, lb, ub = [], [], []
        rcol = sp.csr_matrix(([1.0], ([0], [self.nw - 1])), shape=(1, self.nw))
        self.lbx = np.full(self.nw, -np.inf)
        self.ubx = np.full(self.nw, np.inf)
        self.acc_rows = []
        for d, drone in enumerate(sc.drones):
            for j in range(3):
                vbar, abar = drone.vel_max[j], drone.acc_max[j]
                mv, mp = overshoot(abar, h, h / per)
                blocks.append(self._at(d, j, tchk, 1))
                lb.append(np.full(len(tchk), -(vbar - mv)))
                ub.append(np.full(len(tchk), vbar - mv))
                seg = np.arange(nseg)
                acc = sp.vstack([self._rows(d, j, seg, np.zeros(nseg), 2),
                                 self._rows(d, j, seg, np.ones(nseg), 2)]).tocsr()
                self.acc_rows.append(acc)
                blocks.append(acc)
                lb.append(np.full(2 * nseg, -abar))
                ub.append(np.full(2 * nseg, abar))
                pos = self._at(d, j, tchk, 0)
                r_all = sp.vstack([rcol] * len(tchk))
                blocks += [pos - r_all, pos + r_all]
                lb += [np.full(len(tchk), sc.workspace.lo[j] + mp), np.full(len(tchk), -np.inf)]
                ub += [np.full(len(tchk), np.inf), np.full(len(tchk), sc.workspace.hi[j] - mp)]
                for c, val in ((self._col(d, j, 0, 0), drone.start[j]),
                               (self._col(d, j, 1, 0), 0.0)):
                    self.lbx[c] = self.ubx[c] = val
            for win in self.sched.windows.get(drone.name, []):
                for j in range(3):
                    c0 = self._col(d, j, 0, win.k0)
                    for k in range(win.k0, win.k1 + 1):
                        cv = self._col(d, j, 1, k)
                        self.lbx[cv] = self.ubx[cv] = 0.0
                        if k > win.k0:
                            blocks.append(sp.csr_matrix(([1.0, -1.0], ([0, 0], [c0 + k - win.k0,
                                                        c0])), shape=(1, self.nw)))
                            lb.append([0.0])
                            ub.append([0.0])
                    one = sp.csr_matrix(([1.0], ([0], [c0])), shape=(1, self.nw))
                    blocks += [one - rcol, one + rcol]
                    lb += [[win.box.lo[j]], [-np.inf]]
                    ub += [[np.inf], [win.box.hi[j]]]
        self.A = sp.vstack(blocks).tocsc()
        self.lbg_lin, self.ubg_lin = np.concatenate(lb), np.concatenate(ub)
        self.g_lin = ca.mtimes(ca.DM(self.A), self.w)
        # smoothness regulariser: Σ ∫|a|² dt = Σ h/3 (a0² + a0 a1 + a1²), normalised
        reg = 0
        for acc in self.acc_rows:
            a = ca.mtimes(ca.DM(acc.tocsc()), self.w)
            a0, a1 = a[:nseg], a[nseg:]
            reg += ca.sum1(a0 * a0 + a0 * a1 + a1 * a1) * (h / 3)
        amax = max(max(dr.acc_max) for dr in sc.drones)
        self.reg = 1e-3 * reg / (self.D * sc.horizon * amax**2)

    # ------------------------------------------------------------------ nonlinear rows
    def _positions(self, keys: list[tuple[int, int]]) -> ca.SX:
        """(len(keys), 3) SX positions of (drone, sample) pairs."""
        if not keys:
            return ca.SX(0, 3)
        ds = np.array([k[0] for k in keys])
        t = self.times[np.array([k[1] for k in keys])]
        rows = []
        for j in range(3):
            m = sp.csr_matrix((len(keys), self.nw))
            for d in np.unique(ds):
                sel = np.flatnonzero(ds == d)
                part = self._at(int(d), j, t[sel], 0).tocoo()
                m = m + sp.csr_matrix((part.data, (sel[part.row], part.col)), shape=m.shape)
            rows.append(ca.mtimes(ca.DM(m.tocsc()), self.w))
        return ca.horzcat(*rows)

    def build(self, sep, obs, energy, r_floor, ipopt):
        sc, r = self.sc, self.w[-1]
        sep, obs = sorted(sep), sorted(obs)
        keys = sorted({(i, k) for i, _, k in sep} | {(j, k) for _, j, k in sep}
                      | {(i, k) for i, _, k in obs})
        index = {key: n for n, key in enumerate(keys)}
        P = self._positions(keys)
        g, lb = [self.g_lin], [self.lbg_lin]
        ub = [self.ubg_lin]
        if sep:
            a = P[[index[(i, k)] for i, _, k in sep], :]
            b = P[[index[(j, k)] for _, j, k in sep], :]
            diff = a - b
            gam = sc.separation
            g.append((ca.sum2(diff * diff) - (gam + r) ** 2) / (2 * gam))
            lb.append(np.zeros(len(sep)))
            ub.append(np.full(len(sep), np.inf))
        lam = self.lam
        for i, q, k in obs:
            box = sc.obstacles[q]
            p = P[index[(i, k)], :].T
            faces = ca.vertcat(p - ca.DM(box.hi), ca.DM(box.lo) - p)
            g.append(ca.log(ca.sum1(ca.exp(lam * faces))) / lam - math.log(6) / lam - r)
            lb.append([0.0])
            ub.append([np.inf])
        f = -r + self.reg
        if energy is not None:
            f += energy["eta"] * self._energy(energy["v_star"])
        lbx, ubx = self.lbx.copy(), self.ubx.copy()
        if r_floor is not None:
            lbx[-1] = r_floor
        gg = ca.vertcat(*g)
        opts = dict(_IPOPT)
        opts.update(ipopt or {})
        solver = ca.nlpsol("refine", "ipopt", {"x": self.w, "f": f, "g": gg}, opts)
        return (solver, np.concatenate(lb), np.concatenate(ub), lbx, ubx, int(gg.numel()))

    def transit_mask(self, name: str) -> np.ndarray:
        """Dense samples where the drone is in transit (not inside a dwell window)."""
        knots = self.sched.knots
        m = np.ones(len(self.times), dtype=bool)
        for win in self.sched.windows.get(name, []):
            m &= ~((self.times >= knots[win.k0] - 1e-9) & (self.times <= knots[win.k1] + 1e-9))
        return m

    def _energy(self, v_star: dict[str, float]) -> ca.SX:
        total = 0
        for d, name in enumerate(self.names):
            t = self.times[self.transit_mask(name)]
            if len(t) == 0:
                continue
            vx = ca.mtimes(ca.DM(self._at(d, 0, t, 1).tocsc()), self.w)
            vy = ca.mtimes(ca.DM(self._at(d, 1, t, 1).tocsc()), self.w)
            vf = ca.sqrt(vx * vx + vy * vy + 1e-4)
            total += ca.sum1((1 - vf / v_star[name]) ** 2)
        return total

    def forward_cost(self, plan: TeamPlan, v_star: float | None) -> float | None:
        if v_star is None:
            return None
        from stlc.team.energy import feasible_forward_speed, forward_cost

        return sum(forward_cost(plan.vel[dr.name], self.transit_mask(dr.name),
                                feasible_forward_speed(v_star, dr.vel_max))
                   for dr in self.sc.drones)

    # ------------------------------------------------------------------ packing
    def pack(self, knots: dict[str, tuple[np.ndarray, np.ndarray]]) -> np.ndarray:
        x = np.zeros(self.nw)
        for d, name in enumerate(self.names):
            p, v = knots[name]
            for j in range(3):
                base = (3 * d + j) * 2 * self.K
                x[base:base + self.K] = p[:, j]
                x[base + self.K:base + 2 * self.K] = v[:, j]
        return x

    def plan(self, x: np.ndarray, seed: TeamPlan) -> TeamPlan:
        pos, vel, acc = {}, {}, {}
        for d, name in enumerate(self.names):
            cols = [[self._at(d, j, self.times, o) @ x for j in range(3)] for o in (0, 1, 2)]
            pos[name], vel[name], acc[name] = (np.stack(c, axis=1) for c in cols)
        knots = self.sched.knots
        visits = [Visit(w.visit.drone, w.visit.kind, w.visit.region, float(knots[w.k0]),
                        float(knots[w.k1]))
                  for name in self.names for w in self.sched.windows.get(name, [])]
        return TeamPlan(self.times.copy(), pos, vel, acc, visits,
                        {k: list(v) for k, v in seed.route.items()})
