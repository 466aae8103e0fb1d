"""Round regions and distances in the checker: ``cylinder``, ``sphere``, ``capsule`` and
``dist(p, R)``.

* ``cylinder(center, radius, height)`` — vertical, ``center`` its mid-height point; the
  keyword ``axis = (x, y, z)`` (a direction, any length) tilts it;
* ``sphere(center, radius)``; ``capsule(a, b, radius)`` — every point within ``radius`` of
  the segment a–b;
* ``dist(p, R)`` — the signed Euclidean distance (m) from the point ``p`` to the surface
  of the region ``R`` (a box or a round region, in the world or a human's frame): negative
  inside.  ``dist(p, q)`` of two points stays their Euclidean distance.

Arguments are positional (in the order above) or keywords; lengths in metres (STL204 for
another unit), radius, height and segment length > 0 (STL207; a capsule may have a = b,
a sphere).  The value is a ``RegionV`` whose box is the shape's bounding box and whose
``box.shape`` is the ``shapes.Round`` (``stlc.semantics.shapes``).
"""

from __future__ import annotations

import numpy as np

from stlc.frontend import ast
from stlc.semantics import model, shapes
from stlc.semantics.check import units
from stlc.semantics.check.context import Context, Scope
from stlc.semantics.check.values import (ERROR, ErrorV, Num, RegionV, Sym, Value, distance_expr,
                                         kind_name, to_sym, world_to_frame)

#: the parameters of each shape, in positional order: (name, kind of value, required)
PARAMS = {
    "cylinder": (("center", "point", True), ("radius", "length", True),
                 ("height", "length", True), ("axis", "direction", False)),
    "sphere": (("center", "point", True), ("radius", "length", True)),
    "capsule": (("a", "point", True), ("b", "point", True), ("radius", "length", True)),
}
EXAMPLE = {
    "cylinder": "cylinder(center = (0, 0, 5) m, radius = 1.5 m, height = 10 m)",
    "sphere": "sphere(center = (0, 0, 2) m, radius = 1 m)",
    "capsule": "capsule((0, 0, 1) m, (4, 0, 1) m, 0.5 m)",
}


def _bind(el: Context, n: ast.Call, kind: str) -> dict[str, ast.Node] | None:
    params = PARAMS[kind]
    names = [p[0] for p in params]
    if len(n.args) > len(params):
        el.err("STL206", f"`{kind}` takes at most {len(params)} arguments, got {len(n.args)}",
               n.span, f"e.g. {EXAMPLE[kind]}")
        return None
    got = dict(zip(names, n.args))
    for name, node in n.kwargs:
        if name not in names:
            el.err("STL103", f"`{kind}` has no parameter `{name}`", node.span,
                   "parameters: " + ", ".join(names))
            return None
        if name in got:
            el.err("STL206", f"`{name}` is given twice", node.span)
            return None
        got[name] = node
    missing = [p[0] for p in params if p[2] and p[0] not in got]
    if missing:
        el.err("STL104", f"`{kind}` needs " + ", ".join(f"`{m} = ...`" for m in missing),
               n.span, f"e.g. {EXAMPLE[kind]}")
        return None
    return got


def _round(kind: str):
    def f(el: Context, n: ast.Call, scope: Scope) -> Value:
        got = _bind(el, n, kind)
        if got is None:
            return ERROR
        vals: dict[str, object] = {}
        for name, what, _ in PARAMS[kind]:
            node = got.get(name)
            if node is None:
                continue
            if what == "point":
                v = el.vector(node, scope, 3, units.LENGTH, f"the {kind}'s `{name}`")
            elif what == "direction":
                v = el.vector(node, scope, 3, units.DIMLESS, f"the {kind}'s `{name}`")
            else:
                x = el.number(node, scope, units.LENGTH, f"the {kind}'s `{name}`")
                v = None if x is None else np.array([x])
            if v is None or not el.finite(v, f"the {kind}'s `{name}`", node.span):
                return ERROR
            if what == "length" and float(v[0]) <= 0:
                return el.err("STL207", f"the {kind}'s `{name}` must be positive, found "
                              f"{float(v[0]):g} m", node.span, f"e.g. {EXAMPLE[kind]}")
            if what == "direction" and float(np.linalg.norm(v)) == 0.0:
                return el.err("STL207", "the cylinder's `axis` must not be zero", node.span,
                              "a direction, e.g. axis = (1, 0, 0) for a horizontal one")
            vals[name] = v
        if kind == "capsule":
            a, b = np.asarray(vals["a"]), np.asarray(vals["b"])
            seg = b - a
            length = float(np.linalg.norm(seg))
            axis = tuple(map(float, seg / length)) if length > 0 else shapes.Z_AXIS
            shape = shapes.Round("capsule", tuple(map(float, (a + b) / 2)),  # type: ignore
                                 float(vals["radius"][0]), length / 2, axis)  # type: ignore
        else:
            ax = vals.get("axis")
            axis = shapes.Z_AXIS if ax is None else \
                tuple(map(float, np.asarray(ax) / np.linalg.norm(ax)))
            half = float(vals["height"][0]) / 2 if kind == "cylinder" else 0.0  # type: ignore
            shape = shapes.Round(kind, tuple(map(float, vals["center"])),  # type: ignore
                                 float(vals["radius"][0]), half, axis)  # type: ignore
        lo, hi = shape.bounds()
        return RegionV("", model.Box(lo, hi, shape=shape))

    return f


def region_distance(el: Context, n: ast.Call, p: Value, reg: RegionV, scope: Scope) -> Value:
    """``dist(p, R)``: the signed distance call at ``p`` in R's own coordinates."""
    if isinstance(p, ErrorV):
        return p
    if isinstance(p, Num):
        p = to_sym(p)
    if not isinstance(p, Sym) or len(p.items) != 3:
        return el.err("STL205", "`dist(p, R)` needs a 3-D point `p`", n.args[0].span,
                      "e.g. dist(uav1.pos, tower)")
    if not units.compatible(p.dim, units.LENGTH):
        return el.err("STL204", f"`dist(p, R)` needs a position, found "
                      f"{units.describe(p.dim)}", n.args[0].span)
    return Sym((distance_expr(p.items, reg.box, world_to_frame),), units.LENGTH, False,
               (el.text(n.span),))


def distance_or(point_distance):
    """``dist``: ``dist(p, R)`` for a region R, else ``point_distance`` (``dist(p, q)``)."""
    return lambda el, n, scope: dist(el, n, scope, point_distance)


def dist(el: Context, n: ast.Call, scope: Scope, point_distance) -> Value:
    if len(n.args) == 2 and not n.kwargs:
        second = el.value(n.args[1], scope)
        if isinstance(second, ErrorV):
            return second
        if isinstance(second, RegionV):
            return region_distance(el, n, el.value(n.args[0], scope), second, scope)
        if not isinstance(second, (Num, Sym)):
            return el.err("STL202", f"`dist` takes a point and a region or two points, "
                          f"found {kind_name(second)}", n.args[1].span)
    return point_distance(el, n, scope)


FUNCS = {k: _round(k) for k in PARAMS}
