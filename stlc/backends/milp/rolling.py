"""A feasible point of a large time-indexed MILP by relax-and-fix along the grid.

HiGHS searches a seed MILP's whole tree for its first point with ρ̂ ≥ κ; on a long mission
(the 240 s patrol's 1 s seed grid: 241 samples, 8 k binaries) it found none in 90 s, while
the same search over a few dozen samples closes in a second or two (in blocks: 18 s in all;
the 100 s two-mast inspection's seed, 1.7 k binaries: 11 s whole, 1.2 s in blocks).
``feasible`` therefore walks the grid in blocks: every binary belongs to a sample
(``samples``: the first sample its disjunction reads — an ``eventually``'s choice of its
sample is decided with the window's first sample, so a deadline is never left to a later
block), and each MILP keeps the binaries of the blocks already solved fixed at their values,
the binaries of this block and an overlap after it integer, and every later one continuous
in [0, 1], and maximises ρ̂ for a few seconds (``_block``). The last MILP has every binary
integer or fixed: its point meets every row of the model.

A block with no point proves nothing (earlier choices were fixed by a heuristic): it is
solved again with the block before it freed, then the two before it (``BACKTRACK``); if
that finds none either, the whole MILP is searched as before, in the time left.  Small
models (at most ``MIN_BINARIES``) are always searched whole.  The point found is a seed's
start only, never a proof or an optimum: what follows it (the LPs, the MILP with its
choices free, the exact backend, the exact monitor) is unchanged.
"""

from __future__ import annotations

import math
import time

import numpy as np

MIN_BINARIES = 1000  #: a MILP with more binaries than this is searched in blocks
BLOCK_BINARIES = 500  #: binaries integer per block (about; whole samples)
OVERLAP = 0.5  #: … and this fraction of a block after it integer too
BLOCK_S = 3.0  #: a block maximises ρ̂ for at most this long (then: its first point) …
BLOCK_GAP = 0.2  #: … to this relative gap
BACKTRACK = 2  #: a block with no point is solved again with this many blocks before it freed


def samples(low) -> dict[int, int]:
    """Column → the sample it belongs to: a state or input column its sample, a term the
    first sample any of its operands reads, a choice (and its bits) its disjunction's."""
    at: dict[int, int] = {}
    for lv in low.vehicles:
        for k, cols in enumerate(lv.x):
            at.update((int(j), k) for j in cols)
        for k, cols in enumerate(lv.u):
            at.update((int(j), k) for j in cols)
    never = 1 << 30
    for node in low.encoder.nodes:
        r, terms = node[1], node[4]
        first = min((min((at.get(j, never) for j, _ in t.coefs), default=never)
                     for t in terms), default=never)
        at[r] = first
        if node[0] == "max":
            at.update((j, first) for j in (*node[5], *node[6]))
    return at


def feasible(milp, top: int, kappa_lo: float, limit: float, at: dict[int, int] | None,
             best: bool, phases: list):
    """A point with ρ̂ ≥ ``kappa_lo`` (``Highs`` result): in blocks along the grid when the
    model is large and ``at`` maps its binaries to samples, else (or when a block finds
    none) the whole feasibility MILP in the time left.  Appends its phases."""
    from stlc.solvers.highs import Highs

    t0 = time.perf_counter()
    left = lambda: max(limit - (time.perf_counter() - t0), 0.05)  # noqa: E731
    ints = np.flatnonzero(milp.integer)
    if at is not None and len(ints) > MIN_BINARIES:
        res = _blocks(milp, top, kappa_lo, ints, at, left, phases, best)
        if res is not None:
            return res

    h = Highs(milp, {}, time_limit=left(), rel_gap=1e-4, abs_gap=1e-6, feasibility=True)
    h.set_col_bounds(top, kappa_lo, milp.hi[top])
    res = h.solve()
    phases.append(("feasibility", res.highs_status, res.wall_s))
    return res


def _blocks(milp, top, kappa_lo, ints, at, left, phases, best: bool):
    """Relax-and-fix: the result of the last block, or None when a block finds no point."""
    when = np.array([at.get(int(j), -1) for j in ints])
    n = int(when[when < 1 << 30].max()) + 1
    when = np.clip(when, 0, n - 1)  # a choice of constants only: the last block decides it
    size = max(1, math.ceil(BLOCK_BINARIES * n / len(ints)))
    over = int(OVERLAP * size)
    x, start, wall, back = None, 0, 0.0, 0
    while True:
        end = start + size + over
        lo = max(start - back * size, 0)  # a block with no point: re-decide earlier ones too
        res = _block(milp, top, kappa_lo, ints, when, x, lo, end, left, best=best)
        if best and res.x is None and res.highs_status == "Time limit reached" and left() > 0.1:
            res = _block(milp, top, kappa_lo, ints, when, x, lo, end, left, best=False)
        wall += res.wall_s
        if res.x is None:
            phases.append((f"feasibility in blocks (samples {lo}–{min(end, n) - 1})",
                           res.highs_status, res.wall_s))
            if lo == 0 or back >= BACKTRACK:
                return None
            back += 1
            continue
        x, back = res.x, 0
        if end >= n:
            phases.append((f"feasibility in blocks of {size} samples", res.highs_status, wall))
            res.wall_s = wall
            return res
        start += size


def _block(milp, top, kappa_lo, ints, when, x, lo, end, left, best: bool):
    """One block's MILP: binaries before sample ``lo`` fixed at ``x``, from ``end`` on
    continuous.  ``best``: ρ̂ maximised for at most ``BLOCK_S`` (to ``BLOCK_GAP``) — a block
    that only meets κ leaves later blocks a path at the edge of every region, and the exact
    MILP that starts from it a worse class; else the first point with ρ̂ ≥ κ."""
    from stlc.solvers.highs import Highs

    if best:
        h = Highs(milp, {top: -1.0}, time_limit=min(left(), BLOCK_S), rel_gap=BLOCK_GAP,
                  abs_gap=1e-3, feasibility=True)
    else:
        h = Highs(milp, {}, time_limit=left(), rel_gap=1e-4, abs_gap=1e-6, feasibility=True)
    h.set_col_bounds(top, kappa_lo, milp.hi[top])
    for j, k in zip(ints, when):
        if k < lo:
            v = float(round(x[j]))
            h.set_col_bounds(int(j), v, v)
        elif k >= end:
            h.relax(int(j))
    return h.solve()
