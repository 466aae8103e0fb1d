"""Risk measures on robustness samples: VaR and CVaR of the cost Z = −ρ with DKW bounds,
and the violation probability with a one-sided Clopper–Pearson bound (paper A §3.5).

The conventions (sorted samples, DKW band, VaR/CVaR bounds, ±inf ends) are stated in full in
the docstring of ``stlc.analysis.risk``, which evaluates the cases these measures summarise.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np


class RiskError(ValueError):
    """Invalid input to a risk measure (empty sample, NaN, β or δ out of range)."""


# --------------------------------------------------------------------------- risk measures


def dkw_margin(K: int, delta: float) -> float:
    """ε = sqrt(ln(2/δ)/(2K)), the two-sided DKW band half-width at confidence 1 − δ."""
    if not 0.0 < delta < 1.0:
        raise RiskError(f"delta must be in (0, 1), got {delta}")
    return math.sqrt(math.log(2.0 / delta) / (2.0 * K))


def _units(p: float, K: int) -> float:
    """p·K in sample units, rounded so that 0.7·15000 is 10500 and not 10500.000000000002."""
    return round(p * K, 9)


def _sorted(rho) -> np.ndarray:
    r = np.asarray(rho, dtype=float).ravel()
    if r.size == 0:
        raise RiskError("no robustness samples")
    if np.any(np.isnan(r)):
        raise RiskError("robustness samples contain NaN")
    return np.sort(r)


def _check_beta(beta: float) -> None:
    if not 0.0 < beta < 1.0:
        raise RiskError(f"beta must be in (0, 1), got {beta}")


def _var_z(r: np.ndarray, p: float) -> float:
    """−inf{α | F̂_Z(α) ≥ p} in robustness terms (r sorted ascending, Z = −ρ)."""
    K = r.size
    s = _units(p, K)
    if s > K:
        return -math.inf  # no α reaches the level: VaR of Z is +inf
    if s <= 0:
        return math.inf  # every α qualifies: VaR of Z is −inf
    k = max(1, math.ceil(s))
    return float(r[K - k])


def var_bounds(rho, beta: float, delta: float) -> dict[str, float]:
    """Empirical VaR_β of Z = −ρ and its DKW bounds (eq. 11), in robustness terms.

    Returns ``{"value", "lower", "upper"}`` with lower ≤ value ≤ upper (see the module
    docstring for the formulas); ``lower`` may be −inf and ``upper`` +inf.
    """
    _check_beta(beta)
    r = _sorted(rho)
    eps = dkw_margin(r.size, delta)
    return {"value": _var_z(r, beta), "lower": _var_z(r, beta + eps),
            "upper": _var_z(r, beta - eps)}


def _integral(r: np.ndarray, s1: float, s2: float) -> float:
    """K · ∫ F̂⁻¹(v) dv over [s1/K, s2/K] (s in sample units), F̂⁻¹(v) = r_(⌈vK⌉)."""
    K = r.size
    s1, s2 = max(0.0, min(s1, K)), max(0.0, min(s2, K))
    if s2 <= s1:
        return 0.0
    i = np.arange(1, K + 1, dtype=float)
    w = np.clip(np.minimum(i, s2) - np.maximum(i - 1.0, s1), 0.0, 1.0)
    nz = w > 0
    return float(np.dot(w[nz], r[nz]))


def _mass_term(mass: float, at: float) -> float:
    return 0.0 if mass <= 0 else mass * at


def cvar_bounds(rho, beta: float, delta: float,
                support: tuple[float, float] | None = None) -> dict[str, float]:
    """Empirical CVaR_β of Z = −ρ and bounds from the DKW band, in robustness terms.

    ``value`` is the mean robustness of the worst (1 − β) fraction of realisations;
    ``lower``/``upper`` are the CVaR of the pessimistic/optimistic edge of the DKW band
    (module docstring).  ``support = (L, U)`` bounds ρ; default: the sample range.
    """
    _check_beta(beta)
    r = _sorted(rho)
    K = r.size
    eps = dkw_margin(K, delta)
    lo_s, hi_s = (float(r[0]), float(r[-1])) if support is None else map(float, support)
    if lo_s > r[0] or hi_s < r[-1]:
        raise RiskError(f"samples outside the given support [{lo_s}, {hi_s}]")
    a = 1.0 - beta
    m = _units(a, K)
    e = _units(eps, K)
    # the mean of the worst m samples lies between the smallest and the ⌈m⌉-th (so never
    # above the VaR at the same β), which rounding of the weighted sum must not break
    value = min(max(_integral(r, 0.0, m) / m, float(r[0])), float(r[max(math.ceil(m), 1) - 1]))
    lower = (_mass_term(min(e, m), lo_s) + _integral(r, 0.0, m - e)) / m
    upper = (_integral(r, e, m + e) + _mass_term(m + e - K, hi_s)) / m
    # lower ≤ value ≤ upper holds exactly (stochastic dominance); the three weighted sums
    # round differently (e.g. equal samples), so the order is restored explicitly
    return {"value": value, "lower": min(lower, value), "upper": max(upper, value)}


# --------------------------------------------------------------------------- p(violation)


def _betacf(a: float, b: float, x: float) -> float:
    """Continued fraction of the incomplete beta function (modified Lentz)."""
    tiny, eps = 1e-300, 1e-15
    qab, qap, qam = a + b, a + 1.0, a - 1.0
    c, d = 1.0, 1.0 - qab * x / qap
    d = 1.0 / (d if abs(d) > tiny else tiny)
    h = d
    for m in range(1, 100_000):
        m2 = 2 * m
        for aa in (m * (b - m) * x / ((qam + m2) * (a + m2)),
                   -(a + m) * (qab + m) * x / ((a + m2) * (qap + m2))):
            d = 1.0 + aa * d
            d = 1.0 / (d if abs(d) > tiny else tiny)
            c = 1.0 + aa / c
            c = c if abs(c) > tiny else tiny
            h *= d * c
        if abs(d * c - 1.0) < eps:
            break
    return h


def betainc(a: float, b: float, x: float) -> float:
    """Regularised incomplete beta function I_x(a, b) for a, b > 0."""
    if x <= 0.0:
        return 0.0
    if x >= 1.0:
        return 1.0
    log_front = (math.lgamma(a + b) - math.lgamma(a) - math.lgamma(b)
                 + a * math.log(x) + b * math.log1p(-x))
    if x < (a + 1.0) / (a + b + 2.0):
        return math.exp(log_front) * _betacf(a, b, x) / a
    return 1.0 - math.exp(log_front) * _betacf(b, a, 1.0 - x) / b


def beta_ppf(q: float, a: float, b: float) -> float:
    """Quantile of the Beta(a, b) distribution by bisection on ``betainc``."""
    lo, hi = 0.0, 1.0
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        if betainc(a, b, mid) < q:
            lo = mid
        else:
            hi = mid
        if hi - lo < 1e-15:
            break
    return 0.5 * (lo + hi)


def clopper_pearson_upper(count: int, K: int, delta: float) -> float:
    """One-sided Clopper–Pearson upper bound at confidence 1 − δ on a binomial proportion:
    the (1 − δ)-quantile of Beta(count + 1, K − count); 1 when count = K."""
    if not 0.0 < delta < 1.0:
        raise RiskError(f"delta must be in (0, 1), got {delta}")
    if count >= K:
        return 1.0
    return beta_ppf(1.0 - delta, count + 1.0, float(K - count))


def p_violation(rho, delta: float, kappa: float = 0.0) -> dict[str, float]:
    """Fraction of realisations that violate (ρ < κ, ``stlc.analysis.verdict``) and its
    Clopper–Pearson upper bound."""
    from stlc.analysis.verdict import violated

    r = _sorted(rho)
    count = int(np.count_nonzero(violated(r, kappa)))
    return {"value": count / r.size, "upper": clopper_pearson_upper(count, r.size, delta),
            "count": count}


def summarize(rho, betas: Sequence[float], delta: float,
              support: tuple[float, float] | None = None, kappa: float = 0.0) -> dict:
    """VaR/CVaR for every β (keys ``f"{β:g}"``), p_violation and sample statistics."""
    r = _sorted(rho)
    return {
        "var": {f"{b:g}": var_bounds(r, b, delta) for b in betas},
        "cvar": {f"{b:g}": cvar_bounds(r, b, delta, support) for b in betas},
        "p_violation": p_violation(r, delta, kappa),
        "mean": float(np.mean(r)), "min": float(r[0]), "max": float(r[-1]),
    }
