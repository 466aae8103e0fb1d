"""The seed's timing, fixed: a long mission's windows closed on the samples its seed chose.

``eventually[0, 232] always[0, 3] (pos in north)`` asks the planner to find *when* to look at
the north face; the smooth robustness answers with a smooth max over the 1,161 samples of
the window, a tree of auxiliary variables over the whole horizon.  Several such trees over
one trajectory make the NLP's KKT factorisation fill in: on the 240 s tower inspection
(1,201 knots) an iteration cost 16× one of the 30 s mission's for 8× the variables, the
kinematic guess 30× — the horizon's cost grew much faster than the horizon.

The MILP seed has already decided the timing.  ``fix_windows`` walks the requirement from
its root at sample 0 and, wherever a node is needed at one sample only, keeps the seed's
decision: an ``eventually[a, b] φ`` becomes ``eventually[d, d] φ`` at the offset d of the
window's sample where φ is most robust on the seed path; an ``or`` becomes its most robust
operand; ``φ until[a, b] ψ`` becomes ``eventually[d, d] ψ and always[0, d] φ``.  Each
rewrite keeps one term of a max, so the fixed formula's robustness is at most the
formula's at every trajectory: a plan meeting κ on it meets κ on the requirement (which
the exact monitor judges, as every plan).  A node whose signal cannot be computed on the
seed (it reads a channel the seed has not) is left as written.

With a ``slack`` (the ``timed`` chain of a mission on its own grid), a window is narrowed
to the seed's offset ± slack instead, clipped to the window as written (``until`` keeps
its left operand): the max then runs over a subset of its terms, so the same bound holds,
and the planner may still move each time a little.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from stlc.analysis import monitor
from stlc.semantics import ir
from stlc.semantics.timegrid import steps_ceil, steps_floor


def fix_windows(f: ir.Formula, dt: float, channels: Mapping[str, np.ndarray],
                params: Mapping[str, float], n: int, slack: float = 0.0) -> ir.Formula | None:
    """``f`` with the choices it makes at single samples fixed as the seed ``channels``
    (every channel n samples at step dt) make them; None when nothing was fixed.  With
    ``slack`` > 0 a window is narrowed to the seed's offset ± ``slack`` (s) instead of
    closed on it, so the planner may still move the time a little."""
    fixer = _Fixer(dt, channels, params, n, slack)
    out = fixer.at(f, 0)
    return out if fixer.fixed else None


class _Fixer:
    def __init__(self, dt: float, channels, params, n: int, slack: float = 0.0):
        self.dt, self.channels, self.params, self.n = dt, channels, params, n
        self.slack = slack
        self.fixed = 0

    def signal(self, f: ir.Formula) -> np.ndarray | None:
        try:
            return np.asarray(monitor.robustness_signal(f, self.dt, self.channels, self.params,
                                                        n=self.n), float)
        except KeyError:  # a signal the seed has not (an attitude, a rotor): left as is
            return None

    def window(self, k: int, lo: float, hi: float) -> tuple[int, int]:
        """The samples of ``[lo, hi]`` from sample k, as the exact monitor counts them."""
        b = steps_floor(hi, self.dt) if np.isfinite(hi) else self.n
        return k + steps_ceil(lo, self.dt), min(k + b, self.n - 1)

    def around(self, f: ir.Eventually | ir.Until, d: float) -> tuple[float, float]:
        """``f``'s window narrowed to the offset d ± ``slack``, clipped to it as written."""
        return max(f.lo, d - self.slack), min(f.hi, d + self.slack)

    def at(self, f: ir.Formula, k: int) -> ir.Formula:
        """``f`` needed at sample ``k`` only."""
        if isinstance(f, ir.And):
            return ir.And(tuple(self.at(c, k) for c in f.args), f.span)
        if isinstance(f, ir.Or):
            sigs = [self.signal(c) for c in f.args]
            if any(s is None for s in sigs) or not f.args:
                return f
            best = int(np.argmax([s[k] for s in sigs]))
            self.fixed += 1
            return self.at(f.args[best], k)
        if isinstance(f, ir.Eventually):
            a, b = self.window(k, f.lo, f.hi)
            s = self.signal(f.arg)
            if s is None or a > b or a >= self.n:
                return f
            j = a + int(np.argmax(s[a:b + 1]))
            d = (j - k) * self.dt
            self.fixed += 1
            if self.slack > 0:
                lo, hi = self.around(f, d)
                return ir.Eventually(lo, hi, self.at(f.arg, j), f.span)
            return ir.Eventually(d, d, self.at(f.arg, j), f.span)
        if isinstance(f, ir.Until):
            a, b = self.window(k, f.lo, f.hi)
            left, right = self.signal(f.left), self.signal(f.right)
            if left is None or right is None or a > b or a >= self.n:
                return f
            # the left operand holds from k through k' (the monitor's until, k' included)
            run = np.minimum.accumulate(left[k:b + 1])[a - k:]
            j = a + int(np.argmax(np.minimum(right[a:b + 1], run)))
            d = (j - k) * self.dt
            self.fixed += 1
            if self.slack > 0:
                lo, hi = self.around(f, d)
                return ir.Until(lo, hi, f.left, self.at(f.right, j), f.span)
            return ir.And((ir.Eventually(d, d, self.at(f.right, j), f.span),
                           ir.Always(0.0, d, f.left, f.span)), f.span)
        return f  # needed at many samples (always, release, implies, …): as written
