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

import numpy as np

from stlc import vehicles
from stlc.backends.base import ALL_FUNCTIONS, ALL_NODES, Backend, Capabilities, SolverStatus
from stlc.planning.solution import Solution, Verdict

NAME = "plan library"


class PlanLibrary:
    """Solved plans of one structure: (values, channels) pairs; ``nearest`` by scaled
    Euclidean distance over the value names both share."""

    def __init__(self) -> None:
        self.entries: list[tuple[dict[str, float], dict[str, np.ndarray], str]] = []

    def add(self, values: dict[str, float], channels: dict[str, np.ndarray],
            label: str = "") -> None:
        self.entries.append((dict(values), channels, label))

    def nearest(self, values: dict[str, float], score=None, k: int = 4
                ) -> tuple[dict[str, np.ndarray], str, float] | None:
        """The nearest plan; with ``score`` (channels → a number, e.g. the plan's exact
        robustness at this instance's values), the best-scored of the ``k`` nearest."""
        if not self.entries:
            return None
        if score is not None and len(self.entries) > 1:
            d = self._distances(values)
            near = np.argsort(d, kind="stable")[:k]
            i = max(near, key=lambda j: (score(self.entries[j][1]), -d[j]))
            return self.entries[i][1], self.entries[i][2], float(d[i])
        d = self._distances(values)
        i = int(np.argmin(d))
        return self.entries[i][1], self.entries[i][2], float(d[i])

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
                 own: Backend | None = None):
        self.channels, self.label, self.distance = channels, label, distance
        self.own = own  # the seed this instance's own chain starts from (``next_seed``)

    def accepts(self, problem) -> list:
        return []

    def lower(self, problem):
        return None, None

    def solve(self, lowered, problem):
        return self.channels

    NEXT_LABEL = "this instance's own seed (the plan library's plan missed κ)"

    def next_seed(self, problem, channels) -> Backend | None:
        """The seed this instance's own chain starts from (``own``: the MILP seed of the
        ``nlp`` chain): a neighbour's plan whose energy stage missed κ is in the class the
        MILP chose for *another* instance, so this one is planned as its compile would be
        (``strategy._next_choices`` keeps the better verified plan)."""
        return self.own

    def invert(self, raw, inverse, problem) -> Solution:
        return Solution(mission=problem.mission.name, status=Verdict.VIOLATED,
                        robustness_exact=float("nan"), robustness_smooth=float("nan"),
                        specs={}, energy=0.0, times=problem.grid.times(), channels=dict(raw),
                        timing={"guess_s": 0.0},
                        solver={"name": NAME, "status": str(SolverStatus.NOT_RUN),
                                "from": self.label, "distance": self.distance})


def is_library_seed(seed: Solution | None) -> bool:
    return seed is not None and seed.solver.get("name") == NAME


def warm_start(prob, inv, channels: dict[str, np.ndarray], params: dict[str, float],
               lam: float) -> np.ndarray:
    """Decision vector from a plan's channels (states, inputs on the n − 1 intervals), the
    lifted variables recomputed for ``params``."""
    from stlc.backends.nlp.model import fill_aux

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
