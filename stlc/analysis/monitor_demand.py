"""Demand-driven exact robustness: several formulas at their first sample in one go.

The risk pass's fast path, with the semantics of ``stlc.analysis.monitor`` (the reference oracle):
``robustness_many`` / ``Demand`` evaluate several formulas at their first sample together.
A ``Plan`` numbers the nodes once (shared ones once) and works out at which samples each
node is needed (``eventually[8, 11] p`` needs ``p`` only on 80 … 110 at dt = 0.1), and
signal expressions that are sums of a time-only and a parameter-only part (a point in a
sampled human's frame) stay separated until a predicate needs them (``_Sep``).
"""

from __future__ import annotations

import numpy as np

from stlc.analysis.monitor import (
    _BINARY,
    INF,
    Channels,
    Params,
    _call,
    _channel,
    _param,
    _until,
    sliding,
)
from stlc.semantics import ir, nnf
from stlc.semantics.ir import (
    Always,
    And,
    Bin,
    Call,
    Const,
    Eventually,
    FalseF,
    Implies,
    Neg,
    Next,
    Not,
    Or,
    Param,
    Pred,
    Release,
    Sig,
    TrueF,
    Until,
)
from stlc.semantics.timegrid import steps_ceil, steps_floor

FLAT_MAX = 32  # robustness_many keeps larger and/or operands nested (exact min is associative)



def _kids(e) -> tuple:
    """Children of a formula or expression node (``Pred`` → its expression)."""
    match e:
        case Pred(expr):
            return (expr,)
        case Neg(arg):
            return (arg,)
        case Bin(_, left, right):
            return (left, right)
        case Call(_, args):
            return args
        case Const() | Sig() | Param():
            return ()
    return ir.children(e)


_FORMULAS = ir.FORMULA_NODES
_WINDOWED = ir.WINDOWED


class Plan:
    """Which samples of which node the values at sample 0 of some NNF formulas need.

    The formulas' nodes (formulas and expressions, shared ones once) are numbered, children
    first: ``nodes[i]``, ``kids[i]`` (child numbers), ``roots`` (numbers of the formulas).
    ``need[i]`` is the hull ``(first, last)`` of the sample indices at which some parent
    needs node i — e.g. ``eventually[8, 11] p`` at sample 0 needs ``p`` only at samples
    80 … 110 (dt = 0.1) — or ``None`` when nothing needs it (a window past the end of the
    trace).  ``timed[i]``: expression i reads a signal (else it is a constant or a
    parameter, without a time axis).  Evaluators work on the numbers: nodes are hashed
    only here, once."""

    def __init__(self, roots, dt: float, n: int):
        if not dt > 0:
            raise ValueError(f"dt must be positive, got {dt}")
        if n < 1:
            raise ValueError("the trace has no samples")
        self.dt, self.n = dt, n
        index: dict = {}
        self.nodes: list = []
        self.kids: list[tuple[int, ...]] = []
        for r in roots:  # iterative post-order: children are numbered before parents
            if r in index:
                continue
            stack = [(r, False)]
            while stack:
                node, done = stack.pop()
                if done:
                    if node not in index:
                        index[node] = len(self.nodes)
                        self.nodes.append(node)
                        self.kids.append(tuple(index[c] for c in _kids(node)))
                    continue
                if node in index:
                    continue
                if isinstance(node, (Not, Implies)):
                    raise ValueError("Plan needs formulas in negation normal form "
                                     "(nnf.normalize)")
                stack.append((node, True))
                stack.extend((c, False) for c in reversed(_kids(node)) if c not in index)
        self.roots = tuple(index[r] for r in roots)
        self.steps = [_steps(f.lo, f.hi, dt) if isinstance(f, _WINDOWED) else None
                      for f in self.nodes]
        self.timed = [False] * len(self.nodes)
        for i, node in enumerate(self.nodes):
            self.timed[i] = isinstance(node, Sig) or (
                not isinstance(node, _FORMULAS) and any(self.timed[c] for c in self.kids[i]))
        need: list = [None] * len(self.nodes)
        for r in self.roots:
            need[r] = (0, 0)
        for i in reversed(range(len(self.nodes))):  # parents before children
            if need[i] is not None:
                for c, (s, e) in self._child_needs(i, *need[i]):
                    old = need[c]
                    need[c] = (s, e) if old is None else (min(old[0], s), max(old[1], e))
        self.need = need
        # how many times the evaluation reads each formula node (parents and roots), so an
        # evaluator can drop a value after its last read
        self.reads = [0] * len(self.nodes)
        for r in self.roots:
            self.reads[r] += 1
        for i, node in enumerate(self.nodes):
            if need[i] is not None and isinstance(node, _FORMULAS) and not isinstance(node, Pred):
                for c in self.kids[i]:
                    if need[c] is not None:
                        self.reads[c] += 1

    def _child_needs(self, i: int, s: int, e: int):
        n, node, kids = self.n, self.nodes[i], self.kids[i]
        if isinstance(node, _WINDOWED):
            a, b = self.steps[i]
            if b >= a and s + a <= n - 1:
                last = min(e + b, n - 1)
                if isinstance(node, (Always, Eventually)):
                    yield kids[0], (s + a, last)
                else:
                    yield kids[0], (s, last)
                    yield kids[1], (s + a, last)
        elif isinstance(node, Next):
            if s + 1 <= n - 1:
                yield kids[0], (s + 1, min(e + 1, n - 1))
        else:
            for c in kids:
                yield c, (s, e)


def _steps(lo: float, hi: float, dt: float) -> tuple[int, int]:
    if lo < 0 or hi < 0:
        raise ValueError(f"negative time bound in [{lo}, {hi}]")
    return steps_ceil(lo, dt), steps_floor(hi, dt)


def _pad(x: np.ndarray, length: int, fill: float, front: int = 0) -> np.ndarray:
    """``x`` with ``front`` samples of ``fill`` before it, cut or padded to ``length``."""
    if front:
        x = np.concatenate([np.full(x.shape[:-1] + (front,), fill), x], axis=-1)
    m = x.shape[-1]
    if m >= length:
        return x[..., :length]
    return np.concatenate([x, np.full(x.shape[:-1] + (length - m,), fill)], axis=-1)



class _Sep:
    """A signal expression kept as ``t + p``: a time-only part ``t`` (shape (n,)) plus a
    parameter-only part ``p`` (shape (K, 1)).  Sums, differences and scalings of such values
    stay separable at the cost of (n,) and (K, 1) operations — e.g. a point in a sampled
    human's frame, ``Rᵀ (p(t) − pos)`` with a fixed attitude — and only a predicate pays one
    (K, n) addition (``full``)."""

    __slots__ = ("t", "p")

    def __init__(self, t, p):
        self.t, self.p = t, p

    def full(self) -> np.ndarray:
        return np.add(self.t, self.p)


def _parts(v, timed: bool):
    """``(t, p)`` of a value that is separable, else ``None``."""
    if isinstance(v, _Sep):
        return v.t, v.p
    if not timed:
        return 0.0, v
    if np.ndim(v) <= 1:
        return v, 0.0
    return None


def _separable(x, args: list, timed: list):
    """The value of ``+ - * /`` or negation on separable operands as a ``_Sep`` (or a plain
    time-only array when no parameter is left), or ``None`` when it is not separable."""
    if isinstance(x, Neg):
        tp = _parts(args[0], timed[0])
        return None if tp is None else _sep(np.negative(tp[0]), np.negative(tp[1]))
    if not isinstance(x, Bin) or x.op not in "+-*/":
        return None
    a, b = (_parts(v, t) for v, t in zip(args, timed))
    if a is None or b is None:
        return None
    if x.op in "+-":
        op = np.add if x.op == "+" else np.subtract
        return _sep(op(a[0], b[0]), op(a[1], b[1]))
    # a product or quotient is separable only with a plain number (not a parameter)
    if x.op == "*" and not timed[0] and isinstance(args[0], float):
        return _sep(args[0] * b[0], args[0] * b[1])
    if not timed[1] and isinstance(args[1], float):
        op = np.multiply if x.op == "*" else np.divide
        return _sep(op(a[0], args[1]), op(a[1], args[1]))
    return None


def _sep(t, p):
    if isinstance(p, float):
        return np.add(t, p) if p != 0.0 else np.asarray(t, dtype=float)
    return _Sep(t, p)


class Demand:
    """Robustness at sample 0 of several NNF formulas on one trace (a ``Plan``) in one
    evaluation: a node shared by several formulas (a predicate, a human-frame coordinate, a
    named spec inside the requirement) is computed once, and only on the samples its
    parents need.  Same semantics as ``Evaluator`` (tests check it); parameters given as
    arrays of shape (K,) give values of shape (K,).

    ``finite[i]`` records that node i's values are all finite (no ``true``/``false``, no
    empty window, finite predicates), which lets the smooth operators skip their guards.
    ``share``, an evaluator on the same plan, trace and parameters, lends its expression
    and predicate values and these flags (``stlc.analysis.smooth_demand.SmoothDemand`` after
    the exact pass)."""

    def __init__(self, plan: Plan, channels: Channels, params: Params | None = None, *,
                 share: Demand | None = None):
        if share is not None and share.plan is not plan:
            raise ValueError("share must be an evaluator on the same plan")
        self.plan, self.n = plan, plan.n
        self.channels, self.params = channels, {} if params is None else params
        self.vals: dict[int, np.ndarray] = {}
        self.reads = list(plan.reads)  # reads left: a value is dropped after its last one
        self.exprs: dict = {} if share is None else share.exprs
        self.finite: dict[int, bool] = {} if share is None else share.finite

    def values(self) -> list:
        """Values at sample 0 of the plan's formulas: floats, or arrays of shape (K,)."""
        out = []
        with np.errstate(all="ignore"):
            for r in self.plan.roots:
                v = self.at(r, 0, 0)[..., 0]
                out.append(float(v) if v.ndim == 0 else v)
        return out

    def at(self, i: int, s: int, e: int) -> np.ndarray:
        """Values of formula node i at samples s … e (within its hull)."""
        v = self.vals.get(i)
        first = self.plan.need[i][0]
        if v is None:
            v = self.vals[i] = self._rule(i, first, self.plan.need[i][1])
        self.reads[i] -= 1
        if self.reads[i] <= 0:  # the last read: keep memory low (fewer page faults)
            del self.vals[i]
        return v[..., s - first:e - first + 1]

    def expr(self, i: int, s: int, e: int):
        """Value of expression node i at samples s … e: constants and parameters as they are
        (a float, or shape (K, 1)); a signal expression as an array, or as a ``_Sep``."""
        v = self.exprs.get(i)
        first, last = self.plan.need[i]
        if v is None:
            v = self.exprs[i] = self._expr_rule(i, first, last)
        if not self.plan.timed[i] or (s == first and e == last):
            return v
        if isinstance(v, _Sep):
            return _Sep(v.t[s - first:e - first + 1], v.p)
        return v[..., s - first:e - first + 1]

    def _expr_rule(self, i: int, s: int, e: int):
        x, kids = self.plan.nodes[i], self.plan.kids[i]
        args = [self.expr(c, s, e) for c in kids]
        match x:
            case Const(value):
                return float(value)
            case Param(name):
                return _param(name, self.params)
            case Sig(name):
                c = _channel(name, self.channels)
                if c.ndim not in (1, 2) or c.shape[-1] != self.n:  # (K, n): K traces
                    raise ValueError(f"signal `{name}` has shape {c.shape}, expected ({self.n},)"
                                     f" or (K, {self.n})")
                return c[..., s:e + 1]
        if self.plan.timed[i]:
            v = _separable(x, args, [self.plan.timed[c] for c in kids])
            if v is not None:
                return v
            args = [a.full() if isinstance(a, _Sep) else a for a in args]
        match x:
            case Neg():
                return np.negative(args[0])
            case Bin(op):
                return _BINARY[op](*args)
            case Call():
                return _call(x, args)
        raise TypeError(f"not an expression node: {x!r}")

    def sep_at(self, i: int, s: int, e: int) -> _Sep | None:
        """Predicate i at samples s … e as ``t + p`` (a ``_Sep``), when it is separable."""
        v = self.exprs.get(("sep", i))
        if v is None:
            return None
        first = self.plan.need[i][0]
        return _Sep(v.t[s - first:e - first + 1], v.p)

    # ---- operators (``SmoothDemand`` overrides these three); ``finite``: every operand
    # value is finite; with ``separated``, ``conj`` also gets each operand's ``sep_at``
    separated = False

    def conj(self, kids: list, is_and: bool, finite: bool, seps=None) -> np.ndarray:
        kids = sorted(kids, key=np.ndim)  # time-only operands first: smaller temporaries
        op = np.minimum if is_and else np.maximum
        out = kids[0]
        for k in kids[1:]:
            if out is not kids[0] and out.shape == np.broadcast_shapes(out.shape, k.shape):
                op(out, k, out=out)  # a temporary of ours: in place
            else:
                out = op(out, k)
        return out

    def window(self, x: np.ndarray, width: int, length: int, is_min: bool,
               finite: bool) -> np.ndarray:
        """min/max of ``x[..., j : j + width + 1]`` (clipped) for j < ``length``."""
        op, ident = (np.minimum, INF) if is_min else (np.maximum, -INF)
        if length == 1:
            return op.reduce(x, axis=-1, keepdims=True)
        return _pad(sliding(x, 0, width, op, ident), length, ident)

    def until(self, f: np.ndarray, g: np.ndarray, a: int, b: int, length: int,
              is_until: bool, finite: bool) -> np.ndarray:
        """``f until[a, b] g`` (or release) at the first ``length`` samples of ``f``; ``g``
        is given from sample ``a`` on."""
        g = _pad(g, f.shape[-1], -INF, front=a)
        f, g = np.broadcast_arrays(f, g)
        if is_until:
            return _until(f, g, a, b)[..., :length]
        return -_until(-f, -g, a, b)[..., :length]

    # ---- formulas
    def _rule(self, i: int, s: int, e: int) -> np.ndarray:
        n, length = self.n, e - s + 1
        f, kids = self.plan.nodes[i], self.plan.kids[i]
        fin = self.finite
        match f:
            case Pred():  # kept with the expressions: shared with a smooth pass
                v = self.exprs.get(-1 - i)
                if v is None:
                    v = self.expr(kids[0], s, e)
                    with np.errstate(all="ignore"):  # (a sum overflowing is only cautious)
                        if isinstance(v, _Sep):
                            fin[i] = bool(np.isfinite(np.sum(v.t) + np.sum(v.p)))
                            self.exprs[("sep", i)] = v
                            v = v.full()
                        else:
                            fin[i] = bool(np.isfinite(np.sum(v)))
                    v = np.broadcast_to(v, np.broadcast_shapes(np.shape(v), (length,)))
                    self.exprs[-1 - i] = v
                return v
            case TrueF() | FalseF():
                fin[i] = False
                return np.full(length, INF if isinstance(f, TrueF) else -INF)
            case And() | Or():
                vals = [self.at(c, s, e) for c in kids]
                fin[i] = all(fin[c] for c in kids)
                if self.separated:
                    return self.conj(vals, isinstance(f, And), fin[i],
                                     [self.sep_at(c, s, e) for c in kids])
                return self.conj(vals, isinstance(f, And), fin[i])
            case Always() | Eventually():
                is_min = isinstance(f, Always)
                a, b = self.plan.steps[i]
                if b < a or s + a > n - 1:
                    fin[i] = False
                    return np.full(length, INF if is_min else -INF)
                x = self.at(kids[0], s + a, min(e + b, n - 1))
                fin[i] = fin[kids[0]] and e + a <= n - 1
                return self.window(x, b - a, length, is_min, fin[kids[0]])
            case Until() | Release():
                is_until = isinstance(f, Until)
                a, b = self.plan.steps[i]
                if b < a or s + a > n - 1:
                    fin[i] = False
                    return np.full(length, -INF if is_until else INF)
                last = min(e + b, n - 1)
                fl, g = self.at(kids[0], s, last), self.at(kids[1], s + a, last)
                ok = fin[kids[0]] and fin[kids[1]]
                fin[i] = ok and e + a <= n - 1
                return self.until(fl, g, a, b, length, is_until, ok)
            case Next():
                if s + 1 > n - 1:
                    fin[i] = False
                    return np.full(length, -INF)
                x = self.at(kids[0], s + 1, min(e + 1, n - 1))
                fin[i] = fin[kids[0]] and e + 1 <= n - 1
                return _pad(x, length, -INF)
        raise TypeError(f"not an NNF formula node: {f!r}")


def robustness_many(formulas, dt: float, channels: Channels, params: Params | None = None,
                    *, n: int | None = None) -> list:
    """Robustness at the first sample of each formula (``nnf.normalize`` is applied) in one
    shared, demand-driven evaluation (``Demand``): floats, or arrays of shape (K,)."""
    if n is None:
        if not channels:
            raise ValueError("no channels: pass the number of samples n")
        n = len(next(iter(channels.values())))
    plan = Plan(nnf.normalize_many(formulas, flat_max=FLAT_MAX), dt, n)
    return Demand(plan, channels, params).values()
