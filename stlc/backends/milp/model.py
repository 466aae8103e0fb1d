"""A mixed-integer linear program under construction, solved by HiGHS (``stlc.solvers.highs``).

``Milp`` collects columns (bounds, integrality) and rows (sparse coefficients, bounds) as
plain lists; the HiGHS adapter (``stlc.solvers.highs.Highs``) hands it to HiGHS in one
``passModel`` call, through ``highspy`` directly rather than through cvxpy because the
exact backend needs what cvxpy's HiGHS interface does not expose: the incumbent *and* the
dual bound when the user's time limit stops branch and bound (a plan reported ``not
converged`` with its gap), a MIP start (``setSolution``), and changing a few row bounds of
a built model and solving again (the deletion filter of ``stlc.backends.milp.conflict``
re-solves one model many times).

``LinearVehicle`` puts a linear vehicle on the grid: state columns x_k (k = 0 … n−1), input
columns u_k (k = 0 … n−2, the zero-order hold of the NLP: for the double integrator the
same discrete model as its RK4), the exact discretisation x_{k+1} = A_d x_k + B_d u_k as
equality rows, the vehicle's bounds as column bounds, the start state fixed, and the
interval of every state at every sample (interval arithmetic through the dynamics, clipped
to the bounds) from which each predicate's big-M is derived.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp

INF = float("inf")


@dataclass
class Milp:
    lo: list[float] = field(default_factory=list)
    hi: list[float] = field(default_factory=list)
    integer: list[bool] = field(default_factory=list)
    rows: list[tuple[dict[int, float], float, float]] = field(default_factory=list)

    @property
    def n_cols(self) -> int:
        return len(self.lo)

    def var(self, lo: float = -INF, hi: float = INF, integer: bool = False) -> int:
        self.lo.append(float(lo))
        self.hi.append(float(hi))
        self.integer.append(integer)
        return len(self.lo) - 1

    def vars(self, n: int, lo: float = -INF, hi: float = INF, integer: bool = False) -> list[int]:
        return [self.var(lo, hi, integer) for _ in range(n)]

    def row(self, coefs: dict[int, float], lo: float = -INF, hi: float = INF) -> int:
        self.rows.append((coefs, float(lo), float(hi)))
        return len(self.rows) - 1

    def matrix(self) -> sp.csc_matrix:
        ri, ci, vi = [], [], []
        for r, (coefs, _, _) in enumerate(self.rows):
            for c, v in coefs.items():
                if v != 0.0:
                    ri.append(r)
                    ci.append(c)
                    vi.append(v)
        return sp.csc_matrix((vi, (ri, ci)), shape=(len(self.rows), self.n_cols))

    @property
    def n_binaries(self) -> int:
        return int(sum(self.integer))


# --------------------------------------------------------------------------- vehicles


def discretise(a: np.ndarray, b: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """Zero-order-hold discretisation (exact for piecewise-constant inputs)."""
    nx, nu = b.shape
    big = np.zeros((nx + nu, nx + nu))
    big[:nx, :nx], big[:nx, nx:] = a, b
    e = sla.expm(big * dt)
    ad, bd = e[:nx, :nx], e[:nx, nx:]
    ad[np.abs(ad) < 1e-14] = 0.0
    bd[np.abs(bd) < 1e-14] = 0.0
    return ad, bd


def propagate(ad: np.ndarray, bd: np.ndarray, x0: np.ndarray, x_lo, x_hi, u_lo, u_hi,
              n: int) -> tuple[np.ndarray, np.ndarray]:
    """The interval [lo_k, hi_k] of every state at samples 0 … n−1 that any admissible input
    sequence can reach from ``x0`` (interval arithmetic, clipped to the state bounds): a
    superset of the reachable states, so big-M values derived from it cut off no plan."""
    nx = len(x0)
    lo, hi = np.empty((n, nx)), np.empty((n, nx))
    lo[0] = hi[0] = x0
    ap, an = np.clip(ad, 0, None), np.clip(ad, None, 0)
    bp, bn = np.clip(bd, 0, None), np.clip(bd, None, 0)
    ulo = np.where(np.isfinite(u_lo), u_lo, -1e9)
    uhi = np.where(np.isfinite(u_hi), u_hi, 1e9)
    for k in range(1, n):
        lo[k] = ap @ lo[k - 1] + an @ hi[k - 1] + bp @ ulo + bn @ uhi
        hi[k] = ap @ hi[k - 1] + an @ lo[k - 1] + bp @ uhi + bn @ ulo
        lo[k] = np.maximum(lo[k], x_lo)
        hi[k] = np.minimum(hi[k], x_hi)
    return lo, hi


@dataclass
class LinearVehicle:
    """Columns and intervals of one linear vehicle on the grid."""

    name: str
    states: list[str]  # channel names
    inputs: list[str]
    ad: np.ndarray
    bd: np.ndarray
    x: np.ndarray  # (n, nx) column indices
    u: np.ndarray  # (n-1, nu) column indices
    lo: np.ndarray  # (n, nx) state intervals
    hi: np.ndarray
    u_lo: np.ndarray
    u_hi: np.ndarray

    def channel(self, name: str, k: int) -> tuple[int, float, float] | None:
        """(column, lo, hi) of channel ``name`` at sample k (an input at the last sample is
        the last interval's, as the NLP's channels repeat it)."""
        if name in self.states:
            i = self.states.index(name)
            return int(self.x[k, i]), float(self.lo[k, i]), float(self.hi[k, i])
        if name in self.inputs:
            j = self.inputs.index(name)
            kk = min(k, self.u.shape[0] - 1)
            return int(self.u[kk, j]), float(self.u_lo[j]), float(self.u_hi[j])
        return None

    def simulate(self, xval: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """States re-simulated from the solution's inputs (clipped to their bounds) through
        the exact discrete model: the plan obeys the dynamics to rounding."""
        uu = np.clip(xval[self.u], self.u_lo, self.u_hi)
        xs = np.empty(self.x.shape)
        xs[0] = xval[self.x[0]]
        for k in range(1, xs.shape[0]):
            xs[k] = self.ad @ xs[k - 1] + self.bd @ uu[k - 1]
        return xs, uu


def linear_vehicle(m: Milp, name: str, states: list[str], inputs: list[str],
                   a: np.ndarray, b: np.ndarray, bounds, x0: np.ndarray, dt: float,
                   n: int, discrete: bool = False) -> LinearVehicle:
    """Add one linear vehicle's columns and dynamics rows to ``m`` (``discrete``: ``a``,
    ``b`` are already the discrete model)."""
    ad, bd = (a, b) if discrete else discretise(a, b, dt)
    nx, nu = b.shape
    x_lo, x_hi = np.asarray(bounds.x_lo, float), np.asarray(bounds.x_hi, float)
    u_lo, u_hi = np.asarray(bounds.u_lo, float), np.asarray(bounds.u_hi, float)
    lo, hi = propagate(ad, bd, np.asarray(x0, float), x_lo, x_hi, u_lo, u_hi, n)
    x = np.array([[m.var(lo[k, i], hi[k, i]) for i in range(nx)] for k in range(n)], dtype=int)
    u = np.array([[m.var(u_lo[j], u_hi[j]) for j in range(nu)] for _ in range(n - 1)],
                 dtype=int).reshape(n - 1, nu)
    for k in range(n - 1):
        for i in range(nx):
            coefs = {int(x[k + 1, i]): 1.0}
            for j in np.flatnonzero(ad[i]):
                coefs[int(x[k, j])] = coefs.get(int(x[k, j]), 0.0) - ad[i, j]
            for j in np.flatnonzero(bd[i]):
                coefs[int(u[k, j])] = -bd[i, j]
            m.row(coefs, 0.0, 0.0)
    return LinearVehicle(name, states, inputs, ad, bd, x, u, lo, hi, u_lo, u_hi)
