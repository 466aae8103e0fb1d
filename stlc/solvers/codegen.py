"""CasADi functions compiled to C, cached on disk.

CasADi evaluates an SX function in its virtual machine, one instruction at a time.  The
NLP evaluates a few such functions at every interval of every iteration — the one-step
Hessian of a multirotor's RK4 step alone has 17 k instructions — and compiled, the same
function runs about 15 times faster (the handover's hexarotor, 170 intervals: 15 → 1 ms
per Hessian).  ``compiled`` has CasADi's code generator write the C, the system's C
compiler (``CC``, else ``cc``, ``gcc`` or ``clang``) build a shared library, and
``casadi.external`` load it.

The library is kept in ``settings.cache_dir()``, named by a digest of the functions (their
serialised form), CasADi's version and the compiler command, so a vehicle's functions are
compiled once per machine.  A compile takes 2–8 s (the larger the RK4 step, the longer),
more than a handover's whole plan, so the run that finds no library does not wait for it:
it plans with CasADi's own functions and, as it ends (``start_pending``), starts the
compiler in the background at the lowest priority; the runs after it load the library.
Not beside the plan: where two cores share one physical core even the lowest priority
takes from it (a two-drone mission's energy stage: 4.3 → 5.7 s).  The compiler writes under a temporary
name that is then renamed, so a reader never sees a partial library, and a compile that is
under way is not started twice.  Without a compiler, when it fails or with
``STLC_COMPILE=0``, the functions stay CasADi's own: the same values to rounding, only
slower; ``last_status()`` says which.
"""

from __future__ import annotations

import atexit
import hashlib
import os
import shlex
import shutil
import subprocess
import threading
import time

import casadi as ca

from stlc import settings

#: the compiler's optimisation: -O1 runs the RK4 Hessian 2.6× faster than -O0 for a
#: compile of 2.4 s instead of 0.7 s, paid once per machine
FLAGS = ("-O1", "-fPIC", "-shared")
#: a compile started this long ago and not finished is taken as dead (its folder removed)
COMPILE_TIMEOUT_S = 300.0

_LOADED: dict[str, list[ca.Function]] = {}
_LOCK = threading.Lock()
_STATUS = {"status": "not asked"}
_BACKGROUND: list[subprocess.Popen] = []  # the compiles started (kept: no warning at exit)
_PENDING: list[str] = []  # the compiles this run leaves for its end (shell scripts)


def compiler() -> str | None:
    """The C compiler's command: ``CC`` if set, else the first of cc, gcc, clang found."""
    cc = settings.c_compiler()
    if cc:
        return cc
    return next((p for p in map(shutil.which, ("cc", "gcc", "clang")) if p), None)


def last_status() -> dict:
    """What the last ``compiled`` call did: ``{"status": "loaded" | "compiled" |
    "compiling" | "off" | "no compiler" | "failed", ...}``."""
    return dict(_STATUS)


def _say(status: str, **more) -> None:
    _STATUS.clear()
    _STATUS.update(status=status, **more)


def compiled(fns: list[ca.Function], label: str, wait: bool = False) -> list[ca.Function]:
    """``fns`` (SX functions, each called by its position) as compiled functions of the same
    inputs and outputs, or ``fns`` themselves when there is no library yet (the compile
    then runs in the background, unless ``wait``) or nothing can be compiled."""
    if not settings.compile_functions():
        _say("off")
        return fns
    cc = compiler()
    if cc is None:
        _say("no compiler")
        return fns
    h = hashlib.sha256()
    for part in (ca.__version__, cc, *FLAGS, *(f.serialize() for f in fns)):
        h.update(part.encode())
        h.update(b"\0")
    key = f"{label}_{h.hexdigest()[:24]}"
    with _LOCK:
        if key in _LOADED:
            _say("loaded", library=key)
            return _LOADED[key]
        lib = os.path.join(settings.cache_dir(), f"{key}.so")
        try:
            how = "loaded"
            if not os.path.exists(lib):
                how = _build(fns, key, cc, lib, wait)
            if how == "compiling":
                _say(how, library=key)
                return fns
            out = [ca.external(name, lib) for name in _names(fns, key)]
        except (OSError, RuntimeError, subprocess.SubprocessError) as e:
            _say("failed", why=str(e).splitlines()[0][:200] if str(e) else type(e).__name__)
            return fns
        _LOADED[key] = out
        _say(how, library=key)
        return out


def _names(fns: list[ca.Function], key: str) -> list[str]:
    return [f"{key}_{i}" for i in range(len(fns))]


def _build(fns: list[ca.Function], key: str, cc: str, lib: str, wait: bool) -> str:
    """Write the C of ``fns`` (renamed to ``key``'s names) and compile it to ``lib``: now
    (``wait``: "compiled") or in the background ("compiling")."""
    d = settings.writable_cache_dir()
    if d is None:
        raise OSError(f"the cache directory {settings.cache_dir()} cannot be written")
    work = os.path.join(d, f".build-{key}")
    try:
        os.mkdir(work)  # claims the compile: one at a time per library
    except FileExistsError:
        if time.time() - os.path.getmtime(work) < COMPILE_TIMEOUT_S:
            return "compiling"  # another run's compile is under way
        shutil.rmtree(work, ignore_errors=True)
        os.mkdir(work)
    gen = ca.CodeGenerator(f"{key}.c", {"with_header": False})
    for f, name in zip(fns, _names(fns, key)):
        gen.add(_renamed(f, name))
    src, part = os.path.join(work, f"{key}.c"), os.path.join(work, f"{key}.so")
    with open(src, "w") as fh:
        fh.write(gen.dump())
    cmd = [cc, *FLAGS, src, "-o", part]
    if wait:
        try:
            r = subprocess.run(cmd, capture_output=True, text=True, timeout=COMPILE_TIMEOUT_S)
            if r.returncode != 0 or not os.path.exists(part):
                raise RuntimeError(f"{cc} exited {r.returncode}: {r.stderr.strip()[:200]}")
            os.replace(part, lib)  # atomic: a reader sees no library or a whole one
        finally:
            shutil.rmtree(work, ignore_errors=True)
        return "compiled"
    nice = shutil.which("nice")
    q = shlex.join
    script = (f"{q([nice, '-n', '19'] if nice else [])} {q(cmd)} >/dev/null 2>&1 && "
              f"mv -f {shlex.quote(part)} {shlex.quote(lib)}; rm -rf {shlex.quote(work)}")
    if not _PENDING:
        atexit.register(start_pending)  # (the command line calls it before its quick exit)
    _PENDING.append(script)
    return "compiling"


def start_pending() -> None:
    """Start the compiles this run left for its end, in the background.  Each runs in its
    own process group (Ctrl-C at the terminal does not reach it; it outlives the run) but
    in the caller's process session, where the lowest priority holds (Linux schedules a
    session of its own as a group beside the caller's, whatever its priority)."""
    while _PENDING:
        script = _PENDING.pop(0)
        try:
            _BACKGROUND.append(subprocess.Popen(
                ["/bin/sh", "-c", script], stdin=subprocess.DEVNULL,
                stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, process_group=0))
        except OSError:  # no shell: CasADi's own functions, as without a compiler
            pass


def _renamed(f: ca.Function, name: str) -> ca.Function:
    """``f`` under another name (an SX function, rebuilt from its own graph)."""
    ins = f.sx_in()
    return ca.Function(name, ins, f.call(ins), f.name_in(), f.name_out())
