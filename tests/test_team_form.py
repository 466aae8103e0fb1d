"""Judging the executed team of a takeover from the checked mission (issue 18): the
checker keeps each team quantifier's per-drone template (``stlc.semantics.teamform``), and
a pure function re-instantiates the mission for the executed team (the backup added) —
no source text, parser or checker after check time, so ``--set`` values are kept.

Expected values come from the *edited file*: its text with the ``--set`` value written in
and the backup written into ``vehicles = [...]``, parsed and checked on its own, then the
exact monitor on the executed trajectory."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from stlc import pipeline
from stlc.analysis import monitor
from stlc.backends.backup import TakeoverBackend
from stlc.frontend.syntax import parse
from stlc.planning.problem import from_mission
from stlc.planning.verify import recompute_derived
from stlc.replan import takeover
from stlc.semantics import model
from stlc.semantics.check import check

ROOT = Path(__file__).resolve().parents[1]
CROSS = ROOT / "tests" / "missions" / "takeover_cross.stl"


def edited_mission(text: str, mission: str, team: tuple[str, ...], path: str):
    """The mission of ``text`` with ``team`` written as its vehicles, checked from text."""
    pat = re.compile(r"(mission\s+" + re.escape(mission) + r"\s*\{.*?vehicles\s*=\s*)\[[^\]]*\]",
                     re.S)
    text2, n = pat.subn(lambda m: m.group(1) + "[" + ", ".join(team) + "]", text, count=1)
    assert n == 1
    program = check(parse(text2, path))
    return program, program.missions[mission]


@pytest.mark.parametrize("setting, old, new", [
    ("Gamma_dis=2.5 m", "const Gamma_dis = 2 m", "const Gamma_dis = 2.5 m"),
    ("tb.center.y=3.5 m", "tb = box(center = ( 8, 4, 4)", "tb = box(center = ( 8, 3.5, 4)"),
])
def test_takeover_is_judged_with_the_set_values(setting, old, new):
    loaded = pipeline.load(str(CROSS), [setting])
    program = loaded.program
    problem, sol = pipeline.plan(program, program.missions["cross"])
    res = takeover.simulate_failure(problem, sol, model.Failure("uav1", 2.0, "uav3"),
                                    model.ReplanConfig(takeover_delay=18.0),
                                    planner=TakeoverBackend())
    assert res.events[0].triggered  # the backup joined the executed team
    text = CROSS.read_text()
    assert old in text
    prog_e, m_e = edited_mission(text.replace(old, new), "cross", ("uav1", "uav2", "uav3"),
                                 str(CROSS))
    p_e = from_mission(prog_e, m_e)
    raw = {k: v for k, v in res.executed.items() if k.split(".")[1] in ("pos", "vel", "acc")}
    ch, _ = recompute_derived(p_e, raw)
    want = {"mission": monitor.robustness(p_e.requirement, p_e.grid.dt, ch, p_e.params)}
    for name, spec in p_e.specs.items():
        want[name] = monitor.robustness(spec.normal, p_e.grid.dt, ch, p_e.params)
    for name, value in want.items():
        assert res.executed_robustness[name] == pytest.approx(float(value), abs=1e-9), name
