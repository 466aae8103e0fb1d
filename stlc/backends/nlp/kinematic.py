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

import contextlib
import threading

import casadi as ca
import numpy as np

from stlc import deadline, interrupt, vehicles
from stlc.backends.nlp import choices
from stlc.backends.nlp.derivatives import derivative_options
from stlc.backends.nlp.smooth import lower_robustness
from stlc.planning.problem import PlanningProblem
from stlc.semantics import ir
from stlc.semantics.timegrid import TimeGrid
from stlc.solvers import ipopt
from stlc.solvers.ipopt import MUMPS

GUESS_LAM = 30.0
#: the guess smooths the MILP seed's path (or finds one): a seed, not a plan.  IPOPT ends it
#: on its tolerances in 13–90 iterations on the handovers, except where it oscillates: 2 of
#: 14 ran to the old 300-iteration cap (10 s, the whole critical path); cut at 80, those
#: compile in 10.9 / 17.4 s instead of 23.6 / 27.6 s with the same verdict and energy
GUESS_MAX_ITER = 80
#: the guess is a seed: IPOPT's acceptable test ends it once its objective has stopped
#: moving (relative change < 1e-5 for 5 iterations) with the path consistent to 1e-2.  Its
#: tight test never ended on plateaus where steps of ~1e-2 left second-order residuals of
#: ~1e-3 (handover_above: iterations 114–192 at the same objective to 7 digits).  At 3e-2,
#: not 1e-2: with the windows narrowed on the seed's samples (``knots.timed``) the lifted
#: rows nearest the root cycled at ~2e-2 (second-order corrections) while the objective no
#: longer changed and the path — its rows are linear and hold at every step — did not move:
#: handover_left ran to the 80-iteration cap (0.73 s) instead of stopping after 26 (0.27 s);
#: 19 handovers, the same plans
GUESS_ACCEPTABLE = {"ipopt.acceptable_tol": 3e-2, "ipopt.acceptable_iter": 5,
                    "ipopt.acceptable_constr_viol_tol": 3e-2,
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
    return GuessNlp(problem, seeded=path is not None).solve(path)


class GuessNlp:
    """The kinematic NLP of ``kinematic_guess``, built before its start path is known (so
    that ``MilpPathSeed`` builds it while HiGHS looks for the path).  ``seeded``: it will
    start from a path and keep that path's choices — the choice form of the formula with
    ``mix`` = 0 built in and the choice rows as NLP parameters, set by ``solve`` from the
    path (``choices.choose``); else the formula as written, from the hover."""

    def __init__(self, problem: PlanningProblem, seeded: bool):
        program, grid = problem.program, problem.grid
        n, N, dt = grid.n, grid.n_intervals, grid.dt
        self.problem, self.seeded = problem, seeded
        self.names = names = list(problem.team)
        keep = {f"{v}.{f}.{a}" for v in names for f in ("pos", "vel") for a in "xyz"}
        self.f0 = f = ir.restrict(problem.requirement, lambda s: s in keep)
        self.nodes, self.rows = [], []  # choice nodes; the names of the parameter rows
        chans: dict = {}
        if seeded and not isinstance(f, (ir.TrueF, ir.FalseF)):
            fixed_form, self.nodes = choices.choice_form(f, windows=True)
            if self.nodes:
                f = fixed_form
                for c in choices.signals(self.nodes):
                    if c == choices.MIX:  # the choices are kept: mix = 0, built in
                        chans[c] = ca.SX(ca.DM.zeros(1, n))
                    else:
                        self.rows.append(c)
                        chans[c] = ca.SX.sym(c, 1, n)
        self.f = f
        syms, g, self.lbx, self.ubx, self.hover = [], [], [], [], []
        self.rest = []  # (bound index, v_max) of each vehicle's last velocity held at rest
        obj = ca.SX(0)
        for k, name in enumerate(names):
            v = program.vehicles[name]
            P, V, A = (ca.SX.sym(f"P{k}", 3, n), ca.SX.sym(f"V{k}", 3, n),
                       ca.SX.sym(f"A{k}", 3, N))
            for i, a in enumerate("xyz"):
                chans[f"{name}.pos.{a}"] = P[i, :]
                chans[f"{name}.vel.{a}"] = V[i, :]
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
                self.rest.append((len(self.lbx) + 1, vmax))
            syms += [ca.vec(P), ca.vec(V), ca.vec(A)]
            self.lbx += [plo.T.ravel(), vlo.T.ravel(), np.tile(-amax, N)]
            self.ubx += [phi_.T.ravel(), vhi.T.ravel(), np.tile(amax, N)]
            # without a path: hover at the start, bent sideways (breaks symmetric traps)
            s_ = np.sin(np.pi * np.arange(n) / max(N, 1))
            P0 = np.tile(start, (n, 1)) + np.outer(s_, [0.0, 0.15 * (1 if k % 2 == 0 else -1),
                                                        0.05])
            self.hover += [P0.ravel(), np.zeros(3 * n), np.zeros(3 * N)]
            obj += 1e-2 * ca.sumsqr(A) / N
        self.nw = ca.vertcat(*syms).numel()
        self.low = self.solver = None
        if isinstance(f, ir.TrueF):
            return
        self.low = low = lower_robustness(f, grid, chans, program.params, GUESS_LAM,
                                          method=problem.smoothing.method)
        cons, lb_r, ub_r = low.constraints()
        n_dyn = sum(x.numel() for x in g)
        self.lbg = np.concatenate([np.zeros(n_dyn), lb_r])
        self.ubg = np.concatenate([np.zeros(n_dyn), ub_r])
        p = ca.vertcat(*[ca.vec(chans[c]) for c in self.rows]) if self.rows else None
        nlp, derivs = derivative_options(ca.vertcat(*syms, low.aux), obj - low.root,
                                         ca.vertcat(*g, cons), p)
        self.solver = ipopt.solver("guess", nlp, {
            **derivs,
            "ipopt.print_level": 0, "ipopt.sb": "yes", "print_time": False,
            "ipopt.max_iter": GUESS_MAX_ITER, "ipopt.tol": 1e-4,
            # bound multipliers μ/slack, as the NLP's: 7 handovers' guesses 22.4 → 16.3 s in
            # all (turned 180°: 6.1 → 1.8 s); 20 handovers' compile median 11.9 → 10.4 s
            "ipopt.bound_mult_init_method": "mu-based", **GUESS_ACCEPTABLE,
            # adaptive μ (monotone μ from 1e-3 from a MILP path was measured worse:
            # path — 14 handovers' guesses 430 → 307 iterations and none at the 80 cap, but
            # on an unseen handover (h24) its converged path led the energy stage to miss κ
            # and the compile took 58 s instead of 22 s (the schedule's whole fallback)
            "ipopt.mu_strategy": "adaptive",
            **{f"ipopt.{k}": v for k, v in MUMPS.items()},
            **deadline.ipopt_options()})  # the run's time limit, if any

    def solve(self, path: dict | None = None
              ) -> dict[str, tuple[np.ndarray, np.ndarray, np.ndarray]]:
        """The guess from ``path`` (a seeded NLP needs one) or from the hover."""
        problem = self.problem
        program, grid = problem.program, problem.grid
        n, N, names = grid.n, grid.n_intervals, self.names
        if self.seeded and path is None:
            raise ValueError("a seeded kinematic NLP starts from a path")
        if path is not None:
            x0 = [a for name in names for a in (path[name][0].T.ravel(), path[name][1].T.ravel(),
                                                path[name][2][:, :N].T.ravel())]
        else:
            x0 = self.hover
        wx0 = np.concatenate(x0)
        if self.solver is None:
            return _unpack(wx0, names, n, N)
        fixed = {}
        if self.nodes:  # the choices of the start path (the rows the NLP reads as parameters)
            fixed = {k: np.asarray(v, float) for k, v in choices.choose(
                self.nodes, path_channels(path), program.params, n, self.f0,
                grid.dt).items()}
        pv = np.concatenate([fixed[c].ravel() for c in self.rows]) if self.rows else []
        low = self.low
        num_ch = path_channels(_unpack(wx0, names, n, N)) | fixed
        aux0, _ = low.init_values(num_ch, program.params, GUESS_LAM)

        def run(lo, hi):
            sol = self.solver(x0=np.concatenate([wx0, np.asarray(aux0).ravel()]), p=pv,
                              lbx=np.concatenate(lo + [np.full(low.aux.numel(), -np.inf)]),
                              ubx=np.concatenate(hi + [np.full(low.aux.numel(), np.inf)]),
                              lbg=self.lbg, ubg=self.ubg)
            interrupt.check()  # CasADi swallows Ctrl-C inside a solve: re-raise it here
            x = np.asarray(sol["x"]).ravel()[: self.nw]
            return x, _kinematic_rho(self.f0, x, names, grid, program.params)

        sol_w, rho = run(self.lbx, self.ubx)
        if self.rest and rho < 0 and not deadline.solve_expired():
            # the end at rest is a preference of the seed (the NLP's rows make the plan
            # holdable): a path that misses the position part is solved again without it
            # (handover_low: −0.41 with it, +0.125 without; the NLP then ends it holdable)
            lo, hi = [a.copy() for a in self.lbx], [a.copy() for a in self.ubx]
            for i, vmax in self.rest:
                lo[i][-3:], hi[i][-3:] = -vmax, vmax
            free_w, free_rho = run(lo, hi)
            if free_rho > rho:
                sol_w = free_w
        return _unpack(sol_w, names, n, N)


def build_in_thread(problem: PlanningProblem):
    """Build the seeded ``GuessNlp`` of ``problem`` in a thread while the caller runs the
    MILP that finds its path (HiGHS releases the GIL, and nothing else in the process
    touches CasADi meanwhile): the returned function joins the thread and gives the NLP, or
    None when it could not be built (``kinematic_guess`` then builds in line and reports)."""
    out: list = []

    def build() -> None:
        with contextlib.suppress(Exception):
            out.append(GuessNlp(problem, seeded=True))

    t = threading.Thread(target=build, name="stlc-guess-build", daemon=True)
    t.start()

    def join() -> GuessNlp | None:
        t.join()
        return out[0] if out else None

    return join


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
