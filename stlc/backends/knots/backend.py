"""Long missions planned on knots: the full NLP on a coarse grid, the plan on the mission's.

Every layer of the ``nlp`` chain works per sample, so a minute-long mission at 0.1 s (601
samples, ~21 k NLP variables for a quadrotor) spends minutes in the NLP's build, the guess
and IPOPT.  ``KnotNlp`` plans such a mission on **knots**: the same ``nlp`` chain (MILP
seed → full-dynamics NLP) on a copy of the problem whose grid has a step h = m·dt of at
most ``KNOT_S`` and every vehicle's ``knot_step`` (``knot_factor``: h divides the horizon and every bound of a temporal
operator, so every window of the formula falls on knots).  The coarse NLP integrates each
knot interval with RK4 sub-steps of the mission's own step (``dynamics.substeps``), its
inputs held between knots, so the plan on the mission grid is the full model stepped on it
from each knot with that knot's inputs (``refine``): the NLP's own discrete model, with
every state and derived signal recomputed.  Size and work grow linearly with the horizon
and are m times smaller than per sample.

The refined plan is judged by the exact monitor on the mission grid (the pipeline's
verification, as every plan).  Between knots the path can cut a corner the knots did not
see.  When the refined plan misses κ while the knots meet it, the knots are planned again
from their plan with κ raised by the gap seen (``TIGHTEN_ROUNDS``: an energy-optimal plan
sits at κ on the knots and dips below it between them); if the plan still misses κ, it is
polished on the mission grid: the full NLP warm-started from it (``library.warm_start``),
and the better verified plan kept.  A coarse seed's proof of infeasibility is a proof about the knots only, so it
is never reported: the mission is then planned by the ``nlp`` chain on its own grid, whose
proof (``milp_conflict``) is the sound one.
"""

from __future__ import annotations

import sys
import time
from dataclasses import replace

import numpy as np

from stlc import deadline, vehicles
from stlc.backends.base import ALL_FUNCTIONS, ALL_NODES, Backend, Capabilities
from stlc.backends.nlp.model import STATUS_MAP
from stlc.planning.coarse_grid import seed_factor
from stlc.diagnostics import Diagnostic
from stlc.planning.problem import PlanningProblem
from stlc.planning.solution import Solution
from stlc.semantics.timegrid import TimeGrid
from stlc.vehicles import dynamics

LONG_SAMPLES = 200  #: a mission grid with more samples than this is planned on knots (the
#: handovers, 171 samples, keep their own grid)
KNOT_S = 0.5  #: the knots' step, at most (s; each vehicle model may ask for less)
TIGHTEN_ROUNDS = 2  #: re-plans of the knots with κ raised, at most
TIGHTEN_EXTRA = 0.02  #: … by the gap seen between knots and mission grid plus this,
TIGHTEN_MAX = 0.25  #: … and by at most this


def knot_factor(problem: PlanningProblem) -> int:
    """The knots' factor m (1: none): the largest m with m·dt ≤ ``KNOT_S`` and every
    vehicle's ``knot_step`` that divides the
    horizon and every finite bound of the requirement's temporal operators, and whose RK4
    sub-steps are the mission grid's own (sub-steps of m·dt = m × those of dt, so the
    refined plan is the coarse NLP's own discrete model)."""
    grid = problem.grid
    step = min([KNOT_S] + [float(getattr(vehicles.model_of(v), "knot_step",
                                         lambda _v: KNOT_S)(v)) for v in problem.vehicles()])
    m = seed_factor(grid, problem.requirement, max_step=step, max_samples=1 << 30)
    while m > 1 and dynamics.substeps(m * grid.dt) != m * dynamics.substeps(grid.dt):
        m = next((k for k in range(m - 1, 0, -1) if grid.n_intervals % k == 0), 1)
        m = seed_factor(grid, problem.requirement, max_step=m * grid.dt + 1e-9,
                        max_samples=1 << 30)
    return m


def coarse_problem(problem: PlanningProblem, m: int) -> PlanningProblem:
    """``problem`` on the knots (step m·dt): the same requirement, objective and κ."""
    grid = problem.grid
    fixed = {k: np.asarray(v)[::m] for k, v in problem.fixed_channels.items()}
    return replace(problem, grid=TimeGrid(m * grid.dt, grid.n_intervals // m),
                   fixed_channels=fixed, seed=None)


def refine(problem: PlanningProblem, channels: dict[str, np.ndarray], m: int
           ) -> tuple[dict[str, np.ndarray], float, np.ndarray]:
    """A knot plan's channels on the mission grid: from each knot's state, the full model
    stepped m times on the mission grid with that knot's inputs held (the coarse NLP's own
    sub-steps), the next knot's state at the next knot; derived signals recomputed:
    (channels, energy, energy per sample).  Restarting at every knot keeps the plan's
    dynamics defect the NLP's own (an open-loop simulation of a multirotor over a minute
    would amplify the NLP's 1e-6 defects into decimetres)."""
    grid = problem.grid
    n, N, dt = grid.n, grid.n_intervals, grid.dt
    nk = N // m  # knot intervals
    out: dict[str, np.ndarray] = {}
    prof = np.zeros(n)
    for v in problem.vehicles():
        vm = vehicles.model_of(v)
        Xk = np.array([np.asarray(channels[c], float) for c in vm.state_channels(v)])
        Uk = np.array([np.asarray(channels[c], float) for c in vm.input_channels(v)])
        Uk = Uk[:, :nk]
        F = dynamics.discrete_dynamics(vm.ode(v), dt, problem.integrator,
                                       dynamics.substeps(dt)).map(nk)
        X = np.empty((Xk.shape[0], n))
        X[:, ::m] = Xk[:, : nk + 1]
        x = Xk[:, :nk]
        for s in range(1, m):
            x = np.asarray(F(x, Uk))
            X[:, s::m] = x[:, : X[:, s::m].shape[1]]
        U = np.repeat(Uk, m, axis=1)  # held between knots: (nu, N)
        for i, c in enumerate(vm.state_channels(v)):
            out[c] = X[i].copy()
        Up = np.hstack([U, U[:, -1:]])
        for i, c in enumerate(vm.input_channels(v)):
            out[c] = Up[i].copy()
        out.update(vm.derived_channels(v, X.T))
        prof += vm.energy_profile(v, X.T, dt)
    return out, float(prof.sum()), prof


class KnotNlp(Backend):
    name = "knot nlp"
    capabilities = Capabilities(vehicle_models=frozenset({"multirotor", "point_mass"}),
                                nodes=ALL_NODES, functions=ALL_FUNCTIONS)
    STATUS_MAP = STATUS_MAP

    #: a window kept on the seed's sample is closed there (on knots, one knot is 0.5 s)
    SLACK = 0.0
    FREE = False  #: the seed's path as first found (no search for a better class after it)
    KEPT_NOTE = ("the knots were planned with the seed's timing kept: every window needed at "
                 "one sample closed on the seed's sample")

    def __init__(self, quiet: bool = True):
        self.quiet = quiet
        self.seed = None  # the MILP seed of the last ``solve``

    def factor(self, problem: PlanningProblem) -> int:
        """The knots' factor m (``knot_factor``)."""
        return knot_factor(problem)

    def keeps(self, problem: PlanningProblem, path: Solution) -> bool:
        """Is the seed ``path``'s timing worth keeping?  On knots always (the formula as
        written follows if the plan misses κ)."""
        return True

    def accepts(self, problem: PlanningProblem) -> list[Diagnostic]:
        from stlc.backends.base import unsupported

        diags = unsupported(self, problem)
        if diags:
            return diags
        if problem.grid.n <= LONG_SAMPLES:
            return [Diagnostic("STL401", f"mission `{problem.name}` has {problem.grid.n} "
                               f"samples: planned on its own grid (knots from "
                               f"{LONG_SAMPLES + 1})", problem.mission.span)]
        if knot_factor(problem) == 1:
            return [Diagnostic("STL401", f"mission `{problem.name}`: no coarser grid divides "
                               "its horizon and every bound of its temporal operators",
                               problem.mission.span)]
        return []

    def lower(self, problem: PlanningProblem):
        return None, None

    def _say(self, problem, text: str) -> None:
        if not self.quiet:
            print(f"{problem.name}: {text}", file=sys.stderr, flush=True)

    def solve(self, lowered, problem: PlanningProblem):
        from stlc.backends.base import run_chain
        from stlc.backends.nlp.backend import CasadiNlp
        from stlc.backends.milp.path_seed import MilpPathSeed
        from stlc.backends.nlp.backend import seed_paths

        t0 = time.perf_counter()
        m = self.factor(problem)
        cp = coarse_problem(problem, m) if m > 1 else problem
        from stlc.planning.budget import check_nlp

        check_nlp(cp, problem.mission.span)  # STL606 before anything is built
        if m > 1:
            self._say(problem, f"planning on knots every {m * problem.grid.dt:g} s "
                      f"({cp.grid.n} knots for {problem.grid.n} samples)")
        seed = MilpPathSeed(self.quiet, smooth=False, free=self.FREE)
        path, sols = _in_process(cp, seed) if self.FREE == "later" else run_chain(cp, [seed])
        if path.status == "infeasible" and m == 1:  # a proof on the mission grid
            return "grid", (path, sols), t0
        if path.status == "infeasible":  # a proof about the knots only: not reported
            self._say(problem, "the knots' seed found no path; planning on the mission "
                      "grid instead")
            return "grid", self._on_grid(problem), t0
        self.seed = seed  # its choices give the ``nlp`` chain's further seeds (``strategy``)
        given = (seed_paths(path, cp.team, cp.grid.n), dict(path.solver.get("seed", {})),
                 seed.resume)
        fixed = self._fixed(cp, path) if self.keeps(cp, path) else None
        if fixed is not None:
            self._say(problem, self.KEPT_NOTE)
            sol_c, sols = run_chain(fixed, [MilpPathSeed(self.quiet, given=given),
                                            CasadiNlp(self.quiet)])
            if m == 1:  # judged as planned; the ``nlp`` chain follows if it misses κ
                sol_c.notes.append(self.KEPT_NOTE)
                return "grid", _with_seed(sol_c, sols, self.SLACK, True), t0
            if sol_c.feasible and _exact(cp, sol_c.channels) >= cp.threshold:
                sol_c.notes.append(self.KEPT_NOTE)
                return "knots", (m, sol_c, sols, fixed), t0
            self._say(problem, "the plan with the seed's timing misses κ on the knots: "
                      "planning them with the formula as written")
        sol_c, sols = run_chain(cp, [MilpPathSeed(self.quiet, given=given),
                                     CasadiNlp(self.quiet)])
        if m == 1:  # nothing to keep: the ``nlp`` chain's first plan (its further seeds
            # follow if it misses κ)
            return "grid", _with_seed(sol_c, sols, self.SLACK, False), t0
        return "knots", (m, sol_c, sols, cp), t0

    def _fixed(self, cp: PlanningProblem, path: Solution) -> PlanningProblem | None:
        """``cp`` with the seed path's timing kept (``windows.fix_windows``), or None."""
        from stlc.backends.knots.windows import fix_windows

        f = fix_windows(cp.requirement, cp.grid.dt, {**cp.fixed_channels, **path.channels},
                        cp.params, cp.grid.n, self.SLACK)
        return None if f is None else replace(cp, requirement=f)

    def _on_grid(self, problem):
        """The ``nlp`` chain on the mission grid: MILP seed → full NLP."""
        from stlc.backends.base import run_chain
        from stlc.backends.nlp.backend import CasadiNlp
        from stlc.backends.milp.path_seed import MilpPathSeed

        return run_chain(problem, [MilpPathSeed(self.quiet), CasadiNlp(self.quiet)])

    def invert(self, raw, inverse, problem: PlanningProblem) -> Solution:
        how, payload, t0 = raw
        if how == "grid":
            sol, _ = payload
            return sol
        m, sol_c, sols, planned = payload
        ch, energy, prof = refine(problem, sol_c.channels, m)
        sol = replace(sol_c, times=problem.grid.times(), channels=ch, energy=energy,
                      energy_profile=prof, comparisons=[], timing=dict(sol_c.timing),
                      solver=dict(sol_c.solver), notes=list(sol_c.notes),
                      problem_size=dict(sol_c.problem_size))
        for c in sol_c.comparisons:  # the comparison plans on the mission grid too
            cc, ce, cp_ = refine(problem, c.channels, m)
            sol.comparisons.append(replace(c, channels=cc, energy=ce, energy_profile=cp_))
        seed = sols[0].solver if sols else {}
        seed = seed.to_json() if hasattr(seed, "to_json") else dict(seed)  # as data
        sol.solver.update({"knots": {"step_s": m * problem.grid.dt, "knots": len(sol_c.times),
                                     "samples": problem.grid.n}, "seed": seed})
        sol.problem_size["samples"] = problem.grid.n
        sol.problem_size["knots"] = len(sol_c.times)
        sol.timing["knots_s"] = time.perf_counter() - t0
        sol.notes.append(f"planned on knots every {m * problem.grid.dt:g} s (the full model "
                         f"between them, inputs held), then simulated on the mission grid")
        rho = _exact(problem, sol.channels)
        self._say(problem, f"knot plan on the mission grid: exact robustness {rho:+.4f}")
        sol, rho = self._tighten(problem, planned, m, sol_c, sol, rho)
        return self._polish(problem, sol, rho)

    def _tighten(self, problem: PlanningProblem, planned: PlanningProblem, m: int,
                 sol_c: Solution, sol: Solution, rho: float) -> tuple[Solution, float]:
        """The knots met κ but the mission grid does not (a corner cut between knots, a
        speed exceeded between them): plan the knots again, from their plan, with κ raised
        by the gap seen (``TIGHTEN_ROUNDS`` at most); the best plan on the mission grid
        is kept."""
        from stlc.backends.base import run_chain
        from stlc.backends.nlp.backend import CasadiNlp
        from stlc.backends.nlp.library import LibrarySeed

        cp = coarse_problem(problem, m)  # judged on the requirement as written
        kappa = problem.threshold
        for k in range(TIGHTEN_ROUNDS):
            on_knots = _exact(cp, sol_c.channels)
            if rho >= kappa or not on_knots >= kappa or deadline.solve_expired():
                break
            raised = planned.threshold + min(on_knots - rho + TIGHTEN_EXTRA, TIGHTEN_MAX)
            self._say(problem, f"the knots have exact robustness {on_knots:+.4f}, the mission "
                      f"grid {rho:+.4f}: planning the knots again with κ = {raised:.4g}")
            planned = replace(planned, threshold=raised)
            try:
                again, _ = run_chain(planned, [LibrarySeed(sol_c.channels, "knot plan", 0.0),
                                          CasadiNlp(self.quiet)])
            except deadline.TimeLimitReached:
                deadline.caught()
                break
            ch, energy, prof = refine(problem, again.channels, m)
            r2 = _exact(problem, ch)
            self._say(problem, f"knot plan {k + 2} on the mission grid: exact robustness "
                      f"{r2:+.4f}")
            if again.feasible and r2 == r2 and r2 > rho:
                iters = int(sol.solver.get("iterations", 0)) + \
                    int(again.solver.get("iterations", 0))
                sol = replace(sol, channels=ch, energy=energy, energy_profile=prof,
                              robustness_smooth=again.robustness_smooth,
                              solver={**sol.solver, "iterations": iters,
                                      "stages": list(sol.solver.get("stages", []))
                                      + list(again.solver.get("stages", []))})
                sol.notes.append(f"the knots were planned again with κ raised to {raised:.4g} "
                                 "(the first plan missed κ between knots)")
                sol_c, rho = again, r2
        return sol, rho

    def _polish(self, problem: PlanningProblem, sol: Solution, rho: float) -> Solution:
        """The refined plan misses κ on the mission grid: the full NLP on the mission grid
        from it (warm start), if time is left; the better plan (exact robustness) is kept."""
        if rho >= problem.threshold or deadline.solve_expired():
            return sol
        from stlc.backends.base import run_chain
        from stlc.backends.nlp.backend import CasadiNlp
        from stlc.backends.nlp.library import LibrarySeed

        self._say(problem, f"exact robustness {rho:+.4f} < κ = {problem.threshold:g}: "
                  "polishing on the mission grid from the knot plan")
        try:
            fine, _ = run_chain(problem, [LibrarySeed(sol.channels, "knot plan", 0.0),
                                          CasadiNlp(self.quiet)])
        except deadline.TimeLimitReached:
            deadline.caught()
            sol.notes.append("the polish on the mission grid was stopped by the time limit")
            return sol
        r2 = _exact(problem, fine.channels)
        if r2 == r2 and r2 > rho and fine.feasible:
            fine.notes.append(f"polished on the mission grid from a plan on knots (exact "
                              f"robustness {rho:+.4g} before)")
            fine.solver["knots"] = sol.solver.get("knots")
            fine.solver["iterations"] = int(fine.solver.get("iterations", 0)) + \
                int(sol.solver.get("iterations", 0))
            return fine
        sol.notes.append(f"a polish on the mission grid found no better plan ({r2:+.4g})")
        return sol


def _in_process(problem: PlanningProblem, seed) -> tuple[Solution, list]:
    """``seed`` (a ``MilpPathSeed``) run in this process, not apart: its MILP's search for
    a better class (``seed.resume``) can then run beside the kinematic guess of the seed
    given its path, in a child forked from this process (as in the ``nlp`` chain)."""
    from stlc.planning.effort import heartbeat

    with heartbeat(f"{seed.name} running (no verified plan yet)", seed.quiet):
        c0 = time.process_time()
        result, dt_s = seed.solve(None, problem)
        cpu_s = time.process_time() - c0
    sol = seed.invert((result, dt_s, cpu_s, 0.0), None, problem)
    return sol, [sol]


def _with_seed(sol: Solution, sols: list, slack: float, kept: bool
               ) -> tuple[Solution, list]:
    """A plan on the mission grid with its seed's record (what the MILP chose), as the
    ``nlp`` chain's plan has it, and whether the seed's timing was kept (``seed_timing``:
    ``strategy`` plans a plan that misses κ again with the ``nlp`` chain)."""
    rec = sols[0].solver.get("seed") if sols else None
    if isinstance(rec, dict):
        sol.solver["seed"] = rec
    sol.solver["seed_timing"] = {"kept": kept, "slack_s": slack}
    return sol, sols


def _exact(problem: PlanningProblem, channels: dict[str, np.ndarray]) -> float:
    """Exact robustness of ``problem``'s requirement on ``channels`` (its own grid)."""
    from stlc.analysis import monitor

    return float(monitor.robustness(problem.requirement, problem.grid.dt,
                                    {**problem.fixed_channels, **channels}, problem.params))
