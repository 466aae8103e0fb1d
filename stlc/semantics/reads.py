"""When does a requirement read a signal?  The samples at which some predicate over given
channels can be evaluated, when the formula is judged at time 0.

A predicate under ``always[lo, hi]`` / ``eventually[lo, hi]`` evaluated over the times
``[a, b]`` is read over ``[a + lo, b + hi]``; the left side of ``until[lo, hi]`` (and of its
dual ``release``) over ``[a, b + hi]``, the right side over ``[a + lo, b + hi]``; ``next``
shifts by one step; boolean connectives pass the interval on.  The result is a superset of
the samples whose value can change the robustness (a sound over-approximation: a
disjunct that never binds still counts).

Used by the initial guess: a multirotor's heading follows the course only where the
requirement reads the heading, and is held elsewhere (``stlc.vehicles.multirotor``).
"""

from __future__ import annotations

import math

import numpy as np

from stlc.semantics import ir

_EPS = 1e-9


def read_mask(f: ir.Formula, names: set[str] | frozenset[str], dt: float, n: int
              ) -> np.ndarray:
    """Boolean mask over the ``n`` samples (step ``dt``) at which ``f``, judged at time 0,
    reads any of the channels ``names``."""
    mask = np.zeros(n, dtype=bool)
    end = (n - 1) * dt

    def mark(a: float, b: float) -> None:
        if a > end + _EPS:
            return
        lo = max(0, math.ceil(a / dt - _EPS))
        hi = n - 1 if math.isinf(b) else min(n - 1, math.floor(b / dt + _EPS))
        mask[lo:hi + 1] = True

    def walk(g: ir.Formula, a: float, b: float) -> None:
        match g:
            case ir.Pred(expr):
                if any(isinstance(s, ir.Sig) and s.name in names for s in ir.expr_leaves(expr)):
                    mark(a, b)
            case ir.Always(lo, hi, arg) | ir.Eventually(lo, hi, arg):
                walk(arg, a + lo, b + hi)
            case ir.Until(lo, hi, left, right) | ir.Release(lo, hi, left, right):
                walk(left, a, b + hi)
                walk(right, a + lo, b + hi)
            case ir.Next(arg):
                walk(arg, a + dt, b + dt)
            case _:
                for c in ir.children(g):
                    walk(c, a, b)

    walk(f, 0.0, 0.0)
    return mask


def reader(f: ir.Formula, dt: float, n: int):
    """``read_mask`` of ``f`` as a function of one channel name (what a vehicle model's
    ``guess`` asks: ``needed("uav1.att.z")``)."""
    return lambda name: read_mask(f, {name}, dt, n)
