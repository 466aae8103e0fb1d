"""Polyhedral bounds of signed distances: how the MILP encodings see round shapes.

A MILP term is affine (or a min/max of affine terms, with binaries for a max), so a
predicate that reads a signed distance (``dist(p, R)``, ``p in`` / ``not in`` a round
region) is replaced by a formula of affine predicates (``polyhedral``).  **Direction of
the error: the replacement's robustness is a lower bound of the exact robustness at every
point** — an inner approximation of the set where the predicate holds, so a MILP plan
with robustness ρ̂ has an exact robustness ≥ ρ̂ (robustness is monotone in the predicates
of a formula in negation normal form), and a MILP that finds no plan proves nothing.  The
exact monitor judges every plan.

* ``c·sd + rest`` with c > 0 (a clearance, ``dist(p, R) >= d``, ``p not in R``) uses
  ``sd ≥ max_n (n·q − h(n))`` over a finite set of unit directions n — the face distances
  of the circumscribed polytope, h the support function of the shape (equal to sd for
  every point whose nearest-surface normal is one of the n): an ``or`` of affine
  predicates.  Directions: 16 around the axis and the two poles (a box: its 26 face, edge
  and corner normals) — each a binary of the disjunction per sample, which is what a MILP
  pays for (with 32 around the axis and two 45° cones of 16, or 16 and two of 8, the
  seed of ``specs/tower_inspection.stl`` at a 0.5 s step stopped at its 15 s limit; with
  these 18 at 1 s it is optimal in ≈ 2 s of CPU).  Worst error beside a cylinder or capsule: sd is
  under-estimated by (1 − cos(π/16)) ≈ 2 % of the distance from the axis; off a cylinder's
  rim it is the larger of the side and end excesses (down to 1/√2 of sd on the diagonal).
* ``c·sd + rest`` with c < 0 (a band's far side, ``dist(p, R) <= d``, ``p in R``) uses an
  upper bound ``sd ≤ max(pieces)``: the Euclidean norms inside sd replaced by polygon norms
  scaled by 1/cos of their half-angle (32 sides around the axis, 4 per quarter-plane),
  which are ≥ the norm: an ``and`` of affine predicates (no binary).  Exact inside the
  shape; worst error outside ≈ 0.5 % beside a cylinder, ≈ 2.4 % off its rim.
"""

from __future__ import annotations

import itertools
import math
from functools import lru_cache

import numpy as np

from stlc.semantics import ir
from stlc.semantics.shapes import circle, dot, is_sd

K = 32  #: sides of the polygon around the axis (upper bounds)
J = 4  #: sides of the quarter-plane polygon of the upper bounds
#: the lower bounds' directions besides the two poles: (elevation, count) — each one a
#: branch (a binary) of the clearance's disjunction at every sample
RINGS = ((0.0, 16),)
#: what a plan's notes say when a MILP saw distances through these bounds
DISTANCE_NOTE = ("the MILP seed saw each distance to a region through a polyhedral bound "
                 "below it (a round region as its circumscribed polytope): its robustness "
                 "under-estimates the exact one; the exact monitor judged this plan")


def _quarter() -> list[tuple[float, float]]:
    """``(α, β)`` with ‖(x, y)‖ ≤ max(α x + β y) for x, y ≥ 0 (mid-angle polygon / cos)."""
    d = math.pi / 2 / J
    return [(math.cos((j + 0.5) * d) / math.cos(d / 2), math.sin((j + 0.5) * d) / math.cos(d / 2))
            for j in range(J)]


def _c(e: ir.Expr, k: float) -> ir.Expr:
    return ir.Bin("-", e, ir.Const(float(k))) if k else e


def lower_pieces(call: ir.Call) -> list[ir.Expr]:
    """Affine expressions with ``sd ≥ max`` of them everywhere (module docstring)."""
    q, ps = call.args[:3], [float(a.value) for a in call.args[3:]]  # type: ignore[attr-defined]
    out = []
    if call.fn == "sd_box":
        for n in itertools.product((-1.0, 0.0, 1.0), repeat=3):
            if n == (0.0, 0.0, 0.0):
                continue
            v = np.array(n) / np.linalg.norm(n)
            out.append(_c(dot(v, q), float(np.abs(v) @ np.array(ps))))
        return out
    r, half = ps
    dirs = [(1.0, 0.0, 0.0), (-1.0, 0.0, 0.0)]
    for phi, count in RINGS:
        for m in circle(count, 0.0 if phi == 0 else math.pi / count):
            dirs.append((math.sin(phi), math.cos(phi) * m[0], math.cos(phi) * m[1]))
    for n in dirs:
        h = abs(n[0]) * half + r * (math.hypot(n[1], n[2]) if call.fn == "sd_cylinder" else 1.0)
        out.append(_c(dot(n, q), h))
    return out


def upper_pieces(call: ir.Call) -> list[ir.Expr]:
    """Affine expressions with ``sd ≤ max`` of them everywhere (module docstring)."""
    q, ps = call.args[:3], [float(a.value) for a in call.args[3:]]  # type: ignore[attr-defined]
    quarter = _quarter()
    out = []
    if call.fn == "sd_box":
        h = ps
        for i in range(3):  # one face excess d_i = ±q_i − h_i
            for s in (1.0, -1.0):
                w = [0.0, 0.0, 0.0]
                w[i] = s
                out.append(_c(dot(w, q), h[i]))
        for i, j in itertools.combinations(range(3), 2):  # two excesses: the edge norm
            for (al, be), si, sj in itertools.product(quarter, (1.0, -1.0), (1.0, -1.0)):
                w = [0.0, 0.0, 0.0]
                w[i], w[j] = al * si, be * sj
                out.append(_c(dot(w, q), al * h[i] + be * h[j]))
        for (a1, b1), (a2, b2) in itertools.product(quarter, quarter):  # three: nested
            for s in itertools.product((1.0, -1.0), repeat=3):
                w = [a1 * a2 * s[0], a1 * b2 * s[1], b1 * s[2]]
                out.append(_c(dot(w, q), a1 * a2 * h[0] + a1 * b2 * h[1] + b1 * h[2]))
        return out
    r, half = ps
    ms = circle(K) / math.cos(math.pi / K)  # ‖w‖ ≤ max_k m_k·w
    for m in ms:
        out.append(_c(dot((0.0, m[0], m[1]), q), r))  # ‖w‖ − r
        for (al, be), s in itertools.product(quarter, (1.0, -1.0)):
            w = (be * s, al * m[0], al * m[1])  # α‖w‖ + β(±a − half) (− α r: cylinder)
            lift = al * r + be * half if call.fn == "sd_cylinder" else r + be * half
            out.append(_c(dot(w, q), lift))
    if call.fn == "sd_cylinder":
        for s in (1.0, -1.0):
            out.append(_c(dot((s, 0.0, 0.0), q), half))  # ±a − half
    return out


def split(e: ir.Expr) -> tuple[float, ir.Call | None, ir.Expr] | None:
    """``e`` as ``c·sd + rest`` with one signed-distance call (``(0, None, e)`` without
    one); None when it is not of that form (a product of two, a distance in a function)."""
    match e:
        case ir.Call() if is_sd(e):
            return 1.0, e, ir.Const(0.0)
        case ir.Neg(a):
            s = split(a)
            return None if s is None else (-s[0], s[1], ir.Neg(s[2]))
        case ir.Bin(op, a, b) if op in "+-":
            sa, sb = split(a), split(b)
            if sa is None or sb is None or (sa[1] is not None and sb[1] is not None):
                return None
            k = 1.0 if op == "+" else -1.0
            call = sa[1] or sb[1]
            return sa[0] + k * sb[0], call, ir.Bin(op, sa[2], sb[2])
        case ir.Bin("*", ir.Const(c), b) | ir.Bin("*", b, ir.Const(c)):
            s = split(b)
            return None if s is None else (c * s[0], s[1], ir.Bin("*", ir.Const(c), s[2]))
        case ir.Bin("/", a, ir.Const(c)) if c != 0:
            s = split(a)
            return None if s is None else (s[0] / c, s[1], ir.Bin("/", s[2], ir.Const(c)))
    if any(is_sd(x) for x in ir.expr_nodes(e)):
        return None
    return 0.0, None, e


@lru_cache(maxsize=8192)
def polyhedral(p: ir.Pred) -> ir.Formula | None:
    """The affine replacement of a predicate that reads one signed distance linearly (an
    ``or`` or ``and`` of affine predicates, robustness ≤ the exact one), or None."""
    s = split(p.expr)
    if s is None or s[1] is None or s[0] == 0.0:
        return None
    c, call, rest = s
    pieces = lower_pieces(call) if c > 0 else upper_pieces(call)
    preds = tuple(ir.Pred(ir.Bin("+", ir.Bin("*", ir.Const(c), e), rest), p.label, p.span,
                          None, p.origin) for e in pieces)
    return (ir.Or if c > 0 else ir.And)(preds, p.span)


def has_distance(f: ir.Formula) -> bool:
    return any(is_sd(x) for p in ir.predicates(f) for x in ir.expr_nodes(p.expr))


def polyhedral_formula(f: ir.Formula) -> ir.Formula:
    """``f`` (NNF) with every signed-distance predicate replaced by ``polyhedral``'s."""
    memo: dict[int, ir.Formula] = {}

    def go(g: ir.Formula) -> ir.Formula:
        hit = memo.get(id(g))
        if hit is None:
            if isinstance(g, ir.Pred):
                hit = polyhedral(g) or g
            else:
                hit = ir.map_children(g, go)
            memo[id(g)] = hit
        return hit

    return go(f)
