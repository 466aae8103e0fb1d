"""The CasADi backends behind the common interface: a kinematic seed and the full NLP.

* ``KinematicGuess`` — every vehicle as a double integrator maximising the smooth
  robustness of the position/velocity part of the requirement (``schedule.kinematic_guess``);
  its ``Solution`` carries ``<v>.pos.*``, ``<v>.vel.*`` and ``<v>.acc.*`` channels.
* ``CasadiNlp`` — the smooth-robustness trajectory NLP with the vehicles' dynamics
  (``nlp.model.build`` + the λ/energy schedule of ``schedule.solve_mission``), seeded from
  the previous backend's channels.

Their ``invert`` returns channels in mission-level names (states, inputs, and derived
signals recomputed by the vehicle models), the smooth robustness, energy, the solver log
with the shared ``SolverStatus``, and the comparison plans.  The exact monitor's verdict is
the verification pass's (``stlc.planning.verify``), not a backend's.
"""

from __future__ import annotations

import sys
import time
from dataclasses import dataclass

import numpy as np

from stlc import vehicles
from stlc.analysis import smooth
from stlc.backends.base import ALL_FUNCTIONS, ALL_NODES, Backend, Capabilities, SolverStatus
from stlc.backends.nlp.model import STATUS_MAP
from stlc.diagnostics import Diagnostic, StlcError
from stlc.planning.solution import Comparison, Solution, Verdict
from stlc.planning.problem import PlanningProblem

IPOPT_STATUS_MAP = STATUS_MAP  # IPOPT's codes → SolverStatus, for every backend running IPOPT


def pad(a: np.ndarray, n: int) -> np.ndarray:
    """Inputs live on the n − 1 intervals; as channels they repeat the last one."""
    return a if a.shape[-1] == n else np.concatenate([a, a[..., -1:]], axis=-1)


class KinematicGuess(Backend):
    name = "kinematic guess"
    capabilities = Capabilities(vehicle_models=frozenset({"multirotor", "point_mass"}),
                                nodes=ALL_NODES, functions=ALL_FUNCTIONS)
    STATUS_MAP = STATUS_MAP

    def accepts(self, problem: PlanningProblem) -> list[Diagnostic]:
        return []  # it plans the position/velocity part only and ignores the rest

    def lower(self, problem: PlanningProblem):
        return None, None

    def solve(self, lowered, problem: PlanningProblem):
        from stlc.backends.nlp import schedule

        t0 = time.perf_counter()
        kin = schedule.kinematic_guess(problem)
        return kin, time.perf_counter() - t0

    def start(self, lowered, problem: PlanningProblem):
        """The guess is computed in a forked child while the chain lowers the full NLP."""
        from stlc import apart

        wait = apart.start(self.solve, lowered, problem)

        def result():  # the time spent here is the guess not hidden behind the lowering
            t0 = time.perf_counter()
            (kin, dt_s), cpu_s = wait()
            return kin, dt_s, cpu_s, time.perf_counter() - t0

        result.cancel = wait.cancel
        return result

    def invert(self, raw, inverse, problem: PlanningProblem) -> Solution:
        kin, dt_s, cpu_s, waited_s = raw
        n = problem.grid.n
        ch: dict[str, np.ndarray] = {}
        for name, (P, V, A) in kin.items():
            for i, a in enumerate("xyz"):
                ch[f"{name}.pos.{a}"] = P[i]
                ch[f"{name}.vel.{a}"] = V[i]
                ch[f"{name}.acc.{a}"] = pad(A, n)[i]
        return Solution(mission=problem.mission.name, status=Verdict.VIOLATED,
                        robustness_exact=float("nan"), robustness_smooth=float("nan"),
                        specs={}, energy=0.0, times=problem.grid.times(), channels=ch,
                        timing={"guess_s": dt_s, "guess_cpu_s": cpu_s,
                                "guess_wait_s": waited_s},
                        solver={"name": self.name, "status": str(SolverStatus.NOT_RUN)})


def seed_paths(seed: Solution, team: tuple[str, ...], n: int
               ) -> dict[str, tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """Per vehicle (P 3×n, V 3×n, A 3×(n−1)) from a seed Solution's channels."""
    out = {}
    for name in team:
        P = np.array([seed.channels[f"{name}.pos.{a}"] for a in "xyz"])
        V = np.array([seed.channels[f"{name}.vel.{a}"] for a in "xyz"])
        A = np.array([seed.channels[f"{name}.acc.{a}"] for a in "xyz"])[:, : n - 1]
        out[name] = (P, V, A)
    return out


@dataclass
class _Lowered:
    prob: object  # casadi_nlp.NlpProblem
    inv: object  # casadi_nlp.InverseData
    build_s: float = 0.0  # 0 when the build was reused (nlp_cache)


class CasadiNlp(Backend):
    name = "casadi/ipopt"
    capabilities = Capabilities(vehicle_models=frozenset({"multirotor", "point_mass"}),
                                nodes=ALL_NODES, functions=ALL_FUNCTIONS)
    STATUS_MAP = STATUS_MAP

    lower_needs_seed = False  # built while the kinematic guess runs apart

    def __init__(self, quiet: bool = True):
        self.quiet = quiet

    def lower(self, problem: PlanningProblem):
        from stlc.backends.nlp.smooth import LoweringError

        from stlc.backends.nlp import cache as nlp_cache

        grid = problem.grid
        try:  # one build per structure: the instance's values are bound (nlp_cache)
            prob, inv, built = nlp_cache.lowered(problem, quiet=self.quiet)
        except LoweringError as e:
            raise StlcError([Diagnostic("STL401", f"cannot plan mission `{problem.name}`: "
                                        f"{e}", problem.mission.span)]) from None
        if not self.quiet:
            how = f"built in {prob.build_s:.2f} s" if built else "reused"
            print(f"{problem.name}: {grid.n} samples, {prob.n_vars} variables, {prob.n_cons} "
                  f"constraints ({how})", file=sys.stderr)
        return _Lowered(prob, inv, prob.build_s if built else 0.0), inv

    def solve(self, lowered: _Lowered, problem: PlanningProblem):
        from stlc.backends.nlp import schedule

        if problem.seed is None:
            raise ValueError("the CasADi NLP needs a seed (run KinematicGuess first)")
        from stlc.backends.nlp import library

        t0 = time.perf_counter()
        if library.is_library_seed(problem.seed):  # warm start from a solved instance
            w0 = library.warm_start(lowered.prob, lowered.inv, problem.seed.channels,
                                    problem.params, problem.smoothing.lam)
        else:
            kin = seed_paths(problem.seed, problem.team, problem.grid.n)
            w0 = schedule.full_guess(problem.program, lowered.prob, lowered.inv, kin,
                                     problem.smoothing.lam)
        guess_s = time.perf_counter() - t0 + problem.seed.timing.get("guess_s", 0.0)
        if not self.quiet:
            print(f"  initial guess: {guess_s:.2f} s", file=sys.stderr)
        raw = schedule.solve_mission(problem, lowered.prob, lowered.inv, w0, self.quiet,
                                     warm=library.is_library_seed(problem.seed))
        return raw, lowered.prob, guess_s, lowered.build_s

    def invert(self, raw_all, inv, problem: PlanningProblem) -> Solution:
        from stlc.backends.nlp import model as casadi_nlp

        raw, prob, guess_s, build_s = raw_all
        sm = problem.smoothing
        ch = channels_with_derived(inv, raw.w)
        lam = raw.lam
        smooth_v = float(smooth.smooth_robustness(inv.formula, inv.grid.dt, ch, problem.params,
                                                  lam, sm.method))
        energy, profile = energy_profile(inv, ch)
        last = raw.stages[-1] if raw.stages else None
        defect = casadi_nlp.dynamics_defect(raw.w, inv, problem.integrator)
        feasible = defect <= casadi_nlp.FEASIBLE_DEFECT
        failed = not feasible or all(s.status == "failed" for s in raw.stages)
        sol = Solution(
            mission=problem.name, status=Verdict.SOLVER_FAILED if failed else Verdict.VIOLATED,
            robustness_exact=float("nan"), robustness_smooth=smooth_v, specs={},
            energy=energy, times=inv.grid.times(), channels=ch,
            solver={"name": "ipopt (casadi)",
                    "iterations": sum(s.iterations for s in raw.stages),
                    "return_status": last.status if last else "not_run",
                    "max_dynamics_defect": defect,
                    "converged": bool(last.converged) if last else False,
                    "stages": [vars(s) for s in raw.stages]},
            smoothing={"method": sm.method, "lambda": sm.lam,
                       "lambda_final": lam, "threshold": problem.threshold},
            problem_size={"samples": inv.grid.n, "variables": prob.n_vars,
                          "constraints": prob.n_cons,
                          "aux": inv.aux_slice.stop - inv.aux_slice.start},
            energy_profile=profile, feasible=feasible)
        sol.timing.update({"build_s": build_s, "guess_s": guess_s,
                           "solve_s": sum(s.solve_s for s in raw.stages)})
        seed_t = problem.seed.timing if problem.seed is not None else {}
        sol.timing.update({k: seed_t[k] for k in ("guess_cpu_s", "guess_wait_s") if k in seed_t})
        if not feasible:
            sol.notes.append(f"the solver found no dynamically feasible plan (largest dynamics "
                             f"defect {defect:.2e} > {casadi_nlp.FEASIBLE_DEFECT:g})")
        if lam != sm.lam:
            sol.notes.append(f"the smoothing λ was raised from {sm.lam:g} to "
                             f"{lam:g} (the smooth robustness under-estimates by up to ln(n)/λ)")
        for st in raw.stages:
            if not st.converged:
                sol.notes.append(f"stage `{st.label}` (λ = {st.lam:g}) did not converge "
                                 f"({st.status} after {st.iterations} iterations)")
        sol.notes.extend(raw.notes)
        for label, wc in raw.comparisons.items():
            chc = channels_with_derived(inv, wc)
            ec, pc = energy_profile(inv, chc)
            sol.comparisons.append(Comparison(label, chc, ec, pc))
        return sol


def channels_with_derived(inv, w: np.ndarray) -> dict[str, np.ndarray]:
    """Named channels of a decision vector, with the vehicles' derived signals recomputed."""
    from stlc.backends.nlp.model import trajectory_channels

    ch = trajectory_channels(w, inv)
    for L in inv.layouts:
        v = L.vehicle
        ch.update(vehicles.model_of(v).derived_channels(v, vehicles.state_matrix(v, ch)))
    return ch


def energy_profile(inv, ch: dict[str, np.ndarray]) -> tuple[float, np.ndarray]:
    prof = np.zeros(inv.grid.n)
    for L in inv.layouts:
        v = L.vehicle
        prof += vehicles.model_of(v).energy_profile(v, vehicles.state_matrix(v, ch),
                                                    inv.grid.dt)
    return float(prof.sum()), prof
