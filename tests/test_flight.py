"""``stlc fly`` and its engine (``stlc.flight``), each checked against a value computed
another way: the exact monitor run on the written ``flown.csv``, the steady-state offset
of a PD loop under a constant force, the Dryden filters' variance and correlation, the
Clopper–Pearson bound from scipy, the per-run monitor loop, and local vs Dask runs."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from stlc.analysis.trace import read_trace
from stlc.flight import engine, rigid, wind
from stlc.pipeline import load

from clirun import stlc

ROOT = Path(__file__).resolve().parent.parent
CLIMB = ROOT / "tests" / "missions" / "hexa_climb.stl"


@pytest.fixture(scope="module")
def flown(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("fly")
    r = stlc("fly", str(CLIMB), "-o", str(out), "-q", "--runs", "60", "--wind", "3,0,0",
             "--turbulence", "light", "--seed", "5", cwd=out)
    assert r.returncode in (0, 3), r.stderr
    return out


def test_fly_writes_the_contract(flown):
    rec = json.loads((flown / "flight.json").read_text())
    for key in ("robustness",):
        assert isinstance(rec["plan"][key], float) and isinstance(rec["flown"][key], float)
    assert set(rec["flown"]["specs"]) == {"stay", "reach"}
    assert rec["tracking"]["max_error_m"] >= rec["tracking"]["rms_error_m"] > 0
    runs = rec["runs"]
    assert runs["n"] == 60
    assert 0 <= runs["p_violation"] <= runs["p_violation_upper"] <= 1
    assert set(runs["var"]) == set(runs["cvar"]) == {"0.7", "0.8", "0.9"}
    for b in runs["var"]:
        assert runs["cvar"][b] <= runs["var"][b]  # the worst tail's mean is below its edge
    # the flown trajectory has trajectory.csv's columns, and its exact robustness is the
    # monitor's on the written numbers
    assert (flown / "flown.csv").read_text().splitlines()[0] == \
        (flown / "trajectory.csv").read_text().splitlines()[0]
    r = stlc("monitor", str(CLIMB), "--trace", str(flown / "flown.csv"), "--json", cwd=flown)
    specs = json.loads(r.stdout)["specs"]
    assert specs["climb"]["robustness"] == pytest.approx(rec["flown"]["robustness"], abs=1e-6)
    assert specs["reach"]["robustness"] == pytest.approx(rec["flown"]["specs"]["reach"],
                                                         abs=1e-6)
    assert {"flight.json", "flown.csv"} <= set(json.loads(
        (flown / ".stlc-outputs.json").read_text())["files"])


def test_the_bound_is_clopper_pearson(flown):
    from scipy.stats import beta

    runs = json.loads((flown / "flight.json").read_text())["runs"]
    k, n, d = runs["violations"], runs["n"], runs["delta"]
    want = 1.0 if k == n else beta.ppf(1 - d, k + 1, n - k)
    assert runs["p_violation_upper"] == pytest.approx(want, rel=1e-6)


@pytest.fixture(scope="module")
def climb_plan(flown):
    program = load(str(CLIMB)).program
    tr = read_trace(flown / "trajectory.csv")
    return program, program.missions["climb"], tr


def test_nominal_flight_tracks_the_plan(climb_plan):
    program, m, tr = climb_plan
    b = engine.fly_batch(program, m, tr.times, tr.channels, rigid.FlightSetup(), 1, 0)
    # the tilted hexarotor's plan is dynamically consistent: millimetres, not centimetres
    assert b.err_max[0] < 0.02
    plan = engine.fly_batch(program, m, tr.times, tr.channels, rigid.FlightSetup(), 1, 0)
    assert plan.robustness["climb"][0] == b.robustness["climb"][0]  # deterministic


def test_runs_are_the_same_locally_and_in_chunks(climb_plan):
    program, m, tr = climb_plan
    setup = rigid.FlightSetup(wind=(2.0, 0.0, 0.0), turbulence="light", noise_pos=0.01)
    a = engine.many(program, m, tr.times, tr.channels, setup, 7, seed=3)
    b = engine.chunk_summary(program, m, tr.times, tr.channels, setup, 7, 3, 1)
    np.testing.assert_array_equal(a["robustness"], b["robustness"])
    c = engine.many(program, m, tr.times, tr.channels, setup, 7, seed=4)
    assert not np.array_equal(a["robustness"], c["robustness"])


def test_batched_monitor_equals_the_per_run_loop(climb_plan):
    from stlc.analysis import monitor_demand

    program, m, tr = climb_plan
    setup = rigid.FlightSetup(wind=(3.0, 0.0, 0.0), turbulence="moderate")
    bt = engine.fly_batch(program, m, tr.times, tr.channels, setup, 5, 1)
    fs = engine.formulas(program, m)
    for j in range(5):
        one = {k: np.asarray(x)[j] for k, x in bt.channels.items()}
        vals = monitor_demand.robustness_many(list(fs.values()), tr.dt, one, program.params,
                                              n=tr.n)
        for k, v in zip(fs, vals):
            assert bt.robustness[k][j] == v


def test_steady_wind_offsets_a_hover_by_drag_over_stiffness():
    """Hovering in a constant 3 m/s wind, the position loop settles where its stiffness
    k_x = m ω_p² balances the drag ½ ρ C_dA |w|² (no integral action)."""
    program = load(str(CLIMB)).program
    v = program.vehicles["uav1"]
    n = 801  # 8 s at 0.01 s
    t = np.linspace(0.0, 8.0, n)
    from stlc.flight.export import Track

    z = np.zeros((n, 3))
    hover = Track("uav1", t, np.tile([0.0, 0.0, 1.0], (n, 1)), z, z, z, np.zeros(n), z)
    setup = rigid.FlightSetup(wind=(0.0, 3.0, 0.0))
    fl = rigid.fly(v, hover, t, setup, 1, np.random.default_rng(0))
    drag = 0.5 * rigid.AIR_DENSITY * setup.drag_area * 9.0
    kx = v.mass * rigid.Gains().kp_pos[1]
    assert fl.states[0, -1, 1] == pytest.approx(drag / kx, rel=0.01)
    assert abs(fl.states[0, -1, 0]) < 1e-6 and abs(fl.states[0, -1, 2] - 1.0) < 1e-3


def test_dryden_variance_and_correlation():
    rng = np.random.default_rng(11)
    w = wind.Wind((3.0, 0.0, 0.0), "moderate", 2.0, 0.02, 4000, rng)
    s = np.array([w.sample() for _ in range(400)])  # (steps, runs, 3)
    np.testing.assert_allclose(s.std(axis=(0, 1)), w.sigma, rtol=0.03)
    np.testing.assert_allclose(s.mean(axis=(0, 1)), [3.0, 0.0, 0.0], atol=0.15)  # ~4 SE
    # along the wind: first order, correlation exp(−Δ/τ) with τ = L_u / V
    h = 10.0  # ft: the standard's lower end (2 m is below it)
    L_u = h / (0.177 + 0.000823 * h) ** 1.2 * wind.FT
    lag = 25  # steps of 0.02 s
    u = s[:, :, 0] - 3.0
    rho = np.mean(u[:-lag] * u[lag:]) / np.mean(u * u)
    assert rho == pytest.approx(np.exp(-lag * 0.02 / (L_u / 3.0)), abs=0.03)
    calm = wind.Wind((1.0, 2.0, 0.0), "none", 1.0, 0.02, 3, rng)
    np.testing.assert_array_equal(calm.sample(), [[1.0, 2.0, 0.0]] * 3)


def test_runs_on_dask_equal_the_local_runs(climb_plan, monkeypatch):
    """Two chunks (cut on the client) on a local Dask cluster of two workers (the sweep's
    client setup) give the numbers of the local loop."""
    from stlc.sweeping.run import close_client, dask_client

    program, m, tr = climb_plan
    monkeypatch.setattr(engine, "CHUNK", 4)
    setup = rigid.FlightSetup(wind=(1.0, 1.0, 0.0), turbulence="light")
    local = engine.many(program, m, tr.times, tr.channels, setup, 7, seed=2)
    client, cluster = dask_client(2, None, str(CLIMB))
    try:
        dist = engine.many(program, m, tr.times, tr.channels, setup, 7, seed=2, client=client)
    finally:
        close_client(client, cluster)
    for k in local:
        np.testing.assert_array_equal(local[k], dist[k])


def test_the_report_has_the_flight_section(flown):
    """The report of `stlc fly` carries the flight section: its tiles and spec table in
    the page, and in its data the flown path (= flown.csv) and the tracking error at each
    plan sample (= ‖flown − plan‖ recomputed from the two CSVs)."""
    import html as htmlmod
    import re

    page = (flown / "report.html").read_text()
    assert '<section id="flight"' in page and 'href="#flight"' in page
    rec = json.loads((flown / "flight.json").read_text())
    section = page[page.index('<section id="flight"'):]
    section = section[:section.index("</section>")]
    assert f"{rec['flown']['robustness']:+.4f}" in section and "P(violation)" in section
    for name in rec["flown"]["specs"]:
        assert f"<code>{name}</code>" in section
    raw = re.search(r'<script type="application/json" id="report-data">(.*?)</script>', page,
                    re.S).group(1)
    data = json.loads(htmlmod.unescape(raw) if raw.lstrip().startswith("&") else raw)["flight"]
    fl, plan = read_trace(flown / "flown.csv"), read_trace(flown / "trajectory.csv")
    path = data["paths"][0]
    assert path["vehicle"] == "uav1"
    np.testing.assert_allclose(path["flown"][0], fl.channels["uav1.pos.x"], rtol=1e-4, atol=1e-6)
    err = np.linalg.norm(np.stack([fl.channels[f"uav1.pos.{a}"] - plan.channels[f"uav1.pos.{a}"]
                                   for a in "xyz"]), axis=0)
    np.testing.assert_allclose(data["error"]["e"], err, rtol=1e-4, atol=1e-6)
    assert data["runs"]["n"] == 60


AIR = """
  simulate {
    wind { velocity = (3, 0, 0) m/s; turbulence = light }
    noise { pos = 0.01 m; vel = 0.02 m/s }
  }
}
"""


def _with_air(text: str) -> str:
    return CLIMB.read_text().rstrip().removesuffix("}") + text


def test_wind_and_noise_are_declared_in_the_simulate_block(tmp_path):
    from stlc.diagnostics import StlcError

    f = tmp_path / "air.stl"
    f.write_text(_with_air(AIR))
    sim = load(str(f)).program.missions["climb"].simulate
    assert sim.wind.velocity == (3.0, 0.0, 0.0) and sim.wind.turbulence == "light"
    assert (sim.noise.pos, sim.noise.vel) == (0.01, 0.02)
    bad = tmp_path / "bad.stl"
    bad.write_text(_with_air(AIR.replace("light", "lite").replace("0.01 m", "0.01 s")))
    with pytest.raises(StlcError) as e:
        load(str(bad))
    got = sorted((d.code, d.message) for d in e.value.diagnostics)
    assert [c for c, _ in got] == ["STL108", "STL204"]
    assert "turbulence` is one of" in got[0][1] and e.value.diagnostics[0].help
    bad.write_text(_with_air(AIR.replace("wind {", "wind uav1 {")))
    with pytest.raises(StlcError) as e:
        load(str(bad))
    assert [d.code for d in e.value.diagnostics] == ["STL108"]
    assert "applies to every vehicle" in e.value.diagnostics[0].message
    # the command line replaces the file's wind, the file's turbulence and noise stay
    r = stlc("fly", str(f), "-o", str(tmp_path / "out"), "-q", "--wind", "0,1,0", cwd=tmp_path)
    assert r.returncode in (0, 3), r.stderr
    setup = json.loads((tmp_path / "out" / "flight.json").read_text())["setup"]
    assert setup["wind_mps"] == [0.0, 1.0, 0.0] and setup["turbulence"] == "light"
    assert setup["noise"] == {"pos_m": 0.01, "vel_mps": 0.02}


HUMAN = """
scenario {
  human operator {
    pos = (1.1, 0, 0) m
    region zone = box((-0.2, -0.2, 0), (0.2, 0.2, 2.5)) m
  }
}
"""
LEVELS = """
  spec clear = always[0, 3] (uav1.pos not in operator.zone)
  risk {
    K = 50; beta = [0.9]; delta = 0.05
    require p_violation <= 1
    require var(0.9) >= 5 m
    case wide { operator.pos ~ normal((1.1, 0, 0) m, diag(0.2, 0.2, 0) m^2) }
  }
}
"""


def test_judge_levels_against_the_order_statistics():
    from scipy.stats import beta as beta_dist

    from stlc.semantics.model import RiskLevel

    rho = np.random.default_rng(0).normal(0.1, 0.2, 200)
    r = np.sort(rho)
    levels = (RiskLevel("var", 0.8, ">=", 0.0), RiskLevel("cvar", 0.9, ">=", -0.5),
              RiskLevel("p_violation", None, "<=", 0.4))
    got = engine.judge_levels(levels, rho, 0.01)
    assert got[0]["value"] == r[200 - 160]  # r_(K − ⌈βK⌉ + 1), 1-based
    assert got[1]["value"] == pytest.approx(r[:20].mean())  # the worst 10 %
    k = int(np.count_nonzero(rho <= 0))
    assert got[2]["value"] == pytest.approx(beta_dist.ppf(0.99, k + 1, 200 - k), rel=1e-6)
    assert [g["holds"] for g in got] == [r[40] >= 0, r[:20].mean() >= -0.5,
                                         got[2]["value"] <= 0.4]


def test_risk_levels_judge_the_flown_runs(tmp_path):
    f = tmp_path / "levels.stl"
    f.write_text(_levels_file())
    program = load(str(f)).program
    lv = program.missions["climb"].risk.levels
    assert [(x.measure, x.beta, x.op, x.bound) for x in lv] == [
        ("p_violation", None, "<=", 1.0), ("var", 0.9, ">=", 5.0)]
    r = stlc("fly", str(f), "-o", str(tmp_path / "out"), "-q", "--runs", "12", cwd=tmp_path)
    assert r.returncode == 3, r.stderr
    assert "risk level `var(0.9) >= 5 m`" in r.stderr and "does not hold" in r.stderr
    runs = json.loads((tmp_path / "out" / "flight.json").read_text())["runs"]
    assert runs["uncertain"] == ["operator.pos.x", "operator.pos.y", "operator.pos.z"]
    assert [x["holds"] for x in runs["levels"]] == [True, False]
    # the runs draw the operator: `clear` varies with the draw, beyond the wind-free flight
    assert runs["robustness"]["max"] > runs["robustness"]["min"]


def _levels_file() -> str:
    """hexa_climb with an operator standing on its path, a spec keeping clear of them and
    a risk block with two levels."""
    text = CLIMB.read_text()
    i = text.index("scenario {") + len("scenario {")
    human = HUMAN.strip().removeprefix("scenario {").rstrip().removesuffix("}")
    text = text[:i] + human + text[i:]
    text = text.replace("require stay and reach", "require stay and reach and clear")
    return text.rstrip().removesuffix("}") + LEVELS


def test_compile_judges_the_risk_levels_per_case(tmp_path):
    """The risk pass of `stlc compile` judges the levels on each case's exact robustness
    of the requirement (risk.json), and a level not met exits 3 with the level named."""
    f = tmp_path / "levels.stl"
    f.write_text(_levels_file())
    r = stlc("compile", str(f), "-o", str(tmp_path / "out"), "-q", cwd=tmp_path)
    assert r.returncode == 3, r.stderr
    assert "risk level `var(0.9) >= 5 m` (line" in r.stderr and "case `wide`" in r.stderr
    risk = json.loads((tmp_path / "out" / "risk.json").read_text())
    got = risk["levels"]["wide"]
    samples = np.load(tmp_path / "out" / "risk_samples.npz")
    rho = np.sort(samples["wide/exact/requirement"])
    assert got[1]["value"] == rho[len(rho) - int(np.ceil(0.9 * len(rho)))]
    assert [g["holds"] for g in got] == [True, False]
    # `stlc risk` on the written plan judges the same levels, and exits 3 alike
    r = stlc("risk", str(f), "--trajectory", str(tmp_path / "out" / "trajectory.csv"),
             "-o", str(tmp_path / "again"), cwd=tmp_path)
    assert r.returncode == 3, r.stderr
    assert "risk level `var(0.9) >= 5 m` (line" in r.stderr and "case `wide`" in r.stderr
    again = json.loads((tmp_path / "again" / "risk.json").read_text())["levels"]["wide"]
    assert [g["holds"] for g in again] == [True, False]


PUSHED = """
  replan { threshold = 0.2 m; keep = [stay] }
  simulate { disturb uav1 { time = 1 s; displacement = (0, 0.4, 0) m } }
}
"""


def test_a_push_is_replanned_and_the_controller_tracks_the_replan(tmp_path):
    f = tmp_path / "pushed.stl"
    f.write_text(CLIMB.read_text().rstrip().removesuffix("}") + PUSHED)
    r = stlc("fly", str(f), "-o", str(tmp_path / "out"), "-q", cwd=tmp_path)
    assert r.returncode in (0, 3), r.stderr
    rec = json.loads((tmp_path / "out" / "flight.json").read_text())
    assert rec["replan"]["replans"] >= 1 and rec["replan"]["accepted"] >= 1
    assert rec["setup"]["pushes"][0]["displacement"] == [0.0, 0.4, 0.0]
    assert rec["flown"]["specs"]["stay"] > 0  # the kept spec holds when flown
    page = (tmp_path / "out" / "report.html").read_text()
    assert '<section id="replan"' in page and '<section id="flight"' in page
    # the flown trajectory really was pushed: 0.4 m off the plan right after t = 1 s
    fl, plan = read_trace(tmp_path / "out" / "flown.csv"), read_trace(
        tmp_path / "out" / "trajectory.csv")
    k = int(np.searchsorted(fl.times, 1.0 + 1e-9))
    assert fl.channels["uav1.pos.y"][k] - plan.channels["uav1.pos.y"][k] > 0.3


@pytest.mark.parametrize("level, decision", [("require var(0.9) >= 5 m", "replan"),
                                             ("require var(0.9) >= -5 m", "keep")])
def test_an_operator_move_is_decided_by_the_risk_levels(tmp_path, level, decision):
    """Paper A §6: the operator steps 1 cm aside; the plan still meets κ there (its exact
    robustness 0.039 moves by at most the step), so the risk level decides — one that
    fails at the new pose replans, one that holds keeps."""
    f = tmp_path / "move.stl"
    f.write_text(_levels_file().replace("require var(0.9) >= 5 m", level))
    r = stlc("simulate", str(f), "--move", "operator@1:1.1,0.01,0", "-o",
             str(tmp_path / "out"), "-q", cwd=tmp_path)
    assert r.returncode in (0, 3), r.stderr
    detail = json.loads((tmp_path / "out" / "replan.json").read_text())["events"][0]["detail"]
    assert detail["robustness_new_pose"] >= detail["threshold"]
    assert detail["decision"] == decision
    assert detail["decided_by"] == ("risk level" if decision == "replan"
                                    else "threshold and risk levels")
    assert bool(detail["risk_levels_failed"]) == (decision == "replan")


@pytest.mark.parametrize("args, says", [(["--wind", "1,2"], "expected 3 numbers"),
                                        (["--runs", "0"], "must be at least 1"),
                                        (["--noise", "0.1,-1"], "not negative"),
                                        (["--turbulence", "gusty"], "invalid choice"),
                                        (["--workers", "2", "--scheduler", "x"],
                                         "not allowed with")])
def test_bad_fly_options_are_usage_errors(capsys, args, says):
    from stlc.cli import main

    with pytest.raises(SystemExit) as e:
        main(["fly", str(CLIMB), *args])
    assert e.value.code == 2 and says in capsys.readouterr().err
