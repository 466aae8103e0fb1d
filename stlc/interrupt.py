"""Running a command so that Ctrl-C stops it at once and deep recursion cannot crash it.

``run(fn)`` calls ``fn`` in a worker thread with a large stack (``STACK_BYTES``) and a high
recursion limit, so that walks over very deep formulas (a chain of hundreds of named specs)
work instead of overflowing, while the main thread waits for it.  Python delivers SIGINT
to the main thread only; there ``run`` turns Ctrl-C into ``request()``: the flag is set
and a ``KeyboardInterrupt`` is raised asynchronously in the worker, which stops pure
Python code at once.  IPOPT runs in C and CasADi swallows exceptions raised in its
iteration callback (the solve just ends early), so the solve schedule calls ``check()``
after every ``nlpsol`` call, which re-raises.  ``deferred()`` marks a short section (the
final renames of the outputs) that an interrupt must not cut in half; the main thread waits
for it to end.  Then ``run`` raises ``KeyboardInterrupt`` in the main thread (the CLI exits
130); a second Ctrl-C, or a worker that does not stop within ``GRACE_S``, ends the wait.
``on_termination()`` gives SIGTERM (``timeout``, ``kill``, a cancelled CI job) and SIGHUP
(a closed terminal) the same contract: they interrupt like Ctrl-C, and ``exit_code()``
is then 128 + the signal's number (143, 129) instead of 130.

``soften(hook)`` (``stlc compile --keep-on-interrupt``) changes what the *first* Ctrl-C
does: ``hook()`` is called from the main thread (``deadline.cut``: the planning limit ends
now, so the solvers stop as on a time limit and the best verified plan is written) and the
command goes on to write its outputs; it then exits 130 (``softened``).  A hook that finds
nothing to cut (no planning under way), a second Ctrl-C, SIGTERM and SIGHUP stop at once
as above.
"""

from __future__ import annotations

import contextlib
import ctypes
import signal
import sys
import threading
from collections.abc import Callable, Iterator
from typing import TypeVar

T = TypeVar("T")

STACK_BYTES = 512 * 1024 * 1024  # virtual; only the pages actually used are committed
RECURSION_LIMIT = 60_000
GRACE_S = 1.5
POLL_S = 0.05

_requested = threading.Event()
_lock = threading.Lock()
_state = {"worker": None, "deferring": 0, "pending": False, "abandoned": False, "signal": 0}
_soft: dict = {"hook": None, "used": False}


def _terminate(signum: int, frame: object) -> None:
    _state["signal"] = signum
    raise KeyboardInterrupt


def on_termination() -> None:
    """SIGTERM and SIGHUP interrupt like Ctrl-C (call in the main thread, before ``run``)."""
    _state["signal"] = 0
    for name in ("SIGTERM", "SIGHUP"):
        if hasattr(signal, name):
            signal.signal(getattr(signal, name), _terminate)


def exit_code() -> int:
    """The exit status of an interrupted command: 130 for Ctrl-C, 128 + N for signal N."""
    return 128 + int(_state["signal"] or signal.SIGINT)


def abandoned() -> bool:
    """Did the last ``run`` return while its worker was still running (in C code)?  Then the
    process must end with ``os._exit``: finalising the interpreter would kill the worker
    inside C++ code, which aborts."""
    return bool(_state["abandoned"])


def soften(hook: Callable[[], bool]) -> None:
    """The first Ctrl-C of the running command calls ``hook()`` instead of stopping it
    (module docstring); ``hook`` returns False when it has nothing to stop."""
    _soft["hook"] = hook


def softened() -> bool:
    """Was the running command asked to stop by a softened Ctrl-C (it then exits 130)?"""
    return bool(_soft["used"])


def _soft_stop() -> bool:
    hook = _soft["hook"]
    if hook is None or _soft["used"] or _state["signal"]:
        return False
    _soft["used"] = True
    return bool(hook())


def requested() -> bool:
    return _requested.is_set()


def check() -> None:
    """Raise ``KeyboardInterrupt`` if Ctrl-C was pressed (call after a C solver returns)."""
    if _requested.is_set():
        raise KeyboardInterrupt


def _raise_in(ident: int) -> None:
    ctypes.pythonapi.PyThreadState_SetAsyncExc(ctypes.c_ulong(ident),
                                               ctypes.py_object(KeyboardInterrupt))


def request() -> None:
    """Ask the running command to stop (called from the main thread on Ctrl-C)."""
    _requested.set()
    with _lock:
        worker = _state["worker"]
        if worker is None:
            return
        if _state["deferring"]:
            _state["pending"] = True
        else:
            _raise_in(worker)


@contextlib.contextmanager
def deferred() -> Iterator[None]:
    """A section an interrupt must not cut: it takes effect when the section ends."""
    with _lock:
        _state["deferring"] += 1
    try:
        yield
    finally:
        with _lock:
            _state["deferring"] -= 1
            pending = _state["pending"] and not _state["deferring"]
            _state["pending"] = False if pending else _state["pending"]
        if pending:
            raise KeyboardInterrupt


def _deferring() -> bool:
    with _lock:
        return bool(_state["deferring"])


def run(fn: Callable[[], T]) -> T:
    """``fn()`` in a big-stack worker thread; Ctrl-C raises ``KeyboardInterrupt`` here."""
    if threading.current_thread() is not threading.main_thread() or _state["worker"]:
        return fn()  # nested use (tests, the fuzzer's own workers): no extra thread
    box: dict[str, object] = {}
    done = threading.Event()

    def target() -> None:
        try:
            box["value"] = fn()
        except BaseException as e:  # noqa: BLE001 - handed to the main thread
            box["error"] = e
        finally:
            done.set()

    _requested.clear()
    _state["abandoned"] = False
    _soft.update(hook=None, used=False)
    old_stack = threading.stack_size()
    try:
        threading.stack_size(STACK_BYTES)
        worker = threading.Thread(target=target, name="stlc-worker", daemon=True)
    except (ValueError, RuntimeError):  # pragma: no cover - platform without stack control
        return fn()
    finally:
        threading.stack_size(old_stack)
    old_limit = sys.getrecursionlimit()
    sys.setrecursionlimit(max(old_limit, RECURSION_LIMIT))
    try:
        worker.start()
        with _lock:
            _state["worker"] = worker.ident
        # not ``worker.join()``: in Python 3.11 a join interrupted by Ctrl-C marks the
        # still running thread as stopped (bpo-45274's fix); an Event is safe to interrupt
        try:
            # polled: the kernel may deliver SIGINT to any thread (CasADi's evaluation
            # threads too), and then a blocking wait here is never interrupted
            while True:
                try:
                    while not done.wait(POLL_S):
                        pass
                    break
                except KeyboardInterrupt:
                    if not _soft_stop():  # softened: the command stops planning, writes
                        raise
        except KeyboardInterrupt:
            request()
            try:
                done.wait(GRACE_S)
                while not done.is_set() and _deferring():
                    done.wait(0.05)
            except KeyboardInterrupt:
                pass  # a second Ctrl-C: stop waiting
            _state["abandoned"] = not done.is_set()
            raise KeyboardInterrupt from None
    finally:
        with _lock:
            _state["worker"] = None
        sys.setrecursionlimit(old_limit)
    if "error" in box:
        raise box["error"]  # type: ignore[misc]
    return box["value"]  # type: ignore[return-value]
