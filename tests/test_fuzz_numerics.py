"""The fuzzer's classes with a known right answer (``stlc.fuzz.numerics``) at a small
budget in CI: large coordinates, boundary optima, written-file round trips, ``fmt``
idempotence and the language server's analysis — no wrong verdict, internal error or
hang.  The long profile: ``python -m stlc.fuzz --kinds coords,boundary,roundtrip,fmt,lsp``."""

from __future__ import annotations

from stlc.fuzz import numerics
from stlc.fuzz.runner import run


def test_numeric_classes_small_budget():
    kinds = numerics.KINDS
    report = run(n=2 * len(kinds), seed=101, jobs=1, timeout=60.0, kinds=kinds)
    assert report.total == 2 * len(kinds)
    assert set(report.counts) == set(kinds)
    assert report.failures == [], report.failures


def test_boundary_inputs_have_the_floor_binding():
    import random

    text = numerics.survey(random.Random(3), floor=True)
    assert "start { pos = (" in text and ", 0.0) m }" in text and "threshold = 0" in text
