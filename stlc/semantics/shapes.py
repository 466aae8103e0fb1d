"""Round regions — cylinders, spheres, capsules — and signed distances to regions.

A round region is a ``Round``: a ``kind`` (``cylinder`` | ``sphere`` | ``capsule``), a
``center``, a ``radius``, a ``half`` length along a unit ``axis`` and nothing else:

* a **cylinder** is the set of points whose axial coordinate ``a`` (along ``axis``, from
  ``center``) is within ``±half`` and whose distance from the axis is ≤ ``radius`` — its
  ``center`` is the mid-height point, its height ``2·half``;
* a **capsule** is every point within ``radius`` of the segment ``center ± half·axis``;
* a **sphere** is the capsule with ``half = 0``.

A region keeps its axis-aligned bounding box as ``model.Box.lo/hi`` (so everything that
needs a box — the workspace test, the report's axes, a seed's clearance — keeps working,
conservatively) and the round shape beside it (``model.Box.shape``).

Signed distances (negative inside, metres) are three IR functions over *local* coordinates
(the point minus the region's centre, in the region's own frame; ``local``):

==================================  ==============================================
``sd_box(x, y, z, hx, hy, hz)``     a box with half-sizes ``h`` centred at 0
``sd_cylinder(a, u, v, r, half)``   ``a`` along the axis, ``(u, v)`` across it
``sd_capsule(a, u, v, r, half)``    the same coordinates; a sphere has ``half = 0``
==================================  ==============================================

``SD_NUMPY`` evaluates them exactly (the monitor's semantics, vectorised); the smooth
backend and the MILP's polyhedral bounds (``stlc.semantics.polyhedral``) read the same calls.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from stlc.semantics import ir
from stlc.semantics.nnf import negate_expr

Vec3 = tuple[float, float, float]
KINDS = ("cylinder", "sphere", "capsule")
SD_FUNCS = ("sd_box", "sd_cylinder", "sd_capsule")
Z_AXIS: Vec3 = (0.0, 0.0, 1.0)


@dataclass(frozen=True, slots=True)
class Round:
    """A cylinder, sphere or capsule (module docstring); lengths in metres."""

    kind: str
    center: Vec3
    radius: float
    half: float = 0.0
    axis: Vec3 = Z_AXIS

    def bounds(self) -> tuple[Vec3, Vec3]:
        """The axis-aligned bounding box ``(lo, hi)``: for a cylinder the box around its two
        end disks (a disk with normal u reaches r·√(1 − u_i²) along axis i), for a capsule
        the box around its two end balls."""
        c, u = np.asarray(self.center, float), np.asarray(self.axis, float)
        ext = np.abs(u) * self.half
        if self.kind == "cylinder":
            ext = ext + self.radius * np.sqrt(np.clip(1.0 - u * u, 0.0, 1.0))
        else:
            ext = ext + self.radius
        return tuple(map(float, c - ext)), tuple(map(float, c + ext))  # type: ignore

    def grown(self, r: float) -> Round:
        """Every point within ``r`` of the shape is inside the result (a cylinder grows on
        its side and both ends)."""
        if r <= 0:
            return self
        return replace(self, radius=self.radius + r,
                       half=self.half + (r if self.kind == "cylinder" else 0.0))

    def scaled(self, s: float) -> Round:
        return replace(self, center=tuple(float(x * s) for x in self.center),  # type: ignore
                       radius=self.radius * s, half=self.half * s)

    def moved(self, d) -> Round:
        c = tuple(float(x + e) for x, e in zip(self.center, d))
        return replace(self, center=c)  # type: ignore[arg-type]

    def describe(self) -> str:
        c = ", ".join(f"{x:g}" for x in self.center)
        if self.kind == "sphere":
            return f"sphere(center = ({c}) m, radius = {self.radius:g} m)"
        if self.kind == "cylinder":
            ax = "" if self.axis == Z_AXIS else \
                ", axis = (" + ", ".join(f"{x:g}" for x in self.axis) + ")"
            return (f"cylinder(center = ({c}) m, radius = {self.radius:g} m, "
                    f"height = {2 * self.half:g} m{ax})")
        a, b = self.ends()
        return ("capsule((" + ", ".join(f"{x:g}" for x in a) + ") m, ("
                + ", ".join(f"{x:g}" for x in b) + f") m, {self.radius:g} m)")

    def ends(self) -> tuple[Vec3, Vec3]:
        """The two end points of the axis segment (a capsule's ``a`` and ``b``)."""
        c, u = np.asarray(self.center, float), np.asarray(self.axis, float)
        return (tuple(map(float, c - self.half * u)),  # type: ignore[return-value]
                tuple(map(float, c + self.half * u)))


def basis(axis: Vec3) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(axis, e1, e2)``: a right-handed orthonormal frame; for the z axis it is
    ``(z, x, y)``, so a vertical shape's ``(u, v)`` are its world ``(x, y)`` offsets."""
    u = np.asarray(axis, float)
    u = u / np.linalg.norm(u)
    if np.allclose(u, Z_AXIS):
        return u, np.array([1.0, 0.0, 0.0]), np.array([0.0, 1.0, 0.0])
    helper = np.array([0.0, 0.0, 1.0]) if abs(u[2]) < 0.9 else np.array([1.0, 0.0, 0.0])
    e1 = np.cross(helper, u)
    e1 /= np.linalg.norm(e1)
    return u, e1, np.cross(u, e1)


# --------------------------------------------------------------------------- exact (numpy)


def sd_box(x, y, z, hx, hy, hz):
    d = [np.abs(x) - hx, np.abs(y) - hy, np.abs(z) - hz]
    out = np.sqrt(sum(np.maximum(di, 0.0) ** 2 for di in d))
    return out + np.minimum(np.maximum(np.maximum(d[0], d[1]), d[2]), 0.0)


def sd_cylinder(a, u, v, r, half):
    dr, dz = np.hypot(u, v) - r, np.abs(a) - half
    return np.hypot(np.maximum(dr, 0.0), np.maximum(dz, 0.0)) + \
        np.minimum(np.maximum(dr, dz), 0.0)


def sd_capsule(a, u, v, r, half):
    t = np.maximum(np.abs(a) - half, 0.0)
    return np.sqrt(t * t + u * u + v * v) - r


SD_NUMPY = {"sd_box": sd_box, "sd_cylinder": sd_cylinder, "sd_capsule": sd_capsule}


def signed_distance(points: np.ndarray, lo, hi, shape: Round | None) -> np.ndarray:
    """Exact signed distance of world points (…, 3) to a world-frame region (a box
    ``[lo, hi]`` when ``shape`` is None)."""
    p = np.asarray(points, float)
    if shape is None:
        lo, hi = np.asarray(lo, float), np.asarray(hi, float)
        q, h = p - (lo + hi) / 2, (hi - lo) / 2
        return sd_box(q[..., 0], q[..., 1], q[..., 2], h[0], h[1], h[2])
    ax, e1, e2 = basis(shape.axis)
    q = p - np.asarray(shape.center, float)
    return SD_NUMPY[f"sd_{'capsule' if shape.kind == 'sphere' else shape.kind}"](
        q @ ax, q @ e1, q @ e2, shape.radius, shape.half)


# --------------------------------------------------------------------------- IR


def _c(x: float) -> ir.Const:
    return ir.Const(float(x))


def _sub(a: ir.Expr, b: ir.Expr) -> ir.Expr:
    if isinstance(b, ir.Const) and b.value == 0.0:
        return a
    if isinstance(a, ir.Const) and isinstance(b, ir.Const):
        return _c(a.value - b.value)
    return ir.Bin("-", a, b)


def dot(w, q: tuple[ir.Expr, ...]) -> ir.Expr:
    """``Σ w_i q_i`` with zero weights left out (an affine expression of ``q``)."""
    out: ir.Expr | None = None
    for wi, qi in zip(w, q):
        wi = float(wi)
        if abs(wi) < 1e-15:
            continue
        if isinstance(qi, ir.Const):
            term: ir.Expr = _c(wi * qi.value)
        elif wi == 1.0:
            term = qi
        elif wi == -1.0:
            term = negate_expr(qi)
        else:
            term = ir.Bin("*", _c(wi), qi)
        if out is None:
            out = term
        elif isinstance(term, ir.Neg):
            out = ir.Bin("-", out, term.arg)
        else:
            out = ir.Bin("+", out, term)
    return out if out is not None else _c(0.0)


def centre_exprs(center: Vec3, placed: str | None) -> tuple[ir.Expr, ...]:
    """The centre as constants, or as the parameters of a placed region (``--set``)."""
    if placed is not None:
        return tuple(ir.Param(f"{placed}.center.{a}") for a in "xyz")
    return tuple(_c(x) for x in center)


def local(p: tuple[ir.Expr, ...], center: tuple[ir.Expr, ...], axis: Vec3 | None
          ) -> tuple[ir.Expr, ...]:
    """``p − center`` in the shape's coordinates: ``(x, y, z)`` for a box (``axis`` None),
    ``(a, u, v)`` along and across ``axis`` for a round shape."""
    q = tuple(_sub(pi, ci) for pi, ci in zip(p, center))
    if axis is None:
        return q
    return tuple(dot(e, q) for e in basis(axis))


def sd_call(q: tuple[ir.Expr, ...], lo, hi, shape: Round | None) -> ir.Call:
    """The signed-distance call of a region at local coordinates ``q``."""
    if shape is None:
        h = [(b - a) / 2 for a, b in zip(lo, hi)]
        return ir.Call("sd_box", (*q, *map(_c, h)))
    fn = "sd_cylinder" if shape.kind == "cylinder" else "sd_capsule"
    return ir.Call(fn, (*q, _c(shape.radius), _c(shape.half)))


def sd_expr(q: tuple[ir.Expr, ...], lo, hi, shape: Round | None) -> ir.Expr:
    """``sd_call``, folded to a constant when ``q`` is constant."""
    c = sd_call(q, lo, hi, shape)
    if all(isinstance(a, ir.Const) for a in c.args):
        return _c(fold(c.fn, [a.value for a in c.args]))  # type: ignore[union-attr]
    return c


def is_sd(e: ir.Expr) -> bool:
    return isinstance(e, ir.Call) and e.fn in SD_FUNCS


def fold(fn: str, xs: list[float]) -> float:
    """A signed distance of constants (the checker's constant folding)."""
    return float(SD_NUMPY[fn](*xs))


def circle(n: int, offset: float = 0.0) -> np.ndarray:
    """``n`` unit vectors evenly spaced on the circle, the first at angle ``offset``."""
    t = offset + 2 * math.pi * np.arange(n) / n
    return np.stack([np.cos(t), np.sin(t)], axis=1)
