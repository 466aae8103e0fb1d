"""Risk levels (``require var(β) >= x``, ``require cvar(β) >= x``, ``require p_violation
<= p`` in a mission's ``risk`` block, ``model.RiskLevel``) judged on robustness samples:
by ``stlc compile``'s risk pass (each case's exact robustness of the requirement) and by
``stlc fly --runs`` (the flown robustness).

VaR and CVaR are judged by their empirical value at the level's β (robustness terms, see
``stlc.analysis.risk``); P(violation) by its one-sided Clopper–Pearson upper bound at
1 − δ, so a P(violation) level that holds holds with confidence 1 − δ.
"""

from __future__ import annotations

import numpy as np

from stlc.analysis import risk_measures as rm

_OPS = {">=": np.greater_equal, ">": np.greater, "<=": np.less_equal, "<": np.less}


def judge_levels(levels, rho: np.ndarray, delta: float) -> list[dict]:
    """Each level with the measure's ``value`` on ``rho`` and whether it ``holds``."""
    out = []
    for lv in levels:
        if lv.measure == "p_violation":
            value = rm.p_violation(rho, delta)["upper"]
        elif lv.measure == "var":
            value = rm.var_bounds(rho, lv.beta, delta)["value"]
        else:
            value = rm.cvar_bounds(rho, lv.beta, delta)["value"]
        out.append({"level": lv.text, "line": lv.span.line, "measure": lv.measure,
                    "beta": lv.beta, "op": lv.op, "bound": lv.bound, "value": float(value),
                    "holds": bool(_OPS[lv.op](value, lv.bound))})
    return out
