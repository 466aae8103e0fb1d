"""The refinement NLP over waypoint knots (CasADi SX + IPOPT, exact Hessian).

Layout of the decision vector w: for drone d and axis j, the block
``[p_0 … p_{K−1}, v_0 … v_{K−1}]`` starts at ``(3d + j)·2K``; the margin r is the last entry.
Every sampled quantity is a sparse linear row of w (``_rows``), so the linear constraints
(velocity, acceleration, workspace, dwell) are one constant sparse matrix, and the only
nonlinear rows are the separation and obstacle rows chosen by constraint generation plus
the optional energy term. See ``stlc.team.refine`` for the formulation.

**Fixed drones** (backup-drone takeover, paper B §IV-C, ``stlc.replan.takeover``): a drone
of the scenario given as a ``FixedDrone`` carries its dense trajectory on the refinement
grid. It is not planned: its knot variables are pinned to 0 and it has no linear rows
(bounds, workspace, dwells) and no energy or smoothness term; it appears only in the
separation rows, as constant positions (rows between two fixed drones and obstacle rows of
a fixed drone involve no variable and are dropped), and ``plan`` returns its given
trajectory. Because it is a member of the scenario, the refinement's constraint generation
(``stlc.team.refine``) finds the samples where a planned drone comes close to it exactly as
for two planned drones. Without fixed drones nothing changes.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import casadi as ca
import numpy as np
import scipy.sparse as sp

from stlc import deadline
from stlc.solvers import ipopt as ipopt_solver
from stlc.team import Drone, TeamPlan, TeamScenario, Visit
from stlc.team.retime import Schedule
from stlc.team.waypoints import locate, check_times, hermite_weights, overshoot

_IPOPT = {"ipopt.print_level": 0, "print_time": False, "ipopt.sb": "yes",
          "ipopt.max_iter": 400, "ipopt.tol": 1e-6, "ipopt.mu_strategy": "adaptive"}


@dataclass(frozen=True, eq=False)
class FixedDrone(Drone):
    """A drone whose trajectory is given, not planned (see the module docstring): ``pos``,
    ``vel``, ``acc`` are (n, 3) arrays on the refinement's dense grid; ``start`` must be
    ``pos[0]``."""

    pos: np.ndarray | None = None
    vel: np.ndarray | None = None
    acc: np.ndarray | None = None


def fixed_trajectory(drone: Drone) -> np.ndarray | None:
    """The given positions of a fixed drone, None for a planned one."""
    return getattr(drone, "pos", None)


class TeamNLP:
    def __init__(self, scenario: TeamScenario, sched: Schedule, times: np.ndarray,
                 lam: float = 10.0):
        self.sc, self.sched, self.times, self.lam = scenario, sched, times, lam
        self.names = [d.name for d in scenario.drones]
        #: drone index -> given (n, 3) positions, for the fixed drones
        self.fixed = {d: np.asarray(fixed_trajectory(dr), dtype=float)
                      for d, dr in enumerate(scenario.drones)
                      if fixed_trajectory(dr) is not None}
        for d, p in self.fixed.items():
            if p.shape != (len(times), 3):
                raise ValueError(f"fixed drone {self.names[d]}: positions of shape "
                                 f"{p.shape}, expected ({len(times)}, 3)")
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
        seg, s, _ = locate(self.sched.knots, np.asarray(t, dtype=float))
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
            if d in self.fixed:  # not planned: every knot variable pinned to 0
                for j in range(3):
                    c = self._col(d, j, 0, 0)
                    self.lbx[c:c + 2 * K] = self.ubx[c:c + 2 * K] = 0.0
                continue
            for j in range(3):
                # 1e-6 inside the bounds: IPOPT may relax bounds by ~1e-8 (bound_relax_factor)
                vbar, abar = drone.vel_max[j] - 1e-6, drone.acc_max[j] - 1e-6
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
                m = win.k1 - win.k0
                for j in range(3):
                    c0 = self._col(d, j, 0, win.k0)
                    cv = self._col(d, j, 1, win.k0)
                    self.lbx[cv:cv + m + 1] = self.ubx[cv:cv + m + 1] = 0.0
                    if m > 0:  # p_k − p_k0 = 0 for the other knots of the window
                        rows = np.repeat(np.arange(m), 2)
                        cols = np.stack([c0 + 1 + np.arange(m), np.full(m, c0)], 1).ravel()
                        vals = np.tile([1.0, -1.0], m)
                        blocks.append(sp.csr_matrix((vals, (rows, cols)), shape=(m, self.nw)))
                        lb.append(np.zeros(m))
                        ub.append(np.zeros(m))
                    one = sp.csr_matrix(([1.0], ([0], [c0])), shape=(1, self.nw))
                    blocks += [one - rcol, one + rcol]
                    lb += [[win.box.lo[j]], [-np.inf]]
                    ub += [[np.inf], [win.box.hi[j]]]
        self.A = sp.vstack(blocks).tocsc()
        self.lbg_lin, self.ubg_lin = np.concatenate(lb), np.concatenate(ub)
        self.A_dm = ca.DM(self.A)
        # smoothness regulariser: Σ ∫|a|² dt = Σ h/3 (a0² + a0 a1 + a1²), normalised
        a0 = sp.vstack([acc[:nseg] for acc in self.acc_rows]).tocsc()
        a1 = sp.vstack([acc[nseg:] for acc in self.acc_rows]).tocsc()
        self.acc_ends = (ca.DM(a0), ca.DM(a1))
        amax = max(max(dr.acc_max) for d, dr in enumerate(sc.drones) if d not in self.fixed)
        planned = self.D - len(self.fixed)
        self.reg_weight = 1e-3 * (h / 3) / (planned * sc.horizon * amax**2)
        lam, gam = self.lam, sc.separation
        p, q, lo, hi = (ca.SX.sym(n, 3) for n in ("p", "q", "lo", "hi"))
        c, r = ca.SX.sym("c"), ca.SX.sym("r")
        d = p - q
        self._sep_fn = ca.Function("sep", [p, q, r], [(ca.dot(d, d) - (gam + r) ** 2) / (2 * gam)])
        faces = ca.vertcat(p - hi, lo - p)
        lse = c + ca.log(ca.sum1(ca.exp(lam * (faces - c)))) / lam
        self._obs_fn = ca.Function("obs", [p, lo, hi, c, r], [lse - math.log(6) / lam - r])
        vx, vy, vs = ca.SX.sym("vx"), ca.SX.sym("vy"), ca.SX.sym("vs")
        self._en_fn = ca.Function("en", [vx, vy, vs],
                                  [(1 - ca.sqrt(vx * vx + vy * vy + 1e-4) / vs) ** 2])

    # ------------------------------------------------------------------ nonlinear rows
    def _select(self, ds: np.ndarray, ks: np.ndarray, order: int) -> list[sp.csc_matrix]:
        """Per axis, the sparse (len, nw) map to drone ds[i]'s derivative at sample ks[i]."""
        out = []
        t = self.times[ks]
        for j in range(3):
            m = sp.csr_matrix((len(ks), self.nw))
            for d in np.unique(ds):
                if int(d) in self.fixed:  # constant: see _fixed_at
                    continue
                sel = np.flatnonzero(ds == d)
                part = self._at(int(d), j, t[sel], order).tocoo()
                m = m + sp.csr_matrix((part.data, (sel[part.row], part.col)), shape=m.shape)
            out.append(m.tocsc())
        return out

    def _fixed_at(self, ds: np.ndarray, ks: np.ndarray) -> np.ndarray:
        """(3, len) given positions of the fixed drones among ds[i] at samples ks[i]
        (0 for planned drones)."""
        out = np.zeros((3, len(ks)))
        for d, p in self.fixed.items():
            sel = np.flatnonzero(ds == d)
            out[:, sel] = p[ks[sel]].T
        return out

    def build(self, x, sep, obs, energy, r_floor, ipopt):
        """IPOPT solver for the given separation/obstacle rows; all in MX over one vector:
        sampled positions are constant sparse products, the nonlinear rows are tiny SX
        functions mapped over them (set-up stays cheap as rows grow)."""
        sc = self.sc
        w = ca.MX.sym("w", self.nw)
        r = w[-1]
        g, lb, ub = [ca.mtimes(self.A_dm, w)], [self.lbg_lin], [self.ubg_lin]

        def positions(ds, ks):
            ds, ks = np.asarray(ds), np.asarray(ks)
            mats = self._select(ds, ks, 0)
            sym = ca.horzcat(*[ca.mtimes(ca.DM(m), w) for m in mats]).T
            const = self._fixed_at(ds, ks)
            if self.fixed:
                sym = sym + ca.DM(const)
            return sym, np.stack([m @ x for m in mats], axis=0) + const

        fixed = self.fixed
        sep = {key for key in sep if not (key[0] in fixed and key[1] in fixed)}
        obs = {key for key in obs if key[0] not in fixed}
        if sep:
            items = sorted(sep)
            pa, _ = positions([i for i, _, _ in items], [k for *_, k in items])
            pb, _ = positions([j for _, j, _ in items], [k for *_, k in items])
            g.append(self._sep_fn.map(len(items))(pa, pb, r).T)
            lb.append(np.zeros(len(items)))
            ub.append(np.full(len(items), np.inf))
        if obs:
            items = sorted(obs)
            p, p0 = positions([i for i, _, _ in items], [k for *_, k in items])
            lo = np.array([sc.obstacles[q].lo for _, q, _ in items]).T
            hi = np.array([sc.obstacles[q].hi for _, q, _ in items]).T
            # sound smooth max LSE_λ(faces) − ln 6/λ ≤ max(faces), shifted by the current
            # max of each row so that the exponentials stay in range
            shift = np.max(np.vstack([p0 - hi, lo - p0]), axis=0)[None, :]
            g.append(self._obs_fn.map(len(items))(p, lo, hi, shift, r).T)
            lb.append(np.zeros(len(items)))
            ub.append(np.full(len(items), np.inf))
        a0, a1 = (ca.mtimes(m, w) for m in self.acc_ends)
        f = -r + self.reg_weight * (ca.dot(a0, a0) + ca.dot(a0, a1) + ca.dot(a1, a1))
        if energy is not None:
            f += energy["eta"] * self._energy(w, energy["v_star"])
        lbx, ubx = self.lbx.copy(), self.ubx.copy()
        if r_floor is not None:
            lbx[-1] = r_floor
        gg = ca.vertcat(*g)
        opts = dict(_IPOPT)
        opts.update(ipopt or {})
        opts.update(deadline.ipopt_options())  # the run's time limit (stlc.deadline)
        solver = ipopt_solver.solver("refine", {"x": w, "f": f, "g": gg}, opts)
        return (solver, np.concatenate(lb), np.concatenate(ub), lbx, ubx, int(gg.numel()))

    def transit_mask(self, name: str) -> np.ndarray:
        """Dense samples where the drone is in transit (not inside a dwell window)."""
        knots = self.sched.knots
        m = np.ones(len(self.times), dtype=bool)
        for win in self.sched.windows.get(name, []):
            m &= ~((self.times >= knots[win.k0] - 1e-9) & (self.times <= knots[win.k1] + 1e-9))
        return m

    def _energy(self, w: ca.MX, v_star: dict[str, float]) -> ca.MX:
        """Σ over the dense transit samples of (1 − v_for/v*)², v_for = hypot(v_x, v_y)."""
        total = 0
        for d, name in enumerate(self.names):
            ks = np.flatnonzero(self.transit_mask(name))
            if len(ks) == 0 or d in self.fixed:
                continue
            mx, my, _ = self._select(np.full(len(ks), d), ks, 1)
            vx, vy = ca.mtimes(ca.DM(mx), w), ca.mtimes(ca.DM(my), w)
            total += ca.sum2(self._en_fn.map(len(ks))(vx.T, vy.T, v_star[name]))
        return total

    def forward_cost(self, plan: TeamPlan, v_star) -> float | None:
        """Σ over drones of eq. 9's term; ``v_star`` is one v* or a v* per drone."""
        if v_star is None:
            return None
        from stlc.team.energy import feasible_forward_speed, forward_cost

        vs = v_star if isinstance(v_star, dict) else {d.name: v_star for d in self.sc.drones}
        return sum(forward_cost(plan.vel[dr.name], self.transit_mask(dr.name),
                                feasible_forward_speed(vs[dr.name], dr.vel_max))
                   for d, dr in enumerate(self.sc.drones) if d not in self.fixed)

    # ------------------------------------------------------------------ packing
    def pack(self, knots: dict[str, tuple[np.ndarray, np.ndarray]]) -> np.ndarray:
        x = np.zeros(self.nw)
        for d, name in enumerate(self.names):
            if d in self.fixed:
                continue
            p, v = knots[name]
            for j in range(3):
                base = (3 * d + j) * 2 * self.K
                x[base:base + self.K] = p[:, j]
                x[base + self.K:base + 2 * self.K] = v[:, j]
        return x

    def plan(self, x: np.ndarray, seed: TeamPlan) -> TeamPlan:
        pos, vel, acc = {}, {}, {}
        for d, name in enumerate(self.names):
            if d in self.fixed:
                dr = self.sc.drones[d]
                pos[name], vel[name], acc[name] = (np.array(a, dtype=float)
                                                   for a in (dr.pos, dr.vel, dr.acc))
                continue
            cols = [[self._at(d, j, self.times, o) @ x for j in range(3)] for o in (0, 1, 2)]
            pos[name], vel[name], acc[name] = (np.stack(c, axis=1) for c in cols)
        knots = self.sched.knots
        visits = [Visit(w.visit.drone, w.visit.kind, w.visit.region, float(knots[w.k0]),
                        float(knots[w.k1]))
                  for name in self.names for w in self.sched.windows.get(name, [])]
        return TeamPlan(self.times.copy(), pos, vel, acc, visits,
                        {k: list(v) for k, v in seed.route.items()})
