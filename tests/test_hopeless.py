"""A start that cannot meet κ is an error at check time (STL505), before any planning.

* the workspace floor: the handover with its start on the floor (z = 0) and κ = 0.01 —
  `stlc check` exits 1 in well under a second, naming the mission, the spec `safety`, the
  predicate (the workspace's z ≥ lo face), the time (0 s) and the value (+0 m);
* inside a grown obstacle, over a speed limit, inside a round obstacle: the value the error
  names is the one computed here by hand;
* only proofs: κ = 0 on the boundary, an `eventually`, an `always` that starts later, an
  `or` with a temporal operand — no error;
* `stlc compile` and `stlc simulate` stop at once with exit 1 and write nothing.
"""

from __future__ import annotations

import re
import subprocess
import sys
import time
from pathlib import Path

import pytest

from stlc.analysis.hopeless import hopeless
from stlc.frontend.syntax import parse
from stlc.semantics.check import check

ROOT = Path(__file__).resolve().parent.parent
HANDOVER = ROOT / "specs" / "handover.stl"


@pytest.fixture
def floor(tmp_path) -> Path:
    src = HANDOVER.read_text()
    moved = src.replace("start { pos = (-1.8, 0, 1.0) m;", "start { pos = (-1.8, 0, 0) m;")
    assert moved != src
    path = tmp_path / "floor.stl"
    path.write_text(moved)
    return path


def test_workspace_floor_is_an_error_at_check(floor):
    t0 = time.perf_counter()
    r = subprocess.run([sys.executable, "-m", "stlc", "check", str(floor)],
                       capture_output=True, text=True, timeout=60)
    wall = time.perf_counter() - t0
    assert r.returncode == 1
    errors = [ln for ln in r.stderr.splitlines() if "error[STL505]" in ln]
    assert len(errors) == 3  # one per mission of the file
    for ln in errors:
        assert "spec `safety`" in ln and "`uav1.pos in workspace (z >= lo)`" in ln
        assert "at t = 0 s" in ln and "+0 m" in ln and "κ = 0.01" in ln
    assert re.search(r"floor\.stl:44:31: error\[STL505\]: mission `handover_left_tb`", r.stderr)
    # the check itself, past the interpreter's start: far under a second
    prog = check(parse(floor.read_text(), str(floor)))
    t0 = time.perf_counter()
    diags = hopeless(prog)
    assert time.perf_counter() - t0 < 1.0 and len(diags) == 3
    assert wall < 30  # the whole command, interpreter included (a loaded machine)


def test_compile_stops_before_planning(floor, tmp_path):
    out = tmp_path / "out"
    t0 = time.perf_counter()
    r = subprocess.run([sys.executable, "-m", "stlc", "compile", str(floor), "--mission",
                        "handover_left", "-o", str(out)], capture_output=True, text=True,
                       timeout=120)
    assert r.returncode == 1 and "error[STL505]" in r.stderr
    assert "IPOPT" not in r.stderr and "iter" not in r.stderr  # nothing was planned
    assert not out.exists() or not any(out.iterdir())
    assert time.perf_counter() - t0 < 60
    r = subprocess.run([sys.executable, "-m", "stlc", "simulate", str(floor), "--mission",
                        "handover_left", "-o", str(out)], capture_output=True, text=True,
                       timeout=120)
    assert r.returncode == 1 and "error[STL505]" in r.stderr
    assert not out.exists() or not any(out.iterdir())


PM = """\
vehicle d : point_mass {{
  vel_max = (2, 2, 2) m/s
  acc_max = (1, 1, 1) m/s^2
  radius = 0.3 m
  start {{ pos = {pos} m; vel = {vel} m/s }}
}}
scenario {{
  workspace = box((-5, -5, 0), (5, 5, 4)) m
  obstacle pole = box((1, -1, 0), (2, 1, 4)) m
  obstacle tower = cylinder(center = (-3, 3, 2) m, radius = 1 m, height = 4 m)
}}
mission m {{
  vehicles = [d]
  horizon = 5 s
  step = 0.5 s
  threshold = {kappa}
  spec s = {spec}
  require s
}}
"""


def _diags(spec: str, pos="(0, 0, 1)", vel="(0, 0, 0)", kappa="0.05"):
    return hopeless(check(parse(PM.format(spec=spec, pos=pos, vel=vel, kappa=kappa), "<h>")))


def _value(d) -> float:
    return float(re.search(r"start gives ([-+0-9.e]+)", d.message).group(1))


def test_inside_the_grown_obstacle():
    # 0.8 m west of the pole's face x = 1: 0.2 m from it, less the 0.3 m radius
    (d,) = _diags("always[0, 5] (d.pos not in pole)", pos="(0.8, 0, 1)")
    assert d.code == "STL505" and "spec `s`" in d.message and "d.pos not in pole" in d.message
    assert _value(d) == pytest.approx(0.2 - 0.3)
    assert "m" in d.message.split("gives")[1]


def test_over_a_limit_and_inside_a_round_obstacle():
    (d,) = _diags("always[0, 5] (d.speed <= 0.5 m/s)", vel="(1, 0, 0)")
    assert _value(d) == pytest.approx(-0.5) and "m/s" in d.message
    # 1.5 m from the tower's axis: 0.5 m outside its surface, 0.2 m outside the grown one
    assert not _diags("always[0, 5] (d.pos not in tower)", pos="(-1.5, 3, 2)", kappa="0.1")
    (d,) = _diags("always[0, 5] (d.pos not in tower)", pos="(-1.5, 3, 2)", kappa="0.3")
    assert _value(d) == pytest.approx(0.2)
    (d,) = _diags("always[0, 5] (dist(d.pos, tower) >= 1 m)", pos="(-3, 3.5, 2)")
    assert _value(d) == pytest.approx(-0.5 - 1.0)  # inside: 0.5 m from the side


@pytest.mark.parametrize("spec,pos,kappa", [
    ("always[0, 5] (d.pos in workspace)", "(0, 0, 0)", "0"),  # on the boundary, κ = 0
    ("eventually[0, 5] (d.pos in workspace)", "(0, 0, 0)", "0.05"),  # it may climb
    ("always[1, 5] (d.pos in workspace)", "(0, 0, 0)", "0.05"),  # not at t = 0
    ("always[0, 5] (d.pos in workspace) or eventually[0, 5] (d.pos.z >= 1 m)", "(0, 0, 0)",
     "0.05"),
    ("always[0, 5] (d.acc.x <= 0.5 m/s^2)", "(0, 0, 1)", "0.05"),  # an input: free
])
def test_only_proofs_are_reported(spec, pos, kappa):
    assert _diags(spec, pos=pos, kappa=kappa) == []


def test_until_left_side_and_margins():
    # the left side of an until must hold at 0; a margin in m/s decides for the speed
    (d,) = _diags("(d.pos.z >= 1.2 m) until[0, 5] (d.pos.z >= 2 m)")
    assert _value(d) == pytest.approx(1.0 - 1.2)
    text = PM.format(spec="always[0, 5] (d.speed <= 1 m/s and d.pos in workspace)",
                     pos="(0, 0, 1)", vel="(0.95, 0, 0)", kappa="0")
    ok = text.replace("threshold = 0", "margin = [0.5 m, 0.01 m/s]")
    assert hopeless(check(parse(ok, "<h>"))) == []
    bad = text.replace("threshold = 0", "margin = [0.5 m, 0.1 m/s]")
    (d,) = hopeless(check(parse(bad, "<h>")))
    assert _value(d) == pytest.approx(0.05 - 0.1)  # 0.05 m/s of slack, 0.1 asked


def test_language_server_shows_it(floor):
    from stlc.tools import ide

    an = ide.analyze(floor.read_text(), str(floor))
    assert [d.code for d in an.diagnostics if d.severity == "error"] == ["STL505"] * 3
