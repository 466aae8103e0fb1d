"""What a sweep's worker does around the solve, made cheaper without changing a result: the
file's check kept between tasks (``overrides.base``) equals a fresh check, a pre-empted
instance's time limit ends at once, and a pre-empted cold try waits again (brute force)."""

from __future__ import annotations

import threading
import time

import numpy as np
import pytest
from test_set import SOURCE

from stlc import deadline
from stlc.frontend.syntax import parse
from stlc.semantics import overrides
from stlc.sweeping.order import Order
from stlc.sweeping.task import preemptible

ITEMS = [
    [("op.att.z", "30 deg"), ("op.pos.x", "1.2 m")],
    [("op.att.z", "-0.5 rad"), ("p.start.pos.y", "20 cm")],
    [("T", "2 s"), ("op.pos.y", "-0.1 m")],  # a const: checked again
    [],
]


@pytest.mark.parametrize("items", ITEMS)
def test_kept_check_equals_a_fresh_one(items):
    tree = parse(SOURCE, "m.stl")
    base = overrides.base(tree)
    kept, v1 = overrides.checked(tree, items, checked_base=base)
    fresh, v2 = overrides.checked(parse(SOURCE, "m.stl"), items)
    assert v1 == v2
    assert kept.params == fresh.params
    assert kept.vehicles == fresh.vehicles
    assert kept.scenario == fresh.scenario
    assert repr(kept.missions["m"].requirement) == repr(fresh.missions["m"].requirement)
    # the kept base is not changed by an instance
    again, _ = overrides.checked(tree, [], checked_base=base)
    assert again.params == overrides.checked(parse(SOURCE, "m.stl"))[0].params


def test_preempted_block_sees_its_limit_end():
    fired = threading.Event()
    flag = {"set": False}
    with deadline.bounded(100.0):
        with preemptible(lambda: flag["set"], fired):
            time.sleep(0.3)
            assert not deadline.solve_expired() and not fired.is_set()
            flag["set"] = True
            t0 = time.monotonic()
            while not deadline.solve_expired() and time.monotonic() - t0 < 5:
                time.sleep(0.01)
            assert deadline.solve_expired() and fired.is_set()
    assert not deadline.active()
    with deadline.bounded(100.0), preemptible(None, fired := threading.Event()):
        time.sleep(0.05)
        assert not deadline.solve_expired() and not fired.is_set()


def test_requeued_instance_is_chosen_again_by_distance():
    """A pre-empted cold try waits again; then ``next`` gives, as always, the waiting
    instance nearest to a solved one — checked against brute force over the grid."""
    pts = [{"a": float(a), "b": float(b)} for a in range(5) for b in range(4)]
    o = Order(pts, ["a", "b"])
    first = o.seeds(2)
    solved, pre = first
    o.add(solved, pts[solved], {"x": np.zeros(3)}, "")
    o.requeue(pre)
    seen = {solved}
    while True:
        i = o.next()
        if i is None:
            break
        waiting = [j for j in range(len(pts)) if j not in seen and j != i]
        x = o.x
        d = lambda j: min(np.linalg.norm(x[j] - x[s]) for s in seen)  # noqa: E731
        assert d(i) <= min([d(j) for j in waiting], default=np.inf) + 1e-12
        seen.add(i)
        o.add(i, pts[i], {"x": np.zeros(3)}, "")
    assert seen == set(range(len(pts)))  # the pre-empted instance was solved too


def test_first_plan_preempts_a_slow_cold_instance(tmp_path, monkeypatch):
    """Two workers start cold on one instance each; the one past the axis' middle never
    finishes by itself (``sweep_stub``).  The first plan pre-empts it: it is solved again,
    warm, by the real task, and the sweep has one satisfied row per instance."""
    import csv
    import json

    import sweep_stub

    from stlc.sweeping import run

    monkeypatch.setattr("stlc.sweeping.task.run_instance", sweep_stub.run_instance)
    f = tmp_path / "m.stl"
    f.write_text(SOURCE)
    out = tmp_path / "out"
    t0 = time.monotonic()
    rc = run.sweep(str(f), "m", ["op.pos.x=1 m:1.5 m:4"], [], str(out), workers=2, quiet=True)
    assert time.monotonic() - t0 < 55  # not the stub's 60 s
    assert rc == 0
    with open(out / "sweep.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    assert [int(r["instance"]) for r in rows] == [0, 1, 2, 3]
    assert {r["status"] for r in rows} == {"satisfied"}
    assert "stub" not in {r["worker"] for r in rows}  # the kept rows are real solves
    summary = json.loads((out / "sweep.json").read_text())
    assert summary["preempted"] == 1
    assert summary["nlp_builds"] >= 2  # the stub's "build" counts


def test_map_threads_follow_the_environment(monkeypatch):
    import os

    from stlc.backends.nlp.derivatives import MAX_THREADS, map_threads

    monkeypatch.delenv("STLC_MAP_THREADS", raising=False)
    assert map_threads() == max(1, min(os.cpu_count() or 1, MAX_THREADS))
    for value, want in (("1", 1), ("0", 1), ("x", max(1, min(os.cpu_count() or 1,
                                                                MAX_THREADS)))):
        monkeypatch.setenv("STLC_MAP_THREADS", value)
        assert map_threads() == want


def test_local_workers_get_their_share_of_the_cores(tmp_path):
    # K worker processes on the machine's cores: each derivative map gets cores // K threads
    import os

    from stlc.sweeping.run import dask_client

    client, cluster = dask_client(2, None, str(tmp_path / "x.stl"))
    try:
        got = client.run(lambda: os.environ.get("STLC_MAP_THREADS"))
        assert sorted(got.values()) == [str(max(1, (os.cpu_count() or 1) // 2))] * 2
    finally:
        client.close()
        cluster.close()
