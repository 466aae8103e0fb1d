"""Resource limits: what stlc refuses before allocating (budgets before allocation).

* Input files are read with a size limit (``read_limited``): a mission file above
  ``MAX_SOURCE_BYTES``, a trace above ``MAX_TRACE_BYTES`` is STL601 at line 1, after reading
  at most one byte more than the limit, whatever the file is (a symlink to ``/dev/zero``, a
  FIFO, a 1 GB file).
* The memory budget (``max_memory()``): by default a safe share of the machine's memory
  (``DEFAULT_SHARE`` of ``MemTotal``, at most ``DEFAULT_CAP``); ``--max-memory`` moves it
  (``set_max_memory``).  The planners estimate a problem's memory from the checked program
  before building it (``stlc.planning.budget``) and refuse with STL606 what does not fit.
* ``MAX_EXPANSION`` bounds quantifier expansion (STL606): instances × the source nodes
  of the body (the checker elaborates ~0.1–0.3 ms per node: about 10 s at the limit).
"""

from __future__ import annotations

import os
import re

from stlc.diagnostics import Diagnostic, Span, StlcError

MAX_SOURCE_BYTES = 4 << 20   # a mission file (shipped ones are < 20 kB)
MAX_TRACE_BYTES = 64 << 20   # a trace (100,000 rows of 30 columns ≈ 40 MB)
MAX_TRACE_ROWS = 200_000
MAX_EXPANSION = 50_000       # quantifier instances × body nodes the checker may elaborate
DEFAULT_SHARE = 0.5
DEFAULT_CAP = 16 << 30
_CHUNK = 1 << 20

_state: dict[str, int | None] = {"max_memory": None}


def read_limited(path: str, limit: int, what: str, hint: str) -> bytes:
    """The bytes of ``path``, or ``StlcError`` (STL601 at line 1) when it is longer than
    ``limit``; reads in chunks, so a device or a FIFO that never ends costs ``limit`` bytes."""
    span = Span(path, 1, 1, 1, 1)
    try:
        with open(path, "rb") as fh:
            parts, total = [], 0
            while total <= limit:
                chunk = fh.read(min(_CHUNK, limit + 1 - total))
                if not chunk:
                    break
                parts.append(chunk)
                total += len(chunk)
    except FileNotFoundError:
        raise StlcError([Diagnostic("STL601", f"cannot read {what} `{path}`: no such file",
                                    span, hint)]) from None
    except IsADirectoryError:
        raise StlcError([Diagnostic("STL601", f"cannot read {what} `{path}`: it is a "
                                    "directory", span, hint)]) from None
    except (OSError, ValueError) as e:
        raise StlcError([Diagnostic("STL601", f"cannot read {what} `{path}`: "
                                    f"{getattr(e, 'strerror', None) or e}", span, hint)]
                        ) from None
    if total > limit:
        raise StlcError([Diagnostic(
            "STL601", f"{what} `{path}` is larger than the limit of {human(limit)}", span,
            f"stlc reads {what}s up to {human(limit)}; is `{path}` the file you meant?")])
    return b"".join(parts)


def source_text(path: str) -> str:
    """A mission file's text for rendering diagnostics (size-limited, lenient decoding)."""
    data = read_limited(path, MAX_SOURCE_BYTES, "file", "")
    return data.decode("utf-8", errors="replace").removeprefix("\ufeff")


def human(n: float) -> str:
    """``n`` bytes as ``1.5 GB`` (powers of 1024, as ``free -h``)."""
    for unit in ("bytes", "kB", "MB", "GB"):
        if abs(n) < 1024 or unit == "GB":
            return f"{n:.0f} {unit}" if unit == "bytes" else f"{n:.3g} {unit}"
        n /= 1024
    return f"{n:.3g} GB"  # pragma: no cover


def _mem_total() -> int | None:
    try:
        with open("/proc/meminfo", encoding="ascii") as fh:
            for line in fh:
                if line.startswith("MemTotal:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    try:
        return os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    except (OSError, ValueError, AttributeError):
        return None


def default_max_memory() -> int:
    total = _mem_total() or 8 << 30
    return int(min(total * DEFAULT_SHARE, DEFAULT_CAP))


def max_memory() -> int:
    """The memory budget of one planning problem, in bytes."""
    return _state["max_memory"] or default_max_memory()


def set_max_memory(n: int | None) -> None:
    _state["max_memory"] = n


_SIZE = re.compile(r"\s*([0-9]+(?:\.[0-9]*)?)\s*([kKmMgGtT]?)i?[bB]?\s*")


def parse_size(text: str) -> int:
    """``"2G"``, ``"512 MB"``, ``"1.5g"``, ``"1000000"`` (bytes) → bytes; ValueError else."""
    m = _SIZE.fullmatch(text)
    if not m:
        raise ValueError(f"{text!r} is not a size (e.g. 2G, 512M)")
    value = float(m.group(1)) * 1024 ** "_KMGT".index(m.group(2).upper() or "_")
    if not 1 << 20 <= value <= 1 << 50:
        raise ValueError(f"{text!r} is out of range (1M to 1024T)")
    return int(value)
