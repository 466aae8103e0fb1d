"""Data of the CasADi smooth-robustness lowering (``nlp.smooth``): its result, values
and windows.

``LoweredRobustness`` is what ``lower_robustness`` returns (root, aux, constraints, init).
A node's values are block rows (``Val``: SX components, span, length) at sorted sample
indices (``Row``); ``assemble`` scatters pieces back into one row.  The window helpers map
the samples a node is needed at onto the samples its children are needed at
(``child_needs``: ``always[0,17]`` at {0} needs its child at 0..170), give the dyadic blocks
of a window length (``bits_desc``) and the fan-in of an operator (``fan_in``).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import casadi as ca
import numpy as np

from stlc.backends.nlp.expr import LoweringError
from stlc.semantics import ir
from stlc.semantics.timegrid import TimeGrid

PARAM, LAM = "param:", ":lam"  # input names of ``LoweredRobustness.init``


@dataclass
class LoweredRobustness:
    """Smooth robustness as SX: maximise ``root`` over the trajectory and ``aux`` subject to
    ``g >= 0`` and ``h == 0``.  ``init`` maps numeric channels (inputs named by signal),
    symbolic parameters (``param:<name>``) and λ (``:lam``, if symbolic) to ``aux`` initial
    values satisfying all constraints and to the un-lifted ``root``; ``init_values`` wraps it.
    ``stats``: smooth-op ``operands``, ``aux``/``g``/``h`` sizes, evaluated formula ``nodes``."""

    root: ca.SX
    aux: ca.SX
    g: ca.SX
    h: ca.SX
    init: ca.Function
    stats: dict[str, int]

    def constraints(self) -> tuple[ca.SX, np.ndarray, np.ndarray]:
        """``(vertcat(g, h), lbg, ubg)`` ready for ``nlpsol``."""
        ng, nh = self.g.numel(), self.h.numel()
        lb = np.zeros(ng + nh)
        ub = np.concatenate([np.full(ng, np.inf), np.zeros(nh)])
        return ca.vertcat(self.g, self.h), lb, ub

    def init_values(self, channels: Mapping[str, np.ndarray],
                    params: Mapping[str, float] | None = None,
                    lam: float | None = None) -> tuple[np.ndarray, float]:
        """Numeric aux initial values and the un-lifted smooth root for numeric inputs."""
        args: dict[str, object] = {}
        for name in self.init.name_in():
            if name == LAM:
                args[name] = lam
            elif name.startswith(PARAM):
                args[name] = (params or {})[name[len(PARAM):]]
            else:
                args[name] = np.reshape(np.asarray(channels[name], float), (1, -1))
        out = self.init(**args)
        return np.array(out["aux"]).ravel(), float(out["root"])


@dataclass
class Val:
    """A block row: components (1×L SX rows), its span, and its length."""

    comps: tuple[ca.SX, ...]
    span: int

    @property
    def size(self) -> int:
        return self.comps[0].numel()

    def take(self, pos: np.ndarray) -> Val:
        if len(pos) == self.size and (len(pos) == 0 or (pos == np.arange(len(pos))).all()):
            return self
        sel = pos.tolist()
        return Val(tuple(c[0, sel] for c in self.comps), self.span)


@dataclass
class Row:
    """A node's values at the sorted sample indices ``idx``."""

    idx: np.ndarray
    val: Val

    def at(self, samples: np.ndarray) -> Val:
        return self.val.take(np.searchsorted(self.idx, samples))


def const_value(v: float, size: int) -> Val:
    return Val((ca.SX(np.full((1, size), v)),), 0)


def assemble(pieces: list[tuple[np.ndarray, Val]]) -> Val:
    """Scatter (positions, plain row) pieces back into one row ordered by position."""
    pieces = [(p, v) for p, v in pieces if len(p)]
    if len(pieces) == 1:
        return pieces[0][1]
    pos = np.concatenate([p for p, _ in pieces])
    row = ca.horzcat(*[v.comps[0] for _, v in pieces])
    span = max(v.span for _, v in pieces)
    return Val((row,), span).take(np.argsort(pos, kind="stable"))


def bits_desc(length: int) -> list[int]:
    return [j for j in range(length.bit_length() - 1, -1, -1) if length >> j & 1]


def sample_windows(samples: np.ndarray, a: int, b: int, n: int) -> tuple[np.ndarray, np.ndarray]:
    """First and last sample of each window (clipped to the grid; empty if first > last)."""
    return samples + a, np.minimum(samples + b, n - 1)


def _union(first: np.ndarray, last: np.ndarray) -> np.ndarray:
    """Sorted samples in the union of the intervals [first_i, last_i] (both nondecreasing)."""
    keep = first <= last
    first, last = first[keep], last[keep]
    if not len(first):
        return np.zeros(0, dtype=np.int64)
    out, lo, hi = [], first[0], last[0]
    for f, e in zip(first[1:], last[1:]):
        if f > hi + 1:
            out.append(np.arange(lo, hi + 1))
            lo = f
        hi = max(hi, e)
    out.append(np.arange(lo, hi + 1))
    return np.concatenate(out).astype(np.int64)


def check_window(f: ir.Formula, grid: TimeGrid) -> tuple[int, int]:
    a, b = grid.window(f.lo, f.hi)
    if a < 0:
        raise LoweringError(f"negative window start in {type(f).__name__}[{f.lo}, {f.hi}]")
    return a, b


def child_needs(f: ir.Formula, k: np.ndarray, grid: TimeGrid
                 ) -> list[tuple[ir.Formula, np.ndarray]]:
    """Which samples of each child the node needs to be evaluated at samples ``k``."""
    n = grid.n
    match f:
        case ir.And(args) | ir.Or(args):
            return [(c, k) for c in args]
        case ir.Always(lo, hi, c) | ir.Eventually(lo, hi, c):
            a, b = grid.window(lo, hi)
            return [(c, _union(*sample_windows(k, a, b, n)))]
        case ir.Until(lo, hi, left, right) | ir.Release(lo, hi, left, right):
            a, b = grid.window(lo, hi)
            first, last = sample_windows(k, a, b, n)
            return [(left, _union(k, last)), (right, _union(first, last))]
        case ir.Next(c):
            return [(c, k[k + 1 < n] + 1)]
        case ir.Pred() | ir.TrueF() | ir.FalseF():
            return []
    raise LoweringError(f"not a formula node in negation normal form: {type(f).__name__}")


def fan_in(f: ir.Formula, grid: TimeGrid) -> int:
    """Operands of one smooth op of ``f`` (and/or: its arguments; a temporal operator: its
    whole window, unclipped), ≥ 1."""
    if isinstance(f, ir.And | ir.Or):
        return max(1, len(f.args))
    if isinstance(f, ir.WINDOWED):
        a, b = grid.window(f.lo, f.hi)
        return max(1, (b - a + 1) if isinstance(f, ir.Always | ir.Eventually) else b + 2)
    return 1
