"""Risk analysis: sampling, VaR/CVaR with DKW bounds, p(violation), case evaluation.

The pure-math tests do not need the monitor; case evaluation runs against a small stand-in
monitor (below) and, when ``stlc.analysis.monitor`` exists, is cross-checked against it.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from scipy import stats

from stlc.analysis.risk import evaluate_case, evaluate_risk, run_cases, save_samples
from stlc.analysis.risk_measures import (
    RiskError,
    betainc,
    clopper_pearson_upper,
    cvar_bounds,
    dkw_margin,
    p_violation,
    var_bounds,
)
from stlc.analysis.sampling import (
    SamplingError,
    human_frame_point,
    merge_distributions,
    rotation,
    sample_params,
)
from stlc.semantics.ir import Always, And, Bin, Const, Eventually, Or, Param, Pred, Sig
from stlc.semantics.model import Normal, RiskCase, RiskConfig

# --------------------------------------------------------------------------- hand examples

RHO10 = np.array([5.0, -2.0, 3.0, 0.0, 7.0, -1.0, 1.0, 6.0, 2.0, 4.0])  # = −2 … 7 shuffled
# ε = sqrt(ln(2/δ)/(2K)) = 0.25 for K = 10  ⇔  ln(2/δ) = 2·10·0.0625 = 1.25
DELTA10 = 2.0 * math.exp(-1.25)


def test_dkw_margin_is_round():
    assert dkw_margin(10, DELTA10) == pytest.approx(0.25, abs=1e-12)
    assert dkw_margin(15000, 0.01) == pytest.approx(math.sqrt(math.log(200) / 30000))


def test_var_hand_example():
    # sorted r = −2 −1 0 1 2 3 4 5 6 7 (r_(i) = i − 3); value = r_(K − ⌈βK⌉ + 1).
    # β = 0.8: ⌈8⌉ = 8 → r_(3) = 0 (8 of 10 samples are ≥ 0).
    #   lower: β + ε = 1.05 > 1 → no α with F̂_Z − ε ≥ β → −inf.
    #   upper: β − ε = 0.55 → ⌈5.5⌉ = 6 → r_(5) = 2.
    assert var_bounds(RHO10, 0.8, DELTA10) == {"value": 0.0, "lower": -math.inf, "upper": 2.0}
    # β = 0.7: ⌈7⌉ = 7 → r_(4) = 1;  β + ε = 0.95 → ⌈9.5⌉ = 10 → r_(1) = −2;
    #   β − ε = 0.45 → ⌈4.5⌉ = 5 → r_(6) = 3.
    assert var_bounds(RHO10, 0.7, DELTA10) == {"value": 1.0, "lower": -2.0, "upper": 3.0}


def test_var_hand_example_integer_levels():
    # ρ = 0 … 99, K = 100, ε = 0.1 (ln(2/δ) = 2·100·0.01 = 2).  (β ± ε)·K are integers,
    # which must not be pushed to the next index by rounding of ε.
    # β = 0.8: ⌈80⌉ → r_(21) = 20;  β + ε: ⌈90⌉ → r_(11) = 10;  β − ε: ⌈70⌉ → r_(31) = 30.
    r = np.arange(100.0)
    d = 2.0 * math.exp(-2.0)
    assert var_bounds(r, 0.8, d) == {"value": 20.0, "lower": 10.0, "upper": 30.0}
    # the paper's β = 0.7 with K = 15000: ⌈0.7·15000⌉ = 10500 exactly
    big = np.arange(15000.0)
    assert var_bounds(big, 0.7, 0.01)["value"] == 15000 - 10500


def test_cvar_hand_example():
    # value = mean of the worst (1 − β)K realisations.  Support defaults to [−2, 7].
    # β = 0.8, a = 0.2, m = aK = 2, ε·K = 2.5:
    #   value = (−2 − 1)/2 = −1.5
    #   lower = (min(2.5, 2)·L + I(0, max(2 − 2.5, 0)))/2 = (2·(−2) + 0)/2 = −2
    #   upper = I(2.5, 4.5)/2 = (½·r_(3) + r_(4) + ½·r_(5))/2 = (0 + 1 + 1)/2 = 1
    assert cvar_bounds(RHO10, 0.8, DELTA10) == pytest.approx(
        {"value": -1.5, "lower": -2.0, "upper": 1.0})
    # β = 0.7, m = 3:  value = (−2 − 1 + 0)/3 = −1
    #   lower = (2.5·(−2) + ½·r_(1))/3 = (−5 − 1)/3 = −2
    #   upper = I(2.5, 5.5)/3 = (½·0 + 1 + 2 + ½·3)/3 = 1.5
    assert cvar_bounds(RHO10, 0.7, DELTA10) == pytest.approx(
        {"value": -1.0, "lower": -2.0, "upper": 1.5})
    # ρ = 0 … 99, ε = 0.1, β = 0.8: value = mean(0 … 19) = 9.5,
    #   lower = (10·0 + Σ 0 … 9)/20 = 45/20 = 2.25,  upper = Σ 10 … 29 / 20 = 390/20 = 19.5
    assert cvar_bounds(np.arange(100.0), 0.8, 2.0 * math.exp(-2.0)) == pytest.approx(
        {"value": 9.5, "lower": 2.25, "upper": 19.5})


def test_cvar_support():
    assert cvar_bounds(RHO10, 0.8, DELTA10, support=(-math.inf, math.inf))["lower"] == -math.inf
    assert cvar_bounds(RHO10, 0.8, DELTA10, support=(-4.0, 7.0))["lower"] == pytest.approx(-4.0)
    with pytest.raises(RiskError):
        cvar_bounds(RHO10, 0.8, DELTA10, support=(0.0, 7.0))


def test_cvar_matches_rockafellar_uryasev():
    # CVaR_β(Z) = min_α α + E[(Z − α)+]/(1 − β); the minimum is attained at a sample
    rng = np.random.default_rng(3)
    rho = rng.normal(size=37)
    z = -rho
    for beta in (0.5, 0.7, 0.8, 0.9, 0.95):
        ru = min(a + np.mean(np.maximum(z - a, 0.0)) / (1 - beta) for a in z)
        assert cvar_bounds(rho, beta, 0.05)["value"] == pytest.approx(-ru, abs=1e-12)


def test_bad_inputs():
    with pytest.raises(RiskError):
        var_bounds([], 0.8, 0.01)
    with pytest.raises(RiskError):
        var_bounds([1.0, math.nan], 0.8, 0.01)
    with pytest.raises(RiskError):
        var_bounds([1.0], 1.0, 0.01)
    with pytest.raises(RiskError):
        cvar_bounds([1.0], 0.5, 0.0)


# --------------------------------------------------------------------------- large sample


def test_bounds_bracket_the_truth_normal():
    mu, sd, K, delta = 1.0, 0.5, 20_000, 0.01
    rho = np.random.default_rng(11).normal(mu, sd, K)
    for beta in (0.7, 0.8, 0.9):
        v = var_bounds(rho, beta, delta)
        c = cvar_bounds(rho, beta, delta)
        # level kept with probability β: P(ρ ≥ v) = β
        true_var = stats.norm.ppf(1 - beta, mu, sd)
        # mean of the lower (1 − β) tail of N(μ, σ²): μ − σ φ(z_a)/a
        a = 1 - beta
        true_cvar = mu - sd * stats.norm.pdf(stats.norm.ppf(a)) / a
        assert v["lower"] <= v["value"] <= v["upper"]
        assert v["lower"] <= true_var <= v["upper"]
        assert v["upper"] - v["lower"] < 0.1
        assert c["lower"] <= c["value"] <= c["upper"]
        assert c["lower"] <= true_cvar <= c["upper"]
        assert c["value"] <= v["value"]
        # the true CDF lies in the DKW band at the empirical quantile
        eps = dkw_margin(K, delta)
        assert abs(np.mean(rho <= v["value"]) - stats.norm.cdf(v["value"], mu, sd)) <= eps


# --------------------------------------------------------------------------- p(violation)


def test_p_violation_counts_below_kappa():
    """The one verdict rule (ρ ≥ κ satisfies, κ = 0 without a threshold): ρ = 0 holds."""
    pv = p_violation(RHO10, 0.05)
    assert pv["count"] == 2 and pv["value"] == pytest.approx(0.2)  # −2, −1
    assert p_violation(RHO10, 0.05, 0.5)["count"] == 3  # −2, −1, 0
    assert pv["upper"] >= pv["value"]
    assert p_violation(np.ones(5), 0.05)["value"] == 0.0
    assert p_violation(-np.ones(5), 0.05)["upper"] == 1.0


def test_p_violation_upper_tends_to_value():
    gaps = []
    for K in (100, 1000, 10_000, 100_000):
        rho = np.where(np.arange(K) % 10 == 0, -1.0, 1.0)  # exactly 10 % violate
        pv = p_violation(rho, 0.01)
        assert pv["value"] == pytest.approx(0.1)
        assert pv["upper"] >= pv["value"]
        gaps.append(pv["upper"] - pv["value"])
    assert all(a > b for a, b in zip(gaps, gaps[1:]))
    assert gaps[-1] < 0.003


@pytest.mark.parametrize("K", [1, 7, 50, 1000, 15_000])
def test_clopper_pearson_matches_scipy(K):
    for x in sorted({0, 1, K // 3, K // 2, K - 1} - {K}):
        for delta in (0.01, 0.05, 0.2):
            want = stats.beta.ppf(1 - delta, x + 1, K - x)
            assert clopper_pearson_upper(x, K, delta) == pytest.approx(want, abs=1e-6)
    assert clopper_pearson_upper(K, K, 0.01) == 1.0


def test_betainc_matches_scipy():
    for a, b in ((0.5, 0.5), (1.0, 3.0), (20.0, 5.0), (200.0, 14800.0)):
        for x in (1e-4, 0.01, 0.2, 0.5, 0.9):
            assert betainc(a, b, x) == pytest.approx(stats.beta.cdf(x, a, b), abs=1e-9)


# --------------------------------------------------------------------------- sampling

POS = Normal(("h.pos.x", "h.pos.y", "h.pos.z"), (0.0, 0.0, 1.7),
             ((0.25, 0.0, 0.0), (0.0, 0.25, 0.0), (0.0, 0.0, 0.0)))
ATT = Normal(("h.att.x", "h.att.y", "h.att.z"), (0.07, 0.07, 0.09),
             ((0.09, 0, 0), (0, 0.09, 0), (0, 0, 0.52)))
NOMINAL = {"h.pos.x": 0.0, "h.pos.y": 0.0, "h.pos.z": 1.7, "h.att.x": 0.0, "h.att.y": 0.0,
           "h.att.z": 0.0, "other": 3.5}


def test_sampling_reproducible():
    a = sample_params(NOMINAL, [POS, ATT], 500, seed=7)
    b = sample_params(NOMINAL, [POS, ATT], 500, seed=7)
    c = sample_params(NOMINAL, [POS, ATT], 500, seed=8)
    for k in ("h.pos.x", "h.att.z"):
        assert np.array_equal(a[k], b[k])
        assert not np.array_equal(a[k], c[k])
    assert a["other"] == 3.5 and isinstance(a["other"], float)


def test_sampling_zero_variance_and_moments():
    s = sample_params(NOMINAL, [POS, ATT], 20_000, seed=1)
    assert s["h.pos.x"].shape == (20_000,)
    assert np.all(s["h.pos.z"] == 1.7)  # exactly the mean
    x = np.stack([s[k] for k in ("h.pos.x", "h.pos.y", "h.att.x", "h.att.z")])
    assert np.allclose(x.mean(axis=1), [0, 0, 0.07, 0.09], atol=0.03)
    assert np.allclose(np.cov(x), np.diag([0.25, 0.25, 0.09, 0.52]), atol=0.03)


def test_sampling_singular_correlated_and_errors():
    full = Normal(("a", "b"), (1.0, 2.0), ((1.0, 1.0), (1.0, 1.0)))  # rank 1: b − a = 1
    s = sample_params({}, [full], 1000, seed=0)
    assert np.allclose(s["b"] - s["a"], 1.0, atol=1e-12)
    with pytest.raises(SamplingError):
        sample_params({}, [Normal(("a", "b"), (0, 0), ((1, 2), (2, 1)))], 10, 0)  # indefinite
    with pytest.raises(SamplingError):
        sample_params({}, [Normal(("a", "b"), (0, 0), ((0, 1), (1, 1)))], 10, 0)
    with pytest.raises(SamplingError):
        sample_params({}, [Normal(("a",), (0,), ((1,),)), Normal(("a",), (0,), ((1,),))], 10, 0)


def test_merge_distributions_marginalises():
    override = Normal(("h.pos.x", "h.pos.y"), (1.0, 1.0), ((0.5, 0.0), (0.0, 0.5)))
    merged = merge_distributions([POS, ATT], [override])
    assert merged[0] == Normal(("h.pos.z",), (1.7,), ((0.0,),))
    assert merged[1] is ATT and merged[2] is override


# --------------------------------------------------------------------------- geometry


def test_human_frame_point():
    # yaw 90°: the human's +x (front) is world +y; world (1, 0, 0) is on the human's right
    p = human_frame_point([1.0, 0.0, 0.0], [0.0, 0.0, 0.0], [0.0, 0.0, math.pi / 2])
    assert np.allclose(p, [0.0, -1.0, 0.0])
    p = human_frame_point([1.0, 3.0, 2.0], [1.0, 2.0, 0.0], [0.0, 0.0, math.pi / 2])
    assert np.allclose(p, [1.0, 0.0, 2.0])
    r, pi, y = 0.3, -0.2, 1.1
    Rx = np.array([[1, 0, 0], [0, math.cos(r), -math.sin(r)], [0, math.sin(r), math.cos(r)]])
    Ry = np.array([[math.cos(pi), 0, math.sin(pi)], [0, 1, 0], [-math.sin(pi), 0, math.cos(pi)]])
    Rz = np.array([[math.cos(y), -math.sin(y), 0], [math.sin(y), math.cos(y), 0], [0, 0, 1]])
    assert np.allclose(rotation([r, pi, y]), Rz @ Ry @ Rx)
    # broadcasting one point against K poses
    pos = np.random.default_rng(0).normal(size=(5, 3))
    att = np.random.default_rng(1).normal(size=(5, 3))
    loc = human_frame_point(np.array([1.0, 2.0, 3.0]), pos, att)
    assert loc.shape == (5, 3)
    back = np.einsum("kij,kj->ki", rotation(att), loc) + pos
    assert np.allclose(back, [1.0, 2.0, 3.0])


# --------------------------------------------------------------------------- case evaluation


def _expr(e, chans, params):
    match e:
        case Const(v):
            return v
        case Sig(n):
            return np.asarray(chans[n], dtype=float)
        case Param(n):
            v = params[n]
            return np.asarray(v, dtype=float)[..., None] if np.ndim(v) else float(v)
        case Bin("+", a, b):
            return _expr(a, chans, params) + _expr(b, chans, params)
        case Bin("-", a, b):
            return _expr(a, chans, params) - _expr(b, chans, params)
    raise NotImplementedError(e)


def _trace(f, dt, n, chans, params):
    """Robustness at every sample, shape (..., n) — a brute-force stand-in monitor."""
    match f:
        case Pred(e):
            v = _expr(e, chans, params)
            return np.broadcast_to(v, np.broadcast_shapes(np.shape(v), (n,)))
        case And(args) | Or(args):
            kids = np.broadcast_arrays(*[_trace(a, dt, n, chans, params) for a in args])
            return (np.min if isinstance(f, And) else np.max)(np.stack(kids), axis=0)
        case Always(lo, hi, a) | Eventually(lo, hi, a):
            x = _trace(a, dt, n, chans, params)
            red = np.min if isinstance(f, Always) else np.max
            i0, i1 = round(lo / dt), round(hi / dt)
            cols = [red(x[..., k + i0:min(k + i1, n - 1) + 1], axis=-1) for k in range(n)]
            return np.stack(cols, axis=-1)
    raise NotImplementedError(f)


CALLS = {"exact": 0, "smooth": 0}


def _at_zero(f, dt, channels, params):
    n = len(next(iter(channels.values())))
    out = _trace(f, dt, n, channels, params)[..., 0]
    return float(out) if np.ndim(out) == 0 else out


def standin_robustness(f, dt, channels, params):
    CALLS["exact"] += 1
    return _at_zero(f, dt, channels, params)


def standin_smooth(f, dt, channels, params, lam, method="gkl"):
    CALLS["smooth"] += 1
    return _at_zero(f, dt, channels, params) - 1.0 / lam


AHEAD = Always(0.0, 1.0, Pred(Bin("-", Param("h.pos.x"), Sig("uav.pos.x")), "ahead"))
SIDE = Eventually(0.0, 1.0, Pred(Bin("+", Param("h.pos.y"), Const(0.5)), "side"))
REQ = And((AHEAD, SIDE))
SPECS = {"ahead": AHEAD, "side": SIDE}
CHANNELS = {"uav.pos.x": np.linspace(0.0, 1.0, 11)}  # dt = 0.1, horizon 1 s


def _case(name, var):
    return RiskCase(name, (Normal(("h.pos.x", "h.pos.y", "h.pos.z"), (1.5, 0.0, 1.7),
                                  ((var, 0, 0), (0, var, 0), (0, 0, 0))),))


def _eval(case, cfg, **kw):
    return evaluate_case(case, cfg, REQ, SPECS, 0.1, CHANNELS, NOMINAL, 10.0, "gkl",
                         robustness_fn=standin_robustness, smooth_fn=standin_smooth, **kw)


def test_evaluate_case_standin(tmp_path):
    cfg = RiskConfig(cases=(_case("c1", 0.25),), K=4000, delta=0.01, seed=7)
    CALLS.update(exact=0, smooth=0)
    res = _eval(cfg.cases[0], cfg)
    assert CALLS == {"exact": 4, "smooth": 3}  # one call per formula (+ nominal), no K loop
    px, py = res.params["h.pos.x"], res.params["h.pos.y"]
    ahead, side = px - 1.0, py + 0.5  # always over uav.pos.x ∈ [0, 1] → min at x = 1
    assert np.allclose(res.exact["requirement"], np.minimum(ahead, side))
    assert np.allclose(res.smooth["requirement"], np.minimum(ahead, side) - 0.1)
    assert res.nominal_robustness == pytest.approx(-1.0)  # nominal h.pos.x = 0
    js = res.to_json()
    json.dumps(js, allow_nan=False)
    assert js["name"] == "c1" and js["K"] == 4000 and js["seed"] == 7 and js["delta"] == 0.01
    assert list(js["var"]) == ["0.7", "0.8", "0.9"] and list(js["cvar"]) == ["0.7", "0.8", "0.9"]
    want = var_bounds(np.minimum(ahead, side), 0.8, 0.01)
    assert js["var"]["0.8"] == pytest.approx(want)
    assert js["p_violation"]["value"] == pytest.approx(np.mean(np.minimum(ahead, side) <= 0))
    assert js["specs"]["ahead"]["p_violation"] == pytest.approx(np.mean(ahead <= 0))
    assert js["specs"]["side"]["p_violation"] == pytest.approx(np.mean(side <= 0))
    bad = np.minimum(ahead, side) <= 0
    n_ahead = int(np.sum(bad & (ahead <= side)))
    assert js["drivers"]["ahead"]["count"] == n_ahead
    assert js["drivers"]["ahead"]["count"] + js["drivers"]["side"]["count"] == bad.sum()
    assert js["smooth"]["var"]["0.8"]["value"] == pytest.approx(want["value"] - 0.1)

    path = tmp_path / "samples.npz"
    save_samples(path, [res])
    z = np.load(path)
    assert list(z["cases"]) == ["c1"]
    assert np.array_equal(z["c1/exact/requirement"], res.exact["requirement"])
    assert np.array_equal(z["c1/param/h.pos.x"], px)
    again = var_bounds(z["c1/exact/requirement"], 0.9, float(z["c1/meta"][1]))
    assert again["value"] == js["var"]["0.9"]["value"]


def test_evaluate_risk_order_and_covariance_trend(tmp_path):
    cases = tuple(_case(f"p{i}", v) for i, v in enumerate((0.125, 0.25, 0.5, 0.75), 1))
    cfg = RiskConfig(cases=cases, K=3000, delta=0.01, seed=3)
    out = evaluate_risk(cfg, REQ, SPECS, 0.1, CHANNELS, NOMINAL, 10.0, "gkl",
                        robustness_fn=standin_robustness, smooth_fn=standin_smooth,
                        samples_path=tmp_path / "s.npz")
    assert [c["name"] for c in out["cases"]] == ["p1", "p2", "p3", "p4"]
    for b in ("0.7", "0.8", "0.9"):
        vals = [c["var"][b]["value"] for c in out["cases"]]
        assert all(x > y for x, y in zip(vals, vals[1:]))  # larger covariance ⇒ lower VaR
    assert (tmp_path / "s.npz").exists()
    again = run_cases(cfg, REQ, SPECS, 0.1, CHANNELS, NOMINAL, 10.0, "gkl",
                      robustness_fn=standin_robustness, smooth_fn=standin_smooth)
    assert [r.to_json() for r in again] == out["cases"]


def test_base_distributions_are_overridden():
    cfg = RiskConfig(cases=(_case("c", 0.25),), K=100, seed=1)
    res = _eval(cfg.cases[0], cfg, base=[POS, ATT], with_smooth=False)
    assert set(res.params) == {"h.pos.x", "h.pos.y", "h.pos.z", "h.att.x", "h.att.y", "h.att.z"}
    assert np.mean(res.params["h.pos.x"]) > 1.0  # the case's mean 1.5, not the base's 0
    assert res.smooth == {} and "smooth" not in res.to_json()
    wide = _eval(cfg.cases[0], cfg, with_smooth=False, support=(-10.0, 10.0)).to_json()
    assert wide["cvar_support"] == [-10.0, 10.0]
    assert wide["cvar"]["0.9"]["lower"] < res.to_json()["cvar"]["0.9"]["lower"]


def test_against_real_monitor():
    monitor = pytest.importorskip("stlc.analysis.monitor")
    cfg = RiskConfig(cases=(_case("c", 0.25),), K=500, seed=2)
    real = evaluate_case(cfg.cases[0], cfg, REQ, SPECS, 0.1, CHANNELS, NOMINAL,
                         with_smooth=False, robustness_fn=monitor.robustness)
    ref = _eval(cfg.cases[0], cfg, with_smooth=False)
    for k in ref.exact:
        assert np.allclose(real.exact[k], ref.exact[k])
    assert real.to_json() == ref.to_json()


def test_or_standin_sanity():
    # the stand-in itself: or/eventually over a trace
    f = Or((Pred(Bin("-", Sig("uav.pos.x"), Const(2.0))), Eventually(0, 1, Pred(Sig("uav.pos.x")))))
    assert standin_robustness(f, 0.1, CHANNELS, {}) == pytest.approx(1.0)
