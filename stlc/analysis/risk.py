"""Risk analysis of a fixed plan under uncertain scenario parameters (paper A §3.5, §4.3).

The plan (channels) is fixed; the human pose is drawn K times (``stlc.analysis.sampling``) and the
robustness ρ of the requirement and of every named spec is evaluated for all K realisations
at once through the monitor's parameter broadcasting, in one shared, demand-driven
evaluation (``shared_robustness``: ``stlc.analysis.monitor_demand.Demand`` and
``stlc.analysis.smooth_demand.SmoothDemand`` over chunks of realisations).  The risk measures are
defined on the *cost* Z = −ρ, as in the paper, and reported back in robustness terms.

Conventions (r_(1) ≤ … ≤ r_(K) are the sorted robustness samples, F̂ the empirical CDF of ρ)
----------------------------------------------------------------------------------------
* satisfied ⇔ ρ ≥ κ (``stlc.analysis.verdict``; κ the mission's threshold, 0 without
  one); a realisation with ρ < κ counts as a violation.
* DKW margin ε = sqrt(ln(2/δ) / (2K)): with probability ≥ 1 − δ the true CDF lies in the
  band F̂ − ε ≤ F ≤ F̂ + ε everywhere (Dvoretzky–Kiefer–Wolfowitz–Massart).
* VaR: VaR_β(Z) = inf{α | F_Z(α) ≥ β}.  Reported ``value`` = −VaR_β(Z) with the empirical
  CDF = r_(K−⌈βK⌉+1): the robustness level the plan keeps with probability β
  (P̂(ρ ≥ value) ≥ β).  Bounds, eq. (11): the upper VaR of Z (F̂_Z − ε ≥ β) gives the
  robustness ``lower`` = r_(K−⌈(β+ε)K⌉+1), −inf when β + ε > 1; the lower VaR of Z
  (F̂_Z + ε ≥ β) gives ``upper`` = r_(K−⌈(β−ε)K⌉+1), +inf when β − ε ≤ 0.
* CVaR: CVaR_β(Z) = inf_α (α + E[(Z − α)⁺]/(1 − β)) = (1/(1−β)) ∫_β^1 F_Z⁻¹(u) du, so
  −CVaR_β(Z) = (1/a) ∫_0^a F_ρ⁻¹(v) dv with a = 1 − β: the mean robustness of the worst
  (1 − β) fraction of realisations.  Empirically, with m = aK,
  ``value`` = (Σ_{i ≤ ⌊m⌋} r_(i) + (m − ⌊m⌋) r_(⌊m⌋+1)) / m.
  Bounds: CVaR is monotone in first-order stochastic dominance, so it is bracketed by the
  CVaR of the two extreme distributions of the DKW band.  With I(s, t) = ∫_s^t F̂⁻¹(v) dv
  and a support [L, U] for ρ:
    ``lower`` = (min(ε, a)·L + I(0, max(a − ε, 0))) / a   — CDF min(F̂ + ε, 1): mass ε at L,
    ``upper`` = (I(ε, min(a + ε, 1)) + max(a + ε − 1, 0)·U) / a — CDF (F̂ − ε)⁺: mass ε at U.
  Without a known support the DKW band lets the mass ε sit at ρ = −∞ and the lower bound
  is −inf; by default [L, U] is the observed sample range [r_(1), r_(K)] (an empirical
  assumption, recorded as ``cvar_support = "sample"``); pass ``support`` for a rigorous one.
* Unbounded ends are ±inf in the Python results and ``null`` in JSON.
* Rounding never breaks the order of the results: CVaR ``lower ≤ value ≤ upper`` and the
  CVaR value lies between r_(1) and r_(⌈(1−β)K⌉) (so it never exceeds the VaR value).
* ``to_json`` adds ``histogram`` (``robustness_histogram``: 40 bins over the finite exact
  ρ of the requirement, ±inf counted apart) and ``driver`` (the spec that is tightest in
  most violating realisations, ``violation_drivers``/``main_driver``).
* p_violation: fraction of ρ < κ, with a one-sided Clopper–Pearson upper bound at
  confidence 1 − δ, computed without scipy (regularised incomplete beta by continued
  fraction, inverted by bisection).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np

from stlc.analysis.risk_measures import (
    RiskError,
    clopper_pearson_upper,
    cvar_bounds,
    dkw_margin,
    p_violation,
    summarize,
    var_bounds,
)
from stlc.analysis.sampling import (
    SamplingError,
    human_frame_point,
    merge_distributions,
    sample_params,
    scenario_distributions,
)
from stlc.semantics.ir import Formula
from stlc.semantics.model import Normal, RiskCase, RiskConfig

__all__ = [
    "CaseResult", "RiskError", "SamplingError", "clopper_pearson_upper", "cvar_bounds",
    "dkw_margin", "evaluate_case", "evaluate_risk", "human_frame_point", "run_cases",
    "histogram_range", "p_violation", "robustness_histogram", "sample_params", "save_samples",
    "scenario_distributions", "shared_robustness", "var_bounds",
]


# --------------------------------------------------------------------------- case evaluation

RobustnessFn = Callable[..., "float | np.ndarray"]


@dataclass
class CaseResult:
    """Everything computed for one risk case; ``to_json`` is the report contract."""

    name: str
    K: int
    delta: float
    seed: int
    betas: tuple[float, ...]
    epsilon: float
    params: dict[str, np.ndarray]  # sampled parameters, shape (K,) each
    exact: dict[str, np.ndarray]  # "requirement" and every named spec → (K,)
    smooth: dict[str, np.ndarray]  # same keys, smooth robustness (empty if not computed)
    specs: tuple[str, ...]
    nominal_robustness: float
    support: tuple[float, float] | None = None  # CVaR support of ρ; None = sample range
    exact_summary: dict = field(default_factory=dict)
    smooth_summary: dict = field(default_factory=dict)
    spec_summary: dict = field(default_factory=dict)
    drivers: dict = field(default_factory=dict)

    def to_json(self) -> dict:
        ex = self.exact_summary
        out = {
            "name": self.name, "K": self.K, "delta": self.delta, "seed": self.seed,
            "epsilon": self.epsilon, "robustness": "exact",
            "cvar_support": "sample" if self.support is None else _json(list(self.support)),
            "params": sorted(self.params),
            "nominal_robustness": _num(self.nominal_robustness),
            "var": _json(ex["var"]), "cvar": _json(ex["cvar"]),
            "p_violation": _json(ex["p_violation"]),
            "mean": _num(ex["mean"]), "min": _num(ex["min"]), "max": _num(ex["max"]),
            "specs": _json(self.spec_summary), "drivers": _json(self.drivers),
            "driver": main_driver(self.drivers),
            "histogram": robustness_histogram(self.exact["requirement"]),
        }
        if self.smooth_summary:
            out["smooth"] = _json(self.smooth_summary)
        return out


#: bins of the exact-robustness histogram in ``risk.json``
HIST_BINS = 40


def histogram_range(lo: float, hi: float, bins: int) -> tuple[float, float]:
    """``(lo, hi)`` widened so that each of ``bins`` bins is wider than the floating-point
    spacing at the values: a degenerate range by ±0.5e-3, and equal huge values (a drone
    1e15 m away, where ±0.5e-3 vanishes and numpy refuses "too many bins") by enough."""
    least = max(1e-12, 4 * bins * float(np.spacing(max(abs(lo), abs(hi)))))
    if hi - lo < least:
        mid, half = (lo + hi) / 2, max(0.5e-3, least)
        lo, hi = mid - half, mid + half
    return lo, hi


def robustness_histogram(rho, bins: int = HIST_BINS) -> dict:
    """``{"edges": [bins + 1], "counts": [bins], "neg_inf": n, "pos_inf": n}``: a histogram
    of the finite values of ``rho`` over their range (a degenerate range is widened by
    ±0.5e-3); infinite values are counted apart, and no finite value gives empty lists."""
    r = np.asarray(rho, dtype=float).ravel()
    fin = r[np.isfinite(r)]
    out = {"edges": [], "counts": [], "neg_inf": int(np.count_nonzero(np.isneginf(r))),
           "pos_inf": int(np.count_nonzero(np.isposinf(r)))}
    if fin.size:
        lo, hi = histogram_range(float(fin.min()), float(fin.max()), bins)
        counts, edges = np.histogram(fin, bins=bins, range=(lo, hi))
        out["edges"] = [float(e) for e in edges]
        out["counts"] = [int(c) for c in counts]
    return out


def main_driver(drivers: Mapping[str, Mapping]) -> str | None:
    """The named spec that is the tightest in most violating realisations (first declared on
    ties), or ``None`` when nothing is violated."""
    best = max(drivers.items(), key=lambda kv: kv[1]["count"], default=None)
    return best[0] if best is not None and best[1]["count"] > 0 else None


def _num(x: float) -> float | None:
    return float(x) if math.isfinite(x) else None


def _json(d):
    if isinstance(d, dict):
        return {k: _json(v) for k, v in d.items()}
    if isinstance(d, list | tuple):
        return [_json(v) for v in d]
    if isinstance(d, bool | int | str) or d is None:
        return d
    return _num(float(d))


def _default_monitor() -> RobustnessFn:
    from stlc.analysis import monitor
    return monitor.robustness


def _default_smooth() -> RobustnessFn:
    from stlc.analysis import smooth
    return smooth.smooth_robustness


def _per_realisation(value, K: int) -> np.ndarray:
    """A monitor result as shape (K,): a formula without sampled params gives a scalar."""
    v = np.asarray(value, dtype=float)
    if v.ndim == 0:
        return np.full(K, float(v))
    if v.shape != (K,):
        raise RiskError(f"monitor returned shape {v.shape}, expected ({K},)")
    return v


#: realisations evaluated together by ``shared_robustness``: (chunk, samples) temporaries of
#: ~1 MB stay in cache, and the memory use does not grow with K
CHUNK = 512
CHUNK_BYTES = 64 << 20


def _plan_chunk(plan, chunk: int = CHUNK) -> int:
    """Realisations per chunk for a ``monitor_demand.Plan``: the (chunk, samples) values of
    every timed node of one chunk stay within CHUNK_BYTES whatever the trace's length
    (512 realisations × 100,000 rows were 400 MB per node, 5.3 GB in all)."""
    span = sum((e - s + 1) for need, timed in zip(plan.need, plan.timed)
               if timed and need is not None for s, e in (need,))
    return max(1, min(chunk, CHUNK_BYTES // (8 * max(span, 1))))


def realisation_chunk(formulas: Mapping[str, Formula], dt: float, n: int,
                      chunk: int = CHUNK) -> int:
    """The number of realisations ``shared_robustness`` evaluates together for
    ``formulas`` on ``n`` samples (≤ ``chunk``, smaller on long traces to bound the memory);
    ``risk_parallel`` cuts its batches at multiples of it."""
    from stlc.analysis.monitor_demand import Plan
    from stlc.semantics import nnf

    return _plan_chunk(Plan([nnf.normalize(f) for f in formulas.values()], dt, n), chunk)


def shared_robustness(formulas: Mapping[str, Formula], dt: float,
                      channels: Mapping[str, np.ndarray], params: Mapping[str, object],
                      K: int, lam: float = 10.0, method: str = "gkl", *,
                      with_smooth: bool = True, chunk: int = CHUNK,
                      ) -> tuple[dict[str, np.ndarray], dict[str, np.ndarray]]:
    """Exact (and smooth) robustness at t = 0 of every formula for the K realisations of
    ``params`` in one shared evaluation: a node common to several formulas (a named spec
    inside the requirement, a predicate, the human-frame coordinates) is computed once,
    only on the samples its parents need (``monitor_demand.Plan``), and the smooth pass
    reuses the exact pass's predicate values.  Realisations are processed ``chunk`` at a time.
    Returns ``(exact, smooth)``, each ``{key: (K,) array}`` (smooth empty without it)."""
    from stlc.analysis.monitor_demand import Demand, Plan
    from stlc.analysis.smooth_demand import SmoothDemand
    from stlc.semantics import nnf

    keys = list(formulas)
    n = len(next(iter(channels.values())))
    plan = Plan([nnf.normalize(formulas[k]) for k in keys], dt, n)
    chunk = _plan_chunk(plan, chunk)
    exact = {k: np.empty(K) for k in keys}
    smooth = {k: np.empty(K) for k in keys} if with_smooth else {}
    for lo in range(0, K, chunk):
        hi = min(K, lo + chunk)
        part = {k: (v[lo:hi] if isinstance(v, np.ndarray) else v) for k, v in params.items()}
        ex = Demand(plan, channels, part)
        for k, v in zip(keys, ex.values(), strict=True):
            exact[k][lo:hi] = v
        if with_smooth:
            sm = SmoothDemand(plan, channels, part, lam, method, share=ex)
            for k, v in zip(keys, sm.values(), strict=True):
                smooth[k][lo:hi] = v
    return exact, smooth


def violation_drivers(requirement: np.ndarray, specs: Mapping[str, np.ndarray],
                      kappa: float = 0.0) -> dict:
    """For each realisation violating the requirement (ρ < κ), the named spec with the
    lowest robustness (ties: the first declared); counts and fractions per spec."""
    from stlc.analysis.verdict import violated

    bad = violated(requirement, kappa)
    n_bad = int(np.count_nonzero(bad))
    names = list(specs)
    counts = np.zeros(len(names), dtype=int)
    if names and n_bad:
        stack = np.stack([specs[n][bad] for n in names])
        counts = np.bincount(np.argmin(stack, axis=0), minlength=len(names))
    return {n: {"count": int(c), "fraction": (int(c) / n_bad if n_bad else 0.0)}
            for n, c in zip(names, counts, strict=True)}


def evaluate_case(case: RiskCase, cfg: RiskConfig, requirement: Formula,
                  specs: Mapping[str, Formula], dt: float,
                  channels: Mapping[str, np.ndarray], nominal_params: Mapping[str, float],
                  lam: float = 10.0, method: str = "gkl", *,
                  base: Sequence[Normal] = (), with_smooth: bool = True,
                  support: tuple[float, float] | None = None,
                  robustness_fn: RobustnessFn | None = None,
                  smooth_fn: RobustnessFn | None = None,
                  shared: Callable | None = None, kappa: float = 0.0) -> CaseResult:
    """Sample the case's distributions (overriding ``base`` ones parameter by parameter),
    evaluate exact (and smooth) robustness of the requirement and every named spec for
    all K realisations and summarise.

    By default the formulas are evaluated together by ``shared_robustness`` (each shared
    node once, only where it is needed, exact predicates reused by the smooth pass).  With
    ``robustness_fn``/``smooth_fn`` (signature of ``stlc.analysis.monitor.robustness`` /
    ``stlc.analysis.smooth.smooth_robustness``) each formula is one vectorised call instead; a
    missing one of the two defaults to the ``stlc`` function.  All realisations use
    ``cfg.seed`` (common random numbers across cases, so cases differ only by their
    distributions).  ``support`` bounds the exact ρ for its CVaR bounds (default, and
    always for the smooth ρ̃: the sample range, see ``cvar_bounds``).  ``shared`` replaces
    ``shared_robustness`` (same signature), e.g. ``risk_parallel``'s batches on Dask.
    """
    K = cfg.K
    dists = merge_distributions(base, case.distributions)
    params = sample_params(nominal_params, dists, K, cfg.seed)
    sampled = {k: v for k, v in params.items() if isinstance(v, np.ndarray)}
    chans = dict(channels)
    formulas = {"requirement": requirement, **{f"spec:{n}": f for n, f in specs.items()}}
    if robustness_fn is None and smooth_fn is None:
        exact, smooth = (shared or shared_robustness)(formulas, dt, chans, params, K, lam,
                                                      method, with_smooth=with_smooth)
    else:
        rob = robustness_fn or _default_monitor()
        exact = {k: _per_realisation(rob(f, dt, chans, params), K) for k, f in formulas.items()}
        smooth = {}
        if with_smooth:
            smo = smooth_fn or _default_smooth()
            smooth = {k: _per_realisation(smo(f, dt, chans, params, lam, method=method), K)
                      for k, f in formulas.items()}
    rob = robustness_fn or _default_monitor()
    nominal = float(rob(requirement, dt, chans, {k: float(v) for k, v in
                                                  nominal_params.items()}))
    spec_rho = {n: exact[f"spec:{n}"] for n in specs}
    drivers = violation_drivers(exact["requirement"], spec_rho, kappa)
    spec_summary = {}
    for n, r in spec_rho.items():
        pv = p_violation(r, cfg.delta, kappa)
        spec_summary[n] = {"p_violation": pv["value"], "p_violation_upper": pv["upper"],
                           "min": float(np.min(r)), "driver_count": drivers[n]["count"],
                           "driver_fraction": drivers[n]["fraction"]}
    return CaseResult(
        name=case.name, K=K, delta=cfg.delta, seed=cfg.seed, betas=tuple(cfg.betas),
        epsilon=dkw_margin(K, cfg.delta), params=sampled, exact=exact, smooth=smooth,
        specs=tuple(specs), nominal_robustness=nominal, support=support,
        exact_summary=summarize(exact["requirement"], cfg.betas, cfg.delta, support, kappa),
        smooth_summary=(summarize(smooth["requirement"], cfg.betas, cfg.delta, None, kappa)
                        if with_smooth else {}),
        spec_summary=spec_summary, drivers=drivers,
    )


def run_cases(cfg: RiskConfig, *args, **kwargs) -> list[CaseResult]:
    """``evaluate_case`` for every case of ``cfg`` in declared order (same arguments
    after ``case, cfg``)."""
    return [evaluate_case(case, cfg, *args, **kwargs) for case in cfg.cases]


def evaluate_risk(cfg: RiskConfig, *args, samples_path: str | None = None,
                  **kwargs) -> dict:
    """``{"cases": [CaseResult.to_json(), …]}`` in declared order; with ``samples_path``
    the per-realisation arrays are also written there (``save_samples``)."""
    results = run_cases(cfg, *args, **kwargs)
    if samples_path is not None:
        save_samples(samples_path, results)
    return {"cases": [r.to_json() for r in results]}


def save_samples(path_npz, results: Sequence[CaseResult]) -> None:
    """Write every per-realisation array with ``np.savez_compressed``.

    Keys: ``cases`` (names), and per case ``<case>/exact/requirement``,
    ``<case>/exact/spec:<name>``, ``<case>/smooth/…`` (same), ``<case>/param/<param>``,
    ``<case>/meta`` = [K, delta, seed, epsilon] and ``<case>/betas``.
    """
    np.savez_compressed(path_npz, **sample_arrays(results))


def sample_arrays(results: Sequence[CaseResult]) -> dict[str, np.ndarray]:
    """The per-realisation arrays of ``save_samples``, in memory (keys as there)."""
    arrays: dict[str, np.ndarray] = {"cases": np.array([r.name for r in results])}
    for r in results:
        for kind, d in (("exact", r.exact), ("smooth", r.smooth), ("param", r.params)):
            for k, v in d.items():
                arrays[f"{r.name}/{kind}/{k}"] = np.asarray(v)
        arrays[f"{r.name}/meta"] = np.array([r.K, r.delta, r.seed, r.epsilon], dtype=float)
        arrays[f"{r.name}/betas"] = np.array(r.betas, dtype=float)
    return arrays
