"""The replanning NLP of paper A §4.4: one vehicle, one segment, built once and reused,
behind the ``Backend`` interface (``SegmentBackend``: ``lower`` once per mission and
vehicle, ``solve`` per event).

A segment replans a vehicle from a (predicted) start state at mission sample ``s`` to the
reference's full state at a waypoint sample ``g = s + L``; it is the part of the
trajectory NLP that replanning needs and nothing more:

* **dynamics** — the vehicle model's ODE (``stlc.vehicles.model_of(v).ode(v)``) discretised
  with the plan's integrator at the mission step (``dynamics.discrete_dynamics``, same
  sub-steps as ``nlp.model``), multiple shooting, inputs held over each step; the state and
  input bounds (rotor forces, per-axis velocity/acceleration) and the flight envelope of
  the vehicle model (``envelope``);
* **a fixed number of intervals** ``M`` (the longest segment the waypoint rule can produce)
  with a *mask* parameter: ``x_{k+1} = x_k + m_k·(F(x_k, u_k) − x_k)``, ``m_k = 1`` for the
  ``L`` active steps and ``0`` after them, where the state is held.  So every segment lies on
  the mission grid (it splices into the reference sample by sample, and the exact monitor
  judges it on the same samples), and one NLP serves every segment length;
* **rejoin** — the state at the last node equals the goal state (all components: position,
  attitude, velocities, rotor forces), so after the segment the vehicle flies the reference
  again exactly (up to IPOPT's constraint tolerance);
* **kept specs** — each must be (a conjunction of) ``always[a, b]`` over a formula of the
  vehicle's state predicates (no temporal operator inside).  The body is put in planner form
  ``P_κ`` (``nlp.expr.planner_form``: margins with the sign of m − κ, scaled per box) and
  lowered with ``nlp.expr.lower_expr``; each conjunct of the body is one constraint per
  node, ``or`` is the GKL smooth max and a nested ``and`` the smooth min (``nlp.expr``,
  λ = ``KEPT_LAMBDA``): both are lower bounds of the exact max/min, so a constraint ≥ 0
  implies the exact margin ≥ κ at that node.  Which nodes a clause covers (its window
  ``[a, b]`` ∩ the segment) is set per solve through the constraint bounds;
* **objective** — mean squared input, scaled by the input bound, plus the mean squared
  distance of the position from the reference's (parameter), so the replan returns smoothly
  and stays near the (safe) reference path;
* **recovery** — a start already inside a kept spec's violation set (a push into a
  clearance band) leaves no segment that keeps it at every node.  Each node has a slack
  ``σ_j ≥ 0`` added to its kept rows (``row + σ_j ≥ margin``), fixed at 0 for an ordinary
  segment (IPOPT takes fixed variables out: the NLP is the one above) and free for a
  ``recover`` problem, whose objective adds ``RECOVERY_WEIGHT · Σ σ_j``: an exact L1
  penalty, so the segment keeps the specs wherever it can and otherwise takes the way back
  with the least summed shortfall below κ — it leaves the violation set as fast as the
  vehicle's bounds allow, then keeps the specs;
* **a start outside the state bounds** (a velocity kick past ``vel_max``) — node j's bound
  on that component is widened by what the vehicle cannot have shed by then: the excess
  less ``a·j·dt`` for a velocity (``a`` the model's sound acceleration bound), less a
  linear share of the segment otherwise; the widening is gone once the vehicle can be back
  inside (``SegmentResult.detail["outside_bounds"]`` names the components);
* **parameters** — start state, goal state, reference positions, mask: nothing is rebuilt
  between events.  The primal guess is the reference with the start offset fading out
  linearly over the segment; IPOPT's multipliers are not warm-started.

IPOPT stops at ``max_wall_time`` = the compute budget t_c; its return status is mapped
through ``nlp.model.STATUS_MAP``.  Only the solver call is timed (wall and CPU).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import casadi as ca
import numpy as np

from stlc import vehicles
from stlc.backends.base import ALL_FUNCTIONS, Backend, Capabilities, SolverStatus
from stlc.backends.nlp.expr import ExprEnv, gkl_max, lower_expr, planner_form, smin
from stlc.backends.nlp.model import STATUS_MAP, substeps
from stlc.planning.kept import BODY_NODES, Clause, kept_clauses
from stlc.planning.solution import Solution, Verdict
from stlc.semantics import ir, model
from stlc.solvers import ipopt
from stlc.vehicles import dynamics

#: λ of the smooth max/min inside a kept spec's body (on scaled planner margins)
KEPT_LAMBDA = 50.0
#: a kept constraint asks the smooth planner margin to be at least this (scaled units), so
#: that the exact margin is ≥ κ with IPOPT's tolerance to spare
KEPT_MARGIN = 1e-3
#: weight of the squared position deviation (per m², mean over nodes) against the mean
#: squared scaled input
DEVIATION_WEIGHT = 1.0
#: weight of a recovery's summed shortfall of the kept rows (scaled planner margins), far
#: above the input and deviation terms (both O(1)): the L1 penalty is exact above the
#: constraints' multipliers
RECOVERY_WEIGHT = 1e3
IPOPT_OPTIONS = {
    "ipopt.print_level": 0, "ipopt.sb": "yes", "print_time": False,
    "ipopt.tol": 1e-6, "ipopt.constr_viol_tol": 1e-8, "ipopt.acceptable_tol": 1e-4,
    "ipopt.acceptable_constr_viol_tol": 1e-7, "ipopt.max_iter": 300,
    "ipopt.linear_solver": "mumps", "ipopt.mu_strategy": "adaptive",
}


def _lower_body(f: ir.Formula, env: ExprEnv, top: bool) -> list:
    """Rows (1×M SX) whose nonnegativity implies the body at every node (see docstring)."""
    match f:
        case ir.Pred(expr):
            v = lower_expr(expr, env)
            return [v if isinstance(v, ca.SX) else ca.SX(v)]
        case ir.TrueF():
            return [] if top else [ca.SX(1e3)]
        case ir.FalseF():
            return [ca.SX(-1e3)]
        case ir.And(args):
            rows = [r for a in args for r in _lower_body(a, env, top)]
            return rows if top else [smin(rows, env.lam)]
        case ir.Or(args):
            rows = [r for a in args for r in _lower_body(a, env, False)]
            return [gkl_max(rows, env.lam)]
    raise TypeError(f"not a state formula: {f!r}")


@dataclass
class SegmentResult:
    status: SolverStatus
    return_status: str
    iterations: int
    solve_s: float  # wall time of the solver call
    cpu_s: float  # CPU time of the solver call (time.process_time)
    X: np.ndarray  # (L + 1, nx) states of the NLP at nodes 0..L
    U: np.ndarray  # (L, nu) inputs
    objective: float
    detail: dict = field(default_factory=dict)


class SegmentNlp:
    """The replanning NLP of one vehicle (see module docstring); ``solve`` per event."""

    def __init__(self, vehicle: model.Vehicle, dt: float, M: int, clauses: list[Clause],
                 params: dict[str, float], kappa: float, budget: float,
                 integrator: str = "rk4"):
        t0 = time.perf_counter()
        self.vehicle, self.dt, self.M, self.clauses = vehicle, dt, M, clauses
        vm = vehicles.model_of(vehicle)
        self.vm = vm
        nx, nu = vm.state_size(vehicle)
        self.nx, self.nu = nx, nu
        self.pos = vm.pos_index()
        F = dynamics.discrete_dynamics(vm.ode(vehicle), dt, integrator, substeps(dt))
        self.step = F
        X = ca.SX.sym("X", nx, M)  # nodes 1..M
        U = ca.SX.sym("U", nu, M)
        x0, xg = ca.SX.sym("x0", nx), ca.SX.sym("xg", nx)
        pref = ca.SX.sym("pref", 3, M)  # reference positions at nodes 1..M
        mask = ca.SX.sym("mask", 1, M)
        Xa = ca.horzcat(x0, X)
        prev = Xa[:, :-1]
        nxt = prev + ca.repmat(mask, nx, 1) * (F.map(M)(prev, U) - prev)
        g = [ca.vec(X - nxt), X[:, -1] - xg]
        self.n_eq = nx * M + nx
        b = vm.envelope(vehicle, vm.bounds(vehicle))
        u_scale = np.where(np.isfinite(b.u_hi), np.maximum(np.abs(b.u_hi), np.abs(b.u_lo)), 1.0)
        # kept-spec rows, one block per clause, each M long (node-major inside a row)
        chans = {c: X[i, :] for i, c in enumerate(vm.state_channels(vehicle))}
        self.kept_rows: list[tuple[int, int]] = []  # (clause index, number of rows)
        S = ca.SX.sym("S", 1, M)  # a recovery's shortfall per node (fixed at 0 otherwise)
        for ci, cl in enumerate(clauses):
            env = ExprEnv(chans, dict(params), KEPT_LAMBDA, "gkl")
            rows = _lower_body(planner_form(cl.body, kappa, params), env, True)
            for r in rows:
                g.append(ca.vec((ca.repmat(r, 1, M) if r.numel() == 1 else r) + S))
            self.kept_rows.append((ci, len(rows)))
        Us = U / ca.DM(u_scale)
        dp = X[self.pos, :] - pref
        obj = (ca.sumsqr(Us) / M + DEVIATION_WEIGHT * ca.sumsqr(dp) / M
               + RECOVERY_WEIGHT * ca.sum2(S))
        w = ca.vertcat(ca.vec(X), ca.vec(U), ca.vec(S))
        p = ca.vertcat(x0, xg, ca.vec(pref), ca.vec(mask))
        gg = ca.vertcat(*g)
        self.ng = gg.numel()
        opts = dict(IPOPT_OPTIONS)
        opts["ipopt.max_wall_time"] = float(budget)
        self.solver = ipopt.solver("replan", {"x": w, "p": p, "f": obj, "g": gg}, opts)
        self.lbx = np.concatenate([np.tile(b.x_lo, M), np.tile(b.u_lo, M), np.zeros(M)])
        self.ubx = np.concatenate([np.tile(b.x_hi, M), np.tile(b.u_hi, M), np.zeros(M)])
        self.n_vars = w.numel()
        self.build_s = time.perf_counter() - t0

    def bounds_g(self, s: int, L: int) -> tuple[np.ndarray, np.ndarray]:
        """Constraint bounds for a segment starting at mission sample ``s`` of ``L`` steps:
        equalities, then each clause's rows active on nodes j = 1..L with s + j in its
        window (node j > L repeats the goal and is left free)."""
        lb, ub = [np.zeros(self.n_eq)], [np.zeros(self.n_eq)]
        nodes = s + np.arange(1, self.M + 1)
        for ci, nrows in self.kept_rows:
            cl = self.clauses[ci]
            on = (nodes >= cl.first) & (nodes <= cl.last) & (np.arange(1, self.M + 1) <= L)
            row = np.where(on, KEPT_MARGIN, -np.inf)
            lb.append(np.tile(row, nrows))
            ub.append(np.full(self.M * nrows, np.inf))
        return np.concatenate(lb), np.concatenate(ub)

    def solve(self, s: int, L: int, x_start: np.ndarray, ref_X: np.ndarray,
              ref_U: np.ndarray, recover: bool = False) -> SegmentResult:
        """Replan ``L`` steps (1 ≤ L ≤ M) from ``x_start`` to ``ref_X[L]``; ``ref_X`` (L + 1,
        nx) and ``ref_U`` (L, nu) are the reference on the segment (cost and guess);
        ``recover``: the kept rows may fall short, at a price (module docstring)."""
        M, nx, nu = self.M, self.nx, self.nu
        if not 1 <= L <= M:
            raise ValueError(f"segment of {L} steps, the NLP has {M}")
        goal = ref_X[L]
        Xr = np.vstack([ref_X[1:], np.repeat(goal[None], M - L, axis=0)])  # nodes 1..M
        fade = np.clip(1.0 - np.arange(1, M + 1) / L, 0.0, 1.0)[:, None]
        Xg = Xr + fade * (x_start - ref_X[0])[None, :]
        Ug = np.vstack([ref_U, np.zeros((M - L, nu))])
        mask = (np.arange(M) < L).astype(float)
        p = np.concatenate([x_start, goal, Xr[:, self.pos].ravel(), mask])
        w0 = np.concatenate([Xg.ravel(), Ug.ravel(), np.zeros(M)])
        lbg, ubg = self.bounds_g(s, L)
        lbx, ubx, outside = self._widened(x_start, L)
        if recover:
            ubx[-M:] = np.inf
        c0, t0 = time.process_time(), time.perf_counter()
        sol = self.solver(x0=w0, p=p, lbx=lbx, ubx=ubx, lbg=lbg, ubg=ubg)
        wall, cpu = time.perf_counter() - t0, time.process_time() - c0
        st = self.solver.stats()
        ret = str(st.get("return_status", "unknown"))
        w = np.asarray(sol["x"]).ravel()
        X = w[:nx * M].reshape(M, nx)
        U = w[nx * M:nx * M + nu * M].reshape(M, nu)
        return SegmentResult(
            status=STATUS_MAP.get(ret, SolverStatus.FAILED), return_status=ret,
            iterations=int(st.get("iter_count", 0)), solve_s=wall, cpu_s=cpu,
            X=np.vstack([x_start, X[:L]]), U=U[:L].copy(), objective=float(sol["f"]),
            detail={"ipopt_wall_s": float(st.get("t_wall_total", wall)),
                    **({"outside_bounds": outside} if outside else {})})

    def _widened(self, x_start: np.ndarray, L: int) -> tuple[np.ndarray, np.ndarray, dict]:
        """The variable bounds for a start ``x_start``, widened per node where the start
        lies outside a state bound (module docstring); the components outside (name →
        excess, SI)."""
        M, nx = self.M, self.nx
        lbx, ubx = self.lbx.copy(), self.ubx.copy()
        lo, hi = self.lbx[:nx], self.ubx[:nx]
        over = np.maximum(x_start - hi, 0.0) + np.maximum(lo - x_start, 0.0)
        if not np.any(over > 0):
            return lbx, ubx, {}
        rate = over / (max(L, 1) * self.dt)  # a linear share of the segment
        _, a_lo, a_hi = self.vm.kinematic_envelope(self.vehicle)
        vel = self.vm.vel_index()
        rate[vel] = np.maximum(np.abs(a_lo), np.abs(a_hi))
        j = np.arange(1, M + 1)[:, None] * self.dt
        extra = np.maximum(over[None, :] - rate[None, :] * j, 0.0)  # (M, nx)
        up, down = x_start > hi, x_start < lo
        ubx[:nx * M] += (extra * up[None, :]).ravel()
        lbx[:nx * M] -= (extra * down[None, :]).ravel()
        names = self.vm.state_channels(self.vehicle)
        return lbx, ubx, {names[i]: float(over[i]) for i in np.flatnonzero(over > 0)}

    def integrate(self, x_start: np.ndarray, U: np.ndarray) -> np.ndarray:
        """States (L + 1, nx) from flying the inputs ``U`` (L, nu) open loop."""
        X = [np.asarray(x_start, dtype=float)]
        for u in U:
            X.append(np.asarray(self.step(X[-1], u)).ravel())
        return np.array(X)


class SegmentBackend(Backend):
    """The segment NLP as a backend.  Constructor settings: the number of intervals
    ``steps`` (the longest segment), the compute ``budget`` (IPOPT's wall-time limit) and
    the ``integrator``.

    * ``lower(problem)``: ``problem.team`` is the one vehicle replanned, ``problem.specs``
      the kept specs, ``problem.fixed_channels`` the other vehicles' plans (so a kept spec
      about them is not this segment's); builds the NLP once;
    * ``solve(lowered, event)``: ``event.start_states[v]`` the predicted start state,
      ``event.window`` (t_s, t_g) on the mission grid, ``event.seed`` the current
      reference (states and inputs by channel name): the goal is its state at t_g, its
      path the cost and the guess; ``event.recover``: the start breaks a kept spec, so
      the segment first takes the way back (module docstring);
    * ``invert``: a ``Solution`` on the window's samples (the NLP's states, its inputs held
      over each step, the last repeated) with the solver log.
    """

    name = "segment nlp"
    capabilities = Capabilities(vehicle_models=frozenset({"multirotor", "point_mass"}),
                                nodes=frozenset({ir.Always, *BODY_NODES}),
                                functions=ALL_FUNCTIONS, team=False, windows=True)
    STATUS_MAP = STATUS_MAP

    def __init__(self, steps: int, budget: float, integrator: str = "rk4"):
        self.steps, self.budget, self.integrator = steps, budget, integrator

    def accepts(self, problem) -> list:
        return []  # ``kept_clauses`` refuses what a segment cannot keep (KeptSpecError)

    def lower(self, problem):
        v = problem.vehicles()[0]
        clauses = kept_clauses(problem, tuple(problem.specs), v)
        nlp = SegmentNlp(v, problem.grid.dt, self.steps, clauses, dict(problem.params),
                         problem.threshold, self.budget, self.integrator)
        return nlp, nlp

    def solve(self, nlp: SegmentNlp, problem) -> tuple[SegmentResult, int, int]:
        v = problem.vehicles()[0]
        vm = vehicles.model_of(v)
        dt = problem.grid.dt
        s, g = (int(round(t / dt)) for t in problem.window)
        ref = problem.seed.channels
        ref_X = np.stack([np.asarray(ref[c], float)[s:g + 1] for c in vm.state_channels(v)],
                         axis=1)
        ref_U = np.stack([np.asarray(ref[c], float)[s:g] for c in vm.input_channels(v)],
                         axis=1)
        return nlp.solve(s, g - s, np.asarray(problem.start_states[v.name]), ref_X, ref_U,
                         recover=problem.recover), s, g

    def invert(self, raw, nlp: SegmentNlp, problem) -> Solution:
        res, s, g = raw
        v = problem.vehicles()[0]
        vm = vehicles.model_of(v)
        ch = {c: res.X[:, i].copy() for i, c in enumerate(vm.state_channels(v))}
        Up = np.vstack([res.U, res.U[-1:]])
        ch.update({c: Up[:, i].copy() for i, c in enumerate(vm.input_channels(v))})
        return Solution(
            mission=problem.mission.name, status=Verdict.VIOLATED,
            robustness_exact=float("nan"), robustness_smooth=float("nan"), specs={},
            energy=0.0, times=problem.grid.times()[s:g + 1], channels=ch,
            timing={"solve_s": res.solve_s, "build_s": nlp.build_s},
            solver={"name": self.name, "status": str(res.status),
                    "converged": res.status.converged, "return_status": res.return_status,
                    "iterations": res.iterations, "cpu_s": res.cpu_s,
                    "objective": res.objective, **res.detail},
            problem_size={"variables": nlp.n_vars, "constraints": nlp.ng})

