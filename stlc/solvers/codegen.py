"""CasADi functions compiled to C, cached on disk.

CasADi evaluates an SX function in its virtual machine, one instruction at a time.  The
NLP evaluates a few such functions at every interval of every iteration — the one-step
Hessian of a multirotor's RK4 step alone has 17 k instructions — and compiled, the same
function runs about 15 times faster (the handover's hexarotor, 170 intervals: 15 → 1 ms
per Hessian).  ``compiled`` has CasADi's code generator write the C, the system's C
compiler (``CC``, else ``cc``, ``gcc`` or ``clang``) build a shared library, and
``casadi.external`` load it.

The library is cached in ``settings.cache_dir()``, named by a digest of the functions (their
serialised form), CasADi's version and the compiler command: a vehicle's functions are
compiled once per machine (about 2 s), and every later run loads them.  The library is
written under a temporary name and renamed, so a reader never sees a partial file, and two
processes that compile the same functions both end with a whole one.  Without a compiler,
when it fails or with ``STLC_COMPILE=0``, the functions stay CasADi's own: the same values to
rounding, only slower; ``last_status()`` says which.
"""

from __future__ import annotations

import hashlib
import os
import shutil
import subprocess
import tempfile
import threading

import casadi as ca

from stlc import settings

#: the compiler's optimisation: -O1 runs the RK4 Hessian 2.6× faster than -O0 for a
#: compile of 2.4 s instead of 0.7 s, paid once per machine
FLAGS = ("-O1", "-fPIC", "-shared")
COMPILE_TIMEOUT_S = 120.0

_LOADED: dict[str, list[ca.Function]] = {}
_LOCK = threading.Lock()
_STATUS = {"status": "not asked"}


def compiler() -> str | None:
    """The C compiler's command: ``CC`` if set, else the first of cc, gcc, clang found."""
    cc = settings.c_compiler()
    if cc:
        return cc
    return next((p for p in map(shutil.which, ("cc", "gcc", "clang")) if p), None)


def last_status() -> dict:
    """What the last ``compiled`` call did: ``{"status": "loaded" | "compiled" | "off" |
    "no compiler" | "failed", ...}``."""
    return dict(_STATUS)


def compiled(fns: list[ca.Function], label: str) -> list[ca.Function]:
    """``fns`` (SX functions, each called by its position) as compiled functions of the same
    inputs and outputs, or ``fns`` themselves when nothing can be compiled."""
    if not settings.compile_functions():
        _STATUS.update(status="off")
        return fns
    cc = compiler()
    if cc is None:
        _STATUS.clear()
        _STATUS.update(status="no compiler")
        return fns
    h = hashlib.sha256()
    for part in (ca.__version__, cc, *FLAGS, *(f.serialize() for f in fns)):
        h.update(part.encode())
        h.update(b"\0")
    key = f"{label}_{h.hexdigest()[:24]}"
    with _LOCK:
        if key in _LOADED:
            return _LOADED[key]
        try:
            out, how = _load_or_build(fns, key, cc)
        except (OSError, RuntimeError, subprocess.SubprocessError) as e:
            _STATUS.clear()
            _STATUS.update(status="failed", why=str(e).splitlines()[0][:200] if str(e) else
                           type(e).__name__)
            return fns
        _LOADED[key] = out
        _STATUS.clear()
        _STATUS.update(status=how, library=key)
        return out


def _names(fns: list[ca.Function], key: str) -> list[str]:
    return [f"{key}_{i}" for i in range(len(fns))]


def _load_or_build(fns: list[ca.Function], key: str, cc: str
                   ) -> tuple[list[ca.Function], str]:
    d = settings.cache_dir()
    lib = os.path.join(d, f"{key}.so")
    how = "loaded"
    if not os.path.exists(lib):
        d = settings.writable_cache_dir()
        if d is None:
            raise OSError(f"the cache directory {settings.cache_dir()} cannot be written")
        _build(fns, key, cc, d, lib)
        how = "compiled"
    return [ca.external(name, lib) for name in _names(fns, key)], how


def _build(fns: list[ca.Function], key: str, cc: str, d: str, lib: str) -> None:
    """Write the C of ``fns`` (renamed to ``key``'s names) and compile it to ``lib``."""
    gen = ca.CodeGenerator(f"{key}.c", {"with_header": False})
    for f, name in zip(fns, _names(fns, key)):
        gen.add(_renamed(f, name))
    with tempfile.TemporaryDirectory(dir=d, prefix=".build-") as tmp:
        src = os.path.join(tmp, f"{key}.c")
        with open(src, "w") as fh:
            fh.write(gen.dump())
        out = os.path.join(tmp, f"{key}.so")
        r = subprocess.run([cc, *FLAGS, src, "-o", out], capture_output=True, text=True,
                           timeout=COMPILE_TIMEOUT_S)
        if r.returncode != 0 or not os.path.exists(out):
            raise RuntimeError(f"{cc} exited {r.returncode}: {r.stderr.strip()[:200]}")
        os.replace(out, lib)  # atomic: a reader sees no library or a whole one


def _renamed(f: ca.Function, name: str) -> ca.Function:
    """``f`` under another name (an SX function, rebuilt from its own graph)."""
    ins = f.sx_in()
    return ca.Function(name, ins, f.call(ins), f.name_in(), f.name_out())
