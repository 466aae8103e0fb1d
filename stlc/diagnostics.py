"""Diagnostics: source spans, registered error codes and rustc-style rendering.

Every error the front end reports is a ``Diagnostic`` with a registered code
(``STL0xx`` syntax, ``STL1xx`` names, ``STL2xx`` types and units, ``STL3xx`` time,
``STL4xx`` backend applicability, ``STL5xx`` solve outcomes, ``STL6xx`` input files).
A pass collects all of its diagnostics; ``render`` prints them as

    file:line:col: error[STL204]: unit mismatch: expected a time, found a length
       |
     7 |   horizon = 17 m
       |             ^^^^
       = help: write the horizon in seconds, e.g. `17 s`
"""

from __future__ import annotations

import difflib
import json
import re
from dataclasses import dataclass, field

_LINE_END = re.compile(r"\r\n|\r|\n")


def normalize_newlines(text: str) -> str:
    """``\\r\\n`` and lone ``\\r`` → ``\\n`` (columns are unchanged)."""
    return text.replace("\r\n", "\n").replace("\r", "\n") if "\r" in text else text


def source_lines(text: str) -> list[str]:
    """The lines of a source file as every pass numbers them: split at ``\\n``, ``\\r\\n``
    and a lone ``\\r`` only (not at ``\\f``, ``\\v``, U+2028 … as ``str.splitlines`` does).
    A final line end does not start another line."""
    lines = _LINE_END.split(text)
    if lines and lines[-1] == "" and len(lines) > 1:
        lines.pop()
    return lines if text else []


#: every code the tool can emit, with a one-line description (docs/errors.md lists these)
CODES: dict[str, str] = {
    # syntax
    "STL001": "unexpected character",
    "STL002": "unexpected token",
    "STL003": "unexpected end of file",
    "STL004": "nesting too deep",
    "STL005": "file is not valid UTF-8 text",
    "STL006": "line too long",
    # names
    "STL101": "unknown name",
    "STL102": "duplicate definition",
    "STL103": "unknown field",
    "STL104": "missing required field",
    "STL105": "unknown vehicle model",
    "STL106": "named spec used before it is defined, or recursively",
    "STL107": "unknown function",
    "STL108": "wrong kind of declaration here",
    "STL109": "no mission or spec to work on",
    "STL110": "unusable backup drone (already in the team, or no payload capacity)",
    # types and units
    "STL201": "expected a formula, found a number",
    "STL202": "expected a number, found a formula",
    "STL203": "unknown unit",
    "STL204": "unit mismatch",
    "STL205": "wrong vector size",
    "STL206": "wrong number of arguments",
    "STL207": "value out of range",
    "STL208": "expected a region",
    "STL209": "invalid covariance matrix",
    "STL210": "expected a constant value",
    "STL211": "empty region",
    "STL212": "quantifier over an empty set",
    # time
    "STL301": "negative time bound",
    "STL302": "interval bounds out of order",
    "STL303": "interval not aligned to the mission step",
    "STL304": "formula reaches beyond the mission horizon",
    "STL305": "invalid horizon or step",
    "STL306": "simulation event outside the mission horizon",
    # backend applicability
    "STL401": "the backend does not support this construct",
    "STL402": "vehicle start state violates its bounds",
    # solve outcomes
    "STL501": "no satisfying plan found",
    "STL502": "the solver failed",
    "STL503": "no task assignment exists (capacity, stations, reach or horizon)",
    "STL504": "no plan can satisfy the mission: its specs conflict (proved infeasible)",
    "STL505": "the start state cannot meet the threshold κ: no plan exists",
    # input files (traces, trajectories)
    "STL601": "cannot read file",
    "STL602": "malformed trace",
    "STL603": "trace is missing a signal",
    "STL604": "trace time column is not uniform",
    # output files
    "STL605": "cannot write the output directory",
    "STL606": "problem too large for the resource budget (memory, instances, samples)",
    "STL607": "cannot connect to the Dask scheduler (`--scheduler`)",
    # warnings (`stlc.semantics.lint`, `stlc.analysis.vacuity`): exit 0 unless --deny-warnings
    "STLW01": "a binary operator's right operand is outside the temporal operator before it",
    "STLW02": "an implication holds only vacuously on the plan",
    "STLW03": "a region lies outside the workspace",
    "STLW04": "declared and never used",
    "STLW05": "one threshold κ over predicates measured in different units",
}


@dataclass(frozen=True, slots=True)
class Span:
    """A region of a source file: 1-based line/column of start and end (end exclusive)."""

    file: str
    line: int
    col: int
    end_line: int
    end_col: int

    @staticmethod
    def none() -> Span:
        return Span("", 0, 0, 0, 0)

    @property
    def known(self) -> bool:
        return self.line > 0

    def to(self, other: Span) -> Span:
        if not self.known:
            return other
        if not other.known:
            return self
        return Span(self.file, self.line, self.col, other.end_line, other.end_col)


@dataclass(frozen=True, slots=True)
class Diagnostic:
    code: str
    message: str
    span: Span
    help: str | None = None
    notes: tuple[str, ...] = ()
    severity: str = "error"

    def __post_init__(self) -> None:
        if self.code not in CODES:
            raise ValueError(f"unregistered diagnostic code {self.code}")

    @property
    def line(self) -> int:
        """1-based line (0 when the diagnostic has no location)."""
        return self.span.line

    @property
    def column(self) -> int:
        """1-based column."""
        return self.span.col

    def sort_key(self) -> tuple:
        return (self.span.file, self.span.line, self.span.col, self.code, self.message)

    def to_json(self) -> dict:
        return {
            "code": self.code,
            "severity": self.severity,
            "message": self.message,
            "file": self.span.file,
            "line": self.span.line,
            "col": self.span.col,
            "end_line": self.span.end_line,
            "end_col": self.span.end_col,
            "help": self.help,
            "notes": list(self.notes),
        }


class StlcError(Exception):
    """Raised by a pass that cannot go on; carries every diagnostic collected so far."""

    def __init__(self, diagnostics: list[Diagnostic]):
        self.diagnostics = sorted_unique(diagnostics)
        super().__init__("\n".join(d.message for d in self.diagnostics))


def sorted_unique(diags: list[Diagnostic]) -> list[Diagnostic]:
    seen: set[tuple] = set()
    out = []
    for d in sorted(diags, key=Diagnostic.sort_key):
        k = d.sort_key()
        if k not in seen:
            seen.add(k)
            out.append(d)
    return out


@dataclass
class Collector:
    """Accumulates diagnostics during a pass."""

    diagnostics: list[Diagnostic] = field(default_factory=list)

    def error(self, code: str, message: str, span: Span, help: str | None = None,
              notes: tuple[str, ...] = ()) -> None:
        self.diagnostics.append(Diagnostic(code, message, span, help, notes))

    @property
    def failed(self) -> bool:
        return any(d.severity == "error" for d in self.diagnostics)

    def raise_if_failed(self) -> None:
        if self.failed:
            raise StlcError(self.diagnostics)


MAX_SUGGEST_LEN = 64  # names longer than this get no suggestion
MAX_COMPARED = 500  # candidates compared per suggestion, the closest in length first


class _Index:
    """Candidate names by length and by lower-case spelling, for one set of names.  Kept
    between calls and extended when the next set is a superset (a checker's scope grows by
    one name per declaration): a file with thousands of errors then costs linear time."""

    def __init__(self) -> None:
        self.names: frozenset | set = frozenset()
        self.by_len: dict[int, list[str]] = {}
        self.by_first: dict[tuple[int, str], list[str]] = {}  # (length, first letter)
        self.lower: dict[str, str] = {}
        #: ``update_parts``: the collections read (held, so their ids stay theirs) and how
        #: many entries of each are indexed
        self.parts: tuple = ()
        self.seen: list[int] = []

    def _add(self, names) -> None:
        for c in sorted(names, key=str):
            if isinstance(c, str) and len(c) <= MAX_SUGGEST_LEN:
                self.by_len.setdefault(len(c), []).append(c)
                self.by_first.setdefault((len(c), c[:1].lower()), []).append(c)
                self.lower.setdefault(c.lower(), c)

    def update(self, cands: frozenset) -> None:
        if self.parts or not self.names <= cands:
            self.__init__()
        if cands == self.names:
            return
        self._add(cands - self.names)
        self.names = cands

    def update_parts(self, parts: tuple) -> None:
        """Index the union of ``parts`` — insertion-ordered collections that only grow
        between calls (a checker's scopes: one name per declaration) — reading only the
        entries added since the last call: a file with thousands of unknown names costs
        linear time, not one pass over every bound name per name."""
        if len(parts) != len(self.parts) or any(a is not b for a, b in zip(parts, self.parts)) \
                or any(len(p) < k for p, k in zip(parts, self.seen)):
            self.__init__()
            self.parts, self.seen, self.names = parts, [0] * len(parts), set()
        for i, p in enumerate(parts):
            k = self.seen[i]
            if len(p) > k:
                new = [c for c in (list(p)[k:] if k else p) if c not in self.names]
                self.names.update(new)
                self._add(new)
                self.seen[i] = len(p)


_INDEX = _Index()


def did_you_mean(name: str, candidates) -> str | None:
    """A "did you mean `x`?" hint by edit distance (Elm's nearbyNames).

    Bounded work per call: only candidates whose length allows a similarity ratio of 0.6
    (``2·min/(a+b) >= 0.6``) are compared, at most ``MAX_COMPARED`` of them, closest in
    length and with the same first letter first; very long names get no suggestion."""
    if not name or len(name) > MAX_SUGGEST_LEN:
        return None
    parts = getattr(candidates, "parts", None)
    if parts is not None:  # a view over growing scopes (``check.context.Names``)
        _INDEX.update_parts(parts)
    else:
        _INDEX.update(candidates if isinstance(candidates, frozenset)
                      else frozenset(candidates))
    n = len(name)
    lengths = sorted((m for m in range(1, MAX_SUGGEST_LEN + 1)
                      if 2 * min(n, m) >= 0.6 * (n + m)), key=lambda m: abs(m - n))
    near: list[str] = []
    seen: set[str] = set()
    first = name[:1].lower()  # names with the same first letter first, then the others
    for bucket in [_INDEX.by_first.get((m, first), ()) for m in lengths] + \
            [_INDEX.by_len.get(m, ()) for m in lengths]:
        for c in bucket:
            if len(near) >= MAX_COMPARED:
                break
            if c not in seen:
                seen.add(c)
                near.append(c)
    lower = _INDEX.lower
    close = difflib.get_close_matches(name, near, n=1, cutoff=0.6)
    if not close and name.lower() in lower:
        close = [lower[name.lower()]]
    return f"did you mean `{close[0]}`?" if close else None


MAX_SHOWN_LINE = 200


def _shown(line: str) -> str:
    """A source line as printed: tabs and other control characters become one column each
    (so carets stay aligned and no escape sequence reaches the terminal)."""
    return "".join(c if c.isprintable() else " " if c == "\t" else "\ufffd" for c in line)


def render(d: Diagnostic, sources: dict[str, str] | None = None,
           _lines: dict[str, list[str]] | None = None) -> str:
    """Render one diagnostic like rustc/ruff; ``sources`` maps file name to its text
    (``_lines`` caches their split lines across the diagnostics of ``render_all``)."""
    s = d.span
    head = f"{s.file or '<input>'}:{s.line}:{s.col}: {d.severity}[{d.code}]: {d.message}"
    lines = [head]
    text = (sources or {}).get(s.file)
    if text is not None and s.known:
        cache = {} if _lines is None else _lines
        src_lines = cache.get(s.file)
        if src_lines is None:
            src_lines = cache[s.file] = source_lines(text)
        if 0 < s.line <= len(src_lines):
            src = _shown(src_lines[s.line - 1])
            col0 = s.col - 1
            width = (s.end_col - s.col) if s.end_line == s.line else len(src) - col0
            width = max(1, width)
            if len(src) > MAX_SHOWN_LINE:  # keep very long lines readable
                start = max(0, col0 - 40)
                src = ("…" if start else "") + src[start:start + MAX_SHOWN_LINE] + "…"
                col0 = col0 - start + (1 if start else 0)
                width = min(width, MAX_SHOWN_LINE)
            gutter = str(s.line)
            pad = " " * len(gutter)
            lines.append(f"{pad} |")
            lines.append(f"{gutter} | {src}")
            lines.append(f"{pad} | {' ' * col0}{'^' * width}")
    for n in d.notes:
        lines.append(f"  = note: {n}")
    if d.help:
        lines.append(f"  = help: {d.help}")
    return "\n".join(lines)


def render_all(diags: list[Diagnostic], sources: dict[str, str] | None = None) -> str:
    cache: dict[str, list[str]] = {}
    return "\n\n".join(render(d, sources, cache) for d in diags)


def to_json(diags: list[Diagnostic]) -> str:
    return json.dumps({"diagnostics": [d.to_json() for d in diags]}, indent=2)


def emit_warnings(warnings: list[Diagnostic], deny: bool,
                  sources: dict[str, str] | None = None) -> None:
    """Print ``warnings`` to stderr (``warning[STLWxx]``); with ``deny``
    (``--deny-warnings``) raise them as errors instead."""
    import sys
    from dataclasses import replace

    if not warnings:
        return
    if deny:
        raise StlcError([replace(w, severity="error") for w in warnings])
    if sources is None:
        sources = {}
        for f in {w.span.file for w in warnings if w.span.file}:
            try:
                with open(f, encoding="utf-8", errors="replace") as fh:
                    sources[f] = fh.read().removeprefix("\ufeff")
            except OSError:
                pass
    print(render_all(warnings, sources), file=sys.stderr)
    print(f"stlc: {count_text(warnings)}", file=sys.stderr)


def count_text(diags: list[Diagnostic]) -> str:
    """``1 error, 2 warnings``: the diagnostics counted as they are shown (by severity)."""
    n = sum(1 for d in diags if d.severity == "error")
    w = len(diags) - n
    parts = [f"{k} {word}{'s' if k != 1 else ''}" for k, word in ((n, "error"), (w, "warning"))
             if k]
    return ", ".join(parts) or "0 errors"
