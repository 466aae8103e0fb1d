"""The run's time limit (``--time-limit SECONDS`` or a mission's ``time_limit``).

A process-wide deadline on the monotonic clock, set by the pipeline around one mission's
planning and read by the solvers: IPOPT's iteration callback stops a solve when it has
passed (the solve keeps its best *verified* iterate, as it does on its iteration limit),
solves built per call get ``ipopt.max_wall_time`` = the time left, the solve schedule
starts no new stage, and the team MILP gets the time left as its budget.  What is written
is the best plan found so far, judged by the exact monitor as always; the solver log says
``stopped_by: "time_limit"`` and ``converged: false``.

The limit covers planning *and* writing: ``RESERVE_S`` (a share of the limit, at most
``RESERVE_MAX_S``) is kept back from the solvers for verification and the outputs, and
risk cases are skipped when the limit has run out (the report says so).

Work that cannot see the limit (building an NLP, waiting for the kinematic guess) is cut by
a watchdog: while the limit is *armed* (from ``limited`` until a solver that checks the
limit itself calls ``disarm``), a timer raises ``TimeLimitReached`` in the planning thread
when the solvers' share has run out (as ``stlc.interrupt`` does for Ctrl-C; a C call
finishes first, and so does an import, which an exception would leave half done).  The
pipeline then writes the best plan it has — with nothing found yet, the vehicles hovering
at their start — judged by the exact monitor.

Without ``--time-limit`` or ``time_limit`` a run still has one: ``DEFAULT_LIMIT_S`` (no solve
without a time limit), so no NLP solve, stage or build runs unbounded; a run that
reaches it ends like any stopped run (best verified plan written, exit 3), and its notes say
the limit was the default.  It is generous — 30× the slowest shipped mission (10–60 s on a
loaded two-core machine) — so it never binds a mission that plans normally; the
developers' ``STLC_DEFAULT_TIME_LIMIT`` (seconds, read by ``stlc.settings``) overrides it.

Ctrl-C is not a time limit: it still stops at once and writes nothing (``stlc.interrupt``)
— unless the user asks for the best plan (``stlc compile --keep-on-interrupt``): then
``cut()`` ends the planning limit at once, from the main thread, and the run ends as a
stopped one.
"""

from __future__ import annotations

import contextlib
import ctypes
import math
import os
import sys
import threading
import time
from collections.abc import Callable, Iterator

#: kept back from the solvers for verification, risk and writing the outputs
RESERVE_FRACTION = 0.3
RESERVE_MAX_S = 2.5

#: the limit of a run that gives none (see the module docstring)
DEFAULT_LIMIT_S = 1800.0



class _State(threading.local):
    """The limit of the calling thread: a sweep's instances running as threads of one Dask
    worker each keep their own (the watchdog hands its thread's limit to the writer)."""

    def __init__(self) -> None:
        self.__dict__.update(end=None, limit=None, start=None, default=None, cut=False)

    def __getitem__(self, key: str):
        return self.__dict__[key]

    def update(self, **kw) -> None:
        self.__dict__.update(kw)

    def copy(self) -> dict:
        return dict(self.__dict__)


_state = _State()
#: a thread stuck in one long C call (CasADi differentiating a large NLP; the GIL is
#: released) does not see the exception; after ``GRACE_S`` the watchdog itself runs the
#: ``overrun`` writer (the fallback plan's outputs) and ends the process with its exit code
GRACE_S = 0.4
_watch: dict = {"timer": None, "thread": None, "armed": False, "fired": False,
                "caught": False, "overrun": None, "entered": False, "state": {},
                "live": None}
_lock = threading.Lock()


class TimeLimitReached(BaseException):  # noqa: N818 - like KeyboardInterrupt, not an error
    """Raised in the planning thread by the watchdog when the limit ran out while armed."""


def set_limit(seconds: float | None, start: float | None = None,
              default: bool = False) -> None:
    """Start a limit of ``seconds`` (None or ∞ clears it), counted from ``start``
    (``time.monotonic()``, default now); ``default``: the run gave none (``default_limit``)."""
    if seconds is None or not math.isfinite(seconds):
        clear()
        return
    t0 = time.monotonic() if start is None else start
    _state.update(start=t0, limit=float(seconds), end=t0 + float(seconds),
                  default=1.0 if default else None, cut=False)


def clear() -> None:
    _state.update(end=None, limit=None, start=None, default=None, cut=False)


def default_limit() -> float:
    """``DEFAULT_LIMIT_S``, or the developers' ``STLC_DEFAULT_TIME_LIMIT`` when it is a
    positive number of seconds."""
    from stlc import settings

    return settings.default_time_limit(DEFAULT_LIMIT_S)


def is_default() -> bool:
    """Is the active limit the default one (the run gave none)?"""
    return active() and _state["default"] is not None


@contextlib.contextmanager
def limited(seconds: float | None, start: float | None = None,
            overrun: Callable[[], int] | None = None) -> Iterator[None]:
    """``set_limit`` for the duration of a block, with the watchdog armed for the calling
    thread (see the module docstring); ``overrun()`` writes the fallback outputs and returns
    the exit code when the thread does not answer the watchdog in time.  ``seconds`` None:
    the default limit (``default_limit``): no run plans without one."""
    if seconds is None:
        set_limit(default_limit(), start, default=True)
    else:
        set_limit(seconds, start)
    if active():
        with _lock:
            _watch.update(thread=threading.get_ident(), armed=True, fired=False,
                          caught=False, overrun=overrun, entered=False, state=_state.copy(),
                          live=_state.__dict__)
            t = threading.Timer(max(0.0, solve_remaining()), _fire)
            t.daemon = True
            _watch["timer"] = t
        t.start()
    try:
        with _lock:  # the watchdog raises only inside the block (see _fire)
            _watch["entered"] = True
        yield
    finally:
        with _lock:
            if _watch["timer"] is not None:
                _watch["timer"].cancel()
            _watch.update(timer=None, thread=None, armed=False, overrun=None, entered=False,
                          live=None)
        clear()


@contextlib.contextmanager
def serial() -> Iterator[None]:
    """One planning at a time per process: the solvers' cached NLPs (CasADi/IPOPT objects,
    ``stlc.backends.nlp.cache``) and this module's watchdog are process-wide, and two
    threads solving one cached NLP at once corrupt its memory (the interpreter aborts).  A
    second thread that plans (``stlc.compile`` from a thread pool) waits for the first:
    the API is safe under threads, and serialised; for parallel planning use processes
    (``stlc sweep`` runs one planning thread per worker process)."""
    with _planning:
        yield


_planning = threading.RLock()


@contextlib.contextmanager
def bounded(seconds: float | None = None) -> Iterator[None]:
    """A limit of ``seconds`` (None: the default, ``default_limit``) for a block that runs
    solves, without the watchdog (``simulate``'s replans, a sweep's instance in a Dask
    worker: every solve there sees it, a build is not cut); a limit already active is
    kept."""
    if active():
        yield
        return
    set_limit(default_limit() if seconds is None else seconds, default=seconds is None)
    try:
        yield
    finally:
        clear()


def _importing(thread: int | None) -> bool:
    """Is ``thread`` inside an import?  An exception raised there can leave a module half
    initialised in ``sys.modules`` (CasADi without ``SX``) for the writer that comes next."""
    frame = sys._current_frames().get(thread) if thread is not None else None
    while frame is not None:
        if frame.f_code.co_filename.startswith("<frozen importlib"):
            return True
        frame = frame.f_back
    return False


def _fire() -> None:
    with _lock:
        if _watch["armed"] and (not _watch["entered"] or _importing(_watch["thread"])):
            # not inside the block yet, or importing a module: soon
            t = threading.Timer(0.02, _fire)
            t.daemon = True
            _watch["timer"] = t
            t.start()
            return
        if _watch["armed"] and _watch["thread"] is not None:
            _watch["fired"] = True
            ctypes.pythonapi.PyThreadState_SetAsyncExc(
                ctypes.c_ulong(_watch["thread"]), ctypes.py_object(TimeLimitReached))
            t = threading.Timer(GRACE_S, _hard_stop)
            t.daemon = True
            _watch["timer"] = t
            t.start()


def _hard_stop() -> None:
    """The planning thread is still inside one C call: write the fallback from here."""
    with _lock:
        if not (_watch["armed"] and not _watch["caught"] and _watch["overrun"] is not None):
            return
        _watch["caught"] = True  # the planning thread must not write too
        overrun = _watch["overrun"]
        _state.update(**_watch["state"])  # the planning thread's limit, for the writer
    code = 3
    try:
        code = overrun()
    finally:
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(code)


def caught() -> None:
    """The planning thread has the ``TimeLimitReached``: it writes the fallback itself —
    unless the watchdog already does (then it waits for the process to end)."""
    with _lock:
        taken = _watch["caught"]
        _watch["caught"] = True
    if taken:
        while True:
            time.sleep(1.0)


def stopper() -> Callable[[], None]:
    """A function that, called from any thread, ends the *calling* thread's active limit
    now: its solves stop as on their time limit (best verified iterate, not converged).
    A sweep pre-empts a cold instance with it (``stlc.sweeping.task``)."""
    st = _state.__dict__  # this thread's state (``_State`` is thread-local)

    def stop() -> None:
        if st.get("end") is not None:
            st["end"] = min(st["end"], time.monotonic())

    return stop


def cut() -> bool:
    """End the limit of the planning under way now, from any thread: its solvers stop as on
    their time limit (IPOPT at its next iteration, a MILP when its own budget returns), and
    a build that cannot see the limit is cut by the watchdog.  The output reserve is kept.
    False when no planning is under way."""
    with _lock:
        live = _watch["live"]
        if live is None or live.get("end") is None:
            return False
        keep = min(RESERVE_MAX_S, RESERVE_FRACTION * (live["limit"] or 0.0))
        live["end"] = min(live["end"], time.monotonic() + keep)
        live["cut"] = True
        if _watch["armed"]:
            if _watch["timer"] is not None:
                _watch["timer"].cancel()
            t = threading.Timer(0.0, _fire)
            t.daemon = True
            _watch["timer"] = t
            t.start()
    return True


def was_cut() -> bool:
    """Did ``cut`` end this thread's limit (a Ctrl-C the user asked to keep the plan on)?"""
    return bool(_state["cut"])


def disarm() -> None:
    """From here on the caller checks the limit itself (an IPOPT callback, a solver's own
    time budget): the watchdog no longer raises."""
    with _lock:
        _watch["armed"] = False


def active() -> bool:
    return _state["end"] is not None


def limit() -> float | None:
    return _state["limit"]


def remaining() -> float:
    """Seconds left for the whole run (∞ without a limit; ≤ 0 once it has passed)."""
    end = _state["end"]
    return math.inf if end is None else end - time.monotonic()


def _reserve() -> float:
    lim = _state["limit"] or 0.0
    return min(RESERVE_MAX_S, RESERVE_FRACTION * lim)


def solve_remaining() -> float:
    """Seconds left for the solvers (the run's time left minus the output reserve)."""
    return remaining() - _reserve() if active() else math.inf


def solve_expired() -> bool:
    """Has the solvers' share of the limit run out?"""
    return active() and solve_remaining() <= 0


def expired() -> bool:
    return active() and remaining() <= 0


def ipopt_options(minimum: float = 0.05) -> dict[str, float]:
    """``ipopt.max_wall_time`` for a solve built per call (empty without a limit)."""
    if not active():
        return {}
    return {"ipopt.max_wall_time": max(minimum, solve_remaining())}


def progress_note() -> str:
    """``, 3.2 s left`` for progress lines (empty without a limit or with the default)."""
    if not active() or is_default():
        return ""
    return f", {max(0.0, remaining()):.1f} s left"


def mission_limit(options: dict, cli: float | None, share: float) -> float | None:
    """The time limit of one mission: ``--time-limit`` (``share``: its part of what is
    left, shared by the missions still to run) or else the mission's ``time_limit``
    field (``options``); None = neither: ``limited`` then sets the default limit."""
    if cli is not None:
        return share
    lim = options.get("time_limit")
    return None if lim is None else float(lim)
