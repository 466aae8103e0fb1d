"""The command line's small things and the report's flags: ``stlc --version``, help text on
every option, a "did you mean" for misspelt keywords, hints for ``team`` outside a mission
and for units written apart (``m / s``), sweep axes in the units they were given in,
warnings counted as shown, and the summary's flags for a close pass to an obstacle and a
high violation probability (levels from ``stlc.output.report.flags``)."""

from __future__ import annotations

import argparse
import math
import subprocess
import sys

import numpy as np
import pytest

import stlc
from stlc import cli
from stlc.diagnostics import Diagnostic, Span, count_text, emit_warnings
from stlc.output.report import build_view, render_report
from stlc.output.report.flags import CLOSE_PASS_M, HIGH_RISK, close_passes, high_risk
from stlc.planning.solution import Solution
from stlc.sweeping.axes import Axis, parse_axis
from stlc.sweeping.report import render


def check(tmp_path, text: str, capsys) -> str:
    f = tmp_path / "m.stl"
    f.write_text(text, encoding="utf-8")
    assert cli.main(["check", str(f)]) == 1
    return capsys.readouterr().err


def test_version_prints_and_exits_0():
    r = subprocess.run([sys.executable, "-m", "stlc", "--version"], capture_output=True,
                       text=True, timeout=60)
    assert r.returncode == 0 and r.stdout.strip() == f"stlc {stlc.__version__}"


def test_every_option_has_help():
    missing = []

    def walk(p: argparse.ArgumentParser, path: str) -> None:
        for a in p._actions:
            if isinstance(a, argparse._SubParsersAction):
                for name, sp in a.choices.items():
                    walk(sp, f"{path} {name}")
            elif not isinstance(a, argparse._HelpAction) and not a.help:
                missing.append(f"{path} {'/'.join(a.option_strings) or a.dest}")

    walk(cli._parser(), "stlc")
    assert missing == []


@pytest.mark.parametrize("typo, meant", [("eventualy", "eventually"), ("alwyas", "always"),
                                         ("forral", "forall")])
def test_misspelt_keyword_gets_did_you_mean(tmp_path, capsys, typo, meant):
    err = check(tmp_path, f"spec a = {typo}[0, 1] (1 > 0)\n", capsys)
    assert f"did you mean `{meant}`?" in err and "error[STL002]" in err


def test_misspelt_operator_called_like_a_function(tmp_path, capsys):
    err = check(tmp_path, "spec a = eventualy (1 > 0)\n", capsys)
    assert "error[STL107]" in err and "did you mean the operator `eventually`?" in err


def test_team_outside_a_mission_and_spaced_units(tmp_path, capsys):
    err = check(tmp_path, (
        "vehicle u : point_mass {\n  vel_max = (1, 1, 1) m / s\n"
        "  acc_max = (1, 1, 1) m/s^2\n  start { pos = (0, 0, 1) m }\n}\n"
        "spec low = forall d in team: always[0, 1] (d.pos.z > 0 m)\n"), capsys)
    assert "unknown name `s`" in err and "without spaces" in err and "`m / s`" in err
    assert "unknown name `team`" in err and "only inside `mission NAME" in err


def test_sweep_page_shows_axes_in_the_units_given():
    ax = parse_axis("f.stl", "operator.att.z=-30 deg:30 deg:3")
    assert (ax.lo, ax.hi, ax.unit) == (-30.0, pytest.approx(30.0), "deg")
    assert ax.label == "operator.att.z (deg)"
    rows = [{"instance": i, "values": {"operator.att.z": math.radians(d)}, "status": "satisfied",
             "robustness": 0.1, "specs": {}, "iterations": 3, "solve_s": 0.1, "total_s": 0.2,
             "worker": "w", "error": ""} for i, d in enumerate((-30.0, 0.0, 30.0))]
    page = render({"mission": "m", "file": "f.stl", "finished": 3, "instances": 3,
                   "interrupted": False, "counts": {"satisfied": 3}, "wall_s": 1.0,
                   "per_instance_s": 0.3, "nlp_builds": 1, "warm_started": 2,
                   "scheduler": "x", "solve_s": {}, "random": None}, [ax], rows, [])
    assert "<th>operator.att.z (deg)</th>" in page
    assert "<td>-30</td>" in page and "<td>30</td>" in page
    assert "-0.523599" not in page  # not in radians
    assert '"xname":"operator.att.z (deg)"' in page and '"x":[-30.0,0.0,30.0]' in page
    assert Axis("a", 1.0, 2.0, 2, "cm", 0.01).shown(0.015) == pytest.approx(1.5)


def test_warnings_are_counted_as_shown(capsys):
    w = Diagnostic("STLW04", "spec `x` is never read", Span("<t>", 1, 1, 1, 2),
                   severity="warning")
    emit_warnings([w], False, {})
    err = capsys.readouterr().err
    assert err.count("warning[STLW04]") == 1 and err.rstrip().endswith("stlc: 1 warning")
    e = Diagnostic("STLW02", "vacuous", Span("<t>", 1, 1, 1, 2), severity="error")
    emit_warnings([e], False, {})  # a plan's warning under --deny-warnings: shown as error
    err = capsys.readouterr().err
    assert "error[STLW02]" in err and err.rstrip().endswith("stlc: 1 error")
    assert count_text([e, w, w]) == "1 error, 2 warnings"


# ------------------------------------------------------------------ report flags

POLE = """\
vehicle uav1 : point_mass {
  vel_max = (2, 2, 1) m/s
  acc_max = (3, 3, 2) m/s^2
  radius = 0.05 m
  start { pos = (0, 0, 1) m }
}
scenario {
  workspace = box((-5, -5, 0), (5, 5, 3)) m
  obstacle pole = box((1, 1, 0), (1.2, 1.2, 3)) m
}
mission pass {
  vehicles = [uav1]
  horizon = 2 s
  step = 1 s
  spec safe = always[0, 2] (uav1.pos not in pole)
  require safe
  maximize robustness
}
"""


def pole_plan(y: float):
    """A hand-made plan passing the pole's face x = 1 at distance ``1 - 0.91`` along y."""
    program = stlc.loads(POLE, "pole.stl")
    m = program.missions["pass"]
    t = np.array([0.0, 1.0, 2.0])
    ch = {"uav1.pos.x": np.array([0.0, 0.91, 0.0]), "uav1.pos.y": np.array([0.0, y, 2.0]),
          "uav1.pos.z": np.ones(3)}
    return program, m, Solution("pass", "satisfied", 0.04, 0.04, {}, math.nan, t, ch)


def test_close_pass_is_flagged_at_the_top_of_the_summary():
    program, m, sol = pole_plan(1.1)  # at t = 1 s: 0.09 m from the face x = 1 (y inside)
    flags = close_passes(program, m, sol)
    assert len(flags) == 1 and "9 cm" in flags[0]["text"] and "t ≈ 1 s" in flags[0]["text"]
    assert f"{CLOSE_PASS_M * 100:.0f} cm" in flags[0]["text"]
    page = render_report(build_view(program, m, sol))
    top = page.index('id="summary"')
    assert top < page.index("Close pass") < page.index('class="tiles"')
    far = pole_plan(3.0)  # (0.91, 3) is 1.8 m from the pole: no flag
    assert close_passes(*far) == []


def test_high_violation_probability_is_flagged():
    risk = {"cases": [
        {"name": "operator", "K": 15000, "delta": 0.01,
         "p_violation": {"value": 0.9569, "upper": 0.9606, "count": 14353}},
        {"name": "calm", "K": 100, "delta": 0.05,
         "p_violation": {"value": HIGH_RISK / 2, "upper": 0.1, "count": 5}}]}
    flags = high_risk(risk)
    assert [f["kind"] for f in flags] == ["risk"]
    assert "`operator`" in flags[0]["text"] and "96 %" in flags[0]["text"]
    assert "15000 realisations" in flags[0]["text"]
    program, m, sol = pole_plan(3.0)
    sol.risk = risk
    page = render_report(build_view(program, m, sol))
    assert page.index("High violation risk") < page.index('class="tiles"')
