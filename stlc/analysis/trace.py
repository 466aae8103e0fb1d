"""Reading trace CSV files, with diagnostics that point into the file.

Contract (LANGUAGE.md, "Command line"): a header row ``t,<signal>,...``, one row per sample,
uniform ``t``.  ``read_trace`` returns a ``Trace`` or raises ``StlcError`` — never another
exception — with

* STL601 the file cannot be read: missing, a directory, binary (NUL bytes), not UTF-8;
* STL602 malformed: no header, first column not ``t``, empty or duplicate column name,
  wrong number of fields, a value that is not a finite number, no data rows;
* STL604 ``t`` is not increasing or not uniform (steps may differ from their median by 1%,
  so times printed with few digits are accepted);

each with a span at the offending line and column and a hint.  Lines end at ``\\n``,
``\\r\\n`` or ``\\r`` (as in ``.stl`` files; not at ``\\f``, ``\\v``, U+2028 …).  Blank lines
are skipped,
a UTF-8 byte-order mark is ignored, names and values may be padded with spaces and names
may be double-quoted.  ``check_signals`` reports STL603 for columns a formula needs.

``read_trace(path, resample=DT)`` (``stlc monitor --resample DT``, for real flight logs
with jitter) accepts any increasing ``t`` and interpolates every column linearly onto
``t_0, t_0 + DT, …`` (≤ t_last); ``Trace.resampled`` notes the largest gap between the
log's samples (and where), which bounds what the interpolation may have missed.

``Trace.dt`` is ``(t_last - t_0) / (n - 1)`` rounded to 10 significant digits (so 0.1 s
written as text is 0.1, not 0.09999999999999999); a one-row trace gets ``dt = 1.0``, which
is harmless: with a single sample only windows starting at 0 are non-empty, for any dt.
"""

from __future__ import annotations

import math
import os
import re
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from stlc.diagnostics import (
    Diagnostic,
    Span,
    StlcError,
    did_you_mean,
    normalize_newlines,
    source_lines,
)

MAX_DIAGNOSTICS = 20
STEP_TOLERANCE = 0.01
_NUMBER = re.compile(r"[+-]?(?:\d+(?:\.\d*)?|\.\d+)(?:[eE][+-]?\d+)?")
_NONFINITE = re.compile(r"[+-]?(?:nan|inf|infinity)", re.IGNORECASE)


@dataclass
class Trace:
    """A uniformly sampled trace: ``channels[name]`` has one value per entry of ``times``."""

    times: np.ndarray
    dt: float
    channels: dict[str, np.ndarray]
    path: str
    header_span: Span = field(default_factory=Span.none)  # the header row, for STL603
    #: after ``resample``: {"dt", "samples_in", "largest_gap", "gap_at"} (else None)
    resampled: dict | None = None

    @property
    def n(self) -> int:
        return len(self.times)


def _fail(code: str, message: str, span: Span, help: str | None = None) -> StlcError:
    return StlcError([Diagnostic(code, message, span, help)])


def _decode(path: str) -> str:
    from stlc.limits import MAX_TRACE_BYTES, read_limited

    data = read_limited(str(path), MAX_TRACE_BYTES, "trace",
                        "give the path of a CSV trace (e.g. a `trajectory.csv`)")

    def at(offset: int) -> Span:  # lines end at \n, \r\n or \r (diagnostics.source_lines)
        head = data[:offset].replace(b"\r\n", b"\n").replace(b"\r", b"\n")
        line = head.count(b"\n") + 1
        col = len(head) - (head.rfind(b"\n") + 1) + 1
        return Span(path, line, col, line, col + 1)

    nul = data.find(b"\0")
    if nul >= 0:
        raise _fail("STL601", "the trace is a binary file, not CSV text", at(nul),
                    "write the trace as a CSV text file with a header row `t,<signal>,...`")
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise _fail("STL601", "the trace is not valid UTF-8 text", at(exc.start),
                    "save the file as UTF-8") from None
    return text.removeprefix("\ufeff")


def _fields(line: str) -> list[tuple[str, int, int]]:
    """``(stripped text, 1-based column, length)`` of each comma-separated field."""
    out, start = [], 0
    for raw in line.split(","):
        stripped = raw.strip()
        col = start + (raw.index(stripped) if stripped else 0) + 1
        out.append((stripped, col, max(1, len(stripped))))
        start += len(raw) + 1
    return out


def _header(path: str, lineno: int, line: str, diags: list[Diagnostic]) -> list[str]:
    names = []
    seen: dict[str, int] = {}
    for i, (text, col, width) in enumerate(_fields(line)):
        name = text[1:-1].strip() if len(text) >= 2 and text[0] == text[-1] == '"' else text
        span = Span(path, lineno, col, lineno, col + width)
        if i == 0 and name != "t":
            diags.append(Diagnostic(
                "STL602", f"the first column of a trace must be `t`, found `{name}`", span,
                "write the header as `t,<signal>,...` with the sample times first"))
        elif not name:
            diags.append(Diagnostic("STL602", "empty column name in the header", span,
                                    "name every column, or remove the extra comma"))
        elif name in seen:
            diags.append(Diagnostic("STL602", f"duplicate column `{name}`", span,
                                    f"column {seen[name] + 1} already has this name"))
        seen.setdefault(name, i)
        names.append(name)
    return names


def _value(text: str) -> float | str:
    """The number in ``text``, or why it is not one."""
    if _NUMBER.fullmatch(text):
        v = float(text)
        return v if math.isfinite(v) else "is too large"
    if not text:
        return "is empty"
    if _NONFINITE.fullmatch(text):
        return "is not a finite number"
    return "is not a number"


def read_trace(path: str | os.PathLike, resample: float | None = None) -> Trace:
    """Read a trace CSV file; raise ``StlcError`` (STL601/602/604) on any bad input.
    With ``resample`` (s > 0) the time column need only increase (see the docstring)."""
    path = os.fspath(path)
    if not isinstance(path, str):
        path = os.fsdecode(path)
    lines = source_lines(normalize_newlines(_decode(path)))
    rows = [(i + 1, ln) for i, ln in enumerate(lines) if ln.strip()]
    if not rows:
        raise _fail("STL602", "the trace is empty: no header row", Span(path, 1, 1, 1, 1),
                    "start the file with a header row `t,<signal>,...`")
    diags: list[Diagnostic] = []
    head_no, head = rows[0]
    names = _header(path, head_no, head, diags)
    header_span = Span(path, head_no, 1, head_no, len(head) + 1)
    if diags:
        raise StlcError(diags)
    if len(rows) == 1:
        raise _fail("STL602", "the trace has a header but no samples",
                    Span(path, head_no, len(head) + 1, head_no, len(head) + 2),
                    "add one row of values per sample below the header")
    data = np.empty((len(rows) - 1, len(names)))
    for r, (lineno, line) in enumerate(rows[1:]):
        if len(diags) >= MAX_DIAGNOSTICS:
            break
        fields = _fields(line)
        if len(fields) != len(names):
            diags.append(Diagnostic(
                "STL602", f"row has {len(fields)} field(s), the header has {len(names)}",
                Span(path, lineno, 1, lineno, len(line) + 1),
                f"give one value per column: {', '.join(names)}"))
            continue
        for c, (text, col, width) in enumerate(fields):
            v = _value(text)
            if isinstance(v, str):
                diags.append(Diagnostic(
                    "STL602", f"value `{text[:40]}` of column `{names[c]}` {v}",
                    Span(path, lineno, col, lineno, col + width),
                    "write a decimal number such as `0.25` or `-1.5e3`"))
            else:
                data[r, c] = v
    if diags:
        raise StlcError(diags)
    times = data[:, 0]
    _check_uniform(path, times, rows[1:], diags, uniform=resample is None)
    if diags:
        raise StlcError(diags)
    if resample is not None:
        return _resampled(path, data, names, float(resample), header_span)
    n = len(times)
    with np.errstate(over="ignore", invalid="ignore"):
        dt = float(f"{(times[-1] - times[0]) / (n - 1):.10g}") if n > 1 else 1.0
    if not (dt > 0 and math.isfinite(dt)):
        raise _fail("STL604", f"the time step {dt:g} s is not a usable step", header_span,
                    "write the sample times in seconds")
    channels = {name: data[:, c].copy() for c, name in enumerate(names) if c}
    return Trace(times.copy(), dt, channels, path, header_span)


def _resampled(path: str, data: np.ndarray, names: list[str], dt: float,
               header_span: Span) -> Trace:
    t = data[:, 0]
    n = int(math.floor((t[-1] - t[0]) / dt + 1e-9)) + 1
    grid = t[0] + dt * np.arange(n)
    channels = {name: np.interp(grid, t, data[:, c]) for c, name in enumerate(names) if c}
    gaps = np.diff(t) if len(t) > 1 else np.zeros(1)
    k = int(np.argmax(gaps))
    note = {"dt": dt, "samples_in": int(len(t)), "largest_gap": float(gaps[k]),
            "gap_at": float(t[k])}
    return Trace(grid, dt, channels, path, header_span, note)


def _check_uniform(path: str, t: np.ndarray, rows: list[tuple[int, str]],
                   diags: list[Diagnostic], uniform: bool = True) -> None:
    if len(t) < 2:
        return
    with np.errstate(over="ignore", invalid="ignore"):  # 1e308 - -1e308 is inf: reported
        steps = np.diff(t)

    def span(i: int) -> Span:
        lineno, line = rows[i]
        _, col, width = _fields(line)[0]
        return Span(path, lineno, col, lineno, col + width)

    bad = np.flatnonzero(steps <= 0)
    if bad.size:
        i = int(bad[0]) + 1
        diags.append(Diagnostic(
            "STL604", f"t is not increasing: {t[i]:g} follows {t[i - 1]:g}", span(i),
            "sort the rows by time and remove repeated samples"))
        return
    if not uniform:
        return
    dt = float(np.median(steps))
    bad = np.flatnonzero(np.abs(steps - dt) > STEP_TOLERANCE * dt)
    if bad.size:
        i = int(bad[0]) + 1
        diags.append(Diagnostic(
            "STL604", f"t is not uniform: step {steps[i - 1]:g} s from {t[i - 1]:g} to {t[i]:g},"
            f" the other steps are {dt:g} s", span(i),
            f"resample the trace to a uniform step (e.g. {dt:g} s), or let `stlc monitor "
            f"--resample {dt:g}` interpolate it"))


def check_signals(trace: Trace, needed: set[str],
                  span_for: Callable[[str], Span] | None = None) -> None:
    """Raise ``StlcError`` with one STL603 per signal in ``needed`` that the trace lacks.

    ``span_for(name)`` gives the span to point at (e.g. the first use in the ``.stl`` file);
    by default the header row of the trace.
    """
    diags = []
    have = sorted(trace.channels)
    for name in sorted(set(needed) - set(trace.channels)):
        span = span_for(name) if span_for is not None else trace.header_span
        hint = did_you_mean(name, have)
        cols = ", ".join(have) if have else "none besides t"
        diags.append(Diagnostic(
            "STL603", f"trace `{trace.path}` has no column `{name}`", span,
            hint or f"add a column `{name}` to the trace", (f"the trace has: {cols}",)))
    if diags:
        raise StlcError(diags)
