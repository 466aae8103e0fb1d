"""``stlc.apart``: a solve in a forked child gives the same result as in-process,
falls back to in-process when the child fails, and stops at once on Ctrl-C."""

from __future__ import annotations

import os
import signal
import time

import numpy as np
import pytest

from stlc import interrupt
from stlc import apart

PARENT = os.getpid()


def _square_sum(n: int) -> tuple[int, np.ndarray]:
    a = np.arange(n, dtype=float)
    return os.getpid(), a * a


def test_the_child_computes_the_result():
    wait = apart.start(_square_sum, 1000)
    (pid, value), cpu = wait()
    assert pid != PARENT  # it really ran apart
    assert np.array_equal(value, np.arange(1000.0) ** 2)
    assert cpu >= 0.0


def _fails_in_child() -> int:
    if os.getpid() != PARENT:
        raise RuntimeError("only in the child")
    return 42


def _dies_in_child() -> int:
    if os.getpid() != PARENT:
        os.kill(os.getpid(), signal.SIGKILL)
    return 7


@pytest.mark.parametrize(("fn", "expected"), [(_fails_in_child, 42), (_dies_in_child, 7)])
def test_a_failed_child_falls_back_to_in_process(fn, expected):
    value, _ = apart.start(fn)()
    assert value == expected


def test_without_fork_the_waiter_computes_in_process(monkeypatch):
    monkeypatch.setenv("STLC_NO_FORK", "1")
    (pid, value), _ = apart.start(_square_sum, 10)()
    assert pid == PARENT and value[3] == 9.0


def _sleeps() -> int:
    time.sleep(30)
    return 1


def test_ctrl_c_while_waiting_kills_the_child_at_once(monkeypatch):
    wait = apart.start(_sleeps)
    monkeypatch.setattr(interrupt, "requested", lambda: True)
    t0 = time.monotonic()
    with pytest.raises(KeyboardInterrupt):
        wait()
    assert time.monotonic() - t0 < 1.0


def test_cancel_kills_the_child():
    wait = apart.start(_sleeps)
    t0 = time.monotonic()
    wait.cancel()
    assert time.monotonic() - t0 < 1.0


def test_a_failed_lowering_cancels_the_solve_apart(monkeypatch):
    """run_chain: when the next backend's lowering fails while the seed solves apart, the
    child is killed and the error propagates at once."""
    from stlc.backends.base import Backend, run_chain

    cancelled = []

    class Seed(Backend):
        name = "seed"

        def accepts(self, problem):
            return []

        def lower(self, problem):
            return None, None

        def start(self, lowered, problem):
            wait = apart.start(_sleeps)

            def result():
                return wait()

            def cancel():
                cancelled.append(True)
                wait.cancel()

            result.cancel = cancel
            return result

    class Broken(Backend):
        name = "broken"
        lower_needs_seed = False

        def accepts(self, problem):
            return []

        def lower(self, problem):
            raise RuntimeError("cannot lower")

    t0 = time.monotonic()
    with pytest.raises(RuntimeError, match="cannot lower"):
        run_chain(object(), [Seed(), Broken()])
    assert cancelled and time.monotonic() - t0 < 1.0


def _interrupted_in_child() -> int:
    if os.getpid() != PARENT:
        os.kill(os.getpid(), signal.SIGINT)  # SIG_DFL in the child: it dies of it
        time.sleep(5)
    return 3


def test_a_child_killed_by_ctrl_c_interrupts_the_parent():
    with pytest.raises(KeyboardInterrupt):
        apart.start(_interrupted_in_child)()
