"""The smoothest of the most robust plans: an LP after the exact MILP.

The exact MILP maximises ρ̂; among the plans with that robustness it returns whichever
vertex HiGHS reached, and a double integrator's vertex plan is bang-bang (accelerations at
their bounds, switching at every sample).  ``least_jerk`` keeps the MILP's discrete choices
and its robustness (ρ̂ ≥ the MILP's value, to rounding) and minimises the L1 norm of the
inputs' changes between samples (Σ |u_{k+1} − u_k|: the jerk of a point mass, whose input
is its acceleration) — an LP, so the plan is as robust as the MILP's and as smooth as that
class allows.  The model is copied; the MILP's own model is left as it was.
"""

from __future__ import annotations

import numpy as np

from stlc.planning import effort
from stlc.backends.milp.model import Milp
from stlc.solvers.highs import Highs

JERK_S = 2.0  #: the LP's wall budget on an idle core (stretched by the machine's load)
ROUND = 0.0  #: ρ̂ may fall this much below the MILP's value


def least_jerk(low, res, phases: list | None = None):
    """``res`` (a HiGHS result of ``low.milp``) with its inputs smoothed as above, or
    ``res`` itself when there is nothing to smooth or the LP finds nothing in time."""
    if res.x is None or low.top < 0 or not low.vehicles:
        return res
    src = low.milp
    m = Milp(list(src.lo), list(src.hi), list(src.integer), list(src.rows))
    cost: dict[int, float] = {}
    for lv in low.vehicles:
        U = np.asarray(lv.u)
        for k in range(U.shape[0] - 1):
            for j in range(U.shape[1]):
                a, b = int(U[k, j]), int(U[k + 1, j])
                t = m.var(0.0, np.inf)
                m.row({t: 1.0, b: -1.0, a: 1.0}, 0.0, np.inf)
                m.row({t: 1.0, b: 1.0, a: -1.0}, 0.0, np.inf)
                cost[t] = 1.0
    if not cost:
        return res
    h = Highs(m, cost, time_limit=JERK_S * effort.load_factor())
    h.fix_integers(np.concatenate([res.x, np.zeros(m.n_cols - src.n_cols)]))
    top = float(res.x[low.top])
    h.set_col_bounds(low.top, min(top - ROUND, src.hi[low.top]), src.hi[low.top])
    out = h.solve()
    if phases is not None:
        phases.append(("least-jerk plan (choices and ρ̂ kept)", out.highs_status, out.wall_s))
    if out.x is None or out.highs_status != "Optimal":
        return res
    res.x = out.x[: src.n_cols]
    res.wall_s += out.wall_s
    return res
