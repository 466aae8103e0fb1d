"""Properties of the signed distances (Hypothesis).

* the exact signed distance of a cylinder, sphere or capsule (any axis) against brute
  force: the distance to a dense sampling of its surface (built here, in a frame of this
  test's own making) bounds |sd| from above and, less the sampling's spacing, from below;
  the sign against a membership test written here;
* the MILP's polyhedral replacement of a predicate never has a larger robustness than the
  exact one (the stated direction), for clearances, bands and memberships;
* the CasADi signed distance equals the exact one outside the region, and its gradient is
  finite everywhere (on the axis, on the surface, at the centre).
"""

from __future__ import annotations

import math

import casadi as ca
import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from stlc.analysis import monitor
from stlc.backends.nlp.smooth_geometry import SD_CASADI
from stlc.semantics import ir
from stlc.semantics.polyhedral import lower_pieces, polyhedral, upper_pieces
from stlc.semantics.shapes import Round, centre_exprs, local, sd_call, signed_distance

coord = st.floats(-3, 3, allow_nan=False)
size = st.floats(0.2, 2.5, allow_nan=False)


@st.composite
def shapes(draw):
    kind = draw(st.sampled_from(["cylinder", "sphere", "capsule"]))
    axis = np.array([draw(coord), draw(coord), draw(coord)])
    if np.linalg.norm(axis) < 0.1:
        axis = np.array([0.0, 0.0, 1.0])
    axis = axis / np.linalg.norm(axis)
    half = 0.0 if kind == "sphere" else draw(size)
    return Round(kind, (draw(coord), draw(coord), draw(coord)), draw(size), half,
                 tuple(map(float, axis)))


def frame(axis) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """An orthonormal frame around ``axis`` by Gram–Schmidt (not the library's)."""
    u = np.asarray(axis, float)
    t = np.array([0.3, -0.8, 0.52])
    e1 = t - (t @ u) * u
    if np.linalg.norm(e1) < 1e-3:
        t = np.array([1.0, 0.0, 0.0])
        e1 = t - (t @ u) * u
    e1 /= np.linalg.norm(e1)
    return u, e1, np.cross(u, e1)


def surface(shape: Round) -> tuple[np.ndarray, float]:
    """Sampled surface points (world) and the sampling's spacing bound h (every surface
    point is within h of a sample)."""
    r, half = shape.radius, shape.half
    nt, na, nr = 240, 81, 41
    th = np.linspace(0, 2 * np.pi, nt, endpoint=False)
    pts, h = [], 0.0
    if shape.kind == "cylinder" or half > 0:  # the side
        a = np.linspace(-half, half, na)
        A, T = np.meshgrid(a, th)
        pts.append(np.stack([A, r * np.cos(T), r * np.sin(T)], -1).reshape(-1, 3))
        h = max(h, math.hypot(r * np.pi / nt, half / (na - 1)))
    if shape.kind == "cylinder":  # the two caps
        rho = np.linspace(0, r, nr)
        R, T = np.meshgrid(rho, th)
        for s in (-1, 1):
            pts.append(np.stack([np.full_like(R, s * half), R * np.cos(T), R * np.sin(T)],
                                -1).reshape(-1, 3))
        h = max(h, math.hypot(r * np.pi / nt, r / (nr - 1) / 2))
    else:  # two hemispheres (one sphere when half = 0)
        ph = np.linspace(0, np.pi / 2, 61)  # the outer half of each end ball
        P, T = np.meshgrid(ph, th)
        for s in (-1, 1):
            pts.append(np.stack([s * (half + r * np.sin(P)), r * np.cos(P) * np.cos(T),
                                 r * np.cos(P) * np.sin(T)], -1).reshape(-1, 3))
        h = max(h, r * math.hypot(np.pi / nt, np.pi / 120 / 2))
    loc = np.concatenate(pts)
    u, e1, e2 = frame(shape.axis)
    return np.asarray(shape.center) + loc @ np.stack([u, e1, e2]), h


def inside(shape: Round, p: np.ndarray) -> bool:
    u = np.asarray(shape.axis)
    q = p - np.asarray(shape.center)
    a = float(q @ u)
    radial = float(np.linalg.norm(q - a * u))
    if shape.kind == "cylinder":
        return abs(a) <= shape.half and radial <= shape.radius
    t = min(max(a, -shape.half), shape.half)  # nearest point of the segment
    return float(np.linalg.norm(q - t * u)) <= shape.radius


@settings(max_examples=60, deadline=None)
@given(shapes(), coord, coord, coord)
def test_signed_distance_against_sampled_surface(shape, x, y, z):
    p = np.asarray(shape.center) + np.array([x, y, z])
    sd = float(signed_distance(p[None, :], None, None, shape)[0])
    pts, h = surface(shape)
    dmin = float(np.min(np.linalg.norm(pts - p, axis=1)))
    assert abs(sd) <= dmin + 1e-9
    assert dmin <= abs(sd) + h + 1e-9
    if abs(sd) > 1e-9:
        assert (sd < 0) == inside(shape, p)


def _pred_robustness(f: ir.Formula, p: np.ndarray) -> float:
    ch = {f"p.{a}": np.array([p[i]]) for i, a in enumerate("xyz")}
    return float(monitor.robustness(f, 1.0, ch, {}))


def _sd_expr(shape: Round | None, lo=None, hi=None) -> ir.Call:
    pt = tuple(ir.Sig(f"p.{a}") for a in "xyz")
    if shape is None:
        c = tuple((a + b) / 2 for a, b in zip(lo, hi))
        return sd_call(local(pt, centre_exprs(c, None), None), lo, hi, None)
    return sd_call(local(pt, centre_exprs(shape.center, None), shape.axis), lo, hi, shape)


@st.composite
def boxes(draw):
    lo = np.array([draw(coord), draw(coord), draw(coord)])
    return tuple(map(float, lo)), tuple(map(float, lo + [draw(size), draw(size), draw(size)]))


@settings(max_examples=80, deadline=None)
@given(st.one_of(shapes(), boxes()), st.floats(-1, 3), coord, coord, coord)
def test_milp_polyhedral_bound_is_below_the_exact_robustness(shape, c, x, y, z):
    sd = _sd_expr(shape) if isinstance(shape, Round) else _sd_expr(None, *shape)
    centre = shape.center if isinstance(shape, Round) else \
        tuple((a + b) / 2 for a, b in zip(*shape))
    p = np.asarray(centre) + np.array([x, y, z])
    exact_sd = _pred_robustness(ir.Pred(sd), p)
    lo = max(_pred_robustness(ir.Pred(e), p) for e in lower_pieces(sd))
    hi = max(_pred_robustness(ir.Pred(e), p) for e in upper_pieces(sd))
    assert lo <= exact_sd + 1e-9 <= hi + 2e-9
    for expr in (ir.Bin("-", sd, ir.Const(c)),  # dist ≥ c, a clearance
                 ir.Bin("-", ir.Const(c), sd),  # dist ≤ c, a band's far side
                 ir.Neg(sd),  # p in R
                 ir.Bin("*", ir.Const(2.0), ir.Bin("-", sd, ir.Const(c)))):
        pred = ir.Pred(expr, "p")
        poly = polyhedral(pred)
        assert poly is not None
        assert _pred_robustness(poly, p) <= _pred_robustness(pred, p) + 1e-9


def _casadi(fn: str, args: list[float]) -> tuple[float, np.ndarray]:
    xs = ca.SX.sym("q", 3)
    e = SD_CASADI[fn]([xs[0], xs[1], xs[2], *args], None)
    f = ca.Function("f", [xs], [e, ca.gradient(e, xs)])
    return f


@settings(max_examples=60, deadline=None)
@given(st.sampled_from(["sd_cylinder", "sd_capsule", "sd_box"]), size, size, size,
       coord, coord, coord)
def test_casadi_signed_distance_exact_outside_finite_gradient(fn, r, half, h3, a, u, v):
    from stlc.semantics.shapes import SD_NUMPY

    args = [r, half] if fn != "sd_box" else [r, half, h3]
    f = _casadi(fn, args)
    exact = float(SD_NUMPY[fn](a, u, v, *args))
    val, grad = f([a, u, v])
    val, grad = float(val), np.asarray(grad).ravel()
    assert np.all(np.isfinite(grad)) and math.isfinite(val)
    if exact >= 0 or (fn != "sd_box" and exact >= -r / 2):
        assert val == np_approx(exact)
    else:
        assert val < 0  # inside stays inside
    for q in ([0.0, 0.0, 0.0], [a, 0.0, 0.0], [half, r, 0.0]):  # centre, axis, rim
        _, g = f(q)
        assert np.all(np.isfinite(np.asarray(g)))


def np_approx(x: float):
    import pytest

    return pytest.approx(x, abs=1e-8)


@settings(max_examples=40, deadline=None)
@given(shapes(), coord, coord, coord, coord, coord, coord)
def test_segment_clearance_of_round_obstacles(shape, x0, y0, z0, x1, y1, z1):
    from stlc.analysis.clearance import segment_region_distance
    from stlc.semantics.model import Box

    lo, hi = shape.bounds()
    box = Box(lo, hi, shape=shape)
    c = np.asarray(shape.center)
    p0, p1 = c + [x0, y0, z0], c + [x1, y1, z1]
    s = np.linspace(0, 1, 4001)
    pts = p0 + s[:, None] * (p1 - p0)
    brute = np.maximum(signed_distance(pts, None, None, shape), 0).min()
    got = float(segment_region_distance(p0[None], p1[None], box)[0])
    step = np.linalg.norm(p1 - p0) / 4000
    assert got <= brute + 1e-9 and got >= brute - step
