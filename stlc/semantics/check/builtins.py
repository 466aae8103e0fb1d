"""Built-in functions of the language: math on signals, constructors for boxes, matrices,
distributions and rotor geometries.  Each takes the checker context, the call node and the
scope and returns a checked value (or reports a diagnostic and returns ``ERROR``); ``FUNCS``
is installed as ``Context.functions`` by ``stlc.semantics.check.program``."""

from __future__ import annotations

import math

import numpy as np

from stlc.frontend import ast
from stlc.semantics import ir, model
from stlc.semantics.check import units
from stlc.semantics.check.context import Context, Scope
from stlc.semantics.check.values import (
    ERROR,
    DistV,
    ErrorV,
    Num,
    RegionV,
    RotorsV,
    Sym,
    Value,
    add,
    call,
    kind_name,
    mul,
    to_sym,
)


def _arity(el: Context, n: ast.Call, lo: int, hi: int | None = None) -> bool:
    hi = lo if hi is None else hi
    k = len(n.args)
    if k < lo or (hi >= 0 and k > hi) or n.kwargs and n.fn not in KW_FUNCS:
        want = str(lo) if lo == hi else (f"{lo} or more" if hi < 0 else f"{lo} to {hi}")
        el.err("STL206", f"`{n.fn}` takes {want} argument{'s' if want != '1' else ''}, "
               f"got {k}" + (" (and keyword arguments)" if n.kwargs else ""), n.span)
        return False
    return True


def _numeric(el: Context, node: ast.Node, scope: Scope) -> Num | Sym | None:
    v = el.value(node, scope)
    if isinstance(v, (Num, Sym)):
        return v
    if not isinstance(v, ErrorV):
        el.err("STL202", f"expected a number, found {kind_name(v)}", node.span)
    return None


def _elementwise(fn: str, out_dim):
    def f(el: Context, n: ast.Call, scope: Scope) -> Value:
        if not _arity(el, n, 1):
            return ERROR
        v = _numeric(el, n.args[0], scope)
        if v is None:
            return ERROR
        if fn in ("sin", "cos") and v.dim not in (None, units.ANGLE, units.DIMLESS):
            return el.err("STL204", f"`{fn}` takes an angle, found {units.describe(v.dim)}",
                          n.args[0].span)
        if fn in ("exp", "log") and v.dim not in (None, units.DIMLESS):
            return el.err("STL204", f"`{fn}` takes a plain number", n.args[0].span)
        dim = out_dim(v.dim)
        if isinstance(v, Num):
            with np.errstate(all="ignore"):
                r = {"abs": np.abs, "sqrt": np.sqrt, "sin": np.sin, "cos": np.cos,
                     "exp": np.exp, "log": np.log}[fn](v.v)
            return Num(np.asarray(r, dtype=float), dim)
        return Sym(tuple(call(fn, e) for e in v.items), dim, v.vector,
                   tuple(f"{fn}({lab})" for lab in v.labels))

    return f


def _sqrt_dim(d):
    try:
        return units.power(d, 0.5)
    except units.UnitError:
        return None


def _norm(el: Context, n: ast.Call, scope: Scope) -> Value:
    if not _arity(el, n, 1):
        return ERROR
    v = _numeric(el, n.args[0], scope)
    if v is None:
        return ERROR
    if isinstance(v, Num):
        return Num(np.array(float(np.linalg.norm(np.atleast_1d(v.v)))), v.dim)
    acc = None
    for e in v.items:
        sq = mul(e, e)
        acc = sq if acc is None else add(acc, sq)
    return Sym((call("sqrt", acc),), v.dim, False, (el.text(n.span),))


def _dist(el: Context, n: ast.Call, scope: Scope) -> Value:
    if not _arity(el, n, 2):
        return ERROR
    sub_node = ast.Call("norm", (ast.Binary("-", n.args[0], n.args[1], n.span),), (), n.span)
    return _norm(el, sub_node, scope)


def _dot(el: Context, n: ast.Call, scope: Scope) -> Value:
    if not _arity(el, n, 2):
        return ERROR
    a, b = _numeric(el, n.args[0], scope), _numeric(el, n.args[1], scope)
    if a is None or b is None:
        return ERROR
    sa = to_sym(a) if isinstance(a, Num) else a
    sb = to_sym(b) if isinstance(b, Num) else b
    if len(sa.items) != len(sb.items):
        return el.err("STL205", "`dot` needs vectors of the same size", n.span)
    acc = None
    for x, y in zip(sa.items, sb.items):
        t = mul(x, y)
        acc = t if acc is None else add(acc, t)
    return Sym((acc,), units.mul(a.dim, b.dim), False, (el.text(n.span),))


def _minmax(fn: str):
    def f(el: Context, n: ast.Call, scope: Scope) -> Value:
        if not _arity(el, n, 1, -1):
            return ERROR
        vals = [_numeric(el, a, scope) for a in n.args]
        if any(v is None for v in vals):
            return ERROR
        for v, a in zip(vals, n.args):
            if isinstance(v, Num) and v.v.ndim > 1:
                return el.err("STL205", f"`{fn}` takes numbers and vectors, found a matrix",
                              a.span)
        items = []
        dims = set()
        for v in vals:
            s = to_sym(v) if isinstance(v, Num) else v
            items.extend(s.items)
            if v.dim is not None:
                dims.add(v.dim)
        if len(dims) > 1:
            return el.err("STL204", f"`{fn}` of values with different units", n.span)
        dim = dims.pop() if dims else None
        if all(isinstance(v, Num) for v in vals):
            arr = np.concatenate([np.atleast_1d(v.v) for v in vals])
            return Num(np.array(float(arr.min() if fn == "min" else arr.max())), dim)
        e = items[0] if len(items) == 1 else call(fn, *items)
        return Sym((e,), dim, False, (el.text(n.span),))

    return f


def _binary_angle(fn: str):
    def f(el: Context, n: ast.Call, scope: Scope) -> Value:
        if not _arity(el, n, 2):
            return ERROR
        a, b = _numeric(el, n.args[0], scope), _numeric(el, n.args[1], scope)
        if a is None or b is None:
            return ERROR
        if not units.compatible(a.dim, b.dim):
            return el.err("STL204", f"`{fn}` of values with different units", n.span)
        if fn == "angdiff" and units.join(a.dim, b.dim) not in (None, units.ANGLE):
            return el.err("STL204", "`angdiff` takes two angles", n.span)
        sa = to_sym(a) if isinstance(a, Num) else a
        sb = to_sym(b) if isinstance(b, Num) else b
        if len(sa.items) != 1 or len(sb.items) != 1:
            return el.err("STL205", f"`{fn}` takes scalars", n.span)
        e = call(fn, sa.items[0], sb.items[0])
        if isinstance(a, Num) and isinstance(b, Num):
            if not isinstance(e, ir.Const):  # not folded: the result is not finite
                return el.err("STL207", f"`{fn}` of these numbers is not finite", n.span)
            return Num(np.array(e.value), units.ANGLE)
        return Sym((e,), units.ANGLE, False, (el.text(n.span),))

    return f


def _box(el: Context, n: ast.Call, scope: Scope) -> Value:
    kw = dict(n.kwargs)
    if set(kw) == {"center", "size"} and not n.args:
        c = el.vector(kw["center"], scope, 3, units.LENGTH, "the box centre")
        s = el.vector(kw["size"], scope, 3, units.LENGTH, "the box size")
        if c is None or s is None:
            return ERROR
        with np.errstate(all="ignore"):
            lo, hi = c - s / 2, c + s / 2
    elif not kw and len(n.args) == 2:
        lo = el.vector(n.args[0], scope, 3, units.LENGTH, "the box corner `lo`")
        hi = el.vector(n.args[1], scope, 3, units.LENGTH, "the box corner `hi`")
        if lo is None or hi is None:
            return ERROR
    else:
        return el.err("STL206", "`box` takes two corners `box(lo, hi)` or "
                      "`box(center = ..., size = ...)`", n.span)
    if not el.finite(np.concatenate([lo, hi]), "the corners of a box", n.span):
        return ERROR
    if np.any(lo > hi):
        return el.err("STL211", "empty box: a `lo` coordinate is above `hi`", n.span,
                      "write the lower corner first: box((xmin, ymin, zmin), (xmax, ymax, zmax))")
    return RegionV("", model.Box(tuple(map(float, lo)), tuple(map(float, hi))))  # type: ignore


def _diag(el: Context, n: ast.Call, scope: Scope) -> Value:
    if not _arity(el, n, 1, -1):
        return ERROR
    vals = []
    dims = set()
    for a in n.args:
        v = el.value(a, scope)
        if isinstance(v, ErrorV):
            return v
        if not isinstance(v, Num):
            return el.err("STL210", "`diag` takes constant numbers", a.span)
        if v.v.ndim > 1:
            return el.err("STL205", "`diag` takes numbers and vectors, found a matrix", a.span,
                          "list the diagonal entries, e.g. diag(1, 2, 3)")
        vals.extend(np.atleast_1d(v.v).tolist())
        if v.dim is not None:
            dims.add(v.dim)
    if len(dims) > 1:
        return el.err("STL204", "`diag` of values with different units", n.span)
    return Num(np.diag(np.array(vals, dtype=float)), dims.pop() if dims else None)


def _normal(el: Context, n: ast.Call, scope: Scope) -> Value:
    kw = dict(n.kwargs)
    args = list(n.args)
    mean_n = kw.get("mean", args[0] if args else None)
    cov_n = kw.get("cov", args[1] if len(args) > 1 else None)
    if mean_n is None or cov_n is None or len(args) + len(kw) != 2:
        return el.err("STL206", "`normal` takes a mean and a covariance: normal(mean, cov)",
                      n.span)
    mean, cov = el.value(mean_n, scope), el.value(cov_n, scope)
    if isinstance(mean, ErrorV) or isinstance(cov, ErrorV):
        return ERROR
    if not isinstance(mean, Num) or not isinstance(cov, Num):
        return el.err("STL210", "`normal` takes constant numbers", n.span)
    if not (el.finite(mean.v, "the mean", mean_n.span) and
            el.finite(cov.v, "the covariance", cov_n.span)):
        return ERROR
    m = np.atleast_1d(mean.v).astype(float)
    c = np.atleast_2d(cov.v).astype(float)
    if cov.v.ndim == 1:
        c = np.diag(cov.v)
    if c.shape != (m.size, m.size):
        return el.err("STL209", f"covariance is {c.shape[0]}x{c.shape[1]} but the mean has "
                      f"{m.size} components", cov_n.span, f"write a {m.size}x{m.size} matrix, "
                      f"e.g. diag({', '.join(['0.1'] * m.size)})")
    if not np.allclose(c, c.T, atol=1e-12):
        return el.err("STL209", "covariance matrix is not symmetric", cov_n.span)
    if np.linalg.eigvalsh(c).min() < -1e-12:
        return el.err("STL209", "covariance matrix is not positive semi-definite", cov_n.span,
                      "variances must be >= 0 and correlations at most 1")
    if mean.dim is not None and cov.dim is not None and units.power(mean.dim, 2) != cov.dim:
        return el.err("STL204", f"covariance unit must be the square of the mean's "
                      f"({units.describe(units.power(mean.dim, 2))}), found "
                      f"{units.describe(cov.dim)}", cov_n.span)
    return DistV(m, c, units.join(mean.dim, _sqrt_dim(cov.dim) if cov.dim else None))


def _rotor_geometry(kind: str):
    def f(el: Context, n: ast.Call, scope: Scope) -> Value:
        from stlc.vehicles import geometry

        if n.args:
            return el.err("STL206", f"`{kind}` takes keyword arguments, e.g. "
                          f"{kind}(arm = 0.39 m{', tilt = 20 deg' if kind == 'hexarotor' else ''})",
                          n.span)
        allowed = {"arm": units.LENGTH, "tilt": units.ANGLE} if kind == "hexarotor" else \
            {"arm": units.LENGTH}
        kw = {}
        for name, node in n.kwargs:
            if name not in allowed and not (kind == "quadrotor" and name == "config"):
                return el.err("STL103", f"`{kind}` has no parameter `{name}`", node.span,
                              "parameters: " + ", ".join(allowed))
            if name == "config":
                v = el.value(node, scope)
                kw[name] = v.s if hasattr(v, "s") else "x"
                continue
            x = el.number(node, scope, allowed[name], name)
            if x is None:
                return ERROR
            if not math.isfinite(x):
                return el.err("STL207", f"`{name}` must be a finite number, found {x:g}",
                              node.span)
            kw[name] = x
        if "arm" not in kw:
            return el.err("STL104", f"`{kind}` needs `arm = ...`", n.span)
        if kw["arm"] <= 0:
            return el.err("STL207", "the arm length must be positive", n.span)
        try:
            rotors = getattr(geometry, kind)(**kw)
        except (TypeError, ValueError) as e:
            return el.err("STL207", f"invalid {kind} geometry: {e}", n.span)
        return RotorsV(tuple(rotors))

    return f


KW_FUNCS = {"box", "normal", "hexarotor", "quadrotor"}

FUNCS = {
    "abs": _elementwise("abs", lambda d: d),
    "sqrt": _elementwise("sqrt", _sqrt_dim),
    "sin": _elementwise("sin", lambda d: units.DIMLESS if d is not None else None),
    "cos": _elementwise("cos", lambda d: units.DIMLESS if d is not None else None),
    "exp": _elementwise("exp", lambda d: d),
    "log": _elementwise("log", lambda d: d),
    "norm": _norm,
    "dist": _dist,
    "dot": _dot,
    "min": _minmax("min"),
    "max": _minmax("max"),
    "atan2": _binary_angle("atan2"),
    "angdiff": _binary_angle("angdiff"),
    "box": _box,
    "diag": _diag,
    "normal": _normal,
    "hexarotor": _rotor_geometry("hexarotor"),
    "quadrotor": _rotor_geometry("quadrotor"),
}

