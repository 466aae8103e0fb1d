"""The risk pass end to end: human-frame regions under sampled poses, the shared
demand-driven evaluation against the reference monitors, ``run_risk``'s ``risk.json`` and
``stlc risk`` on trajectory files."""

from __future__ import annotations

import json
import math
from dataclasses import replace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from strategies import cases, formulas

from stlc import cli
from stlc.analysis import monitor, smooth
from stlc.analysis.assess import risk_table, run_risk
from stlc.analysis.monitor_demand import Demand, Plan, robustness_many
from stlc.analysis.risk import robustness_histogram, shared_robustness
from stlc.analysis.smooth_demand import SmoothDemand, smooth_robustness_many
from stlc.output.solution import trajectory_csv
from stlc.planning.solution import Solution
from stlc.pipeline import load
from stlc.semantics import ir, nnf
from stlc.semantics.ir import Always, And, Bin, Const, Eventually, Param, Pred, Sig, Until

# A point-mass vehicle that sits at one point for 1 s, next to an operator whose region
# `zone` is a box 1…2 m ahead of them, ±0.5 m to the side (their frame: x ahead, y left).
SIT_STL = """\
vehicle uav1 : point_mass {
  vel_max = (2, 2, 1) m/s
  acc_max = (3, 3, 2) m/s^2
  start { pos = (1.5, 0, 1) m }
}
scenario {
  workspace = box((-5, -5, 0), (5, 5, 3)) m
  human operator {
    pos = (0, 0, 0) m
    att = (0, 0, 0) deg
    region zone = box((1, -0.5, 0), (2, 0.5, 2)) m
  }
}
mission sit {
  vehicles = [uav1]
  horizon = 1 s
  step = 0.1 s
  spec inzone = always[0, 1] (uav1.pos in operator.zone)
  spec low = always[0, 1] (uav1.pos.z <= 2.5 m)
  require inzone and low
  minimize -robustness
  risk {
    K = 400; delta = 0.05; beta = [0.7, 0.8, 0.9]; seed = 3
    case front   { operator.pos ~ normal((0, 0, 0) m, diag(0, 0, 0) m^2) }
    case ahead   { operator.pos ~ normal((0.25, 0, 0) m, diag(0, 0, 0) m^2) }
    case turned  { operator.att ~ normal((0, 0, 90) deg, diag(0, 0, 0) deg^2) }
    case yawing  { operator.att ~ normal((0, 0, 0) deg, diag(0, 0, 400) deg^2) }
    case walking { operator.pos ~ normal((0, 0, 0) m, diag(0.04, 0.04, 0) m^2) }
  }
}
"""

N = 11  # samples of the 1 s plan at 0.1 s


def _sol(point=(1.5, 0.0, 1.0), mission="sit") -> Solution:
    """A ``Solution``-like plan that sits at ``point`` (as ``risk_file`` builds from a
    trace: only times and channels matter)."""
    ch = {f"uav1.pos.{a}": np.full(N, float(v)) for a, v in zip("xyz", point, strict=True)}
    ch.update({f"uav1.vel.{a}": np.zeros(N) for a in "xyz"})
    return Solution(mission, "satisfied", 0.0, 0.0, {}, 0.0, np.arange(N) * 0.1, ch)


@pytest.fixture(scope="module")
def sit(tmp_path_factory):
    path = tmp_path_factory.mktemp("sit") / "sit.stl"
    path.write_text(SIT_STL)
    program = load(str(path)).program
    return path, program, program.missions["sit"]


def _box_rho(local: np.ndarray) -> np.ndarray:
    """Robustness of `local in box((1, -0.5, 0), (2, 0.5, 2))` by hand."""
    x, y, z = local[..., 0], local[..., 1], local[..., 2]
    return np.min([x - 1, 2 - x, y + 0.5, 0.5 - y, z, 2 - z], axis=0)


# --------------------------------------------------------------------------- geometry


def test_region_moves_and_turns_with_the_pose(sit):
    _, program, m = sit
    out, results = run_risk(program, m, _sol())
    by = {r.name: r for r in results}
    # nominal pose: the vehicle at (1.5, 0, 1) is 0.5 m inside every face that binds
    assert np.allclose(by["front"].exact["spec:inzone"], 0.5)
    # the operator 0.25 m further ahead: the box moves with them, local x = 1.25
    assert np.allclose(by["ahead"].exact["spec:inzone"], 0.25)
    # yawed by 90°: their front is world +y, the zone is x ∈ [-0.5, 0.5], y ∈ [1, 2]; the
    # vehicle is at local (0, -1.5, 1): 1 m behind the near face and 1 m right of the side
    assert np.allclose(by["turned"].exact["spec:inzone"], -1.0)
    assert np.allclose(by["turned"].exact["requirement"], -1.0)
    assert out["cases"][2]["p_violation"]["value"] == 1.0
    # a vehicle where the turned zone now is is inside it
    _, again = run_risk(program, m, _sol((0.0, 1.5, 1.0)))
    assert np.allclose(again[2].exact["spec:inzone"], 0.5)
    assert np.allclose(again[0].exact["spec:inzone"], -1.0)


def test_sampled_pose_matches_hand_geometry(sit):
    _, program, m = sit
    _, results = run_risk(program, m, _sol((1.4, 0.1, 1.0)))
    p = np.array([1.4, 0.1, 1.0])
    walk, yaw = results[4], results[3]
    pos = np.stack([walk.params[f"operator.pos.{a}"] for a in "xyz"], axis=-1)
    assert np.all(pos[:, 2] == 0.0) and pos[:, 0].std() > 0.1
    assert np.allclose(walk.exact["spec:inzone"], _box_rho(p - pos))
    psi = yaw.params["operator.att.z"]
    c, s = np.cos(psi), np.sin(psi)
    local = np.stack([c * p[0] + s * p[1], -s * p[0] + c * p[1], np.full_like(psi, p[2])], -1)
    assert np.allclose(yaw.exact["spec:inzone"], _box_rho(local))
    assert np.allclose(yaw.exact["requirement"], np.minimum(_box_rho(local), 1.5))
    # the smooth robustness under-approximates the exact one (GKL is sound)
    for r in results:
        assert np.all(r.smooth["requirement"] <= r.exact["requirement"] + 1e-9)


# --------------------------------------------------------------------------- risk.json


def test_same_seed_same_numbers(sit):
    _, program, m = sit
    a, ra = run_risk(program, m, _sol((1.4, 0.1, 1.0)))
    b, rb = run_risk(program, m, _sol((1.4, 0.1, 1.0)))
    assert a == b
    assert all(np.array_equal(x.exact["requirement"], y.exact["requirement"])
               for x, y in zip(ra, rb, strict=True))
    other = replace(m, risk=replace(m.risk, seed=4))
    c, rc = run_risk(program, other, _sol((1.4, 0.1, 1.0)))
    assert c["cases"][4]["seed"] == 4
    assert not np.array_equal(rc[4].exact["requirement"], ra[4].exact["requirement"])
    assert c["cases"][4]["var"] != a["cases"][4]["var"]


def test_risk_json_structure(sit, tmp_path):
    _, program, m = sit
    out, results = run_risk(program, m, _sol((1.4, 0.1, 1.0)))
    text = json.dumps(out, allow_nan=False)  # no NaN/inf anywhere: unbounded ends are null
    back = json.loads(text)
    assert back["mission"] == "sit"
    assert [c["name"] for c in back["cases"]] == ["front", "ahead", "turned", "yawing",
                                                  "walking"]
    for c in back["cases"]:
        assert (c["K"], c["delta"], c["seed"]) == (400, 0.05, 3)
        assert list(c["var"]) == list(c["cvar"]) == ["0.7", "0.8", "0.9"]
        for b in ("0.7", "0.8", "0.9"):
            assert set(c["var"][b]) == set(c["cvar"][b]) == {"value", "lower", "upper"}
        assert {"value", "upper"} <= set(c["p_violation"])
        assert set(c["specs"]) == {"inzone", "low"}
        assert all("p_violation" in s for s in c["specs"].values())
        assert set(c["drivers"]) == {"inzone", "low"}
        h = c["histogram"]
        assert len(h["edges"]) == 41 and len(h["counts"]) == 40
        assert sum(h["counts"]) + h["neg_inf"] + h["pos_inf"] == c["K"]
        assert h["edges"] == sorted(h["edges"])
    walking = back["cases"][4]
    assert walking["driver"] == "inzone"  # `low` never binds
    assert walking["drivers"]["low"]["count"] == 0
    assert walking["drivers"]["inzone"]["count"] == round(walking["p_violation"]["value"]
                                                          * 400)
    assert back["cases"][0]["driver"] is None  # nothing violated
    assert set(walking["smooth"]) >= {"var", "cvar", "p_violation"}
    # histogram of the exact requirement robustness
    counts, _ = np.histogram(results[4].exact["requirement"], bins=np.array(
        walking["histogram"]["edges"]))
    assert counts.tolist() == walking["histogram"]["counts"]


def test_histogram_edge_cases():
    h = robustness_histogram(np.array([0.3] * 5 + [-math.inf, math.inf, math.inf]))
    assert h["neg_inf"] == 1 and h["pos_inf"] == 2 and sum(h["counts"]) == 5
    assert h["edges"][0] < 0.3 < h["edges"][-1]
    assert robustness_histogram(np.array([math.inf]))["edges"] == []


@pytest.mark.parametrize("beta", ["0.7", "0.8", "0.9"])
def test_var_falls_as_covariance_grows(sit, beta):
    # common random numbers: realisation k is offset by σ·z_k, and at the box centre the
    # robustness 0.5 − max|σ z| falls with σ in every realisation, so every quantile falls
    _, program, m = sit
    cases = tuple(
        replace(m.risk.cases[4], name=f"s{v}", distributions=(replace(
            m.risk.cases[4].distributions[0], cov=((v, 0, 0), (0, v, 0), (0, 0, 0))),))
        for v in (0.01, 0.05, 0.125, 0.25, 0.5, 0.75))
    mm = replace(m, risk=replace(m.risk, cases=cases, K=3000))
    out, _ = run_risk(program, mm, _sol())
    var = [c["var"][beta]["value"] for c in out["cases"]]
    cvar = [c["cvar"][beta]["value"] for c in out["cases"]]
    pv = [c["p_violation"]["value"] for c in out["cases"]]
    assert all(a >= b for a, b in zip(var, var[1:], strict=False))
    assert all(a >= b for a, b in zip(cvar, cvar[1:], strict=False))
    assert all(a <= b for a, b in zip(pv, pv[1:], strict=False))
    assert var[0] > var[-1]


def test_bounds_bracket_the_estimate(sit):
    _, program, m = sit
    out, _ = run_risk(program, m, _sol((1.4, 0.1, 1.0)))
    for c in out["cases"]:
        for kind in ("var", "cvar"):
            for b, v in c[kind].items():
                lo = -math.inf if v["lower"] is None else v["lower"]
                hi = math.inf if v["upper"] is None else v["upper"]
                assert lo <= v["value"] <= hi, (c["name"], kind, b, v)
        assert c["p_violation"]["value"] <= c["p_violation"]["upper"] <= 1.0
        assert c["cvar"]["0.9"]["value"] <= c["var"]["0.9"]["value"]


def test_shared_evaluation_matches_the_monitors(sit):
    _, program, m = sit
    _, results = run_risk(program, m, _sol((1.4, 0.1, 1.0)))
    r = results[3]  # yawing: sin/cos of sampled parameters
    params = {**program.params, **r.params}
    sol = _sol((1.4, 0.1, 1.0))
    for key, f in (("requirement", m.requirement), ("spec:inzone", m.specs["inzone"])):
        want = monitor.robustness(f, 0.1, sol.channels, params)
        np.testing.assert_allclose(r.exact[key], want, rtol=1e-12, atol=1e-12)
        want = smooth.smooth_robustness(f, 0.1, sol.channels, params, m.smoothing.lam,
                                        method=m.smoothing.method)
        np.testing.assert_allclose(r.smooth[key], want, rtol=1e-9, atol=1e-9)


def test_chunks_do_not_change_the_numbers():
    rng = np.random.default_rng(0)
    ch = {"x": rng.normal(size=30)}
    p = Param("p")
    f = And((Always(0, 1, Pred(Bin("-", Sig("x"), p))),
             Until(0, 2, Pred(Bin("+", Sig("x"), Const(2.0))), Pred(Bin("-", p, Sig("x"))))))
    params = {"p": rng.normal(size=101)}
    one = shared_robustness({"f": f}, 0.1, ch, params, 101, chunk=1000)
    many = shared_robustness({"f": f}, 0.1, ch, params, 101, chunk=7)
    for a, b in zip(one, many, strict=True):
        assert np.array_equal(a["f"], b["f"])


# --------------------------------------------------------------------------- Demand


def test_plan_needs_only_the_window():
    p = Pred(Sig("x"))
    f = Eventually(8.0, 11.0, p)
    plan = Plan([f], 0.1, 171)
    assert plan.need[plan.roots[0]] == (0, 0)
    assert plan.need[plan.nodes.index(p)] == (80, 110)
    g = Eventually(10.0, 15.0, Always(0.0, 2.0, p))  # shares p: the hull of both needs
    plan = Plan([f, g], 0.1, 171)
    assert plan.need[plan.nodes.index(p)] == (80, 170)
    assert plan.need[plan.nodes.index(g.arg)] == (100, 150)
    past = Always(20.0, 30.0, Pred(Sig("y")))  # beyond the trace: never evaluated
    plan = Plan([past], 0.1, 171)
    assert plan.need[plan.nodes.index(past.arg)] is None
    assert Demand(plan, {"x": np.zeros(171)}).values() == [math.inf]
    with pytest.raises(ValueError):
        Plan([ir.Not(p)], 0.1, 10)


PA = {"p": np.array([-1.0, 0.0, 0.5, 2.0])}


def _same(got, want, tol):
    got, want = np.broadcast_arrays(np.asarray(got, float), np.asarray(want, float))
    assert np.array_equal(np.isposinf(got), np.isposinf(want)), (got, want)
    assert np.array_equal(np.isneginf(got), np.isneginf(want)), (got, want)
    assert np.array_equal(np.isnan(got), np.isnan(want)), (got, want)
    fin = np.isfinite(want)
    np.testing.assert_allclose(got[fin], want[fin], rtol=tol, atol=tol)


@settings(max_examples=150, deadline=None)
@given(cases(params=("p",)), st.data())
def test_demand_matches_the_monitor(case, data):
    f, dt, ch = case
    g = data.draw(formulas(dt, params=("p",), depth=2))
    fs = [f, g, And((f, g))]
    for h, v in zip(fs, robustness_many(fs, dt, ch, PA), strict=True):
        _same(v, monitor.robustness_signal(h, dt, ch, PA)[..., 0], 1e-12)


@settings(max_examples=150, deadline=None)
@given(cases(params=("p",)), st.data(), st.sampled_from([0.7, 4.0, 30.0, 300.0]),
       st.sampled_from(["gkl", "lse"]))
def test_smooth_demand_matches_the_reference(case, data, lam, method):
    # λ = 300 pushes the shifted fast paths onto their logaddexp fallbacks
    f, dt, ch = case
    g = data.draw(formulas(dt, params=("p",), depth=2))
    fs = [f, g, And((f, g))]
    for h, v in zip(fs, smooth_robustness_many(fs, dt, ch, PA, lam, method), strict=True):
        _same(v, smooth.smooth_robustness_signal(h, dt, ch, PA, lam, method)[..., 0], 1e-9)


def test_smooth_shares_the_exact_predicates():
    ch = {"x": np.linspace(-1, 1, 21)}
    f = nnf.normalize(Eventually(0.5, 1.5, Pred(Bin("-", Sig("x"), Param("p")))))
    plan = Plan([f], 0.1, 21)
    ex = Demand(plan, ch, PA)
    ex.values()
    sm = SmoothDemand(plan, ch, PA, 5.0, share=ex)
    assert sm.exprs is ex.exprs
    _same(sm.values()[0], smooth.smooth_robustness(f, 0.1, ch, PA, 5.0), 1e-12)


# --------------------------------------------------------------------------- stlc risk


def _write_csv(path, sol: Solution) -> None:
    path.write_text(trajectory_csv(sol))


def test_cli_risk_writes_outputs(sit, tmp_path, capsys):
    stl, _, _ = sit
    traj = tmp_path / "trajectory.csv"
    _write_csv(traj, _sol((1.4, 0.1, 1.0)))
    assert cli.main(["risk", str(stl), "--trajectory", str(traj)]) == 0
    out = capsys.readouterr().out
    assert "walking" in out and "VaR0.9" in out and "driver" in out
    data = json.loads((tmp_path / "risk.json").read_text())
    assert [c["name"] for c in data["cases"]][-1] == "walking"
    z = np.load(tmp_path / "risk_samples.npz")
    assert z["walking/exact/requirement"].shape == (400,)
    other = tmp_path / "elsewhere"
    assert cli.main(["risk", str(stl), "--trajectory", str(traj), "--mission", "sit",
                     "-o", str(other)]) == 0
    assert json.loads((other / "risk.json").read_text()) == data


@pytest.mark.parametrize("content,code", [
    (None, "STL601"),  # no such file
    ("t,uav1.pos.x\n0,1\n0.1,1\n", "STL603"),  # missing columns
    ("t,uav1.pos.x,uav1.pos.y,uav1.pos.z\n0,1,0,1\n0.1,1,0,1\n0.3,1,0,1\n", "STL604"),
    ("t,uav1.pos.x,uav1.pos.y,uav1.pos.z\n0,1,0,1\n0.1,abc,0,1\n", "STL602"),
    ("", "STL602"),
])
def test_cli_risk_bad_trajectory(sit, tmp_path, capsys, content, code):
    stl, _, _ = sit
    traj = tmp_path / "trajectory.csv"
    if content is not None:
        traj.write_text(content)
    assert cli.main(["risk", str(stl), "--trajectory", str(traj)]) == 1
    err = capsys.readouterr().err
    assert code in err and "Traceback" not in err
    assert not (tmp_path / "risk.json").exists()


def test_cli_risk_bad_mission(sit, tmp_path, capsys):
    stl, _, _ = sit
    traj = tmp_path / "trajectory.csv"
    _write_csv(traj, _sol())
    assert cli.main(["risk", str(stl), "--trajectory", str(traj), "--mission", "sitt"]) == 1
    err = capsys.readouterr().err
    assert "STL101" in err and "`sit`" in err
    norisk = tmp_path / "norisk.stl"
    norisk.write_text(SIT_STL[:SIT_STL.index("  risk {")] + "}\n")
    assert cli.main(["risk", str(norisk), "--trajectory", str(traj)]) == 1
    assert "STL109" in capsys.readouterr().err


def test_risk_table_handles_missing_bounds():
    case = {"name": "c", "K": 10, "delta": 0.1, "seed": 0, "driver": None,
            "p_violation": {"value": 0.5, "upper": None},
            "var": {"0.9": {"value": None, "lower": None, "upper": None}},
            "cvar": {"0.9": {"value": -1.0, "lower": None, "upper": 0.0}}}
    text = risk_table({"mission": "m", "cases": [case]})
    assert "VaR0.9" in text and "-1.0000" in text
