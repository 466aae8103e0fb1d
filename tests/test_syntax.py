"""The parser: unit tests, the precedence contract, line handling, and Hypothesis properties.

Properties:

* round trip — a random AST printed with ``stlc.frontend.printer`` and parsed back is the same AST
  (spans are excluded from equality), and shipped example files survive parse → print →
  parse;
* robustness — random text, random bytes and random token soup never make the front end
  (``parse`` + ``check``) raise anything but ``StlcError``.
"""

from __future__ import annotations

from pathlib import Path

import pytest
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

from stlc.diagnostics import StlcError
from stlc.frontend import ast
from stlc.frontend.printer import print_file
from stlc.frontend.syntax import decode, parse
from stlc.semantics.check import check

REPO = Path(__file__).resolve().parent.parent
SPECS = sorted((REPO / "specs").glob("*.stl"))


def formula(src: str) -> ast.Node:
    """The value of ``spec p = <src>``."""
    [m] = parse(f"spec p = {src}\n").members
    return m.value


def P(*parts: str) -> ast.Path:  # noqa: N802 - reads like the node it builds
    return ast.Path(parts)


def N(text: str) -> ast.Number:  # noqa: N802
    return ast.Number(float(text), text)


# ---------------------------------------------------------------- unit tests


def test_members_of_every_kind():
    src = """\
signal x, y
const T = 2 s
spec phi = always[0, T] (x >= 0.5)
vehicle uav1 : multirotor {
  mass = 2.25 kg
  force = [0.29 N, 11.5 N]
  rotors = hexarotor(arm = 0.39 m, tilt = 20 deg)
  start { pos = (-1.8, 0, 1.0) m }
}
scenario {
  human op { pos = (0, 0, 0) m }
  op.pos ~ normal((0, 0, 0) m, diag(0.1, 0.1, 0) m^2)
}
mission m {
  require phi
  minimize 0.5 * energy - robustness
}
"""
    f = parse(src)
    kinds = [type(m).__name__ for m in f.members]
    assert kinds == ["Signals", "Named", "Named", "Block", "Block", "Block"]
    assert f.members[0] == ast.Signals(("x", "y"))
    assert f.members[1] == ast.Named("const", "T", ast.Quantity(N("2"), "s"))
    veh = f.members[3]
    assert (veh.kind, veh.name, veh.model) == ("vehicle", "uav1", "multirotor")
    assert veh.members[1] == ast.Field("force", ast.List((ast.Quantity(N("0.29"), "N"),
                                                          ast.Quantity(N("11.5"), "N"))))
    assert veh.members[2].value == ast.Call("hexarotor", (), (
        ("arm", ast.Quantity(N("0.39"), "m")), ("tilt", ast.Quantity(N("20"), "deg"))))
    start = veh.members[3]
    assert (start.kind, start.name, start.model) == ("start", None, None)
    assert start.members[0].value == ast.Quantity(ast.Tuple(
        (ast.Unary("-", N("1.8")), N("0"), N("1.0"))), "m")
    unc = f.members[4].members[1]
    assert isinstance(unc, ast.Uncertain) and unc.target == P("op", "pos")
    mis = f.members[5]
    assert mis.members[0] == ast.Require(P("phi"))
    assert mis.members[1] == ast.Objective("minimize", ast.Binary(
        "-", ast.Binary("*", N("0.5"), P("energy")), P("robustness")))


def test_numbers_keep_their_text():
    assert formula("x > 2.50") == ast.Compare(">", P("x"), ast.Number(2.5, "2.50"))
    assert formula("x > 1e3").right == ast.Number(1000.0, "1e3")
    assert formula("x > .5").right == ast.Number(0.5, ".5")


def test_units_attach_to_the_preceding_atom():
    assert formula("x < 0.4 m/s").right == ast.Quantity(N("0.4"), "m/s")
    assert formula("x < 2 m / s").right == ast.Binary("/", ast.Quantity(N("2"), "m"), P("s"))
    assert formula("x < diag(1, 2) kg*m^2").right == ast.Quantity(
        ast.Call("diag", (N("1"), N("2"))), "kg*m^2")
    assert formula("x < 9.81 m/s^2").right.unit == "m/s^2"
    assert formula("x < 30 \u00b0").right.unit == "\u00b0"


def test_paths_with_indices_and_calls():
    f = formula("uav1.force.3 <= max(uav1.force.1, 2 N)")
    assert f.left == P("uav1", "force", "3")
    assert f.right == ast.Call("max", (P("uav1", "force", "1"), ast.Quantity(N("2"), "N")))


def test_quantifiers_with_several_names():
    f = formula("forall d, e in team: dist(d.pos, e.pos) >= 0.5 m")
    assert isinstance(f, ast.Quant)
    assert (f.kind, f.names, f.domain) == ("forall", ("d", "e"), P("team"))
    g = formula("exists q in targets: uav1.pos in q")
    assert g.body == ast.In(P("uav1", "pos"), P("q"))


def test_in_and_not_in():
    assert formula("x in [1, 2]") == ast.In(P("x"), ast.Range(N("1"), N("2")))
    assert formula("p not in box") == ast.In(P("p"), P("box"), True)
    assert formula("not p in r") == ast.Not(ast.In(P("p"), P("r")))


def test_spans_are_one_based_and_exclusive():
    f = parse("signal x\n\nspec abc = x >= 10\n")
    m = f.members[1]
    assert (m.name_span.line, m.name_span.col, m.name_span.end_col) == (3, 6, 9)
    cmp = m.value
    assert (cmp.span.line, cmp.span.col, cmp.span.end_col) == (3, 12, 19)
    assert (cmp.right.span.col, cmp.right.span.end_col) == (17, 19)


def test_spans_do_not_take_part_in_equality():
    assert parse("spec p = x > 1\n") == parse("\n\n   spec   p   =   x>1")


def test_empty_and_comment_only_files():
    assert parse("").members == ()
    assert parse("# nothing\n\n   # here\n").members == ()
    assert parse("signal x;;;\n\n;").members == (ast.Signals(("x",)),)


def test_decode_strips_a_byte_order_mark():
    assert decode(b"\xef\xbb\xbfsignal x\n", "f.stl") == "signal x\n"


# ---------------------------------------------------------------- precedence (contract)

SAME = [
    ("always[0,5] a and b", "(always[0,5] a) and b"),
    ("a implies b implies c", "a implies (b implies c)"),
    ("a or b and c", "a or (b and c)"),
    ("a and b or c", "(a and b) or c"),
    ("a or b implies c", "(a or b) implies c"),
    ("not x > 1 until y < 2", "(not (x > 1)) until (y < 2)"),
    ("a and b until c", "a and (b until c)"),
    ("a until[0, 2] b or c", "(a until[0, 2] b) or c"),
    ("eventually[1, 2] x > 1 or y < 0", "(eventually[1, 2] (x > 1)) or (y < 0)"),
    ("always eventually x > 1", "always (eventually (x > 1))"),
    ("next not x > 1", "next (not (x > 1))"),
    ("not a and b", "(not a) and b"),
    ("forall d in team: a and b", "(forall d in team: a) and b"),
    ("x in [1, 2] and y > 0", "(x in [1, 2]) and (y > 0)"),
    ("x + 1 > 2 * y", "(x + 1) > (2 * y)"),
    ("a - b - c > 0", "((a - b) - c) > 0"),
    ("a / b * c > 0", "((a / b) * c) > 0"),
    ("-x ^ 2 > 0", "(-(x ^ 2)) > 0"),
    ("2 ^ 3 ^ 4 > 0", "(2 ^ (3 ^ 4)) > 0"),
    ("-2 m > x", "(-(2 m)) > x"),
    ("a implies b or c and d until e", "a implies (b or (c and (d until e)))"),
]


@pytest.mark.parametrize("src, parenthesised", SAME)
def test_precedence(src, parenthesised):
    assert formula(src) == formula(parenthesised)


@pytest.mark.parametrize("left, right", [
    ("(a and b) or c", "a and (b or c)"),
    ("(a implies b) implies c", "a implies (b implies c)"),
    ("always[0,5] (a and b)", "(always[0,5] a) and b"),
])
def test_parentheses_matter(left, right):
    assert formula(left) != formula(right)


def test_until_does_not_chain():
    with pytest.raises(StlcError) as e:
        parse("spec p = a until b until c\n")
    assert e.value.diagnostics[0].code == "STL002"


def test_comparisons_do_not_chain():
    with pytest.raises(StlcError):
        parse("spec p = 0 < x < 1\n")


# ---------------------------------------------------------------- line handling


@pytest.mark.parametrize("src", [
    "spec p = x > 1\n  and y > 2\n  or z > 3\n",
    "spec p = x > 1 and\n  y > 2 or\n  z > 3\n",
    "spec p = (x > 1\n  and y > 2)\n  or z > 3\n",
    "spec p = (\n  x > 1 and\n\n  y > 2\n) or z > 3\n",
    "spec p = x > 1\n  # a comment between the lines\n  and y > 2\n  or z > 3\n",
    "spec p = x > 1\r\n  and y > 2\r\n  or z > 3\r\n",
    "spec p = x >\n  1 and y > 2 or z > 3",
])
def test_multi_line_formulas_continue(src):
    [m] = parse(src).members
    assert m.value == formula("((x > 1) and (y > 2)) or (z > 3)")


def test_leading_implies_and_until_continue():
    [m] = parse("spec p = a\n  implies b\n").members
    assert m.value == formula("a implies b")
    [m] = parse("spec p = a\n  until[0, 1] b\n").members
    assert m.value == formula("a until[0, 1] b")


def test_newline_inside_brackets_continues():
    [m] = parse("spec p = max(x,\n  y,\n  z) > 0 and x in [1,\n 2\n]\n").members
    assert m.value == formula("max(x, y, z) > 0 and x in [1, 2]")


def test_a_line_end_ends_a_member():
    f = parse("spec a = x > 1\nspec b = y > 1\n")
    assert [m.name for m in f.members] == ["a", "b"]


def test_names_that_start_with_a_keyword_do_not_continue():
    f = parse("b {\n  spec a = x > 1\n  andy = 2\n  order = 3\n}\n")
    [blk] = f.members
    assert [type(m).__name__ for m in blk.members] == ["Named", "Field", "Field"]


def test_semicolons_and_braces_on_one_line():
    f = parse("mission m { horizon = 1 s; step = 0.1 s; require x > 1 }\n")
    [blk] = f.members
    assert [type(m).__name__ for m in blk.members] == ["Field", "Field", "Require"]
    f = parse("a { b { c = 1 } }\n")
    assert f.members[0].members[0].members[0] == ast.Field("c", N("1"))


def test_member_after_closing_brace_on_the_same_line():
    f = parse("a { } b { }\n")
    assert [m.kind for m in f.members] == ["a", "b"]
    f = parse("a { x = 1 } c = 2\nd { } # comment\ne = 3")
    assert [type(m).__name__ for m in f.members] == ["Block", "Field", "Block", "Field"]


def test_quantifier_over_a_list_and_a_matrix_with_a_unit():
    [m] = parse("spec a = forall d in [uav1, uav3]: d.pos.z > 0\n").members
    assert m.value.domain == ast.List((P("uav1"), P("uav3")))
    [m] = parse("cov = [[1, 0], [0, 1]] deg^2\n").members
    assert m.value == ast.Quantity(ast.List((ast.List((N("1"), N("0"))),
                                             ast.List((N("0"), N("1"))))), "deg^2")
    [m] = parse("d = normal((0, 0) m, [[1, 0], [0, 1]] m^2)\n").members
    assert m.value.args[1].unit == "m^2"


# ---------------------------------------------------------------- round trip (Hypothesis)

KEYWORDS = {"and", "or", "not", "implies", "until", "always", "eventually", "next", "forall",
            "exists", "in", "true", "false", "require", "minimize", "maximize", "signal"}
NAMES = ["x", "y", "z", "uav1", "pos", "vel", "team", "d", "e", "q", "a_b", "t1", "_x", "X2",
         # prefixes of keywords and unit names must still be names
         "andy", "notable", "inx", "orbit", "always1", "nextx", "until_", "forall_", "truex",
         "implies2", "m", "s", "deg", "min", "kg", "spec", "vehicle"]
assert not KEYWORDS & set(NAMES)
UNITS = ["m", "s", "deg", "m/s", "m/s^2", "kg*m^2", "Hz", "N", "km", "min", "rad", "\u00b0",
         "m^-1", "kg*m/s^2"]
FUNCS = ["abs", "norm", "min", "max", "f", "box", "dist", "sqrt", "normal"]

names = st.sampled_from(NAMES)
paths = st.builds(
    lambda head, rest: ast.Path((head, *rest)), names,
    st.lists(st.one_of(names, st.integers(0, 12).map(str)), max_size=2))


@st.composite
def numbers(draw) -> ast.Number:
    i = draw(st.integers(0, 10_000))
    frac = draw(st.text("0123456789", min_size=1, max_size=3))
    text = draw(st.sampled_from([
        str(i), f"{i}.{frac}", f".{frac}", f"{i}.", f"{i}e{draw(st.integers(0, 9))}",
        f"{i}.{frac}E-{draw(st.integers(0, 9))}"]))
    return ast.Number(float(text), text)


strings = st.text("abc xyz_", max_size=6).map(ast.String)


def _extend_exprs(sub):
    return st.one_of(
        st.builds(ast.Quantity, sub, st.sampled_from(UNITS)),
        st.builds(ast.Binary, st.sampled_from("+-*/"), sub, sub),
        st.builds(ast.Binary, st.just("^"), sub, sub),
        st.builds(ast.Unary, st.sampled_from("-+"), sub),
        st.builds(ast.Call, st.sampled_from(FUNCS), st.lists(sub, max_size=3).map(tuple),
                  st.lists(st.tuples(names, sub), max_size=2).map(tuple)),
        st.builds(ast.Tuple, st.lists(sub, min_size=1, max_size=3).map(tuple)),
    )


exprs = st.recursive(st.one_of(paths, numbers(), numbers(), strings), _extend_exprs,
                     max_leaves=8)
intervals = st.one_of(st.none(), st.builds(ast.Interval, exprs, exprs))


domains = st.one_of(paths, st.lists(paths, max_size=3).map(lambda xs: ast.List(tuple(xs))))


def _extend_formulas(sub):
    return st.one_of(
        st.builds(ast.Not, sub),
        st.builds(ast.Logic, st.sampled_from(["and", "or", "implies"]), sub, sub),
        st.builds(ast.Temporal, st.sampled_from(["always", "eventually"]), intervals, sub),
        st.builds(ast.Temporal, st.just("next"), st.none(), sub),
        st.builds(ast.Until, intervals, sub, sub),
        st.builds(ast.Quant, st.sampled_from(["forall", "exists"]),
                  st.lists(names, min_size=1, max_size=3, unique=True).map(tuple), domains, sub),
    )


formulas = st.recursive(
    st.one_of(
        st.builds(ast.Compare, st.sampled_from(["<", "<=", ">", ">="]), exprs, exprs),
        st.builds(ast.In, exprs, st.one_of(st.builds(ast.Range, exprs, exprs), paths, exprs),
                  st.booleans()),
        paths,
        st.builds(ast.Bool, st.booleans()),
    ),
    _extend_formulas, max_leaves=10)

lists = st.lists(exprs, max_size=3).map(lambda xs: ast.List(tuple(xs)))
values = st.one_of(exprs, formulas, lists,
                   st.builds(ast.Quantity, st.lists(lists, max_size=2).map(
                       lambda xs: ast.List(tuple(xs))), st.sampled_from(UNITS)))

simple_members = st.one_of(
    st.builds(ast.Named, names, names, values),
    st.builds(ast.Field, names, values),
    st.builds(ast.Require, formulas),
    st.builds(ast.Objective, st.sampled_from(["minimize", "maximize"]), exprs),
    st.builds(ast.Signals, st.lists(names, min_size=1, max_size=3).map(tuple)),
    st.builds(ast.Uncertain, paths, exprs),
)


@st.composite
def blocks(draw, depth: int = 2) -> ast.Block:
    name = draw(st.one_of(st.none(), names))
    model = draw(st.one_of(st.none(), names)) if name else None
    inner = simple_members if depth <= 1 else st.one_of(simple_members, blocks(depth - 1))
    members = tuple(draw(st.lists(inner, max_size=3)))
    return ast.Block(draw(names), name, model, members)


def assert_round_trip(tree: ast.File) -> None:
    text = print_file(tree)
    back = parse(text)
    assert back == tree, f"printed as:\n{text}"
    assert print_file(back) == text


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(names, formulas)
def test_round_trip_of_formulas(name, f):
    assert_round_trip(ast.File((ast.Named("spec", name, f),)))


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.lists(st.one_of(simple_members, blocks()), max_size=4))
def test_round_trip_of_files(members):
    assert_round_trip(ast.File(tuple(members)))


def test_power_of_a_negation_round_trips():
    tree = ast.Binary("^", ast.Unary("-", P("x")), N("2"))
    assert_round_trip(ast.File((ast.Named("spec", "p", ast.Compare(">", tree, N("1"))),)))


EXAMPLE = """\
signal x, y
spec phi = always[0, 2] (x >= 0.5) and eventually[1, 3] (y < 0)
spec psi = (x > 0) until[0, 4] (y >= 1)
vehicle uav1 : multirotor {
  mass = 2.25 kg
  inertia = diag(2.07e-2, 2.10e-2, 3.10e-2) kg*m^2
  c_f = 11.5e-4
  c_tau = 2.38e-5
  force = [0.29 N, 11.5 N]
  rotors = hexarotor(arm = 0.39 m, tilt = 20 deg)
  start { pos = (-1.8, 0, 1.0) m; att = (0, 0, 0) deg }
}
scenario {
  workspace = box((-3.6, -2.85, 0), (3.6, 2.85, 2.5)) m
  human operator {
    pos = (0, 0, 0) m
    region behind = box((-1, -1, 0), (0, 1, 2)) m
  }
  operator.pos ~ normal((0,0,0) m, diag(0.125, 0.125, 0) m^2)
}
mission m {
  horizon = 17 s
  step = 0.1 s
  spec s = forall d in team: always (d.pos in workspace and d.force.1 in [1 N, 2 N])
  spec t = always[0, 17] (uav1.pos not in operator.behind and uav1.speed <= 0.4 m/s)
  require s and t
  minimize 0.5 * energy - robustness
  risk { K = 100; case a { operator.pos ~ normal((0,0,0) m, diag(0.25, 0.25, 0) m^2) } }
}
"""


def test_round_trip_of_a_whole_mission_file():
    tree = parse(EXAMPLE)
    assert_round_trip(tree)
    check(parse(print_file(tree)))  # the printed file is still a valid program


@pytest.mark.skipif(not SPECS, reason="no example files in specs/ yet")
@pytest.mark.parametrize("path", SPECS, ids=[p.name for p in SPECS])
def test_round_trip_of_shipped_examples(path):
    tree = parse(path.read_text(encoding="utf-8"), str(path))
    assert_round_trip(tree)


# ---------------------------------------------------------------- robustness (Hypothesis)

BASE = """\
signal x, y
vehicle uav1 : point_mass {
  vel_max = (1, 1, 1) m/s
  acc_max = (2, 2, 1) m/s^2
  start { pos = (0, 0, 1) m }
}
scenario {
  workspace = box((-3, -3, 0), (3, 3, 3)) m
  target t1 = box((0, 0, 0), (1, 1, 1)) m
  human op { pos = (0, 0, 0) m; region front = box((0, -1, 0), (2, 1, 2)) m }
}
"""
VOCAB = [
    "signal", "spec", "const", "vehicle", "scenario", "mission", "require", "minimize",
    "maximize", "human", "region", "target", "obstacle", "risk", "case", "start", "replan",
    "and", "or", "not", "implies", "until", "always", "eventually", "next", "forall",
    "exists", "in", "true", "false", "x", "y", "uav1", "team", "targets", "workspace", "op",
    "op.front", "uav1.pos", "uav1.pos.z", "t1", "energy", "robustness", "multirotor",
    "point_mass", "box", "norm", "abs", "min", "diag", "normal", "hexarotor", "horizon",
    "step", "mass", "vehicles", "K", "beta", "delta", "0", "1", "2.5", "0.1", "17", "1e3",
    "inf", "pi", "m", "s", "deg", "m/s", "kg", "Hz", "N", "kg*m^2", "m^2", "furlong", "(",
    ")", "[", "]", "{", "}", ",", ";", ":", ".", "=", "~", "+", "-", "*", "/", "^", "<",
    "<=", ">", ">=", "\n", "\n", '"s"', "# c\n", "$", "\t", "\x00", "\u00e9",
]


def front_end(text: str) -> None:
    """Parse and check; only ``StlcError`` may escape."""
    try:
        check(parse(text, "fuzz.stl"))
    except StlcError as e:
        assert e.diagnostics, "StlcError without diagnostics"
        for d in e.diagnostics:
            assert d.span.file in ("fuzz.stl", "")


@settings(max_examples=300, deadline=None)
@given(st.text())
@example("\x00")
@example("spec a = " + "(" * 200)
@example("}" * 50)
def test_random_text_never_crashes(text):
    front_end(text)


@settings(max_examples=300, deadline=None)
@given(st.binary())
@example(b"\xff\xfe\x00")
@example(b"\xef\xbb\xbf")
def test_random_bytes_never_crash(data):
    try:
        text = decode(data, "fuzz.stl")
    except StlcError as e:
        assert [d.code for d in e.diagnostics] == ["STL005"]
        return
    front_end(text)


token_soup = st.lists(st.sampled_from(VOCAB), max_size=40).map(" ".join)


@settings(max_examples=300, deadline=None)
@given(token_soup)
def test_token_soup_never_crashes(text):
    front_end(text)


@settings(max_examples=300, deadline=None)
@given(st.sampled_from(["spec zz = ", "mission m {\n horizon = 2 s\n step = 0.1 s\n ",
                        "scenario {\n ", "vehicle v : point_mass {\n "]), token_soup)
def test_token_soup_inside_a_program_never_crashes(prefix, soup):
    front_end(BASE + prefix + soup + "\n")


@settings(max_examples=200, deadline=None)
@given(st.data())
def test_mutated_programs_never_crash(data):
    text = EXAMPLE
    for _ in range(data.draw(st.integers(1, 3))):
        i = data.draw(st.integers(0, len(text)))
        j = data.draw(st.integers(i, min(len(text), i + 12)))
        edit = data.draw(st.sampled_from(["delete", "insert", "duplicate"]))
        if edit == "delete":
            text = text[:i] + text[j:]
        elif edit == "insert":
            text = text[:i] + " " + data.draw(st.sampled_from(VOCAB)) + " " + text[i:]
        else:
            text = text[:j] + text[i:j] + text[j:]
    front_end(text)
