"""The fast fuzz profile (CI): Hypothesis over the fuzzer's generators, in process, and a
short run of the worker-process runner.  The long profile is ``python -m stlc.fuzz``.

Every input must be *diagnosed* (located diagnostics) or *accepted* (strict JSON from
``monitor --json``); never an internal error, a hang or an unlocated diagnostic.
"""

from __future__ import annotations

import random

import pytest

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from stlc import fuzz, interrupt
from stlc.fuzz.runner import classify, plan, run

SEEDS = fuzz.seed_files()
FAST = settings(max_examples=60, deadline=None, derandomize=True,
                suppress_health_check=[HealthCheck.too_slow])


def outcome(case: dict) -> str:
    cls, detail = interrupt.run(lambda: classify(case))
    assert cls in ("diagnosed", "accepted"), f"{cls}: {detail}\n--- input:\n{case['stl']!r}"
    return cls


def case(stl, trace=None) -> dict:
    return {"kind": "test", "seed": 0, "stl": stl, "trace": trace}


@FAST
@given(st.randoms(use_true_random=False))
def test_generated_files_are_diagnosed_or_accepted(rng):
    outcome(case(fuzz.gen_source(rng)))


@FAST
@given(st.randoms(use_true_random=False), st.sampled_from(SEEDS))
def test_mutated_shipped_specs_are_diagnosed_or_accepted(rng, seed_file):
    with open(seed_file, encoding="utf-8") as fh:
        outcome(case(fuzz.mutate(fh.read(), rng)))


@FAST
@given(st.randoms(use_true_random=False))
def test_damaged_traces_are_diagnosed_or_give_strict_json(rng):
    stl = "signal x, y, z\nspec a = always[0, 1] (x <= 1)\nspec b = not a\n" \
          "spec c = eventually[0.5, 2] (sqrt(y) > z)\n"
    outcome(case(stl, fuzz.damage_trace(fuzz.gen_trace(rng), rng)))


@settings(max_examples=15, deadline=None, derandomize=True)
@given(st.integers(0, 10**6))
def test_deep_inputs_are_handled(seed):
    outcome(case(fuzz.gen_deep(random.Random(seed))))


@settings(max_examples=40, deadline=None, derandomize=True)
@given(st.text(alphabet=st.sampled_from(list("x=1(){}[]#;,\r\n\f\v\u2028 and\t")), max_size=80))
def test_odd_bytes_and_line_endings(text):
    outcome(case("signal x\n" + text))


def test_every_shipped_spec_is_accepted():
    for f in SEEDS:
        if "/diagnostics/" in f:
            continue
        with open(f, encoding="utf-8") as fh:
            assert outcome(case(fh.read())) == "accepted", f


def test_plan_splits_inputs_over_every_kind():
    p = plan(1000)
    assert len(p) == 1000
    assert {k for k, _ in p} == set(fuzz.KINDS)
    assert len(set(p)) == 1000


def test_runner_fast_profile():
    report = run(n=150, seed=12345, jobs=1, timeout=10.0)
    assert report.total == 150
    assert report.failures == []
    table = report.table()
    assert table.splitlines()[0].split("|")[1].strip() == "kind"
    assert "all" in table


# ---------------------------------------------------------------- whole commands (issue 23)


@pytest.mark.parametrize("kind, seed", [("simulate", 1), ("simulate", 3), ("team", 3),
                                        ("team", 5), ("resource", 0), ("resource", 4)])
def test_command_inputs_are_diagnosed_or_accepted_without_data_loss(kind, seed):
    """A few fast whole-command inputs (the long profile runs hundreds: README): every
    outcome is diagnosed or accepted, and the user files in the output directory survive."""
    outcome(fuzz.make_input(kind, seed, SEEDS))


def test_the_runner_reports_mem_and_hang_as_failures():
    assert {"mem", "hang", "dataloss"} <= set(fuzz.BAD) <= set(fuzz.CLASSES)
    r = run(3, seed=0, jobs=1, timeout=60, kinds=("resource",))
    assert r.bad() == 0, r.failures
    assert set(r.counts) == {"resource"} and r.total == 3
    assert "mem" in r.table() and "dataloss" in r.table()
