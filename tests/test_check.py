"""The checker on valid programs: what the typed program and its IR formulas contain.

Small inline sources, one property each: units in SI, vehicles, regions (world and
human frame), quantifier expansion, ranges, named-spec inlining, temporal operators,
objective weights, risk and replanning options.
"""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pytest

from stlc.diagnostics import StlcError
from stlc.frontend.syntax import parse, parse_file
from stlc.semantics import ir, model
from stlc.semantics.check import check

SPECS = sorted((Path(__file__).resolve().parent.parent / "specs").glob("*.stl"))


def program(src: str) -> model.Program:
    return check(parse(src, "test.stl"))


def spec(src: str, name: str = "a") -> ir.Formula:
    return program(src).specs[name]


def point_mass(name: str, pos=(0, 0, 1), extra: str = "") -> str:
    return (f"vehicle {name} : point_mass {{\n  vel_max = (1, 1, 0.5) m/s\n"
            f"  acc_max = (2, 2, 1) m/s^2\n{extra}"
            f"  start {{ pos = ({pos[0]}, {pos[1]}, {pos[2]}) m }}\n}}\n")


TEAM3 = point_mass("uav1", (0, 0, 1)) + point_mass("uav2", (1, 0, 1)) + \
    point_mass("uav3", (2, 0, 1))

HEXA = """\
vehicle hexa : multirotor {
  mass = 2.25 kg
  inertia = diag(2.07e-2, 2.10e-2, 3.10e-2) kg*m^2
  c_f = 11.5e-4
  c_tau = 2.38e-5
  force = [0.29 N, 11.5 N]
  dforce_max = 20 N/s
  rotors = hexarotor(arm = 0.39 m, tilt = 20 deg)
  start { pos = (-1.8, 0, 1.0) m; att = (0, 0, 90) deg; vel = (0.1, 0, 0) m/s }
}
"""


def mission(body: str, vehicles: str = TEAM3, scenario: str = "", horizon: str = "4 s",
            step: str = "0.5 s") -> model.Mission:
    if vehicles == TEAM3 and "vehicles" not in body and "team =" not in body:
        body = "  vehicles = [uav1, uav2, uav3]\n" + body  # several declared: say which
    src = (vehicles + scenario + f"mission m {{\n  horizon = {horizon}\n  step = {step}\n"
           + body + "\n}\n")
    return program(src).missions["m"]


def consts(e: ir.Expr) -> list[float]:
    match e:
        case ir.Const(v):
            return [v]
        case ir.Neg(a):
            return consts(a)
        case ir.Bin(_, a, b):
            return consts(a) + consts(b)
        case ir.Call(_, args):
            return [c for a in args for c in consts(a)]
    return []


# ---------------------------------------------------------------- units


@pytest.mark.parametrize("quantity, si", [
    ("30 deg", math.radians(30)), ("180 °", math.pi), ("1 rad", 1.0),
    ("80 Hz", 80.0), ("90 rpm", 1.5),
    ("2.25 kg", 2.25), ("500 g", 0.5),
    ("1 km", 1000.0), ("10 cm", 0.1), ("5 mm", 0.005),
    ("250 ms", 0.25), ("2 min", 120.0), ("1 h", 3600.0),
    ("0.4 m/s", 0.4), ("2 m/s^2", 2.0), ("3 N", 3.0), ("2 kg*m^2", 2.0),
    ("36 km/h", 10.0), ("2 * 3 m", 6.0), ("(1 + 2) * 2", 6.0), ("pi", math.pi),
])
def test_quantities_are_converted_to_si(quantity, si):
    f = spec(f"signal x\nspec a = x > {quantity}\n")
    assert isinstance(f, ir.Pred)
    assert f.expr == ir.Bin("-", ir.Sig("x"), ir.Const(pytest.approx(si)))


def test_30_deg_is_half_a_radian_and_a_bit():
    f = spec("signal x\nspec a = x < 30 deg\n")
    assert f.expr.left.value == pytest.approx(0.5236, abs=1e-4)


def test_bare_numbers_in_intervals_are_seconds():
    f = spec("signal x\nspec a = always[0, 2] x > 0\nspec b = eventually[100 ms, 1.5 s] x > 0\n")
    assert (f.lo, f.hi) == (0.0, 2.0)
    g = spec("signal x\nspec b = eventually[100 ms, 1.5 s] x > 0\n", "b")
    assert (g.lo, g.hi) == (pytest.approx(0.1), 1.5)


def test_constants_carry_units():
    f = spec("signal x\nconst T = 2 s\nconst H = 50 cm\nspec a = always[0, 2 * T] x < H\n")
    assert (f.lo, f.hi) == (0.0, 4.0)
    assert f.arg.expr == ir.Bin("-", ir.Const(0.5), ir.Sig("x"))


def test_mission_time_grid_in_seconds():
    m = mission("  require true", horizon="2 min", step="500 ms")
    assert (m.horizon, m.step) == (120.0, 0.5)


# ---------------------------------------------------------------- vehicles


def test_multirotor_in_si():
    v = program(HEXA).vehicles["hexa"]
    assert isinstance(v, model.Multirotor)
    assert v.mass == 2.25
    assert np.allclose(v.inertia, np.diag([2.07e-2, 2.10e-2, 3.10e-2]))
    assert (v.force_min, v.force_max) == (0.29, 11.5)
    assert (v.c_f, v.c_tau) == (11.5e-4, 2.38e-5)
    assert v.dforce_max == 20.0
    assert v.gravity == pytest.approx(9.81)
    assert len(v.rotors) == 6
    assert v.start_pos == (-1.8, 0.0, 1.0)
    assert v.start_att == pytest.approx((0.0, 0.0, math.pi / 2))
    assert v.start_vel == (0.1, 0.0, 0.0)
    for r in v.rotors:
        assert np.linalg.norm(r.axis) == pytest.approx(1.0)
        assert np.linalg.norm(r.position[:2]) == pytest.approx(0.39)
        # tilted by 20 degrees from the body z axis
        assert r.axis[2] == pytest.approx(math.cos(math.radians(20)))
    assert sorted(r.spin for r in v.rotors) == [-1, -1, -1, 1, 1, 1]


QUAD = """\
vehicle quad : multirotor {
  mass = 1.2 kg
  inertia = [[0.01, 0, 0], [0, 0.01, 0], [0, 0, 0.02]]
  c_f = 1e-3
  c_tau = 2e-5
  force = [0 N, 10 N]
  rotor r1 { position = (0.2, 0, 0) m; axis = (0, 0, 2); spin = ccw }
  rotor r2 { position = (0, 0.2, 0) m; spin = cw }
  rotor r3 { position = (-20, 0, 0) cm; spin = ccw }
  rotor r4 { position = (0, -0.2, 0) m; spin = cw }
  start { pos = (0, 0, 1) m }
}
"""


def test_rotor_blocks_and_a_matrix_inertia():
    src = QUAD
    v = program(src).vehicles["quad"]
    assert np.allclose(v.inertia, np.diag([0.01, 0.01, 0.02]))
    assert [r.spin for r in v.rotors] == [1, -1, 1, -1]
    assert v.rotors[0].axis == (0.0, 0.0, 1.0)  # normalised
    assert v.rotors[2].position == pytest.approx((-0.2, 0.0, 0.0))


def test_unnamed_rotor_blocks():
    src = re.sub(r"rotor r\d ", "rotor ", QUAD)
    assert len(program(src).vehicles["quad"].rotors) == 4


def test_two_start_blocks_are_a_duplicate_but_named_rotors_must_differ():
    from stlc.diagnostics import StlcError

    src = QUAD.replace("  start {", "  start { pos = (0, 0, 1) m }\n  start {", 1)
    with pytest.raises(StlcError) as e:
        program(src)
    assert [(d.code, "start" in d.message) for d in e.value.diagnostics] == [("STL102", True)]
    src = re.sub(r"rotor r\d ", "rotor r1 ", QUAD)
    with pytest.raises(StlcError) as e:
        program(src)
    assert {d.code for d in e.value.diagnostics} == {"STL102"}
    assert all("`r1`" in d.message for d in e.value.diagnostics)


def test_matrix_with_a_unit():
    v = program(QUAD.replace("inertia = ", "inertia = [[0.01, 0, 0], [0, 0.01, 0], "
                             "[0, 0, 0.02]] kg*m^2\n  # ")).vehicles["quad"]
    assert np.allclose(v.inertia, np.diag([0.01, 0.01, 0.02]))
    scen = ("scenario {\n  human op {\n    pos = (0, 0, 0) m\n"
            "    pos ~ normal((0, 0, 0) cm, [[4, 0, 0], [0, 4, 0], [0, 0, 1]] cm^2)\n  }\n}\n")
    [dist] = program(scen).scenario.humans[0].uncertain
    assert np.allclose(dist.cov, np.diag([4e-4, 4e-4, 1e-4]))


def test_point_mass_vehicle():
    v = program(point_mass("pm", (1, 2, 3), "  capacity = 4\n  mass = 1500 g\n")).vehicles["pm"]
    assert isinstance(v, model.PointMass)
    assert v.vel_max == (1.0, 1.0, 0.5)
    assert v.acc_max == (2.0, 2.0, 1.0)
    assert v.start_pos == (1.0, 2.0, 3.0)
    assert v.capacity == 4 and isinstance(v.capacity, int)
    assert v.mass == 1.5


def test_vehicle_fields_are_signals():
    f = spec(HEXA + "spec a = hexa.pos.z > 1 and hexa.force.3 < 10 N and hexa.heading < 1 rad "
             "and hexa.speed < 1 m/s\n")
    assert ir.signals(f) == {"hexa.pos.z", "hexa.force.3", "hexa.att.z", "hexa.vel.x",
                             "hexa.vel.y", "hexa.vel.z"}


def test_declaration_order_does_not_matter_for_vehicles():
    src = ("mission m {\n  horizon = 1 s\n  step = 0.1 s\n  require always uav9.pos.z > 0\n}\n"
           + point_mass("uav9"))
    m = program(src).missions["m"]
    assert m.vehicles == ("uav9",)


# ---------------------------------------------------------------- regions


def test_boxes_in_si():
    p = program("scenario {\n  workspace = box((-3, -2, 0), (3, 2, 2.5)) m\n"
                "  obstacle pole = box(center = (1, 1, 1) m, size = (20, 20, 200) cm)\n"
                "  target t1 = box((0, 0, 0) m, (100, 100, 50) cm)\n}\n")
    regions = {r.name: r for r in p.scenario.regions}
    assert regions["workspace"].kind == "workspace"
    assert regions["workspace"].box == model.Box((-3.0, -2.0, 0.0), (3.0, 2.0, 2.5))
    assert regions["pole"].kind == "obstacle"
    assert regions["pole"].box.lo == pytest.approx((0.9, 0.9, 0.0))
    assert regions["pole"].box.hi == pytest.approx((1.1, 1.1, 2.0))
    assert regions["t1"].box.hi == pytest.approx((1.0, 1.0, 0.5))
    assert all(r.box.frame is None for r in regions.values())


def test_world_region_membership_is_six_predicates():
    f = spec(point_mass("uav1") + "scenario { target t1 = box((0, 0, 0), (1, 2, 3)) m }\n"
             "spec a = uav1.pos in t1\n")
    assert isinstance(f, ir.And) and len(f.args) == 6
    exprs = [p.expr for p in f.args]
    assert exprs[0] == ir.Sig("uav1.pos.x")  # x - 0
    assert exprs[5] == ir.Bin("-", ir.Const(3.0), ir.Sig("uav1.pos.z"))  # 3 - z
    assert ir.params(f) == set()


def test_not_in_region_is_a_negation():
    f = spec(point_mass("uav1") + "scenario { obstacle o = box((0, 0, 0), (1, 1, 1)) m }\n"
             "spec a = uav1.pos not in o\n")
    assert isinstance(f, ir.Not) and isinstance(f.arg, ir.And) and len(f.arg.args) == 6


def test_human_frame_regions_use_pose_parameters():
    src = point_mass("uav1") + """\
scenario {
  human op {
    pos = (1, 2, 0) m
    att = (0, 0, 90) deg
    region front = box((0, -1, 0), (2, 1, 2)) m
  }
}
spec a = always uav1.pos not in op.front
spec b = uav1.pos.x > op.pos.x
"""
    p = program(src)
    [h] = p.scenario.humans
    assert h.pos == (1.0, 2.0, 0.0) and h.att == pytest.approx((0, 0, math.pi / 2))
    [r] = [r for r in p.scenario.regions if r.kind == "region"]
    assert r.name == "op.front" and r.box.frame == "op"
    assert r.box == model.Box((0.0, -1.0, 0.0), (2.0, 1.0, 2.0), "op")
    assert ir.params(p.specs["a"]) == {f"op.{k}.{a}" for k in ("pos", "att") for a in "xyz"}
    assert ir.signals(p.specs["a"]) == {"uav1.pos.x", "uav1.pos.y", "uav1.pos.z"}
    assert p.specs["b"].expr == ir.Bin("-", ir.Sig("uav1.pos.x"), ir.Param("op.pos.x"))
    assert p.params == pytest.approx({"op.pos.x": 1.0, "op.pos.y": 2.0, "op.pos.z": 0.0,
                                      "op.att.x": 0.0, "op.att.y": 0.0,
                                      "op.att.z": math.pi / 2})


def test_scenario_uncertainty_attaches_to_the_human():
    p = program("scenario {\n  human op { pos = (0, 0, 0) m }\n"
                "  op.pos ~ normal((0, 0, 0) m, diag(0.125, 0.125, 0) m^2)\n"
                "  op.att ~ normal((0, 0, 10) deg, diag(1, 1, 4) deg^2)\n}\n")
    [h] = p.scenario.humans
    pos, att = h.uncertain
    assert pos.params == ("op.pos.x", "op.pos.y", "op.pos.z")
    assert np.allclose(pos.cov, np.diag([0.125, 0.125, 0.0]))
    assert att.params == ("op.att.x", "op.att.y", "op.att.z")
    assert att.mean == pytest.approx((0.0, 0.0, math.radians(10)))
    assert np.allclose(att.cov, np.diag([1, 1, 4]) * (math.pi / 180) ** 2)


# ---------------------------------------------------------------- quantifiers and ranges


def test_forall_expands_to_one_conjunct_per_vehicle():
    m = mission("  spec alt = forall d in team: always d.pos.z >= 0.5 m\n  require alt")
    f = m.specs["alt"]
    assert isinstance(f, ir.And) and len(f.args) == 3
    assert [ir.signals(g) for g in f.args] == [{"uav1.pos.z"}, {"uav2.pos.z"}, {"uav3.pos.z"}]
    assert all(isinstance(g, ir.Always) for g in f.args)


def test_forall_pairs_expands_to_unordered_pairs():
    m = mission("  spec sep = forall d, e in team: always dist(d.pos, e.pos) >= 0.5 m\n"
                "  require sep")
    f = m.specs["sep"]
    assert isinstance(f, ir.And) and len(f.args) == 3
    pairs = [{s.split(".")[0] for s in ir.signals(g)} for g in f.args]
    assert pairs == [{"uav1", "uav2"}, {"uav1", "uav3"}, {"uav2", "uav3"}]


def test_forall_pairs_with_four_vehicles():
    team = TEAM3 + point_mass("uav4", (3, 0, 1))
    m = mission("  vehicles = [uav1, uav2, uav3, uav4]\n"
                "  require forall d, e in team: dist(d.pos, e.pos) >= 1 m", vehicles=team)
    assert len(m.requirement.args) == 6


def test_team_is_the_missions_vehicles():
    m = mission("  vehicles = [uav3, uav1]\n  require forall d in team: d.pos.z > 0")
    assert m.vehicles == ("uav3", "uav1")
    assert [ir.signals(g) for g in m.requirement.args] == [{"uav3.pos.z"}, {"uav1.pos.z"}]


def test_forall_over_a_single_vehicle_is_the_body():
    m = mission("  vehicles = [uav2]\n  require forall d in team: d.pos.z > 0")
    assert isinstance(m.requirement, ir.Pred)
    assert ir.signals(m.requirement) == {"uav2.pos.z"}


def test_forall_over_an_explicit_list():
    m = mission("  require forall d in [uav1, uav3]: d.pos.z > 0")
    assert [ir.signals(g) for g in m.requirement.args] == [{"uav1.pos.z"}, {"uav3.pos.z"}]


def test_forall_over_a_list_of_regions():
    scen = ("scenario {\n  target a = box((0, 0, 0), (1, 1, 1)) m\n"
            "  target b = box((2, 0, 0), (3, 1, 1)) m\n}\n")
    m = mission("  require eventually exists q in [a, b]: uav1.pos in q", scenario=scen)
    assert isinstance(m.requirement, ir.Eventually) and len(m.requirement.arg.args) == 2


def test_exists_over_targets_is_a_disjunction():
    scen = ("scenario {\n  target a = box((0, 0, 0), (1, 1, 1)) m\n"
            "  target b = box((2, 0, 0), (3, 1, 1)) m\n"
            "  target c = box((4, 0, 0), (5, 1, 1)) m\n  home h = box((0, 0, 0), (1, 1, 1)) m\n}\n")
    m = mission("  require eventually exists q in targets: uav1.pos in q", scenario=scen)
    ev = m.requirement
    assert isinstance(ev, ir.Eventually) and isinstance(ev.arg, ir.Or)
    assert len(ev.arg.args) == 3
    lows = [consts(g.args[0].expr) for g in ev.arg.args]  # x - lo for each target
    assert lows == [[], [2.0], [4.0]]


def test_exists_over_an_empty_group_is_a_located_error():
    """Issue 23: `exists s in stations` without a station could never hold (it was a silent
    `false`, and a team mission reported "violated by inf"); `forall` over too few
    elements stays vacuously true (`forall d, e in team` for a one-drone team)."""
    with pytest.raises(StlcError) as e:
        mission("  require not exists q in stations: uav1.pos in q")
    (d,) = e.value.diagnostics
    assert d.code == "STL212" and "no element" in d.message
    assert (d.span.line, d.span.col) == (20, 27)  # at `stations`
    one = mission("  vehicles = [uav1]\n  require forall a, b in team: dist(a.pos, b.pos) >= 1 m"
                  "\n  minimize -robustness")
    assert one.requirement == ir.TrueF()


def test_scalar_range_is_two_predicates():
    f = spec("signal x\nspec a = x in [1, 2]\n")
    assert isinstance(f, ir.And)
    assert [p.expr for p in f.args] == [ir.Bin("-", ir.Sig("x"), ir.Const(1.0)),
                                        ir.Bin("-", ir.Const(2.0), ir.Sig("x"))]


def test_range_with_units_and_negation():
    f = spec(HEXA + "spec a = hexa.force.1 not in [1 N, 2 N]\n")
    assert isinstance(f, ir.Not) and len(f.arg.args) == 2


def test_vector_comparison_is_one_predicate_per_component():
    f = spec(point_mass("uav1") + "spec a = uav1.pos >= (0, 0, 50) cm\n")
    assert isinstance(f, ir.And) and len(f.args) == 3
    assert f.args[2].expr == ir.Bin("-", ir.Sig("uav1.pos.z"), ir.Const(0.5))


# ---------------------------------------------------------------- formulas


def test_comparison_directions():
    src = "signal x, y\nspec a = x >= y\nspec b = x <= y\nspec c = x < 2\nspec d = 2 > x\n"
    p = program(src)
    assert p.specs["a"].expr == ir.Bin("-", ir.Sig("x"), ir.Sig("y"))
    assert p.specs["b"].expr == ir.Bin("-", ir.Sig("y"), ir.Sig("x"))
    assert p.specs["c"].expr == p.specs["d"].expr == ir.Bin("-", ir.Const(2.0), ir.Sig("x"))
    assert p.specs["a"].label == "x >= y"


def test_temporal_and_boolean_operators():
    p = program("signal x, y\n"
                "spec a = always[1, 2] x > 0\n"
                "spec b = eventually y > 0\n"
                "spec c = x > 0 until[0, 4] y > 0\n"
                "spec d = next x > 0\n"
                "spec e = x > 0 implies y > 0\n"
                "spec f = not (x > 0 or y > 0)\n")
    a, b, c, d, e, f = (p.specs[k] for k in "abcdef")
    assert isinstance(a, ir.Always) and (a.lo, a.hi) == (1.0, 2.0)
    assert isinstance(b, ir.Eventually) and (b.lo, b.hi) == (0.0, math.inf)
    assert isinstance(c, ir.Until) and (c.lo, c.hi) == (0.0, 4.0)
    assert ir.signals(c.left) == {"x"} and ir.signals(c.right) == {"y"}
    assert isinstance(d, ir.Next) and isinstance(d.arg, ir.Pred)
    assert isinstance(e, ir.Implies)
    assert isinstance(f, ir.Not) and isinstance(f.arg, ir.Or)
    assert ir.horizon(a, 0.1) == 2.0 and ir.horizon(d, 0.1) == pytest.approx(0.1)


def test_true_and_false():
    p = program("spec a = true\nspec b = false\n")
    assert isinstance(p.specs["a"], ir.TrueF) and isinstance(p.specs["b"], ir.FalseF)


def test_top_level_specs_are_checked_against_the_mission_step():
    from stlc.diagnostics import StlcError

    src = (TEAM3 + "spec a = always[0, 0.75] uav1.pos.z > 0\n"
           "spec b = eventually[0, 1] a\n"
           "mission m {\n  vehicles = [uav1]; horizon = 4 s\n  step = 0.5 s\n"
           "  require a and b and always a\n}\n"
           "mission n {\n  vehicles = [uav1]; horizon = 3 s\n  step = 0.25 s\n  require b\n}\n")
    with pytest.raises(StlcError) as e:
        program(src)
    diags = e.value.diagnostics
    # once, where the spec writes the interval (line 16), naming the mission; `n` is fine
    assert [(d.code, d.span.line) for d in diags] == [("STL303", 16)]
    assert "mission `m`" in diags[0].message and diags[0].help == "use 1 s"
    assert program(src.replace("0.75", "1.5")).missions["m"].step == 0.5


def test_named_specs_are_inlined():
    p = program("signal x\nspec a = always[0, 1] x > 0\nspec b = a and x < 3\n"
                "spec c = not b\n")
    b = p.specs["b"]
    assert isinstance(b, ir.And) and b.args[0] == p.specs["a"]
    assert p.specs["c"] == ir.Not(b)
    assert set(p.specs) == {"a", "b", "c"}


def test_mission_specs_see_top_level_specs():
    src = ("signal x\nspec safe = always x > 0\n"
           "mission m {\n  horizon = 2 s\n  step = 0.1 s\n"
           "  spec reach = eventually[0, 2] x > 1\n  require safe and reach\n}\n")
    p = program(src)
    m = p.missions["m"]
    assert set(m.specs) == {"reach"}
    assert m.requirement == ir.And((p.specs["safe"], m.specs["reach"]))
    assert p.signals == ("x",)


def test_arithmetic_on_signals():
    f = spec(point_mass("uav1") + point_mass("uav2") +
             "spec a = norm(uav1.vel) <= 1 m/s and abs(uav1.pos.z - uav2.pos.z) > 20 cm\n")
    assert isinstance(f, ir.And)
    n, d = f.args
    assert isinstance(n.expr, ir.Bin) and n.expr.right == ir.Call("sqrt", (
        ir.Bin("+", ir.Bin("+", ir.Bin("*", ir.Sig("uav1.vel.x"), ir.Sig("uav1.vel.x")),
                           ir.Bin("*", ir.Sig("uav1.vel.y"), ir.Sig("uav1.vel.y"))),
               ir.Bin("*", ir.Sig("uav1.vel.z"), ir.Sig("uav1.vel.z"))),))
    assert d.expr == ir.Bin("-", ir.Call("abs", (ir.Bin("-", ir.Sig("uav1.pos.z"),
                                                        ir.Sig("uav2.pos.z")),)),
                            ir.Const(pytest.approx(0.2)))


# ---------------------------------------------------------------- mission options


@pytest.mark.parametrize("objective, rob, energy", [
    ("minimize 0.5 * energy - robustness", 1.0, 0.5),
    ("maximize robustness - 0.1 * energy", 1.0, 0.1),
    ("minimize energy * 2 - 3 * robustness", 3.0, 2.0),
    ("maximize robustness", 1.0, 0.0),
    ("minimize -robustness + 0.25 * energy", 1.0, 0.25),
])
def test_objective_weights(objective, rob, energy):
    o = mission(f"  require true\n  {objective}").objective
    assert (o.robustness_weight, o.energy_weight) == (pytest.approx(rob), pytest.approx(energy))
    assert o.forward_weight == 0.0


def test_default_objective_and_options():
    m = mission("  require true")
    assert m.objective == model.Objective(1.0, 0.0, 0.0, None)
    assert m.smoothing == model.Smoothing("gkl", 10.0)
    assert m.threshold == 0.0
    assert m.risk is None and m.replan is None
    assert m.vehicles == ("uav1", "uav2", "uav3")


def test_forward_cost_objective():
    o = mission("  forward_speed = 0.4 m/s\n  require true\n"
                "  minimize 2 * forward_cost - robustness").objective
    assert (o.forward_weight, o.forward_speed) == (2.0, 0.4)


def test_smoothing_threshold_and_solver_options():
    m = mission("  smoothing = lse\n  lambda = 50\n  threshold = 0.05\n"
                "  integrator = euler\n  max_iter = 300\n  require true")
    assert m.smoothing == model.Smoothing("lse", 50.0)
    assert m.threshold == 0.05
    assert m.options["integrator"] == "euler" and m.options["max_iter"] == 300


def test_risk_block():
    scen = ("scenario {\n  human op { pos = (0, 0, 0) m }\n"
            "  op.pos ~ normal((0, 0, 0) m, diag(0.125, 0.125, 0) m^2)\n}\n")
    body = ("  require true\n  risk {\n    K = 200\n    beta = [0.5, 0.9]\n    delta = 0.05\n"
            "    seed = 7\n"
            "    case near { op.pos ~ normal((1, 0, 0) m, diag(0.25, 0.25, 0) m^2) }\n"
            "    case far { op.pos ~ normal((3, 0, 0) m, diag(0.5, 0.5, 0) m^2) }\n  }")
    r = mission(body, scenario=scen).risk
    assert (r.K, r.betas, r.delta, r.seed) == (200, (0.5, 0.9), 0.05, 7)
    assert [c.name for c in r.cases] == ["near", "far"]
    [d] = r.cases[1].distributions
    assert d.params == ("op.pos.x", "op.pos.y", "op.pos.z")
    assert d.mean == (3.0, 0.0, 0.0)
    assert np.allclose(d.cov, np.diag([0.5, 0.5, 0.0]))


def test_risk_defaults_use_the_scenario_uncertainty():
    scen = ("scenario {\n  human op { pos = (0, 0, 0) m }\n"
            "  op.pos ~ normal((0, 0, 0) m, diag(0.1, 0.1, 0) m^2)\n}\n")
    r = mission("  require true\n  risk { }", scenario=scen).risk
    assert (r.K, r.betas, r.delta, r.seed) == (15000, (0.7, 0.8, 0.9), 0.01, 0)
    assert [c.name for c in r.cases] == ["nominal"]


def test_replan_block():
    m = mission("  spec alt = always uav1.pos.z > 0\n  require alt\n"
                "  replan { threshold = 50 cm; event_period = 200 ms; keep = [alt] }",
                step="0.1 s")
    assert m.replan == model.ReplanConfig(0.5, 0.2, 1.0, 0.4, ("alt",))


def test_several_missions_in_one_file():
    src = TEAM3 + "".join(f"mission {n} {{\n  vehicles = [{v}]\n  horizon = 1 s\n"
                          f"  step = 0.1 s\n  require always {v}.pos.z > 0\n}}\n"
                          for n, v in (("first", "uav1"), ("second", "uav2")))
    p = program(src)
    assert list(p.missions) == ["first", "second"]
    assert ir.signals(p.missions["second"].requirement) == {"uav2.pos.z"}


def test_spans_point_into_the_source():
    src = "signal x\n\nspec a = always[0, 1] (x >= 2)\n"
    p = program(src)
    f = p.specs["a"]
    assert (f.span.line, f.span.col) == (3, 10)
    assert (f.arg.span.line, f.arg.span.col) == (3, 24)
    assert p.spec_spans["a"].line == 3


@pytest.mark.skipif(not SPECS, reason="no example files in specs/ yet")
@pytest.mark.parametrize("path", SPECS, ids=[p.name for p in SPECS])
def test_shipped_examples_check(path):
    p = check(parse_file(str(path)))
    assert p.missions or p.specs
