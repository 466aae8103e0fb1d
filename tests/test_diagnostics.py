"""Diagnostics of the front end (parse + check), driven by `.stl` fixtures.

Every file in ``tests/diagnostics/`` is a small mission file in which each line that must
produce an error carries an inline expectation (mypy test-data style)::

    spec a = sped >= 1  # E: STL101  # H: did you mean `speed`?

``# E:`` lists the codes expected on that line (several allowed); ``# H:`` (optional) is a
piece of text that the help of one of that line's diagnostics must contain.  The test runs
``parse_file`` + ``check`` and asserts that the set of ``(line, code)`` pairs reported
equals the set expected: nothing missing, nothing extra.  A fixture whose first lines hold
``# XFAIL: reason`` documents a known front-end bug (strict xfail: it fails loudly once the
bug is fixed, so the marker can be removed).

Situations that are easier to generate than to write down (deep nesting, invalid UTF-8,
very long lines, inputs that used to crash the checker) are tested below the fixtures.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from stlc.diagnostics import CODES, Diagnostic, StlcError, render_all
from stlc.frontend.postlex import MAX_DEPTH
from stlc.frontend.syntax import MAX_LINE, decode, parse, parse_file
from stlc.semantics.check import check

FIXTURES = Path(__file__).parent / "diagnostics"
FILES = sorted(FIXTURES.glob("*.stl"))

EXPECT = re.compile(r"#\s*[EW]:\s*(?P<codes>(?:STLW?\d{2,3}\s*)+)"
                    r"(?:#\s*H:\s*(?P<help>.*?))?\s*$")
XFAIL = re.compile(r"^#\s*XFAIL:\s*(?P<reason>.+)$", re.M)

#: codes the front end (syntax + check) can emit; each must be exercised by a test here
FRONT_END_CODES = {c for c in CODES if c[3] in "0123" and c != "STL109"} | {"STL402"}


def expectations(text: str) -> tuple[set[tuple[int, str]], dict[int, str]]:
    codes: set[tuple[int, str]] = set()
    helps: dict[int, str] = {}
    for i, line in enumerate(text.splitlines(), 1):
        m = EXPECT.search(line)
        if m:
            codes |= {(i, c) for c in m["codes"].split()}
            if m["help"]:
                helps[i] = m["help"]
    return codes, helps


def front_end(path: str) -> list[Diagnostic]:
    """Diagnostics of parse + check for a file; when it checks, its warnings (``# W:``):
    the lint's, and the vacuous implications (STLW02) of its top-level specs on the trace
    ``<fixture>.csv`` when there is one."""
    from stlc.analysis.trace import read_trace
    from stlc.analysis.vacuity import vacuous
    from stlc.semantics.lint import lint

    try:
        tree = parse_file(path)
        program = check(tree)
    except StlcError as e:
        return e.diagnostics
    out = lint(tree, program)
    trace = Path(path).with_suffix(".csv")
    if trace.exists():
        tr = read_trace(str(trace))
        out += vacuous(dict(program.specs), tr.dt, tr.channels, program.params, tr.n)
    return sorted(out, key=Diagnostic.sort_key)


def diagnose(text: str, file: str = "<test>") -> list[Diagnostic]:
    try:
        check(parse(text, file))
    except StlcError as e:
        return e.diagnostics
    return []


def show(diags: list[Diagnostic]) -> str:
    return "\n".join(f"  {d.span.line}:{d.span.col} {d.code} {d.message} | help: {d.help}"
                     for d in diags)


def _fixture_params():
    for f in FILES:
        m = XFAIL.search(f.read_text(encoding="utf-8"))
        marks = [pytest.mark.xfail(strict=True, reason=m["reason"])] if m else []
        yield pytest.param(f, id=f.stem, marks=marks)


# ---------------------------------------------------------------- fixtures


def test_there_are_enough_fixtures():
    situations = set()
    for f in FILES:
        codes, _ = expectations(f.read_text(encoding="utf-8"))
        situations |= {(f.name, line, code) for line, code in codes}
    assert len(FILES) >= 30
    assert len(situations) >= 30


@pytest.mark.parametrize("path", list(_fixture_params()))
def test_fixture(path: Path):
    text = path.read_text(encoding="utf-8")
    expected, helps = expectations(text)
    assert expected, f"{path.name} has no `# E:` expectation"
    diags = front_end(str(path))
    got = {(d.span.line, d.code) for d in diags}
    missing, extra = sorted(expected - got), sorted(got - expected)
    assert not missing and not extra, (
        f"{path.name}: missing {missing}, unexpected {extra}\nreported:\n{show(diags)}")
    for line, want in helps.items():
        hints = [d.help or "" for d in diags if d.span.line == line]
        assert any(want in h for h in hints), f"{path.name}:{line}: no help contains {want!r}: " \
                                               f"{hints}"
    n_lines = len(text.splitlines())
    for d in diags:
        assert d.span.file == str(path)
        assert 1 <= d.span.line <= n_lines and d.span.col >= 1, d
    assert diags == sorted(diags, key=Diagnostic.sort_key)
    rendered = render_all(diags, {str(path): text})
    assert rendered.count("error[") + rendered.count("warning[") == len(diags)


def test_every_front_end_code_is_exercised():
    """Each registered syntax/name/type/time code appears in a fixture or a test below."""
    in_fixtures = set()
    for f in FILES:
        in_fixtures |= {code for _, code in expectations(f.read_text(encoding="utf-8"))[0]}
    in_tests = {"STL004", "STL005", "STL006"}  # generated below
    assert FRONT_END_CODES - in_fixtures - in_tests == set()


def test_errors_are_collected_and_sorted():
    diags = front_end(str(FIXTURES / "collect_three_errors.stl"))
    assert [(d.span.line, d.code) for d in diags] == [(6, "STL203"), (7, "STL101"),
                                                       (12, "STL103")]


# ---------------------------------------------------------------- hints and messages


def test_did_you_mean_for_unknown_name():
    [d] = diagnose("signal speed\nspec a = always (sped >= 1)\n")
    assert (d.code, d.span.line, d.span.col, d.span.end_col) == ("STL101", 2, 18, 22)
    assert d.message == "unknown name `sped`"
    assert d.help == "did you mean `speed`?"


def test_did_you_mean_for_unknown_field():
    src = ("signal x\nmission m {\n  horizon = 2 s\n  stepp = 0.1 s\n  step = 0.1 s\n"
           "  require x > 0\n}\n")
    [d] = diagnose(src)
    assert (d.code, d.span.line, d.span.col) == ("STL103", 4, 3)
    assert "`stepp`" in d.message
    assert d.help == "did you mean `step`?"


def test_did_you_mean_for_unknown_vehicle_model():
    [d] = diagnose("vehicle v : point_mas {\n  mass = 1 kg\n}\n")
    assert d.code == "STL105" and d.help == "did you mean `point_mass`?"


def test_unit_mismatch_message_names_both_dimensions():
    src = "signal x\nmission m {\n  horizon = 17 m\n  step = 0.1 s\n  require x > 0\n}\n"
    [d] = diagnose(src)
    assert d.code == "STL204"
    assert "a time (s)" in d.message and "a length (m)" in d.message
    assert (d.span.line, d.span.col, d.span.end_col) == (3, 13, 17)  # under `17 m`
    assert "`1 s`" in d.help


def test_unit_mismatch_in_sum_names_operands_in_order():
    [d] = diagnose("signal x\nspec a = (1 m/s + 2 m) > 0 m/s\n")
    assert d.code == "STL204"
    assert d.message.index("a speed") < d.message.index("a length")


def test_duplicate_spec_names_the_first_line():
    [d] = diagnose("signal x\nspec a = x > 1\nspec a = x > 2\n")
    assert d.code == "STL102" and "(line 2)" in d.message and d.span.line == 3


def test_spec_that_uses_itself_inside_a_quantifier():
    src = (VEHICLE + "mission m {\n  horizon = 1 s\n  step = 0.1 s\n"
           "  spec c = forall d in team: (c and d.pos.z > 0)\n  require c\n}\n")
    [d] = diagnose(src)
    assert d.code == "STL106" and d.message == "spec `c` refers to itself"


def test_cannot_hover_message_does_not_repeat_itself():
    src = VEHICLE.replace("point_mass", "multirotor").replace(
        "  vel_max = (1, 1, 1) m/s\n  acc_max = (1, 1, 1) m/s^2\n",
        "  mass = 200 kg\n  inertia = diag(0.02, 0.02, 0.03) kg*m^2\n  c_f = 1e-3\n"
        "  c_tau = 2e-5\n  force = [0.3 N, 11 N]\n  rotors = hexarotor(arm = 0.4 m)\n")
    [d] = diagnose(src)
    assert d.code == "STL402"
    assert d.message.startswith("vehicle `uav1` cannot hover within its force limits")
    assert d.message.count("cannot hover") == 1


def test_too_many_samples_is_short():
    src = "signal x\nmission m {\n  horizon = 1 s\n  step = 1e-300 s\n  require x > 0\n}\n"
    [d] = diagnose(src)
    assert d.code == "STL305" and d.message == "1e+300 samples is more than the limit 20000"


def test_no_cascade_from_bad_declarations():
    src = (VEHICLE.replace("(1, 1, 1) m/s^2", "(1, 1, 1) s") + "signal x\n"
           "const K = 2 * x\nscenario {\n  target t = 3\n}\n"
           "mission m {\n  vehicles = [uav1]\n  horizon = 1 s\n  step = 0.1 s\n"
           "  require uav1.pos in t and uav1.pos.z > K\n}\n")
    assert [(d.span.line, d.code) for d in diagnose(src)] == [
        (3, "STL204"), (7, "STL210"), (9, "STL208")]


def test_region_with_a_unit_that_is_not_a_length():
    [d] = diagnose("scenario {\n  target t = box((0, 0, 0), (1, 1, 1)) s\n}\n")
    assert d.code == "STL204" and "a time (s)" in d.message


def test_spec_used_before_definition():
    # (where the caret goes is pinned by the fixture names_spec_used_before_definition)
    diags = diagnose("signal x\nspec a = b and x > 1\nspec b = x > 2\n")
    assert [d.code for d in diags] == ["STL106"]
    assert "`b`" in diags[0].message


VEHICLE = ("vehicle uav1 : point_mass {\n  vel_max = (1, 1, 1) m/s\n  acc_max = (1, 1, 1) m/s^2\n"
           "  start { pos = (0, 0, 1) m }\n}\n")


# ---------------------------------------------------------------- generated inputs


def test_brackets_nested_too_deep():
    depth = MAX_DEPTH + 5
    src = "signal x\n\nspec a = " + "(" * depth + "x > 1" + ")" * depth + "\n"
    [d] = diagnose(src)
    assert d.code == "STL004"
    assert d.span.line == 3
    assert d.span.col == len("spec a = ") + MAX_DEPTH + 1  # the first bracket too many


def test_brackets_at_the_limit_are_fine():
    src = "signal x\nspec a = " + "(" * MAX_DEPTH + "x > 1" + ")" * MAX_DEPTH + "\n"
    assert diagnose(src) == []


@pytest.mark.parametrize("op", ["-", "not "])
def test_deep_prefix_nesting_without_brackets_is_a_diagnostic(op):
    src = "signal x\nspec a = " + op * 3000 + "x > 1\n"
    codes = {d.code for d in diagnose(src)}
    assert "STL004" in codes or "STL006" in codes


def test_deep_not_chain_is_a_diagnostic_not_a_crash():
    src = "signal x\nspec a = " + "not\n" * 400 + "x > 1\n"
    with pytest.raises(StlcError) as e:
        check(parse(src))
    assert e.value.diagnostics[0].code == "STL004"


def test_parser_recursion_limit_points_at_the_formula():
    src = "signal x\n\nspec a = " + "-\n" * 2000 + "x > 1\n"
    [d] = diagnose(src)
    assert d.code == "STL004"
    assert d.span.line >= 3


def test_invalid_utf8_is_a_diagnostic():
    data = "signal x\nspec a = x > 1 # é\n".encode() + b"spec b = x > \xff\xfe 2\n"
    with pytest.raises(StlcError) as e:
        decode(data, "bad.stl")
    [d] = e.value.diagnostics
    assert d.code == "STL005"
    assert (d.span.file, d.span.line, d.span.col) == ("bad.stl", 3, 14)


def test_invalid_utf8_through_parse_file(tmp_path):
    p = tmp_path / "latin1.stl"
    p.write_bytes("signal x\n# caf\u00e9\n".encode("latin-1"))
    with pytest.raises(StlcError) as e:
        parse_file(str(p))
    assert [(d.code, d.span.line) for d in e.value.diagnostics] == [("STL005", 2)]


def test_byte_order_mark_is_accepted():
    text = decode(b"\xef\xbb\xbfsignal x\nspec a = x > 1\n", "bom.stl")
    assert diagnose(text) == []


def test_line_too_long():
    long = "spec b = x > " + " + ".join(["1"] * (MAX_LINE // 4 + 10))
    assert len(long) > MAX_LINE
    src = f"signal x\nspec a = x > 1\n{long}\n"
    [d] = diagnose(src)
    assert d.code == "STL006"
    assert d.span.line == 3
    assert str(len(long)) in d.message


def test_line_at_the_limit_is_fine():
    head = "signal x\nspec a = x > 0 "
    src = head + "#" * (MAX_LINE - len("spec a = x > 0 ")) + "\n"
    assert max(len(line) for line in src.splitlines()) == MAX_LINE
    assert diagnose(src) == []


def test_control_characters_are_reported_readably():
    [d] = diagnose("signal x\nspec a = x > 1\x00\n")
    assert d.code == "STL001"
    assert "\\x00" in d.message
    assert (d.span.line, d.span.col) == (2, 15)


def test_unexpected_eof_points_at_an_existing_line():
    src = "signal x\nmission m {\n  horizon = 1 s\n"
    [d] = diagnose(src)
    assert d.code == "STL003"
    assert 1 <= d.span.line <= len(src.splitlines())


def test_file_ending_in_open_brace_is_unexpected_eof():
    [d] = diagnose("signal x\nmission m {\n")
    assert d.code == "STL003"
    assert "line 2" in d.help and "`}`" in d.help  # names the brace that is still open


def test_file_ending_after_an_operator_is_unexpected_eof():
    [d] = diagnose("signal x\nspec a = x >\n\n")
    assert d.code == "STL003" and (d.span.line, d.span.col) == (2, 13)


# ---------------------------------------------------------------- the checker never crashes

CRASHERS = {
    "K = inf": "risk { K = inf; case a { } }",
    "K = nan": "risk { K = 0 * inf; case a { } }",
    "seed = 1e400": "risk { seed = 1e400; case a { } }",
    "max_iter = inf": "max_iter = inf",
    "unit ^ inf": "spec s = x > (1 m) ^ 1e400",
    "unit ^ nan": "spec s = x > (1 m) ^ (0 * inf)",
    "min of matrix": "spec s = x > min([[1, 0], [0, 1]], 1)",
    "diag of matrix": "spec s = x > diag(1, [[1, 0], [0, 1]])",
    "seed = nan": "risk { seed = 0 * inf; case a { } }",
    "K = 1e300": "risk { K = 1e300; case a { } }",
    "unit ^ 1e300": "spec s = x > (1 m) ^ 1e300",
    "unit power 400": "spec s = x > 1 km^400",
    "huge component index": "spec s = x > (1, 2, 3)." + "9" * 5000,
    "lambda = inf": "lambda = inf",
    "threshold = nan": "threshold = 0 * inf",
    "time bound 1e400": "spec s = always[0, 1e400 * 1e400 - 1e400 * 1e400] x > 0",
}


@pytest.mark.parametrize("member", list(CRASHERS.values()), ids=list(CRASHERS))
def test_bad_values_are_diagnostics_not_crashes(member):
    src = ("signal x\nmission m {\n  horizon = 1 s\n  step = 0.1 s\n  require x > 0\n"
           f"  {member}\n}}\n")
    with pytest.raises(StlcError) as e:
        check(parse(src))
    assert any(d.span.line == 6 for d in e.value.diagnostics)


def test_nan_time_bound_is_reported():
    src = ("signal x\nspec a = always[0 * inf, 1] x > 0\nmission m {\n  horizon = 1 s\n"
           "  step = 0.1 s\n  require always[0, 0 * inf] x > 0\n}\n")
    lines = {d.span.line for d in diagnose(src)}
    assert {2, 6} <= lines


def test_constant_from_a_signal_is_not_a_constant():
    [d] = diagnose("signal x\nconst U = 2 * x\n")
    assert d.code == "STL210"


def test_second_risk_block_is_reported_once():
    src = ("signal x\nmission m {\n  horizon = 1 s\n  step = 0.1 s\n  require x > 0\n"
           "  risk { K = 10; case a { } }\n  risk { K = 20; case b { } }\n}\n")
    diags = diagnose(src)
    assert [(d.span.line, d.code) for d in diags] == [(7, "STL102")]


# ---------------------------------------------------------------- warnings (STLWxx)


def test_no_warnings_on_shipped_specs():
    from stlc.semantics.lint import lint

    root = Path(__file__).resolve().parent.parent
    for f in sorted((root / "specs").glob("*.stl")) + sorted((root / "tests" / "missions")
                                                            .glob("*.stl")):
        tree = parse_file(str(f))
        assert lint(tree, check(tree)) == [], f.name


def test_every_warning_code_has_a_fixture():
    in_fixtures = set()
    for f in FILES:
        in_fixtures |= {code for _, code in expectations(f.read_text(encoding="utf-8"))[0]}
    assert {c for c in CODES if c.startswith("STLW")} <= in_fixtures
