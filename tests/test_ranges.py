"""Every number field has the range its meaning allows and the code can hold (issue 23,
item 4): out of range is STL207 at the field's value, in range is accepted.  The limits
are the meaning's (κ ≥ 0, a period of at least one step) or what the code stores (a
capacity in an int64 payload count, K realisations held at once)."""

from __future__ import annotations

import pytest

from stlc.diagnostics import Diagnostic, StlcError
from stlc.frontend.syntax import parse
from stlc.semantics.check import check

UAV = """\
vehicle uav : point_mass {
  vel_max = (1, 1, 1) m/s
  acc_max = (2, 2, 2) m/s^2
{extra}  start { pos = (0, 0, 1) m }
}
"""
RISKY = "scenario {\n  human op { pos = (0, 0, 0) m }\n" \
    "  op.pos ~ normal((0, 0, 0) m, diag(1, 1, 1) m^2)\n}\n"


def src(body: str = "", extra: str = "", head: str = "") -> str:
    return (UAV.replace("{extra}", extra) + head + "mission m {\n  horizon = 10 s\n"
            "  step = 0.5 s\n" + body + "\n  require uav.pos.z >= 0\n}\n")


def diagnose(text: str) -> list[Diagnostic]:
    try:
        check(parse(text, "t.stl"))
    except StlcError as e:
        return e.diagnostics
    return []


def at(text: str, d: Diagnostic) -> str:
    return text.splitlines()[d.span.line - 1][d.span.col - 1: d.span.end_col - 1]


#: (case, source, the value text the STL207 must point at)
BAD = [
    ("threshold<0", src("  threshold = -5"), "-5"),
    ("capacity=1e19", src(extra="  capacity = 1e19\n"), "1e19"),
    ("capacity>1000", src(extra="  capacity = 1001\n"), "1001"),
    ("K=1e9", src("  risk { K = 1e9 }", head=RISKY), "1e9"),
    ("K=2e6", src("  risk { K = 2e6 }", head=RISKY), "2e6"),
    ("seed=2^64", src("  risk { seed = 18446744073709551616 }", head=RISKY),
     "18446744073709551616"),
    ("max_iter=0", src("  max_iter = 0"), "0"),
    ("event_period<step", src("  replan { event_period = 1e-9 s }"), "1e-9 s"),
    ("waypoint_period<step", src("  replan { waypoint_period = 0.1 s }"), "0.1 s"),
]
GOOD = [
    ("threshold=0.2", src("  threshold = 0.2")),
    ("capacity=1000", src(extra="  capacity = 1000\n")),
    ("K=1e5", src("  risk { K = 1e5 }", head=RISKY)),
    ("event_period=step", src("  replan { event_period = 0.5 s }")),
    ("waypoint_period=1e300", src("  replan { waypoint_period = 1e300 s }")),
]


@pytest.mark.parametrize("case, text, value", BAD, ids=[b[0] for b in BAD])
def test_out_of_range_is_stl207_at_the_value(case, text, value):
    diags = diagnose(text)
    assert [d.code for d in diags] == ["STL207"], diags
    assert at(text, diags[0]) == value


@pytest.mark.parametrize("case, text", GOOD, ids=[g[0] for g in GOOD])
def test_in_range_is_accepted(case, text):
    assert diagnose(text) == []
