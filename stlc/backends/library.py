"""A plan library: warm starts from the nearest solved instance (``stlc sweep``).

``PlanLibrary`` keeps the plans this process solved (per mission and structure, keyed by
the values of the instance, e.g. the ``--set`` values of a sweep) and ``LibrarySeed`` is a
seed backend that hands the nearest one — nearest in the varied values, each axis scaled
by its range — to ``CasadiNlp`` instead of the kinematic guess: the decision vector starts
at that plan's states and inputs (``warm_start``; the instance's own start state is the
bound of its first sample, IPOPT moves the start into the bounds), its lifted robustness
variables recomputed for *this* instance's parameters.

Soundness: a warm start only changes where IPOPT starts.  The NLP is this instance's (its
parameters and start bound), every iterate is judged by the exact monitor on this
instance's parameters, and the verdict is the verification pass's on the instance's own
plan (``stlc.planning.verify``), as for any other seed.
"""

from __future__ import annotations

import json
import os

import numpy as np

from stlc import vehicles
from stlc.backends.base import ALL_FUNCTIONS, ALL_NODES, Backend, Capabilities, SolverStatus
from stlc.planning.solution import Solution, Verdict

NAME = "plan library"


class PlanLibrary:
    """Solved plans of one structure: (values, channels, label, duals) entries — ``duals``
    the multipliers of the plan's final solve, or None; ``nearest`` by scaled Euclidean
    distance over the value names both share."""

    def __init__(self) -> None:
        self.entries: list[tuple[dict[str, float], dict[str, np.ndarray], str, object]] = []

    def add(self, values: dict[str, float], channels: dict[str, np.ndarray],
            label: str = "", duals: tuple | None = None) -> None:
        self.entries.append((dict(values), channels, label, duals))

    def nearest(self, values: dict[str, float], score=None, k: int = 4
                ) -> tuple[dict[str, np.ndarray], str, float, object] | None:
        """(channels, label, distance, duals) of the nearest plan; with ``score`` (channels →
        a number, e.g. the plan's exact robustness at this instance's values), of the
        best-scored of the ``k`` nearest."""
        if not self.entries:
            return None
        d = self._distances(values)
        i = int(np.argmin(d))
        if score is not None and len(self.entries) > 1:
            near = np.argsort(d, kind="stable")[:k]
            i = max(near, key=lambda j: (score(self.entries[j][1]), -d[j]))
        _, ch, label, duals = self.entries[i]
        return ch, label, float(d[i]), duals

    def _distances(self, values: dict[str, float]) -> np.ndarray:
        """Scaled Euclidean distance of every entry to ``values`` (each axis by its range)."""
        names = sorted(values)
        pts = np.array([[e[0].get(k, np.nan) for k in names] for e in self.entries])
        if pts.size == 0:
            return np.zeros(len(self.entries))
        x = np.array([values[k] for k in names])
        span = np.nanmax(np.vstack([pts, x]), axis=0) - np.nanmin(np.vstack([pts, x]), axis=0)
        span[~(span > 0)] = 1.0
        return np.sqrt(np.nansum(((pts - x) / span) ** 2, axis=1))


class LibrarySeed(Backend):
    """Seed backend: the nearest solved plan's channels (full states and inputs)."""

    name = NAME
    capabilities = Capabilities(vehicle_models=frozenset({"multirotor", "point_mass"}),
                                nodes=ALL_NODES, functions=ALL_FUNCTIONS)

    def __init__(self, channels: dict[str, np.ndarray], label: str, distance: float,
                 duals: tuple | None = None):
        self.channels, self.label, self.distance = channels, label, distance
        self.duals = duals

    def accepts(self, problem) -> list:
        return []

    def lower(self, problem):
        return None, None

    def solve(self, lowered, problem):
        return self.channels

    def invert(self, raw, inverse, problem) -> Solution:
        return Solution(mission=problem.mission.name, status=Verdict.VIOLATED,
                        robustness_exact=float("nan"), robustness_smooth=float("nan"),
                        specs={}, energy=0.0, times=problem.grid.times(), channels=dict(raw),
                        timing={"guess_s": 0.0},
                        solver={"name": NAME, "status": str(SolverStatus.NOT_RUN),
                                "from": self.label, "distance": self.distance},
                        duals=self.duals)


def is_library_seed(seed: Solution | None) -> bool:
    return seed is not None and seed.solver.get("name") == NAME


def warm_start(prob, inv, channels: dict[str, np.ndarray], params: dict[str, float],
               lam: float) -> np.ndarray:
    """Decision vector from a plan's channels (states, inputs on the n − 1 intervals), the
    lifted variables recomputed for ``params``."""
    from stlc.backends.casadi_nlp import fill_aux

    n = inv.grid.n
    w = np.zeros(prob.n_vars)
    for L in inv.layouts:
        v, vm = L.vehicle, vehicles.model_of(L.vehicle)
        X = np.array([np.asarray(channels[c], float)[:n] for c in vm.state_channels(v)])
        U = np.array([np.asarray(channels[c], float)[: n - 1] for c in vm.input_channels(v)])
        lo, hi = prob.lbx[L.x_slice][: L.nx], prob.ubx[L.x_slice][: L.nx]
        X[:, 0] = np.clip(X[:, 0], lo, hi)  # the instance's own start
        w[L.x_slice] = X.T.ravel()
        w[L.u_slice] = U.T.ravel()
    return fill_aux(prob, inv, w, params, lam)


#: IPOPT's warm start from given multipliers (a sweep's instance from a neighbour's plan
#: and the multipliers of its final solve).  IPOPT's default pushes (1e-3) and the NLP's
#: μ_init (1e-4): on 4 neighbour pairs of the handover sweep, 1e-9 pushes with μ_init 1e-6
#: took 146 iterations, these 123, a primal-only start 102.  ``STLC_WARM_IPOPT`` (JSON)
#: overrides, for measuring.
WARM_START = {"ipopt.warm_start_init_point": "yes",
              **json.loads(os.environ.get("STLC_WARM_IPOPT", "{}"))}


def dual_solver(prob) -> "ca.Function":
    """``prob``'s NLP and derivatives with ``WARM_START`` (``casadi_nlp.NlpProblem.nlp``),
    made on first use and kept beside the first solver (nlpsol shares the derivative
    Functions: ~5 ms on the handover, whose build takes 1.5 s)."""
    import casadi as ca

    if prob.warm is None:
        nlp, opts = prob.nlp
        prob.warm = ca.nlpsol("stlc_warm", "ipopt", nlp, {**opts, **WARM_START})
    return prob.warm


def usable_duals(prob, duals: tuple | None) -> tuple | None:
    """``duals`` when they fit ``prob`` (the same NLP structure: sizes), else None."""
    if duals is None or prob.nlp is None:
        return None
    lam_g, lam_x = duals
    return duals if len(lam_g) == prob.n_cons and len(lam_x) == prob.n_vars else None
