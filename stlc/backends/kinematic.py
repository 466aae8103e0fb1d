"""The initial guess of the CasADi backend: a kinematic path for every vehicle.

**Initial guess from the mission itself.**  A small kinematic problem is solved first: every
vehicle as a double integrator (position, velocity, acceleration; modest bounds) maximising
the smooth robustness of the part of the requirement that only reads positions and
velocities (``ir.restrict``).  It is cheap (≈ 9 variables per sample) and finds a path
through the regions the requirement visits *and around* the regions it forbids.  Its start
is the hover at the start position bent slightly sideways: a straight line through a
forbidden box lies on the box's symmetry plane, where the smooth robustness has no
sideways gradient, and the optimiser would stay inside (NLP_NOTES §3).  The full state guess
is then position and velocity from this path, level attitude, zero rates, hover forces.
"""

from __future__ import annotations

import casadi as ca
import numpy as np

from stlc import deadline, interrupt, vehicles
from stlc.backends import choices
from stlc.backends.casadi_nlp import MUMPS
from stlc.backends.derivatives import derivative_options
from stlc.backends.smooth_casadi import lower_robustness
from stlc.planning.problem import PlanningProblem
from stlc.semantics import ir
from stlc.semantics.timegrid import TimeGrid

GUESS_LAM = 30.0
#: the guess smooths the MILP seed's path (or finds one): a seed, not a plan.  IPOPT ends it
#: on its tolerances in 13–90 iterations on the handovers, except where it oscillates: 2 of
#: 14 ran to the old 300-iteration cap (10 s, the whole critical path); cut at 80, those
#: compile in 10.9 / 17.4 s instead of 23.6 / 27.6 s with the same verdict and energy
GUESS_MAX_ITER = 80
#: the guess is a seed: IPOPT's acceptable test ends it once its objective has stopped
#: moving (relative change < 1e-5 for 5 iterations) with the path consistent to 1e-2.  Its
#: tight test never ended on plateaus where steps of ~1e-2 left second-order residuals of
#: ~1e-3 (handover_above: iterations 114–192 at the same objective to 7 digits)
GUESS_ACCEPTABLE = {"ipopt.acceptable_tol": 1e-2, "ipopt.acceptable_iter": 5,
                    "ipopt.acceptable_constr_viol_tol": 1e-2,
                    "ipopt.acceptable_obj_change_tol": 1e-5}


def _start_kinematics(problem: PlanningProblem, name: str) -> tuple[np.ndarray, np.ndarray]:
    """(position, velocity) of the vehicle's start state (the problem's ``start_state``)."""
    v = problem.program.vehicles[name]
    x0 = problem.start_state(name)
    chans = vehicles.model_of(v).state_channels(v)

    def part(field: str, default) -> np.ndarray:
        idx = [chans.index(f"{name}.{field}.{a}") if f"{name}.{field}.{a}" in chans else None
               for a in "xyz"]
        if None in idx:
            return np.array(default, dtype=float)
        return np.array([x0[i] for i in idx], dtype=float)

    return part("pos", v.start_pos), part("vel", (0.0, 0.0, 0.0))


def kinematic_guess(problem: PlanningProblem, path: dict | None = None
                    ) -> dict[str, tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """Per vehicle of the problem's team: positions (3×n), velocities (3×n), accelerations
    (3×N) of the double-integrator path maximising the smooth robustness of the position and
    velocity part of ``problem.requirement`` from the problem's start states.  ``path`` (per
    vehicle (P, V, A): a MILP seed's path) is where IPOPT starts, and its discrete choices
    are kept (``choices``: the branch of every disjunction and the sample of every window
    fixed from the start path), so this local NLP smooths the path without leaving the
    homotopy class the MILP chose."""
    program, grid = problem.program, problem.grid
    n, N, dt = grid.n, grid.n_intervals, grid.dt
    names = list(problem.team)
    keep = {f"{v}.{f}.{a}" for v in names for f in ("pos", "vel") for a in "xyz"}
    f0 = f = ir.restrict(problem.requirement, lambda s: s in keep)
    f, fixed = _start_choices(f, path, program.params, grid) if path else (f, {})
    syms, chans, g, lbx, ubx, x0 = [], {}, [], [], [], []
    rest = []  # (bound index, v_max) of each vehicle's last velocity held at rest
    obj = ca.SX(0)
    for k, name in enumerate(names):
        v = program.vehicles[name]
        P, V, A = ca.SX.sym(f"P{k}", 3, n), ca.SX.sym(f"V{k}", 3, n), ca.SX.sym(f"A{k}", 3, N)
        for i, a in enumerate("xyz"):
            chans[f"{name}.pos.{a}"] = P[i, :]
            chans[f"{name}.vel.{a}"] = V[i, :]
        chans.update({c: ca.SX(ca.DM(row.reshape(1, -1))) for c, row in fixed.items()})
        g.append(ca.vec(P[:, 1:] - P[:, :-1] - dt * V[:, :-1] - 0.5 * dt * dt * A))
        g.append(ca.vec(V[:, 1:] - V[:, :-1] - dt * A))
        vmax, amax = vehicles.model_of(v).kinematic_limits(v)
        start, vel0 = _start_kinematics(problem, name)
        plo, phi_ = np.tile(start, (n, 1)).T.copy(), np.tile(start, (n, 1)).T.copy()
        plo[:, 1:], phi_[:, 1:] = -np.inf, np.inf
        vlo, vhi = np.tile(-vmax, (n, 1)).T.copy(), np.tile(vmax, (n, 1)).T.copy()
        vlo[:, 0] = vhi[:, 0] = vel0
        if problem.hold_end:  # a holdable end (flyable.py)
            vlo[:, -1] = vhi[:, -1] = 0.0
            rest.append((len(lbx) + 1, vmax))
        syms += [ca.vec(P), ca.vec(V), ca.vec(A)]
        lbx += [plo.T.ravel(), vlo.T.ravel(), np.tile(-amax, N)]
        ubx += [phi_.T.ravel(), vhi.T.ravel(), np.tile(amax, N)]
        # start: hover at the start, bent sideways (breaks symmetric traps), vehicle-specific
        s = np.sin(np.pi * np.arange(n) / max(N, 1))
        P0 = np.tile(start, (n, 1)) + np.outer(s, [0.0, 0.15 * (1 if k % 2 == 0 else -1), 0.05])
        if path is not None and name in path:
            Ps, Vs, As = path[name]
            x0 += [Ps.T.ravel(), Vs.T.ravel(), As[:, :N].T.ravel()]
        else:
            x0 += [P0.ravel(), np.zeros(3 * n), np.zeros(3 * N)]
        obj += 1e-2 * ca.sumsqr(A) / N
    w = ca.vertcat(*syms)
    wx0 = np.concatenate(x0)
    if isinstance(f, ir.TrueF):
        sol_w = wx0
    else:
        low = lower_robustness(f, grid, chans, program.params, GUESS_LAM,
                               method=problem.smoothing.method)
        cons, lb_r, ub_r = low.constraints()
        W = ca.vertcat(w, low.aux)
        G = ca.vertcat(*g, cons)
        lbg = np.concatenate([np.zeros(sum(x.numel() for x in g)), lb_r])
        ubg = np.concatenate([np.zeros(sum(x.numel() for x in g)), ub_r])
        nlp, derivs = derivative_options(W, obj - low.root, G)
        solver = ca.nlpsol("guess", "ipopt", nlp,
                           {**derivs,
                            "ipopt.print_level": 0, "ipopt.sb": "yes", "print_time": False,
                            "ipopt.max_iter": GUESS_MAX_ITER, "ipopt.tol": 1e-4,
                            # bound multipliers μ/slack, as the NLP's: 7 handovers' guesses
                            # 22.4 → 16.3 s in all (turned 180°: 6.1 → 1.8 s); 20 handovers'
                            # compile median 11.9 → 10.4 s, all satisfied
                            "ipopt.bound_mult_init_method": "mu-based", **GUESS_ACCEPTABLE,
                            **_mu_options(path is not None),
                            **{f"ipopt.{k}": v for k, v in MUMPS.items()},
                            **deadline.ipopt_options()})  # the run's time limit, if any
        num_ch = path_channels(_unpack(wx0, names, n, N)) | fixed
        aux0, _ = low.init_values(num_ch, program.params, GUESS_LAM)

        def run(lo, hi):
            sol = solver(x0=np.concatenate([wx0, np.asarray(aux0).ravel()]),
                         lbx=np.concatenate(lo + [np.full(low.aux.numel(), -np.inf)]),
                         ubx=np.concatenate(hi + [np.full(low.aux.numel(), np.inf)]),
                         lbg=lbg, ubg=ubg)
            interrupt.check()  # CasADi swallows Ctrl-C inside a solve: re-raise it here
            x = np.asarray(sol["x"]).ravel()[: w.numel()]
            return x, _kinematic_rho(f0, x, names, grid, program.params)

        sol_w, rho = run(lbx, ubx)
        if rest and rho < 0 and not deadline.solve_expired():
            # the end at rest is a preference of the seed (the NLP's rows make the plan
            # holdable): a path that misses the position part is solved again without it
            # (handover_low: −0.41 with it, +0.125 without; the NLP then ends it holdable)
            lo, hi = [a.copy() for a in lbx], [a.copy() for a in ubx]
            for i, vmax in rest:
                lo[i][-3:], hi[i][-3:] = -vmax, vmax
            free_w, free_rho = run(lo, hi)
            if free_rho > rho:
                sol_w = free_w
    return _unpack(sol_w, names, n, N)


def _mu_options(from_path: bool) -> dict:
    """IPOPT's barrier strategy: from a MILP seed's path (not far from a solution) monotone μ
    from 1e-3 — 14 handovers' guesses 430 → 307 iterations, none at the 80 cap where
    adaptive μ oscillated to it on 2 (μ_init 1e-2 / 1e-4: 359 / 362, one at the cap); from
    the hover (no path) adaptive μ, as before."""
    if from_path:
        return {"ipopt.mu_strategy": "monotone", "ipopt.mu_init": 1e-3}
    return {"ipopt.mu_strategy": "adaptive"}


def _start_choices(f: ir.Formula, start: dict, params, grid: TimeGrid
                   ) -> tuple[ir.Formula, dict[str, np.ndarray]]:
    """``f`` in choice form and its choice rows (``choices.choose``) on the start paths: the
    parameter signals that fix its disjunctions and windows as the start path has them
    (``f`` itself and no rows when it has nothing to choose)."""
    if isinstance(f, (ir.TrueF, ir.FalseF)):
        return f, {}
    fixed_form, nodes = choices.choice_form(f, windows=True)
    if not nodes:
        return f, {}
    return fixed_form, {k: np.asarray(v, float) for k, v in choices.choose(
        nodes, path_channels(start), params, grid.n, f, grid.dt).items()}


def _kinematic_rho(f: ir.Formula, w: np.ndarray, names: list[str], grid: TimeGrid,
                   params: dict) -> float:
    """Exact robustness of the position/velocity part ``f`` on a kinematic vector."""
    from stlc.analysis import monitor

    ch = path_channels(_unpack(w, names, grid.n, grid.n_intervals))
    return float(monitor.robustness(f, grid.dt, ch, params))


def path_channels(paths: dict) -> dict[str, np.ndarray]:
    """Position and velocity channels of per-vehicle (P 3×n, V 3×n, A) paths."""
    return {f"{name}.{fld}.{a}": X[i] for name, (P, V, _) in paths.items()
            for fld, X in (("pos", P), ("vel", V)) for i, a in enumerate("xyz")}


def _unpack(w: np.ndarray, names: list[str], n: int, N: int
            ) -> dict[str, tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """Per vehicle (positions 3×n, velocities 3×n, accelerations 3×N) of a kinematic vector."""
    out, off = {}, 0
    for name in names:
        P = w[off:off + 3 * n].reshape(n, 3).T
        V = w[off + 3 * n: off + 6 * n].reshape(n, 3).T
        A = w[off + 6 * n: off + 6 * n + 3 * N].reshape(N, 3).T
        out[name] = (P, V, A)
        off += 6 * n + 3 * N
    return out
