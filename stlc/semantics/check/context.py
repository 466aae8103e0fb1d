"""The checker context: the one object every module of ``stlc.semantics.check`` works on.

Modelled on mypy's ``semanal_shared``: this module holds the state of a checker pass (the
diagnostics sink, the source text, the global scope, the declared world) and the helpers the
other modules share, as *public* methods; the evaluation entry points (``value``,
``formula``, ``uncertain``) are abstract here and implemented by the modules that own them
(``elaborate``, ``formulas``, ``program``).  The modules of the package import this one and
the lower layers (``ast``, ``ir``, ``model``, ``units``, ``values``, ``diagnostics``), never
each other, so there is no import cycle; ``stlc.semantics.check.program`` puts them together.
"""

from __future__ import annotations

import math
import re
from abc import ABC, abstractmethod
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np

from stlc.diagnostics import Collector, Span, did_you_mean
from stlc.frontend import ast
from stlc.semantics import ir, model
from stlc.semantics.check import units
from stlc.semantics.check.values import ERROR, ErrorV, Form, Num, RegionV, Sym, Value, kind_name
from stlc.semantics.timegrid import is_aligned

#: sub-blocks that a block holds at most once
SINGLE_BLOCKS = ("start", "risk", "replan", "simulate")

#: a built-in function: (context, call node, scope) → checked value
Builtin = Callable[["Context", ast.Call, "Scope"], Value]


@dataclass
class Scope:
    """Name → value bindings, innermost first through ``parent``."""

    names: dict[str, Value] = field(default_factory=dict)
    parent: Scope | None = None
    #: names whose value is computed on first use (named specs, to report use-before-def)
    lookup_hook: Callable[[str, Span], Value | None] | None = None

    def get(self, name: str) -> Value | None:
        s: Scope | None = self
        while s is not None:
            if name in s.names:
                return s.names[name]
            s = s.parent
        return None

    def all_names(self, *extra: Iterable[str]) -> Names:
        """Every bound name (and ``extra``), as a view: O(depth) to make, so that a file
        full of unknown names stays linear (each "did you mean" reads it at most once)."""
        views: list[Iterable[str]] = []
        s: Scope | None = self
        while s is not None:
            views.append(s.names)  # the dict itself: the same object while the scope grows
            s = s.parent
        return Names((*views, *extra))

    def hook(self, name: str, span: Span) -> Value | None:
        """Ask the innermost ``lookup_hook`` about a name that is not bound."""
        s: Scope | None = self
        while s is not None:
            if s.lookup_hook is not None:
                return s.lookup_hook(name, span)
            s = s.parent
        return None

    def child(self, names: dict[str, Value]) -> Scope:
        return Scope(dict(names), self)


@dataclass(frozen=True)
class Names:
    """A re-iterable union of name collections (duplicates possible; for hints only)."""

    parts: tuple[Iterable[str], ...]

    def __iter__(self) -> Iterator[str]:
        for p in self.parts:
            yield from p

    def __contains__(self, name: object) -> bool:
        return any(name in p for p in self.parts)  # type: ignore[operator]


class Context(ABC):
    """State of one checker pass and the helpers shared by the checker's modules."""

    #: the built-in functions, by name (set by ``stlc.semantics.check.program``)
    functions: ClassVar[dict[str, Builtin]] = {}

    def __init__(self, tree: ast.File, placed: frozenset[str] = frozenset()):
        self.tree = tree
        #: world regions whose centre is a parameter (``--set 'pole.center.x=...'``)
        self.placed = placed
        self.d = Collector()
        self.lines = source_lines(tree.source)
        self.file = tree.path
        #: the step of the mission being checked (alignment of time bounds), or None
        self.step: float | None = None
        self.globals = Scope()
        self.vehicles: dict[str, model.Vehicle] = {}
        self.regions: list[model.Region] = []
        self.humans: dict[str, model.Human] = {}
        #: human name → {region name: RegionV} (regions in the human's frame)
        self.human_regions: dict[str, dict[str, RegionV]] = {}
        #: names bound by a quantifier whose body has ended (for the hint of a name used
        #: after an unparenthesised body: `forall d in team: p(d) and q(d)`)
        self.closed_quant: dict[str, Span] = {}
        self.params: dict[str, float] = {}
        self.defined: dict[str, Span] = {}
        #: names whose declaration had errors: bound to ``ErrorV`` so that uses stay silent
        self.failed: set[str] = set()
        self.where = tree.members[0].span if tree.members else Span.none()  # for STL004

    def human_region_hint(self, name: str) -> str | None:
        """``handover`` is a human's region: say it is written ``op.handover``."""
        owners = [h for h, regs in self.human_regions.items() if name in regs]
        if not owners:
            return None
        return (f"`{name}` is a region of human `{owners[0]}`: write `{owners[0]}.{name}` "
                "(a human's regions move with the human and carry its name)")

    # ------------------------------------------------------------ implemented elsewhere
    @abstractmethod
    def value(self, node: ast.Node, scope: Scope) -> Value:
        """Evaluate an expression or formula (``stlc.semantics.check.elaborate``)."""

    @abstractmethod
    def formula(self, node: ast.Node, scope: Scope) -> ir.Formula | None:
        """Elaborate a node that must be a formula (``stlc.semantics.check.formulas``)."""

    @abstractmethod
    def team_quant(self, n: ast.Quant, scope: Scope, dom, out: ir.Formula, parts: tuple,
                   total: int) -> ir.Formula:
        """Record a quantifier over ``team`` (``stlc.semantics.check.teams``)."""

    @abstractmethod
    def uncertain(self, m: ast.Uncertain, human: str | None, attach: bool = True
                  ) -> model.Normal | None:
        """Check ``human.pos ~ normal(...)`` (``stlc.semantics.check.declarations``)."""

    # ------------------------------------------------------------ diagnostics
    def err(self, code: str, msg: str, span: Span, help: str | None = None) -> ErrorV:
        self.d.error(code, msg, span, help)
        return ERROR

    def text(self, span: Span) -> str:
        """The source text of a span (single line; for predicate labels)."""
        if not span.known or span.line > len(self.lines):
            return ""
        line = self.lines[span.line - 1]
        if span.end_line == span.line:
            return line[span.col - 1: span.end_col - 1].strip()
        return line[span.col - 1:].strip() + " …"

    def define(self, name: str, span: Span, what: str) -> bool:
        """Record a top-level name; STL102 (and False) if it is taken."""
        if name in self.defined:
            prev = self.defined[name]
            self.d.error("STL102", f"`{name}` is already defined (line {prev.line})", span,
                         f"rename this {what}")
            return False
        self.defined[name] = span
        return True

    def bad_kind(self, kind: str, span: Span, allowed, where: str) -> None:
        self.d.error("STL108", f"`{kind}` is not allowed {where}", span,
                     did_you_mean(kind, allowed) or "allowed here: " + ", ".join(allowed))

    # ------------------------------------------------------------ constants
    def number(self, node: ast.Node, scope: Scope, want: units.Dim | None = None,
               what: str = "value") -> float | None:
        """A constant scalar in SI units, checked against the expected dimension
        (``units.DIMLESS``: a plain number, no unit allowed; ``None``: any)."""
        v = self.value(node, scope)
        if isinstance(v, ErrorV):
            return None
        if not isinstance(v, Num) or not v.is_scalar:
            self.err("STL210", f"expected a constant number for {what}, found {kind_name(v)}"
                     if not isinstance(v, Num) else f"expected a single number for {what}",
                     node.span)
            return None
        if not self.unit_ok(v, want, what, node, f"write it like `{example(want)}`"):
            return None
        return float(v.v)

    def vector(self, node: ast.Node, scope: Scope, n: int | None, want: units.Dim | None,
               what: str) -> np.ndarray | None:
        """Constant numbers (``n`` of them; a scalar is repeated) in SI units."""
        v = self.value(node, scope)
        if isinstance(v, ErrorV):
            return None
        if not isinstance(v, Num):
            self.err("STL210", f"expected constant numbers for {what}, found {kind_name(v)}",
                     node.span)
            return None
        arr = np.atleast_1d(v.v).astype(float)
        if n is not None and arr.shape != (n,):
            if arr.shape == (1,):
                arr = np.repeat(arr, n)
            else:
                self.err("STL205", f"{what} needs {n} components, found {arr.size}", node.span,
                         f"write {n} numbers in parentheses, e.g. ({', '.join(['0'] * n)})")
                return None
        if not self.unit_ok(v, want, what, node, f"add the unit, e.g. `{example(want)}`"):
            return None
        return arr

    def unit_ok(self, v: Num, want: units.Dim | None, what: str, node: ast.Node,
                help: str) -> bool:
        """Report STL204 unless the constant ``v`` has the dimension ``want`` (or none)."""
        if want is None or units.compatible(v.dim, want):
            return True
        if want == units.DIMLESS:  # a plain number: point at the unit written after it
            self.err("STL204", f"unit mismatch: {what} is a plain number, found "
                     f"{units.describe(v.dim)}", unit_span(node),
                     f"drop the unit: {what} takes no unit")
            return False
        self.err("STL204", f"unit mismatch: {what} must be {units.describe(want)}, "
                 f"found {units.describe(v.dim)}", node.span, help)
        return False

    def finite(self, x: np.ndarray | float, what: str, span: Span) -> bool:
        """STL207 unless every number of ``x`` is finite."""
        arr = np.asarray(x, dtype=float)
        if np.all(np.isfinite(arr)):
            return True
        bad = float(arr[~np.isfinite(arr)].flat[0])
        self.err("STL207", f"{what} must be finite, found {bad:g}", span,
                 "`inf` may only be the upper bound of a time interval")
        return False

    # ------------------------------------------------------------ fields of a block
    def fields(self, block: ast.Block, allowed: dict[str, bool], sub_blocks=(),
               named_kinds=()) -> dict[str, ast.Member]:
        """Index a block's members by name; report unknown, duplicate and missing ones.
        ``allowed`` maps field name → required.  Of the ``sub_blocks``, a ``SINGLE_BLOCKS``
        kind may appear once; others may repeat (`rotor { }` blocks), but not under one
        name."""
        out: dict[str, ast.Member] = {}
        for m in block.members:
            if isinstance(m, ast.Field):
                key, span = m.name, m.name_span
                if key not in allowed:
                    self.d.error("STL103", f"unknown field `{key}` in `{block.kind}`", span,
                                 did_you_mean(key, allowed) or
                                 "fields: " + ", ".join(allowed))
                    continue
            elif isinstance(m, ast.Block) and m.kind in sub_blocks:
                if m.kind in SINGLE_BLOCKS:
                    key, span = m.kind, m.span
                    if key in out:
                        self.d.error("STL102", f"`{key}` is given twice: a `{block.kind}` has "
                                     f"one `{key}` block", span, f"merge the `{key}` blocks")
                        continue
                elif m.name:
                    key, span = m.kind + ":" + m.name, m.name_span
                else:
                    continue
            else:  # named members (`named_kinds`) and the rest are checked by the caller
                continue
            if key in out:
                self.d.error("STL102", f"`{key.split(':')[-1]}` is given twice", span)
                continue
            out[key] = m
        for name, required in allowed.items():
            if required and name not in out:
                self.d.error("STL104", f"`{block.kind}` `{block.name or ''}` is missing "
                             f"`{name}`".replace("`` ", ""), block.name_span,
                             f"add `{name} = ...`")
        return out

    def num(self, f: dict, key: str, dim, default=None, positive=False,
            scope: Scope | None = None) -> float | None:
        """The constant scalar field ``key`` of ``f`` (finite; > 0 if ``positive``),
        evaluated in ``scope`` (the global scope by default)."""
        m = f.get(key)
        if m is None:
            return default
        x = self.number(m.value, scope or self.globals, dim, f"`{key}`")
        if x is not None and not math.isfinite(x):
            self.d.error("STL207", f"`{key}` must be a finite number, found {x:g}", m.value.span)
            return None
        if x is not None and positive and not x > 0:
            self.d.error("STL207", f"`{key}` must be positive", m.value.span)
            return None
        return x

    def vec(self, f: dict, key: str, n: int | None, dim, default=None
            ) -> tuple[float, ...] | None:
        """The constant vector field ``key`` of ``f`` (finite)."""
        m = f.get(key)
        if m is None:
            return default
        arr = self.vector(m.value, self.globals, n, dim, f"`{key}`")
        if arr is not None and not np.all(np.isfinite(arr)):
            self.d.error("STL207", f"`{key}` must be finite numbers", m.value.span)
            return None
        return None if arr is None else tuple(float(x) for x in arr)

    def consts(self, members: list[ast.Named], scope: Scope) -> None:
        """Bind ``const NAME = number`` declarations in ``scope``."""
        for m in members:
            if not self.define(m.name, m.name_span, "constant"):
                continue
            v = self.value(m.value, scope)
            if isinstance(v, (Num, ErrorV)):
                scope.names[m.name] = v
                continue
            scope.names[m.name] = ERROR  # reported here, silent where it is used
            if isinstance(v, Sym):
                self.d.error("STL210", "a constant must not read signals", m.value.span,
                             "use the expression in a spec directly, or declare the "
                             "constant from numbers only")
            else:
                self.d.error("STL210", f"a constant must be a number, found {kind_name(v)}",
                             m.value.span, "use `spec` to name a formula"
                             if isinstance(v, Form) else None)

    # ------------------------------------------------------------ named specs
    def named_specs(self, members: list[ast.Named], scope: Scope, step: float | None
                    ) -> tuple[dict[str, ir.Formula], dict[str, Span]]:
        """Elaborate named specs in order: a spec may use only the specs before it; a use of
        a later spec or of itself is STL106 where it is used."""
        specs: dict[str, ir.Formula] = {}
        spans: dict[str, Span] = {}
        seen: dict[str, Span] = {}  # every spec name so far, checked or not
        pending: dict[str, ast.Named] = {}  # specs not elaborated yet (first of each name)
        for m in reversed(members):
            pending[m.name] = m
        current: list[str] = []
        self.step = step

        def hook(name: str, span: Span) -> Value | None:
            if current and name == current[0]:
                self.d.error("STL106", f"spec `{name}` refers to itself", span,
                             self.human_region_hint(name) or
                             "a formula cannot be recursive; use `always` or `eventually` to "
                             "repeat it over time")
                return ERROR
            if name in pending:
                self.d.error("STL106", f"spec `{name}` is used before it is defined", span,
                             f"move the definition of `{name}` (line "
                             f"{pending[name].name_span.line}) above this spec")
                return ERROR
            return None

        scope.lookup_hook = hook
        for m in members:
            if pending.get(m.name) is m:
                del pending[m.name]
            prev = seen.get(m.name)
            if prev is None and scope.get(m.name) is not None:
                prev = self.defined.get(m.name)  # a vehicle, signal, constant, ...
            if prev is not None:
                self.d.error("STL102", f"`{m.name}` is already defined"
                             + (f" (line {prev.line})" if prev.known else ""),
                             m.name_span, "rename this spec")
                continue
            seen[m.name] = m.name_span
            current[:] = [m.name]
            f = self.formula(m.value, scope)
            current.clear()
            scope.names[m.name] = ERROR if f is None else Form(f)
            if f is not None:
                specs[m.name] = f
                spans[m.name] = m.span
        scope.lookup_hook = None
        return specs, spans


# ---------------------------------------------------------------- small shared functions


def source_lines(text: str) -> list[str]:
    """The lines of a source file as the parser counts them: split at ``\n``, ``\r\n`` and
    ``\r`` only (``str.splitlines`` also splits at form feeds and U+2028, which would
    shift every later line)."""
    return re.split(r"\r\n|\r|\n", text)


def example(d: units.Dim | None) -> str:
    u = units.example_unit(d)
    return f"1 {u}" if u else "1"


def unit_span(node: ast.Node) -> Span:
    """The span of the first unit written in ``node`` (the whole node if it has none, e.g.
    when the unit comes from a constant)."""
    stack = [node]
    while stack:
        n = stack.pop()
        s = n.span
        if isinstance(n, ast.Quantity) and s.known and s.end_col > len(n.unit):
            return Span(s.file, s.end_line, s.end_col - len(n.unit), s.end_line, s.end_col)
        stack.extend(reversed(ast.node_children(n)))
    return node.span


def misaligned(t: float, step: float) -> bool:
    """Is a (finite) time bound off the mission's sample grid?"""
    if math.isinf(t):
        return False
    if not math.isfinite(t / step):
        return True
    return not is_aligned(t, step)


def nearest_hint(t: float, step: float, horizon: float | None = None) -> str | None:
    """``use 0.9 s``: the nearest bound on the grid (not past ``horizon`` when given)."""
    q = t / step
    if not math.isfinite(q):
        return None
    k = round(q)
    if horizon is not None and k * step > horizon + 1e-9:
        k = math.floor(q)
    return f"use {k * step:g} s"


def misaligned_intervals(f: ir.Formula, step: float) -> Iterator[tuple[ir.Formula, float]]:
    """Every temporal node of ``f`` with a bound off the grid of ``step`` (and that bound)."""
    stack = [f]
    while stack:
        g = stack.pop()
        if isinstance(g, ir.WINDOWED):
            bad = [t for t in (g.lo, g.hi) if misaligned(t, step)]
            if bad:
                yield g, bad[0]
        stack.extend(reversed(ir.children(g)))
