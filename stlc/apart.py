"""Run work in a forked child process, beside the parent's work.

The seed backend of a single-vehicle mission (the kinematic guess) and the lowering of the
next backend (the full NLP) do not depend on each other, so ``run_chain`` lowers the NLP
while the guess is computed apart; the compile's outputs write the flight-stack files apart
while the report is rendered.  CasADi's symbolic layer is not thread-safe (SX/MX reference
counts are shared) and Python's own work holds one interpreter, so the two cannot be
threads; a forked child has its own copy of everything and sends its result back pickled
through a pipe.

``start(fn, *args)`` forks and returns a waiter; calling it returns ``fn(*args)`` and the
child's CPU seconds (``waiter.cancel()`` kills the child instead).  Where ``fork`` is
missing, or the child failed (it died, or ``fn`` raised), the waiter calls ``fn``
in-process instead, so the result never depends on the process model.  Ctrl-C: SIGINT
kills the child with its process group; a waiting parent polls ``interrupt.requested()``,
kills the child and raises ``KeyboardInterrupt`` at once.
"""

from __future__ import annotations

import contextlib
import os
import pickle
import select
import signal
import time
from collections.abc import Callable
from typing import Any

from stlc import interrupt, settings

POLL_S = 0.05


def _child(fn: Callable[..., Any], args: tuple, wfd: int) -> None:
    try:
        signal.signal(signal.SIGINT, signal.SIG_DFL)
        data = pickle.dumps(("ok", fn(*args)))
    except BaseException as e:  # noqa: BLE001 - reported to the parent, which re-runs fn
        data = pickle.dumps(("error", repr(e)))
    try:
        with os.fdopen(wfd, "wb") as f:
            f.write(data)
    finally:
        os._exit(0)


def _cpu(rusage) -> float:
    return float(rusage.ru_utime + rusage.ru_stime)


def start(fn: Callable[..., Any], *args: Any) -> Callable[[], tuple[Any, float]]:
    """Call ``fn(*args)`` in a forked child; the returned waiter gives (result, child CPU s)."""
    if not hasattr(os, "fork") or settings.no_fork():
        return _inline(fn, args)
    rfd, wfd = os.pipe()
    pid = os.fork()
    if pid == 0:  # pragma: no cover - the child ends in os._exit
        os.close(rfd)
        _child(fn, args, wfd)
    os.close(wfd)

    def kill() -> None:
        os.kill(pid, signal.SIGKILL)
        os.waitpid(pid, 0)

    def cancel() -> None:
        """Kill the child (the chain failed or was interrupted before waiting)."""
        with contextlib.suppress(OSError):
            kill()
            os.close(rfd)

    def wait() -> tuple[Any, float]:
        chunks = []
        try:
            while True:
                if interrupt.requested():
                    raise KeyboardInterrupt
                ready, _, _ = select.select([rfd], [], [], POLL_S)
                if ready:
                    chunk = os.read(rfd, 1 << 20)
                    if not chunk:
                        break
                    chunks.append(chunk)
        except BaseException:
            kill()
            raise
        finally:
            os.close(rfd)
        _, status, rusage = os.wait4(pid, 0)
        if os.WIFSIGNALED(status) and os.WTERMSIG(status) == signal.SIGINT:
            raise KeyboardInterrupt  # Ctrl-C reached the child first
        try:
            kind, value = pickle.loads(b"".join(chunks))
        except Exception:  # noqa: BLE001 - the child died before sending a whole result
            kind, value = "error", None
        if kind != "ok":
            return _inline(fn, args)()
        return value, _cpu(rusage)

    wait.cancel = cancel  # type: ignore[attr-defined]
    return wait


def _inline(fn: Callable[..., Any], args: tuple) -> Callable[[], tuple[Any, float]]:
    def wait() -> tuple[Any, float]:
        c0 = time.process_time()
        value = fn(*args)
        return value, time.process_time() - c0

    wait.cancel = lambda: None  # type: ignore[attr-defined]  # nothing runs before the wait
    return wait
