"""Settings of a run: the one module of ``stlc`` that reads the process environment.

Every other module asks this one.  The environment holds only what a developer or a host
sets for a whole process; the algorithm has no on/off switches here (its choices are
constants of the modules that make them, or typed options of the problem and backends).

* ``STLC_DEBUG`` — a traceback beside an internal error's diagnostic (``debug``);
* ``STLC_DEFAULT_TIME_LIMIT`` — the time limit of a run that gives none, in seconds
  (``default_time_limit``; ``stlc.deadline``);
* ``STLC_IPOPT`` — extra IPOPT options as JSON, e.g. ``'{"ipopt.print_level": 5}'``
  (``ipopt_options``; read once per process, so a cached NLP never meets other options);
* ``STLC_MAP_THREADS`` — threads of the derivatives' map (``map_threads``; a sweep's
  local cluster gives each worker process its share of the cores);
* ``STLC_CACHE_DIR`` — what a run may keep for the next (``cache_dir``: compiled functions,
  the parser's tables, the report's compiled templates; default ``$XDG_CACHE_HOME/stlc``,
  else ``~/.cache/stlc``); ``STLC_COMPILE=0`` keeps every function in CasADi's virtual
  machine (``compile_functions``); ``CC`` names the C compiler (``c_compiler``;
  ``stlc.solvers.codegen``);
* ``STLC_NO_FORK`` — solve "apart" work in-process instead of in a forked child
  (``no_fork``); a caller that must not fork (a Dask worker's task) says so with
  ``override(no_fork=True)`` for its own work instead of changing the environment.

``limit_solver_threads``: one OpenMP/BLAS thread unless the user set these already (IPOPT's
MUMPS and BLAS start one thread per core; on small KKT systems the threads only contend,
and the thread count changes IPOPT's path).  The CLI's entry point and the first planning
of a process (``pipeline.plan``: the API, a sweep's workers) set it, so a plan is the same
from every entry point.  Importing ``stlc`` changes nothing in the process.
"""

from __future__ import annotations

import contextlib
import contextvars
import functools
import json
import math
import os
from collections.abc import Iterator

_OVERRIDES: contextvars.ContextVar[dict] = contextvars.ContextVar("stlc_settings", default={})
SOLVER_THREAD_VARS = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")


def _get(name: str, env: str) -> str:
    over = _OVERRIDES.get()
    if name in over:
        return over[name]
    return os.environ.get(env, "")


@contextlib.contextmanager
def override(**values) -> Iterator[None]:
    """Settings for the work inside the block (this thread and context only):
    ``override(no_fork=True)``."""
    strs = {k: ("1" if v is True else "0" if v is False else str(v)) for k, v in values.items()}
    token = _OVERRIDES.set({**_OVERRIDES.get(), **strs})
    try:
        yield
    finally:
        _OVERRIDES.reset(token)


def debug() -> bool:
    return bool(_get("debug", "STLC_DEBUG"))


def no_fork() -> bool:
    return _get("no_fork", "STLC_NO_FORK") == "1"


def map_threads(default: int) -> int:
    """``STLC_MAP_THREADS`` when it is a whole number, else ``default``."""
    cap = _get("map_threads", "STLC_MAP_THREADS")
    return int(cap) if cap.isdigit() else default


def cache_dir() -> str:
    """``STLC_CACHE_DIR``, else ``$XDG_CACHE_HOME/stlc``, else ``~/.cache/stlc``."""
    d = _get("cache_dir", "STLC_CACHE_DIR")
    if d:
        return d
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return os.path.join(base, "stlc")


def writable_cache_dir() -> str | None:
    """``cache_dir()``, created if it is missing, or None when it cannot be written (then
    nothing is cached: every cache of ``stlc`` is an optimisation)."""
    d = cache_dir()
    try:
        os.makedirs(d, exist_ok=True)
    except OSError:
        return None
    return d if os.access(d, os.W_OK | os.X_OK) else None


def compile_functions() -> bool:
    """False when ``STLC_COMPILE`` is ``0``: no function is compiled to C."""
    return _get("compile", "STLC_COMPILE") != "0"


def c_compiler() -> str:
    """``CC`` (empty when unset)."""
    return _get("c_compiler", "CC")


def default_time_limit(default: float) -> float:
    """``STLC_DEFAULT_TIME_LIMIT`` when it is a positive number of seconds, else ``default``."""
    with contextlib.suppress(ValueError):
        x = float(_get("default_time_limit", "STLC_DEFAULT_TIME_LIMIT"))
        if math.isfinite(x) and x > 0:
            return x
    return default


@functools.cache
def ipopt_options() -> dict:
    """``STLC_IPOPT`` as a dict (empty when unset), read once per process."""
    return dict(json.loads(os.environ.get("STLC_IPOPT", "") or "{}"))


def environment() -> dict[str, str]:
    """The process environment, for a child process started with it."""
    return dict(os.environ)


def limit_solver_threads() -> None:
    """One OpenMP/BLAS thread each, unless the user set these already (the CLI's start):
    IPOPT's sparse solver (MUMPS) and BLAS would start one thread per core, and on small
    KKT systems (~10k rows) the threads only contend (a solve spent 4x more wall time than
    CPU time in the linear solver on a 2-core machine)."""
    for var in SOLVER_THREAD_VARS:
        os.environ.setdefault(var, "1")
