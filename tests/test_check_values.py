"""The checker on the values it lets through (issue 9): plain-number fields take no unit,
every number that reaches a solver or the monitor is finite, horizon and step errors are
STL305, and the mission's dwell times (``install_time``, ``refill_time``).

Expected values are computed here independently (numpy float arithmetic, hand-written SI
conversions); each bad input must give a located diagnostic, never a traceback.
"""

from __future__ import annotations

import dataclasses
import math
import re

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from stlc.diagnostics import Diagnostic, StlcError
from stlc.frontend.syntax import parse
from stlc.semantics import ir, model
from stlc.semantics.check import check

UAV = """\
vehicle uav : point_mass {
  vel_max = (1, 1, 1) m/s
  acc_max = (2, 2, 2) m/s^2
  start { pos = (0, 0, 1) m }
}
"""
HUMAN = "scenario {\n  human op { pos = (0, 0, 0) m }\n}\n"


def diagnose(src: str) -> list[Diagnostic]:
    try:
        check(parse(src, "t.stl"))
    except StlcError as e:
        return e.diagnostics
    return []


def located(src: str, d: Diagnostic) -> str:
    """The source text a (single-line) diagnostic points at."""
    assert d.span.line == d.span.end_line, d
    return src.splitlines()[d.span.line - 1][d.span.col - 1: d.span.end_col - 1]


def mission(body: str, head: str = UAV, horizon: str = "10 s", step: str = "0.5 s") -> str:
    return f"{head}mission m {{\n  horizon = {horizon}\n  step = {step}\n{body}\n  " \
           "require uav.pos.z >= 0\n}\n"


# ---------------------------------------------------------------- units on plain numbers

RISKY = UAV + "scenario {\n  human op { pos = (0, 0, 0) m }\n" \
    "  op.pos ~ normal((0, 0, 0) m, diag(1, 1, 1) m^2)\n}\n"

#: (field, source with the field's value as {v}, value the field gets from `{v}` = 7)
PLAIN_FIELDS = [
    ("seed", mission("  risk { seed = {v} }", RISKY), 7),
    ("K", mission("  risk { K = {v} }", RISKY), 7),
    ("delta", mission("  risk { delta = 0.1 * {v} }", RISKY), 0.7),
    ("beta", mission("  risk { beta = [0.1 * {v}] }", RISKY), 0.7),
    ("lambda", mission("  lambda = {v}"), 7),
    ("max_iter", mission("  max_iter = {v}"), 7),
    ("capacity", UAV.replace("  start", "  capacity = {v}\n  start"), 7),
]


def _plain_value(p: model.Program, field: str):
    if field == "capacity":
        return p.vehicles["uav"].capacity
    m = p.missions["m"]
    return {"seed": lambda: m.risk.seed, "K": lambda: m.risk.K, "delta": lambda: m.risk.delta,
            "beta": lambda: m.risk.betas[0], "lambda": lambda: m.smoothing.lam,
            "max_iter": lambda: m.options["max_iter"]}[field]()


@pytest.mark.parametrize("field, template, value", PLAIN_FIELDS, ids=[f[0] for f in PLAIN_FIELDS])
@pytest.mark.parametrize("unit", ["kg", "m/s", "s", "deg", "N*m"])
def test_a_unit_on_a_plain_number_field_is_stl204_at_the_unit(field, template, value, unit):
    src = template.replace("{v}", f"7 {unit}")
    diags = diagnose(src)
    assert [d.code for d in diags] == ["STL204"], diags
    assert located(src, diags[0]) == unit
    assert f"`{field}`" in diags[0].message and "plain number" in diags[0].message
    assert "drop the unit" in diags[0].help


@pytest.mark.parametrize("field, template, value", PLAIN_FIELDS, ids=[f[0] for f in PLAIN_FIELDS])
def test_the_same_field_without_a_unit_is_accepted(field, template, value):
    src = template.replace("{v}", "7")
    p = check(parse(src, "t.stl"))
    assert _plain_value(p, field) == pytest.approx(value)


def test_a_unit_on_a_rotor_axis_is_stl204():
    src = UAV.replace("point_mass", "multirotor").split("  vel_max")[0] + """\
  mass = 1 kg; inertia = diag(1, 1, 1) kg*m^2; c_f = 1e-3; c_tau = 2e-5; force = [0 N, 9 N]
  rotor r1 { position = (1, 0, 0) m; axis = (0, 0, 1) kg; spin = cw }
  start { pos = (0, 0, 1) m }
}
"""
    diags = diagnose(src)
    assert [d.code for d in diags] == ["STL204"], diags
    assert located(src, diags[0]) == "kg"


# ---------------------------------------------------------------- finite values

#: (source, the text the STL207 diagnostic must point at)
NON_FINITE = [
    (UAV + "scenario { workspace = box((inf - inf, 0, 0), (1, 1, 1)) m }\n", "inf - inf"),
    (UAV + "scenario { target t = box((0, 0, 0), (1, 1, inf)) m }\n",
     "box((0, 0, 0), (1, 1, inf))"),
    (UAV + "scenario { target t = box(center = (0, 0, inf), size = (1, 1, 1)) m }\n",
     "box(center = (0, 0, inf), size = (1, 1, 1))"),
    (UAV + "scenario { target t = box((0, 0, 0), (1, 1, 1e306)) km }\n",
     "box((0, 0, 0), (1, 1, 1e306)) km"),
    (UAV + "scenario {\n  human op { pos = (0, 0, 0) m }\n"
     "  op.pos ~ normal((0, 0, 1e306), diag(1, 1, 1)) km\n}\n",
     "normal((0, 0, 1e306), diag(1, 1, 1)) km"),
    ("signal x\nspec s = x in [(inf - inf), 1]\nspec t = not s\n", "inf - inf"),
    (UAV + "const c = 0 * inf\n", "0 * inf"),
    (UAV + "const c = inf / inf\n", "inf / inf"),
    (UAV + "const c = angdiff(inf, 0)\n", "angdiff(inf, 0)"),
    (UAV + "scenario {\n  human op { pos = (0, 0, 0) m }\n"
     "  op.pos ~ normal((0, 0, inf) m, diag(1, 1, 1) m^2)\n}\n", "(0, 0, inf) m"),
    (UAV + "scenario {\n  human op { pos = (0, 0, 0) m }\n"
     "  op.pos ~ normal((0, 0, 0) m, diag(1, 1, inf) m^2)\n}\n", "diag(1, 1, inf) m^2"),
    (UAV + "scenario { human op { pos = (0, 0, 1e400) m } }\n", "(0, 0, 1e400) m"),
    ("vehicle h : multirotor {\n  mass = 2 kg; inertia = diag(inf, 1, 1) kg*m^2\n"
     "  c_f = 1e-3; c_tau = 2e-5; force = [0 N, 20 N]\n"
     "  rotors = hexarotor(arm = 0.39 m, tilt = 20 deg)\n  start { pos = (0, 0, 1) m }\n}\n",
     "diag(inf, 1, 1) kg*m^2"),
    (UAV + "spec a = uav.pos.x <= inf\n", "uav.pos.x <= inf"),
    (UAV + "spec a = uav.pos.x * (1e308 * 10) >= 0\n", "uav.pos.x * (1e308 * 10) >= 0"),
    (UAV + "spec a = uav.pos.z in [0, 1e400]\n", "uav.pos.z in [0, 1e400]"),
    (UAV + "spec a = always[0, inf - inf] uav.pos.z >= 0\n", "inf - inf"),
    (UAV + "spec a = always[inf, inf] uav.pos.z >= 0\n", "inf"),
    (mission("  minimize inf * energy - robustness"), "inf"),
    (mission("  threshold = 1e400"), "1e400"),
    (mission("  install_time = inf"), "inf"),
]


@pytest.mark.parametrize("src, where", NON_FINITE, ids=[w for _, w in NON_FINITE])
def test_a_non_finite_value_is_stl207_where_it_is_written(src, where):
    diags = diagnose(src)
    assert [d.code for d in diags] == ["STL207"], diags
    assert located(src, diags[0]) == where


def test_an_unbounded_time_interval_is_still_fine():
    p = check(parse(UAV + "spec a = always[0, inf] uav.pos.z >= 0\n"
                    "spec b = eventually uav.pos.z >= 1\n", "t.stl"))
    assert (p.specs["a"].lo, p.specs["a"].hi) == (0.0, math.inf)
    assert (p.specs["b"].lo, p.specs["b"].hi) == (0.0, math.inf)


def _numbers(x, out: list[float]) -> list[float]:
    """Every float in a checked program, except interval upper bounds (they may be inf)."""
    if isinstance(x, (ir.Always, ir.Eventually, ir.Until, ir.Release)):
        out.append(x.lo)
        for k in ir.children(x):
            _numbers(k, out)
    elif isinstance(x, float):
        out.append(x)
    elif isinstance(x, (tuple, list)):
        for y in x:
            _numbers(y, out)
    elif isinstance(x, dict):
        for y in x.values():
            _numbers(y, out)
    elif dataclasses.is_dataclass(x) and not isinstance(x, type):
        for f in dataclasses.fields(x):
            if f.name not in ("span", "spec_spans", "source", "file"):
                _numbers(getattr(x, f.name), out)
    return out


ATOMS = st.sampled_from(["inf", "-inf", "0", "1", "2.5", "1e308", "3"])


@st.composite
def arithmetic(draw, depth: int = 3) -> str:
    if depth == 0 or draw(st.booleans()):
        return draw(ATOMS)
    op = draw(st.sampled_from(["+", "-", "*", "/"]))
    return f"({draw(arithmetic(depth - 1))} {op} {draw(arithmetic(depth - 1))})"


def _value(text: str) -> float:
    """The expression's value with IEEE semantics, independently of the checker."""
    code = re.sub(r"(-?inf|\d+(?:\.\d+)?(?:e\d+)?)", r"np.float64('\1')", text)
    with np.errstate(all="ignore"):
        return float(eval(code, {"np": np}))  # noqa: S307 - our own generated arithmetic


@settings(max_examples=150, deadline=None)
@given(arithmetic(), st.sampled_from(["corner", "compare", "mean", "bound"]))
def test_property_only_finite_numbers_get_through(expr, where):
    src = UAV + {
        "corner": f"scenario {{ target t = box(({expr}, 0, 0), (1e300, 1, 1)) m }}\n",
        "compare": f"spec a = uav.pos.x <= {expr}\n",
        "mean": "scenario {\n  human op { pos = (0, 0, 0) m }\n"
                f"  op.pos ~ normal(({expr}, 0, 0) m, diag(1, 1, 1) m^2)\n}}\n",
        "bound": f"spec a = always[0, {expr}] uav.pos.z >= 0\n",
    }[where]
    x = _value(expr)
    diags = diagnose(src)
    if where == "bound":
        ok = not math.isnan(x) and x >= 0
    else:
        ok = math.isfinite(x) and (where != "corner" or x <= 1e300)
    if ok:
        assert diags == [], (expr, diags)
        p = check(parse(src, "t.stl"))
        nums = _numbers(p, [])
        assert all(math.isfinite(v) for v in nums), (expr, nums)
    else:
        assert diags and all(d.span.line > 0 for d in diags), (expr, diags)
        codes = {d.code for d in diags}
        if math.isnan(x) or (math.isinf(x) and where != "bound"):
            assert codes == {"STL207"}, (expr, diags)


# ---------------------------------------------------------------- horizon and step


@pytest.mark.parametrize("horizon, step, bad", [
    ("0 s", "0.5 s", "0 s"), ("-2 s", "0.5 s", "-2 s"), ("inf", "0.5 s", "inf"),
    ("10 s", "0 s", "0 s"), ("10 s", "-0.5 s", "-0.5 s"), ("10 s", "1e400 s", "1e400 s"),
])
def test_an_invalid_horizon_or_step_is_stl305(horizon, step, bad):
    src = mission("", horizon=horizon, step=step)
    diags = diagnose(src)
    assert [d.code for d in diags] == ["STL305"], diags
    assert located(src, diags[0]) == bad


def test_horizon_and_step_see_mission_constants():
    src = UAV + "mission m {\n  const H = 6 s\n  horizon = H\n  step = H / 12\n" \
                "  require uav.pos.z >= 0\n}\n"
    m = check(parse(src, "t.stl")).missions["m"]
    assert (m.horizon, m.step) == (6.0, 0.5)


# ---------------------------------------------------------------- install and refill times


def test_dwell_times_are_stored_in_seconds():
    src = "const T_ins = 5 s\nconst T_rs = 12 s\n" + mission(
        "  install_time = T_ins\n  refill_time = T_rs", horizon="1 min")
    m = check(parse(src, "t.stl")).missions["m"]
    assert (m.install_time, m.refill_time) == (5.0, 12.0)
    m = check(parse(mission("  install_time = 500 ms\n  refill_time = 0.125 min"),
                    "t.stl")).missions["m"]
    assert (m.install_time, m.refill_time) == (0.5, 7.5)


def test_dwell_times_default_to_none():
    m = check(parse(mission(""), "t.stl")).missions["m"]
    assert m.install_time is None and m.refill_time is None


def test_a_dwell_time_equal_to_the_horizon_is_fine():
    m = check(parse(mission("  refill_time = 10 s"), "t.stl")).missions["m"]
    assert m.refill_time == 10.0


@pytest.mark.parametrize("field", ["install_time", "refill_time"])
@pytest.mark.parametrize("value, code, where", [
    ("0 s", "STL207", "0 s"), ("-1 s", "STL207", "-1 s"), ("10.5 s", "STL207", "10.5 s"),
    ("5 m", "STL204", "5 m"), ("uav.pos.x", "STL210", "uav.pos.x"),
])
def test_a_bad_dwell_time_is_reported(field, value, code, where):
    src = mission(f"  {field} = {value}")
    diags = diagnose(src)
    assert [d.code for d in diags] == [code], diags
    assert located(src, diags[0]) == where


# ---------------------------------------------------------------- fuzz findings (branch rel)


@pytest.mark.parametrize("sep", ["\f", "\v", "\x1c", "\x85", "\u2028", "\u2029"])
def test_predicate_labels_count_lines_like_the_parser(sep):
    """``str.splitlines`` also breaks at these characters; a comment holding one must not
    shift the source text that labels later predicates."""
    src = f"signal x\n# a {sep} b\nspec s = abs(x) > 0\nspec t = x <= 2\n"
    p = check(parse(src, "t.stl"))
    assert p.specs["s"].label == "abs(x) > 0"
    assert p.specs["t"].label == "x <= 2"


def test_name_hints_read_every_scope_without_copying():
    from stlc.semantics.check.context import Scope

    outer = Scope({"alpha": None})  # type: ignore[dict-item]
    inner = outer.child({"beta": None})  # type: ignore[dict-item]
    names = inner.all_names(("pi",))
    outer.names["gamma"] = None  # type: ignore[assignment]  # a view: later names show
    assert sorted(names) == ["alpha", "beta", "gamma", "pi"]
    assert "gamma" in names and "pi" in names and "delta" not in names
    diags = diagnose(UAV + "spec a = uav.pos.z >= alpah\nconst alpha = 1\n")
    assert [d.code for d in diags] == ["STL101"] and "`alpha`" in diags[0].help
