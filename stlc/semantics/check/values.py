"""Values the checker computes while it elaborates the AST, and IR smart constructors.

Constant data (``Num``: scalars, vectors and matrices in SI units) is evaluated at check
time; signal expressions (``Sym``) are tuples of scalar IR expressions, one per vector
component; formulas are ``Form``; declared things (vehicles, humans, regions, groups) are
references.  ``ErrorV`` stands for a sub-expression that already produced a diagnostic, so
that one mistake is reported once and checking goes on.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from stlc.semantics import ir, model, nnf, shapes
from stlc.semantics.check.units import Dim


@dataclass(frozen=True)
class Num:
    v: np.ndarray  # float array, shape () / (n,) / (n, m)
    dim: Dim | None

    @property
    def is_scalar(self) -> bool:
        return self.v.ndim == 0


@dataclass(frozen=True)
class Sym:
    items: tuple[ir.Expr, ...]
    dim: Dim | None
    vector: bool
    labels: tuple[str, ...]


@dataclass(frozen=True)
class Form:
    f: ir.Formula


@dataclass(frozen=True)
class RegionV:
    name: str
    box: model.Box  # a round region's bounding box, with the shape in ``box.shape``


@dataclass(frozen=True)
class VehicleV:
    vehicle: model.Vehicle


@dataclass(frozen=True)
class HumanV:
    human: model.Human


@dataclass(frozen=True)
class GroupV:
    kind: str
    items: tuple  # of values


@dataclass(frozen=True)
class DistV:
    mean: np.ndarray
    cov: np.ndarray
    dim: Dim | None


@dataclass(frozen=True)
class StrV:
    s: str


@dataclass(frozen=True)
class RotorsV:
    rotors: tuple[model.Rotor, ...]


@dataclass(frozen=True)
class ErrorV:
    pass


ERROR = ErrorV()

Value = Num | Sym | Form | RegionV | VehicleV | HumanV | GroupV | DistV | StrV | RotorsV | ErrorV


def kind_name(v: Value) -> str:
    return {
        Num: "a number", Sym: "a signal expression", Form: "a formula", RegionV: "a region",
        VehicleV: "a vehicle", HumanV: "a human", GroupV: "a group", DistV: "a distribution",
        StrV: "a string", RotorsV: "a rotor list", ErrorV: "an erroneous value",
    }[type(v)]


# ---------------------------------------------------------------- IR smart constructors


def const(x: float) -> ir.Const:
    return ir.Const(float(x))


def is_const(e: ir.Expr, value: float | None = None) -> bool:
    return isinstance(e, ir.Const) and (value is None or e.value == value)


def add(a: ir.Expr, b: ir.Expr) -> ir.Expr:
    if isinstance(a, ir.Const) and isinstance(b, ir.Const):
        return const(a.value + b.value)
    if is_const(b, 0.0):
        return a
    if is_const(a, 0.0):
        return b
    if isinstance(b, ir.Const) and b.value < 0:
        return ir.Bin("-", a, const(-b.value))
    return ir.Bin("+", a, b)


def sub(a: ir.Expr, b: ir.Expr) -> ir.Expr:
    if isinstance(a, ir.Const) and isinstance(b, ir.Const):
        return const(a.value - b.value)
    if is_const(b, 0.0):
        return a
    if is_const(a, 0.0):
        return neg(b)
    return ir.Bin("-", a, b)


def mul(a: ir.Expr, b: ir.Expr) -> ir.Expr:
    if isinstance(a, ir.Const) and isinstance(b, ir.Const):
        return const(a.value * b.value)
    if is_const(a, 1.0):
        return b
    if is_const(b, 1.0):
        return a
    if is_const(a, 0.0) or is_const(b, 0.0):
        return const(0.0)
    return ir.Bin("*", a, b)


def div(a: ir.Expr, b: ir.Expr) -> ir.Expr:
    if isinstance(a, ir.Const) and isinstance(b, ir.Const) and b.value != 0:
        return const(a.value / b.value)
    if is_const(b, 1.0):
        return a
    return ir.Bin("/", a, b)


def neg(a: ir.Expr) -> ir.Expr:
    return nnf.negate_expr(a)


def call(fn: str, *args: ir.Expr) -> ir.Expr:
    if fn in shapes.SD_FUNCS:
        if all(isinstance(a, ir.Const) for a in args):
            return const(shapes.fold(fn, [a.value for a in args]))  # type: ignore[union-attr]
        return ir.Call(fn, tuple(args))
    if all(isinstance(a, ir.Const) for a in args):
        vals = [a.value for a in args]  # type: ignore[union-attr]
        with np.errstate(all="ignore"):
            f = {
                "abs": abs, "sqrt": np.sqrt, "sin": np.sin, "cos": np.cos, "exp": np.exp,
                "log": np.log, "min": min, "max": max, "atan2": np.arctan2,
                "angdiff": lambda a, b: float(np.arctan2(np.sin(a - b), np.cos(a - b))),
            }[fn]
            r = float(f(*vals))
        if np.isfinite(r):
            return const(r)
    return ir.Call(fn, tuple(args))


def to_sym(v: Num) -> Sym:
    arr = np.atleast_1d(v.v)
    items = tuple(const(x) for x in arr.ravel())
    return Sym(items, v.dim, v.v.ndim > 0, tuple(f"{x:g}" for x in arr.ravel()))


def broadcast(a: Sym, b: Sym) -> list[tuple[ir.Expr, ir.Expr]] | None:
    """Pair the components of two signal values (a scalar pairs with every component)."""
    if len(a.items) == len(b.items):
        return list(zip(a.items, b.items))
    if len(a.items) == 1:
        return [(a.items[0], y) for y in b.items]
    if len(b.items) == 1:
        return [(x, b.items[0]) for x in a.items]
    return None


def finite_expr(e: ir.Expr) -> bool:
    """Are all constants of the expression ``e`` finite?"""
    stack = [e]
    while stack:
        x = stack.pop()
        match x:
            case ir.Const(value) if not np.isfinite(value):
                return False
            case ir.Neg(a):
                stack.append(a)
            case ir.Bin(_, a, b):
                stack += [a, b]
            case ir.Call(_, args):
                stack.extend(args)
    return True


def box_faces(box: model.Box, k: int) -> tuple[ir.Expr, ir.Expr]:
    """The low and high face of ``box`` along axis ``k``: constants, or the centre parameter
    ∓ the half-size for a placed box (its size stays, its centre is ``--set``)."""
    if box.placed is None:
        return const(box.lo[k]), const(box.hi[k])
    c = ir.Param(f"{box.placed}.center.{'xyz'[k]}")
    h = const((box.hi[k] - box.lo[k]) / 2)
    return sub(c, h), add(c, h)


def world_to_frame(p: tuple[ir.Expr, ...], human: str) -> tuple[ir.Expr, ...]:
    """R(att)ᵀ (p − pos) with R = Rz(yaw) Ry(pitch) Rx(roll), pose as IR parameters."""
    d = [sub(p[k], ir.Param(f"{human}.pos.{a}")) for k, a in enumerate("xyz")]
    r, pi_, y = (ir.Param(f"{human}.att.{a}") for a in "xyz")
    cr, sr = ir.Call("cos", (r,)), ir.Call("sin", (r,))
    cp, sp = ir.Call("cos", (pi_,)), ir.Call("sin", (pi_,))
    cy, sy = ir.Call("cos", (y,)), ir.Call("sin", (y,))
    # rows of R^T = columns of R
    R = [
        [mul(cy, cp), sub(mul(mul(cy, sp), sr), mul(sy, cr)),
         add(mul(mul(cy, sp), cr), mul(sy, sr))],
        [mul(sy, cp), add(mul(mul(sy, sp), sr), mul(cy, cr)),
         sub(mul(mul(sy, sp), cr), mul(cy, sr))],
        [neg(sp), mul(cp, sr), mul(cp, cr)],
    ]
    out = []
    for j in range(3):  # (R^T d)_j = sum_i R[i][j] d_i
        acc: ir.Expr = const(0.0)
        for i in range(3):
            acc = add(acc, mul(R[i][j], d[i]))
        out.append(acc)
    return tuple(out)


def distance_expr(p, box: model.Box, to_frame) -> shapes.ir.Expr:
    """The signed distance expression of ``box`` (a box or a round region) at the world
    point ``p``; ``to_frame(p, human)`` maps a world point into a human's frame."""
    if box.frame is not None:
        p = to_frame(tuple(p), box.frame)
    if box.shape is None:
        c = tuple((a + b) / 2 for a, b in zip(box.lo, box.hi))
        q = shapes.local(tuple(p), shapes.centre_exprs(c, box.placed), None)
    else:
        q = shapes.local(tuple(p), shapes.centre_exprs(box.shape.center, box.placed),
                         box.shape.axis)
    return shapes.sd_expr(q, box.lo, box.hi, box.shape)
