"""Predicates keep their structure: the checker records which signal a simple predicate
bounds and by how much (``ir.Bound``), and the report's limits are read from that data."""

from __future__ import annotations

from pathlib import Path

import pytest

from stlc.pipeline import load
from stlc.planning.bounds import bound_specs, plot_bounds, stated_bounds
from stlc.planning.problem import from_mission
from stlc.semantics import ir, nnf

SPECS = Path(__file__).resolve().parent.parent / "specs"


def test_handover_bounds_from_predicate_structure():
    program = load(str(SPECS / "handover.stl")).program
    m = program.missions["handover_left_tb"]
    got = stated_bounds(nnf.normalize(m.requirement))
    assert got["speed"] == [0.0, pytest.approx(0.4)]
    assert got["rotor_speed"] == [pytest.approx(40.0), pytest.approx(80.0)]
    assert got["heading_margin_deg"] == pytest.approx(30.0)
    assert got["hover_speed"] == pytest.approx(0.1)
    # the vehicle's own limits join them; the hover threshold is not a plotted limit
    pb = plot_bounds(from_mission(program, m))
    assert pb["force"] == [pytest.approx(0.29), pytest.approx(11.5)]
    assert "hover_speed" not in pb
    specs = {k: s.formula for k, s in from_mission(program, m).specs.items()}
    assert bound_specs(specs) == {"speed": ["comfort"], "rotor_speed": ["comfort"],
                                    "heading_margin_deg": ["comfort"],
                                    "hover_speed": ["comfort"]}


def test_bound_follows_negation_and_constant_side(tmp_path):
    src = tmp_path / "b.stl"
    src.write_text("signal x\nspec a = always (2 >= x)\nspec b = not (x in [1, 3])\n",
                   encoding="utf-8")
    program = load(str(src)).program
    (pa,) = ir.predicates(nnf.normalize(program.specs["a"]))
    assert (pa.bound.signal, pa.bound.side, pa.bound.value) == ("x", "upper", 2.0)
    lo, hi = ir.predicates(nnf.normalize(program.specs["b"]))
    # not (1 <= x <= 3) = x < 1 or x > 3: the sides swap, the values stay
    assert {(p.bound.side, p.bound.value) for p in (lo, hi)} == {("upper", 1.0),
                                                                  ("lower", 3.0)}


def test_team_separation_bound():
    program = load(str(SPECS / "bird_diverter_2x7.stl")).program
    m = next(iter(program.missions.values()))
    assert stated_bounds(nnf.normalize(m.requirement))["distance_min"] == pytest.approx(3.0)
