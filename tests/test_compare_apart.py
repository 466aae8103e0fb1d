"""An energy-first mission's robustness-only ``compare`` plans are solved in a forked child
beside the energy stage (``schedule.COMPARE_APART``): the same plans, stages and records as
when they are solved in process after it — only the wall time differs."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from stlc import pipeline
from stlc import apart
from stlc.backends.nlp import schedule

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def program():
    return pipeline.load(str(ROOT / "specs" / "handover.stl")).program


def test_compare_plans_solved_apart_equal_those_solved_in_process(program, monkeypatch):
    started = []
    real_start = apart.start

    def spy(fn, *args):
        started.append(fn.__name__)
        return real_start(fn, *args)

    monkeypatch.setattr(apart, "start", spy)
    m = program.missions["handover_left_tb"]
    sols = {}
    for ahead in (True, False):
        monkeypatch.setattr(schedule, "COMPARE_APART", ahead)
        started.clear()
        sols[ahead] = pipeline.plan(program, m, step=0.25)[1]
        assert ("_guess_compares" in started) == ahead
    a, b = sols[True], sols[False]
    assert a.status == b.status == "satisfied"
    sa, sb = a.solver["stages"], b.solver["stages"]
    assert [s["label"] for s in sa] == [s["label"] for s in sb] == ["energy",
                                                                      "compare no_energy"]
    for x, y in zip(sa, sb):  # the same solves: a forked child computes what the parent would
        assert x["iterations"] == y["iterations"] and x["status"] == y["status"]
        assert x["exact"] == pytest.approx(y["exact"], abs=1e-9)
        assert x["objective"] == pytest.approx(y["objective"], abs=1e-9)
        assert x["t_verify"] > 0.0 and y["t_verify"] > 0.0
    [ca], [cb] = a.comparisons, b.comparisons
    assert ca.label == cb.label == "no_energy"
    assert ca.energy == pytest.approx(cb.energy, rel=1e-9)
    for k in cb.channels:
        np.testing.assert_allclose(ca.channels[k], cb.channels[k], atol=1e-9)
