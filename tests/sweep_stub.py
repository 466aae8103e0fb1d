"""A sweep task for ``tests/test_sweep_overhead.py``: an instance past the middle of the
``op.pos.x`` axis, sent cold (pre-emptible), does not solve but waits — as a slow cold
solve would — until the client pre-empts it (or 60 s pass); every other task is the real
``stlc.sweeping.task.run_instance``.  Importable by the Dask workers (the tests' folder is on
their path)."""

from __future__ import annotations

import threading
import time

from stlc import deadline
from stlc.sweeping import task


def run_instance(source, path, mission, items, values, index, **kw):
    if kw.get("preempt") is None or values["op.pos.x"] <= 1.25:
        return task.run_instance(source, path, mission, items, values, index, **kw)
    fired = threading.Event()
    t0 = time.monotonic()
    with deadline.bounded(60.0), task.preemptible(task._event(kw["preempt"]), fired):
        while not deadline.solve_expired() and time.monotonic() - t0 < 60:
            time.sleep(0.05)
    return {"instance": index, "values": values, "status": "stopped", "error": "",
            "robustness": float("nan"), "specs": {}, "iterations": 0, "solve_s": 0.0,
            "total_s": time.monotonic() - t0, "worker": "stub", "built": True, "warm": "",
            "plan_csv": None, "channels": None, "preempted": fired.is_set()}
