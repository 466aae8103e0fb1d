"""Typed intermediate representation of STL formulas, and walkers over it.

The checker lowers the surface AST into this IR: every expression is a *scalar*
tree in SI units over three kinds of leaves,

* ``Sig(name)``   — a sampled signal channel (``"x"``, ``"uav1.pos.x"``, ``"uav1.force.3"``),
* ``Param(name)`` — a scenario quantity that is fixed for a plan but may be uncertain
                    (``"operator.pos.x"``, ``"operator.att.z"``),
* ``Const(value)``.

Vectors, regions, quantifiers and named specs are gone by the time we get here: a box
membership is an ``And`` of scalar predicates, ``forall d in team`` is an ``And`` over the
team, a reference to a named spec is its (already lowered) formula.  Time bounds are kept
in seconds; a ``TimeGrid`` turns them into sample indices.

Every backend (exact monitor, numpy smooth reference, CasADi NLP) interprets the same IR.
``stlc.semantics.nnf.normalize`` desugars ``Implies``, pushes ``Not`` down to predicates
(negation normal form, adding ``Release`` as the dual of ``Until``) and flattens nested
``And``/``Or``.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import dataclass, field

from stlc.diagnostics import Span
from stlc.semantics.origin import Origin

NO_SPAN = Span.none()


def _hash(self) -> int:
    """The structural hash, computed once per node: formulas are DAGs (a named spec used
    twice is one object), and memo tables keyed by node would otherwise re-hash a whole
    subtree per lookup (quadratic on a chain of hundreds of named specs)."""
    h = self._h
    if h == 0:
        h = hash((type(self).__name__, *(getattr(self, f) for f in self._keys))) or 1
        object.__setattr__(self, "_h", h)
    return h


def _reduce(self):
    """Pickle without the cached hash (string hashes differ between processes)."""
    return type(self), tuple(getattr(self, f) for f in self._init)


def _cached_hash(cls):
    from dataclasses import fields

    cls._keys = tuple(f.name for f in fields(cls) if f.compare)
    cls._init = tuple(f.name for f in fields(cls) if f.init)
    cls.__hash__ = _hash
    cls.__reduce__ = _reduce
    return cls

# --------------------------------------------------------------------------- expressions


@dataclass(frozen=True, slots=True)
class Const:
    value: float


@dataclass(frozen=True, slots=True)
class Sig:
    name: str


@dataclass(frozen=True, slots=True)
class Param:
    name: str


@_cached_hash
@dataclass(frozen=True, slots=True)
class Neg:
    arg: Expr
    _h: int = field(default=0, init=False, repr=False, compare=False)


@_cached_hash
@dataclass(frozen=True, slots=True)
class Bin:
    """Binary arithmetic; ``op`` is one of ``+ - * / ^``."""

    op: str
    left: Expr
    right: Expr
    _h: int = field(default=0, init=False, repr=False, compare=False)


#: unary functions allowed in ``Call``: abs sqrt sin cos exp log
#: n-ary: min max; binary: atan2; ``angdiff(a, b)`` = wrapped a - b in (-pi, pi]
CALLS_1 = ("abs", "sqrt", "sin", "cos", "exp", "log")
CALLS_N = ("min", "max", "atan2", "angdiff")


@_cached_hash
@dataclass(frozen=True, slots=True)
class Call:
    fn: str
    args: tuple[Expr, ...]
    _h: int = field(default=0, init=False, repr=False, compare=False)


Expr = Const | Sig | Param | Neg | Bin | Call

# --------------------------------------------------------------------------- formulas


@dataclass(frozen=True, slots=True)
class Bound:
    """The structure of a simple predicate ``side ≤ value`` (``upper``) or ``side ≥ value``
    (``lower``): which signal it bounds (its canonical name, e.g. ``uav1.speed``,
    ``uav1.rotor_speed.2``, or the source text of an expression), the bounded expression
    itself, and the bound in SI units.  Reports read limits from here, never from labels."""

    signal: str
    side: str  # "upper" | "lower"
    value: float
    expr: Expr
    calls: frozenset[str] = frozenset()  # functions written on the bounded side (dist, …)

    def negated(self) -> Bound:
        return Bound(self.signal, "lower" if self.side == "upper" else "upper", self.value,
                     self.expr, self.calls)


@_cached_hash
@dataclass(frozen=True, slots=True)
class Pred:
    """Atomic predicate ``expr >= 0``; its robustness is the value of ``expr``.

    ``label`` is the human-readable source text (e.g. ``"uav1.pos.z <= 2.5"``) shown as
    written; ``bound`` keeps the structure of a predicate that compares a signal with a
    constant; ``origin`` what the checker made it from (a box face, a range side, negated or
    not: ``stlc.semantics.origin``) — passes read these fields, never the label.
    """

    expr: Expr
    label: str = ""
    span: Span = field(default=NO_SPAN, compare=False)
    bound: Bound | None = field(default=None, compare=False)
    origin: Origin | None = field(default=None, compare=False)
    _h: int = field(default=0, init=False, repr=False, compare=False)


@dataclass(frozen=True, slots=True)
class TrueF:
    """The constant ``true`` (robustness +inf); ``FalseF`` is its negation."""

    span: Span = field(default=NO_SPAN, compare=False)


@dataclass(frozen=True, slots=True)
class FalseF:
    span: Span = field(default=NO_SPAN, compare=False)


@_cached_hash
@dataclass(frozen=True, slots=True)
class Not:
    arg: Formula
    span: Span = field(default=NO_SPAN, compare=False)
    _h: int = field(default=0, init=False, repr=False, compare=False)


@_cached_hash
@dataclass(frozen=True, slots=True)
class And:
    args: tuple[Formula, ...]
    span: Span = field(default=NO_SPAN, compare=False)
    _h: int = field(default=0, init=False, repr=False, compare=False)


@_cached_hash
@dataclass(frozen=True, slots=True)
class Or:
    args: tuple[Formula, ...]
    span: Span = field(default=NO_SPAN, compare=False)
    _h: int = field(default=0, init=False, repr=False, compare=False)


@_cached_hash
@dataclass(frozen=True, slots=True)
class Implies:
    left: Formula
    right: Formula
    span: Span = field(default=NO_SPAN, compare=False)
    _h: int = field(default=0, init=False, repr=False, compare=False)


@_cached_hash
@dataclass(frozen=True, slots=True)
class Always:
    """``always[lo, hi] arg``; bounds in seconds, ``hi`` may be ``math.inf``."""

    lo: float
    hi: float
    arg: Formula
    span: Span = field(default=NO_SPAN, compare=False)
    _h: int = field(default=0, init=False, repr=False, compare=False)


@_cached_hash
@dataclass(frozen=True, slots=True)
class Eventually:
    lo: float
    hi: float
    arg: Formula
    span: Span = field(default=NO_SPAN, compare=False)
    _h: int = field(default=0, init=False, repr=False, compare=False)


@_cached_hash
@dataclass(frozen=True, slots=True)
class Until:
    """``left until[lo, hi] right``: max over k' in the window of
    min(right(k'), min of left over k..k') — the left-window includes k'."""

    lo: float
    hi: float
    left: Formula
    right: Formula
    span: Span = field(default=NO_SPAN, compare=False)
    _h: int = field(default=0, init=False, repr=False, compare=False)


@_cached_hash
@dataclass(frozen=True, slots=True)
class Release:
    """Dual of ``Until`` (only produced by ``normalize``):
    ``a release[lo,hi] b`` = not(not a until[lo,hi] not b)
    = min over k' in window of max(b(k'), max of a over k..k')."""

    lo: float
    hi: float
    left: Formula
    right: Formula
    span: Span = field(default=NO_SPAN, compare=False)
    _h: int = field(default=0, init=False, repr=False, compare=False)


@_cached_hash
@dataclass(frozen=True, slots=True)
class Next:
    arg: Formula
    span: Span = field(default=NO_SPAN, compare=False)
    _h: int = field(default=0, init=False, repr=False, compare=False)


Formula = (Pred | TrueF | FalseF | Not | And | Or | Implies | Always | Eventually | Until
           | Release | Next)

FORMULA_NODES = (Pred, TrueF, FalseF, Not, And, Or, Implies, Always, Eventually, Until, Release,
                 Next)
#: the node types that may remain after ``normalize``
NNF_NODES = (Pred, TrueF, FalseF, And, Or, Always, Eventually, Until, Release, Next)
#: the temporal nodes with a time window ``[lo, hi]`` (the one list of them)
WINDOWED = (Always, Eventually, Until, Release)

# --------------------------------------------------------------------------- utilities


def children(f: Formula) -> tuple[Formula, ...]:
    match f:
        case Pred() | TrueF() | FalseF():
            return ()
        case Not(a) | Always(_, _, a) | Eventually(_, _, a) | Next(a):
            return (a,)
        case And(args) | Or(args):
            return args
        case Implies(a, b) | Until(_, _, a, b) | Release(_, _, a, b):
            return (a, b)
    raise TypeError(f"not a formula node: {f!r}")


def map_children(f: Formula, go) -> Formula:
    """``f`` with ``go`` applied to each direct sub-formula (a leaf is returned as it is):
    the recursion step of a formula rewrite that changes only some node types."""
    match f:
        case Not(a, span) | Next(a, span):
            return type(f)(go(a), span)
        case And(args, span) | Or(args, span):
            return type(f)(tuple(go(a) for a in args), span)
        case Always(lo, hi, a, span) | Eventually(lo, hi, a, span):
            return type(f)(lo, hi, go(a), span)
        case Until(lo, hi, a, b, span) | Release(lo, hi, a, b, span):
            return type(f)(lo, hi, go(a), go(b), span)
        case Implies(a, b, span):
            return Implies(go(a), go(b), span)
        case Pred() | TrueF() | FalseF():
            return f
    raise TypeError(f"not a formula node: {f!r}")


def horizon(f: Formula, dt: float) -> float:
    """How far into the future (seconds) the formula looks from its evaluation time.

    An unbounded window (``hi = inf``) runs to the end of the trace and adds nothing."""
    match f:
        case Pred() | TrueF() | FalseF():
            return 0.0
        case Next(a):
            return dt + horizon(a, dt)
        case Always(_, hi, a) | Eventually(_, hi, a):
            return _finite(hi) + horizon(a, dt)
        case Until(_, hi, a, b) | Release(_, hi, a, b):
            return _finite(hi) + max(horizon(a, dt), horizon(b, dt))
    return max((horizon(c, dt) for c in children(f)), default=0.0)


def _finite(t: float) -> float:
    return 0.0 if math.isinf(t) else t


def expr_leaves(e: Expr) -> set[Expr]:
    """All ``Sig`` and ``Param`` leaves of an expression."""
    match e:
        case Sig() | Param():
            return {e}
        case Const():
            return set()
        case Neg(a):
            return expr_leaves(a)
        case Bin(_, a, b):
            return expr_leaves(a) | expr_leaves(b)
        case Call(_, args):
            out: set[Expr] = set()
            for a in args:
                out |= expr_leaves(a)
            return out
    raise TypeError(f"not an expression node: {e!r}")


def nodes(f: Formula) -> Iterator[Formula]:
    """Every node of ``f`` in depth-first order, each shared node once (iterative: safe on
    chains of thousands of named specs, linear on DAGs)."""
    seen: set[int] = set()
    stack = [f]
    while stack:
        g = stack.pop()
        if id(g) in seen:
            continue
        seen.add(id(g))
        yield g
        stack.extend(reversed(children(g)))


def predicates(f: Formula) -> list[Pred]:
    """Every predicate of ``f`` in depth-first order, each shared node visited once."""
    return [g for g in nodes(f) if isinstance(g, Pred)]


def expr_nodes(e: Expr) -> Iterator[Expr]:
    """Every subexpression of ``e`` (``e`` first), iteratively."""
    stack = [e]
    while stack:
        x = stack.pop()
        yield x
        match x:
            case Bin(_, a, b):
                stack += [a, b]
            case Neg(a):
                stack.append(a)
            case Call(_, args):
                stack.extend(args)


def signals(f: Formula) -> set[str]:
    out: set[str] = set()
    for p in predicates(f):
        out |= {leaf.name for leaf in expr_leaves(p.expr) if isinstance(leaf, Sig)}
    return out


def params(f: Formula) -> set[str]:
    out: set[str] = set()
    for p in predicates(f):
        out |= {leaf.name for leaf in expr_leaves(p.expr) if isinstance(leaf, Param)}
    return out


def depth(f: Formula) -> int:
    return 1 + max((depth(c) for c in children(f)), default=0)


INF = math.inf


def restrict(f: Formula, keep) -> Formula:
    """Replace every predicate that reads a signal for which ``keep(name)`` is false by
    ``true`` and simplify (NNF input).  Used to build a kinematic initial-guess problem
    from the position/velocity part of a requirement."""
    match f:
        case Pred(expr):
            ok = all(keep(leaf.name) for leaf in expr_leaves(expr) if isinstance(leaf, Sig))
            return f if ok else TrueF(f.span)
        case TrueF() | FalseF():
            return f
        case And(args, span) | Or(args, span):
            kids = [restrict(a, keep) for a in args]
            is_and = isinstance(f, And)
            if not is_and and any(isinstance(k, TrueF) for k in kids):
                return TrueF(span)
            kids = [k for k in kids if not isinstance(k, TrueF)] if is_and else kids
            if is_and and any(isinstance(k, FalseF) for k in kids):
                return FalseF(span)
            if not kids:
                return TrueF(span)
            return kids[0] if len(kids) == 1 else type(f)(tuple(kids), span)
        case Always(lo, hi, a, span) | Eventually(lo, hi, a, span):
            k = restrict(a, keep)
            return k if isinstance(k, (TrueF, FalseF)) else type(f)(lo, hi, k, span)
        case Until(lo, hi, a, b, span) | Release(lo, hi, a, b, span):
            ka, kb = restrict(a, keep), restrict(b, keep)
            if isinstance(f, Until) and isinstance(ka, TrueF):
                return restrict(Eventually(lo, hi, b, span), keep)
            if isinstance(f, Release) and isinstance(kb, TrueF):
                return TrueF(span)
            return type(f)(lo, hi, ka, kb, span)
        case Next(a, span):
            k = restrict(a, keep)
            return k if isinstance(k, (TrueF, FalseF)) else Next(k, span)
    raise TypeError(f"restrict expects an NNF formula, got {f!r}")
