"""Margins per unit (``margin = [...]``) and the STLW05 warning, and the MILP seed's
direction on the tower inspection.

* a requirement over metres and m/s with different margins: its robustness on a trace is
  the smallest of (each predicate − its unit's margin), computed here by hand;
* equal margins over every unit present are exactly κ (the requirement is untouched);
* bad margins: no unit (STL204), negative or two in one unit (STL207);
* STLW05 on one κ over two units, not with margins, not with κ = 0, not on one unit;
* the MILP seed of ``specs/tower_inspection.stl`` (its grid is the mission's): the exact
  robustness of its path is ≥ the ρ̂ the MILP reports (the polyhedral bounds lie below).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from stlc.analysis import monitor
from stlc.diagnostics import StlcError
from stlc.frontend.syntax import parse
from stlc.semantics.check import check
from stlc.semantics.lint import lint

ROOT = Path(__file__).resolve().parent.parent

SRC = """\
vehicle p : point_mass {{
  vel_max = (1, 1, 1) m/s
  acc_max = (1, 1, 1) m/s^2
  start {{ pos = (0, 0, 1) m }}
}}
scenario {{
  workspace = box((-5, -5, 0), (5, 5, 3)) m
}}
mission m {{
  vehicles = [p]
  horizon = 2 s
  step = 1 s
  {kappa}
  require always[0, 2] (p.pos.z >= 0.5 m and p.speed <= 0.8 m/s)
}}
"""


def _prog(kappa: str):
    tree = parse(SRC.format(kappa=kappa), "<m>")
    return tree, check(tree)


def _trace():
    z = np.array([1.0, 0.9, 1.2])
    return {"p.pos.x": np.zeros(3), "p.pos.y": np.zeros(3), "p.pos.z": z,
            "p.vel.x": np.array([0.5, 0.7, 0.1]), "p.vel.y": np.zeros(3),
            "p.vel.z": np.zeros(3), "p.speed": np.array([0.5, 0.7, 0.1])}


def test_margins_shift_each_predicate_by_its_unit():
    _, prog = _prog("margin = [0.2 m, 0.05 m/s]")
    m = prog.missions["m"]
    assert m.threshold == 0.0 and m.options["margins"] == {"m": 0.2, "m/s": 0.05}
    rho = monitor.robustness(m.requirement, 1.0, _trace(), prog.params)
    # by hand: z − 0.5 − 0.2 ≥ 0.2 (at 0.9); 0.8 − speed − 0.05 ≥ 0.05 (at 0.7)
    assert rho == pytest.approx(min(0.9 - 0.5 - 0.2, 0.8 - 0.7 - 0.05))


def test_equal_margins_are_kappa():
    _, plain = _prog("threshold = 0.1")
    _, same = _prog("margin = [0.1 m, 0.1 m/s]")
    a, b = plain.missions["m"], same.missions["m"]
    assert b.threshold == 0.1 and a.requirement == b.requirement


@pytest.mark.parametrize("kappa,code", [
    ("margin = [0.2]", "STL204"),
    ("margin = [-0.2 m]", "STL207"),
    ("margin = [0.2 m, 0.3 m]", "STL207"),
])
def test_bad_margins(kappa, code):
    with pytest.raises(StlcError) as e:
        _prog(kappa)
    assert code in [d.code for d in e.value.diagnostics]


@pytest.mark.parametrize("kappa,warned", [
    ("threshold = 0.1", True),
    ("margin = [0.1 m, 0.05 m/s]", False),
    ("threshold = 0", False),
])
def test_stlw05(kappa, warned):
    tree, prog = _prog(kappa)
    codes = [d.code for d in lint(tree, prog)]
    assert ("STLW05" in codes) == warned


def test_stlw05_names_the_units():
    tree, prog = _prog("threshold = 0.1")
    (w,) = [d for d in lint(tree, prog) if d.code == "STLW05"]
    assert "m (1)" in w.message and "m/s (1)" in w.message and w.severity == "warning"
    assert "margin = [0.1 m, 0.1 m/s]" in (w.help or "")


def test_milp_seed_robustness_is_below_the_exact_one():
    from stlc.backends.milp import seed as milp_seed
    from stlc.planning.problem import from_mission

    path = ROOT / "specs" / "tower_inspection.stl"
    prog = check(parse(path.read_text(), str(path)))
    problem = from_mission(prog, prog.missions["inspect"])
    paths, rec = milp_seed.plan(problem, time_limit=60)
    assert paths is not None and rec["step_s"] == problem.grid.dt  # the mission's grid
    P = paths["uav1"][0]
    ch = {f"uav1.pos.{a}": P[i] for i, a in enumerate("xyz")}
    exact = monitor.robustness(problem.requirement, problem.grid.dt, ch, prog.params)
    assert exact >= rec["robustness"] - 1e-6
    assert rec["distances"].startswith("the MILP seed saw each distance")


def test_margins_survive_a_team_re_formed():
    from stlc.semantics.teamform import for_team

    text = """\
vehicle a : point_mass {
  vel_max = (1, 1, 1) m/s
  acc_max = (1, 1, 1) m/s^2
  start { pos = (0, 0, 1) m }
}
vehicle b : point_mass {
  vel_max = (1, 1, 1) m/s
  acc_max = (1, 1, 1) m/s^2
  start { pos = (1, 0, 1) m }
}
mission m {
  team = [a, b]
  horizon = 2 s
  step = 1 s
  margin = [0.2 m, 0.05 m/s]
  require forall d in team: always[0, 2] (d.pos.z >= 0.5 m and d.speed <= 0.8 m/s)
}
"""
    prog = check(parse(text, "<t>"))
    m = for_team(prog.missions["m"], ("a",))
    ch = {f"a.pos.{x}": np.zeros(3) for x in "xyz"}
    ch["a.pos.z"] = np.array([1.0, 0.9, 1.2])
    ch.update({"a.vel.x": np.array([0.5, 0.7, 0.1]), "a.vel.y": np.zeros(3),
               "a.vel.z": np.zeros(3), "a.speed": np.array([0.5, 0.7, 0.1])})
    rho = monitor.robustness(m.requirement, 1.0, ch, prog.params)
    assert m.vehicles == ("a",) and m.threshold == 0.0
    assert rho == pytest.approx(min(0.9 - 0.5 - 0.2, 0.8 - 0.7 - 0.05))


def test_margins_keep_the_limits_as_written():
    from stlc.planning.bounds import stated_bounds

    _, prog = _prog("margin = [0.2 m, 0.05 m/s]")
    assert stated_bounds(prog.missions["m"].requirement)["speed"] == [0.0, 0.8]


PLANNED = """\
vehicle p : point_mass {
  vel_max = (2, 2, 2) m/s
  acc_max = (1, 1, 1) m/s^2
  start { pos = (0, 0, 1) m }
}
scenario {
  workspace = box((-5, -5, 0), (5, 5, 3)) m
  target goal = box((3, -1, 0.5), (4, 1, 1.5)) m
}
mission m {
  vehicles = [p]
  horizon = 10 s
  step = 0.5 s
  margin = [0.3 m, 0.1 m/s]
  require always[0, 10] (p.pos in workspace and p.speed <= 1 m/s)
          and eventually[0, 9] always[0, 1] (p.pos in goal)
}
"""


def test_a_plan_keeps_each_units_margin(tmp_path):
    import json
    import subprocess
    import sys

    from stlc.analysis.trace import read_trace

    src = tmp_path / "m.stl"
    src.write_text(PLANNED)
    r = subprocess.run([sys.executable, "-m", "stlc", "compile", str(src), "-o",
                        str(tmp_path / "out"), "-q"], capture_output=True, text=True,
                       timeout=300)
    assert r.returncode == 0, r.stderr
    assert json.loads((tmp_path / "out" / "solution.json").read_text())["status"] == \
        "satisfied"
    tr = read_trace(str(tmp_path / "out" / "trajectory.csv"))
    P = np.stack([tr.channels[f"p.pos.{a}"] for a in "xyz"], axis=1)
    V = np.stack([tr.channels[f"p.vel.{a}"] for a in "xyz"], axis=1)
    assert np.linalg.norm(V, axis=1).max() <= 1.0 - 0.1 + 1e-6  # the m/s margin
    ws = np.minimum.reduce([P[:, 0] + 5, 5 - P[:, 0], P[:, 1] + 5, 5 - P[:, 1], P[:, 2],
                            3 - P[:, 2]])
    assert ws.min() >= 0.3 - 1e-6  # the metre margin, every sample
    depth = np.minimum.reduce([P[:, 0] - 3, 4 - P[:, 0], P[:, 1] + 1, 1 - P[:, 1],
                               P[:, 2] - 0.5, 1.5 - P[:, 2]])
    held = [depth[k:k + 3].min() for k in range(len(depth) - 2)]  # 1 s = 3 samples
    assert max(held) >= 0.3 - 1e-6


def test_solution_json_names_kappa_and_the_margins(tmp_path):
    """``solution.json`` says what the verdict was judged against: κ, and the margin per
    unit as written (SI values)."""
    import json

    from stlc.cli import main

    f = tmp_path / "m.stl"
    f.write_text(SRC.format(kappa="margin = [0.2 m, 0.05 m/s]"))
    assert main(["compile", str(f), "-o", str(tmp_path / "a"), "-q", "--no-risk"]) == 0
    sol = json.loads((tmp_path / "a" / "solution.json").read_text())
    assert sol["threshold"] == 0.0 and sol["margins"] == {"m": 0.2, "m/s": 0.05}
    import jsonschema

    from stlc.schemas import schema

    jsonschema.validate(sol, schema("solution"))
    f.write_text(SRC.format(kappa="threshold = 0.1"))
    assert main(["compile", str(f), "-o", str(tmp_path / "b"), "-q", "--no-risk"]) == 0
    sol = json.loads((tmp_path / "b" / "solution.json").read_text())
    assert sol["threshold"] == 0.1 and "margins" not in sol
