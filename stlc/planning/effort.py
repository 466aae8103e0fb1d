"""Wall-time budgets of the planners' inner stages, scaled with the problem and the machine.

A stage that searches (a seed's MILP) is given wall time in proportion to its size — its
binaries — not a fixed constant, and that time is stretched by how loaded the machine is
(``load_factor``: the 1-minute load average per core, at least 1), since HiGHS's limit is
wall time and a machine shared with other work gives it only its share of a core.  The
budget never takes more than ``SHARE`` of what the run's time limit leaves for the solvers
(``deadline.solve_remaining``), so the stages after it still run.
"""

from __future__ import annotations

import contextlib
import math
import os
import sys
import threading
import time

from stlc import deadline

SEED_BASE_S = 15.0  #: a seed MILP's budget on an idle core, at least (1–3 s on handovers)
SEED_PER_BINARY_S = 0.05  #: … and this much per binary above that (581 binaries: 29 s)
SHARE = 0.4  #: of the solvers' remaining time, at most
HEARTBEAT_S = 5.0  #: a waiting stage says it is still running this often


def load_factor() -> float:
    """How many times slower than on an idle core wall time passes for one busy thread:
    the 1-minute load average per core, at least 1 (1 where the OS does not tell)."""
    try:
        load = os.getloadavg()[0]
    except (OSError, AttributeError):
        return 1.0
    cores = os.cpu_count() or 1
    return max(1.0, load / cores)


def seed_budget(binaries: int, factor: float | None = None) -> float:
    """Wall seconds for a seed MILP with ``binaries`` binaries: ``SEED_BASE_S`` or
    ``SEED_PER_BINARY_S`` per binary, whichever is larger, times the load factor, at most
    ``SHARE`` of the solvers' remaining time (and at least 0.05 s)."""
    base = max(SEED_BASE_S, SEED_PER_BINARY_S * max(binaries, 0))
    f = load_factor() if factor is None else factor
    left = deadline.solve_remaining()
    cap = SHARE * left if math.isfinite(left) else math.inf
    return float(max(min(base * f, cap), 0.05))


def say(text: str, quiet: bool) -> None:
    """A progress line on stderr (a stage that falls back says so), unless ``quiet``."""
    if not quiet:
        print(text, file=sys.stderr, flush=True)


@contextlib.contextmanager
def heartbeat(text: str, quiet: bool, period: float = HEARTBEAT_S):
    """While the block runs, print ``text`` with the seconds spent every ``period`` s
    (not when ``quiet``): a stage that runs apart (a seed, a guess) is never silent."""
    if quiet:
        yield
        return
    stop = threading.Event()
    t0 = time.perf_counter()

    def beat() -> None:
        while not stop.wait(period):
            print(f"  … {text}: {time.perf_counter() - t0:.0f} s{deadline.progress_note()}",
                  file=sys.stderr, flush=True)

    th = threading.Thread(target=beat, name="stlc-heartbeat", daemon=True)
    th.start()
    try:
        yield
    finally:
        stop.set()
