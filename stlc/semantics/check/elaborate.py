"""Elaboration of expressions: AST nodes → checked values and IR.

``ExpressionElaborator.value(node, scope)`` evaluates constants (with units converted to
SI), turns references to vehicle fields and human poses into scalar IR expressions and
inlines named specs; the formula nodes (comparisons, region membership, ranges, temporal
operators and quantifiers) are ``stlc.semantics.check.formulas``'s and calls go to the built-in
functions (``Context.functions``).  Every mistake becomes a diagnostic in the context's
``Collector`` and an ``ErrorV`` value, so one pass reports all independent errors; a
constant that comes out as NaN is reported where it is computed.
"""

from __future__ import annotations

import math

import numpy as np

from stlc.diagnostics import Span, did_you_mean
from stlc.frontend import ast
from stlc.semantics import ir, model
from stlc.semantics.check import hints, units
from stlc.semantics.check.context import Context, Scope
from stlc.semantics.check.values import (
    ERROR,
    DistV,
    ErrorV,
    Form,
    GroupV,
    HumanV,
    Num,
    RegionV,
    StrV,
    Sym,
    Value,
    VehicleV,
    add,
    box_faces,
    broadcast,
    const,
    div,
    kind_name,
    mul,
    neg,
    sub,
    to_sym,
)
from stlc.vehicles import model_of

BUILTIN_CONSTS = {"pi": (math.pi, units.DIMLESS), "inf": (math.inf, None),
                  "g0": (9.81, units.ACCEL)}
AXIS_NAMES = {"x": 0, "y": 1, "z": 2, "roll": 0, "pitch": 1, "yaw": 2}


class ExpressionElaborator(Context):
    """Evaluation of expressions (the formula nodes are ``FormulaElaborator``'s)."""

    _inside = False  # inside a call of ``value`` (see there)

    # ------------------------------------------------------------ generic evaluation
    def value(self, node: ast.Node, scope: Scope) -> Value:
        method = getattr(self, "_v_" + type(node).__name__.lower())
        if self._inside:
            return _defined(self, method(node, scope), node)
        # the outermost call: a formula nested deeper than Python's stack is a diagnostic
        self._inside = True
        try:
            return _defined(self, method(node, scope), node)
        except RecursionError:
            return self.err("STL004", "formula nested too deeply", node.span,
                            "name sub-formulas with `spec` instead")
        finally:
            self._inside = False

    def _v_number(self, n: ast.Number, scope: Scope) -> Value:
        return Num(np.array(n.value), None)

    def _v_bool(self, n: ast.Bool, scope: Scope) -> Value:
        return Form(ir.TrueF(n.span) if n.value else ir.FalseF(n.span))

    def _v_string(self, n: ast.String, scope: Scope) -> Value:
        return StrV(n.value)

    def _v_quantity(self, n: ast.Quantity, scope: Scope) -> Value:
        try:
            scale, dim = units.parse_unit(n.unit)
        except units.UnitRangeError as e:
            return self.err("STL207", str(e), n.span, "write the quantity in a larger unit")
        except units.UnitError as e:
            bad = str(e)
            return self.err("STL203", f"unknown unit `{bad}`", n.span,
                            did_you_mean(bad, units.UNITS) or
                            "known units: " + ", ".join(units.UNITS))
        v = self.value(n.arg, scope)
        match v:
            case Num():
                if v.dim is not None and v.dim != units.DIMLESS:
                    return self.err("STL204", f"`{n.unit}` applied to a value that already "
                                    f"has a unit ({units.describe(v.dim)})", n.span)
                with np.errstate(over="ignore"):  # inf is reported where it is used
                    return Num(v.v * scale, dim)
            case RegionV(name, box):
                if dim != units.LENGTH:
                    return self.err("STL204", f"unit mismatch: a region is measured in "
                                    f"lengths, found {units.describe(dim)}", n.span,
                                    "write its corners in m, e.g. box(lo, hi) m")
                with np.errstate(over="ignore"):  # an overflow to inf is reported below
                    lo, hi = np.array(box.lo) * scale, np.array(box.hi) * scale
                if not self.finite(np.concatenate([lo, hi]), "the corners of a box", n.span):
                    return ERROR
                return RegionV(name, model.Box(tuple(map(float, lo)),  # type: ignore[arg-type]
                                               tuple(map(float, hi)), box.frame,
                                               shape=box.shape and box.shape.scaled(scale)))
            case DistV(mean, cov, _):
                with np.errstate(over="ignore"):  # reported by `value` if not finite
                    return DistV(mean * scale, cov * scale * scale, dim)
            case ErrorV():
                return v
            case Sym():
                return Sym(tuple(mul(e, const(scale)) for e in v.items), dim, v.vector, v.labels)
        return self.err("STL204", f"a unit cannot follow {kind_name(v)}", n.span)

    def _v_tuple(self, n: ast.Tuple, scope: Scope) -> Value:
        vals = [self.value(i, scope) for i in n.items]
        if any(isinstance(v, ErrorV) for v in vals):
            return ERROR
        if all(isinstance(v, Num) and v.is_scalar for v in vals):
            dims = [v.dim for v in vals]  # type: ignore[union-attr]
            dim = _common_dim(dims)
            if dim is False:
                return self.err("STL204", "the components of a vector have different units",
                                n.span)
            return Num(np.array([float(v.v) for v in vals]), dim)  # type: ignore[union-attr]
        if all(isinstance(v, (Num, Sym)) for v in vals):
            items, labels, dims = [], [], []
            for v, node in zip(vals, n.items):
                s = to_sym(v) if isinstance(v, Num) else v
                if s.vector or len(s.items) != 1:
                    return self.err("STL205", "vector components must be scalars", node.span)
                items.append(s.items[0])
                labels.append(self.text(node.span))
                dims.append(s.dim)
            dim = _common_dim(dims)
            if dim is False:
                return self.err("STL204", "the components of a vector have different units",
                                n.span)
            return Sym(tuple(items), dim, True, tuple(labels))
        return self.err("STL205", "a vector holds numbers or signals only", n.span)

    def _v_list(self, n: ast.List, scope: Scope) -> Value:
        vals = [self.value(i, scope) for i in n.items]
        if any(isinstance(v, ErrorV) for v in vals):
            return ERROR
        if vals and all(isinstance(v, Num) for v in vals):
            shapes = {v.v.shape for v in vals}  # type: ignore[union-attr]
            dim = _common_dim([v.dim for v in vals])  # type: ignore[union-attr]
            if len(shapes) == 1 and dim is not False:
                return Num(np.array([v.v for v in vals], dtype=float), dim)  # type: ignore
        return GroupV("list", tuple(vals))

    def _v_path(self, n: ast.Path, scope: Scope) -> Value:
        head = n.parts[0]
        v = scope.get(head)
        if v is None:
            v = scope.hook(head, _head_span(n))
        if v is None and head in BUILTIN_CONSTS:
            x, dim = BUILTIN_CONSTS[head]
            v = Num(np.array(x), dim)
        if v is None:
            cands = scope.all_names(BUILTIN_CONSTS)
            q = self.closed_quant.get(head)
            hint = (f"`{head}` is bound by the quantifier at line {q.line}, whose body ended "
                    "before this operator (its body is a prefix-level formula): parenthesise "
                    "the body, e.g. `forall d in team: (a and b)`") if q is not None else None
            hint = hint or hints.unknown_name(head, scope.get("team") is not None)
            return self.err("STL101", f"unknown name `{head}`", _head_span(n),
                            hint or self.human_region_hint(head) or did_you_mean(head, cands))
        for i, part in enumerate(n.parts[1:], start=1):
            if isinstance(v, ErrorV):  # a declaration with errors, already reported
                return v
            v = self.member(v, part, n, i)
        return v

    def member(self, v: Value, part: str, n: ast.Path, i: int) -> Value:
        """``v.part`` — vehicle fields, human pose and regions, vector components."""
        prefix = ".".join(n.parts[:i])
        span = n.span
        match v:
            case VehicleV(veh):  # cached: quantifier bodies read fields thousands of times
                holes = self.__dict__.get("_hole_reads")
                if holes and veh.name in holes:  # a team template's placeholder (teams.py)
                    holes[veh.name].add(part)
                cache = self.__dict__.setdefault("_vehicle_fields", {})
                hit = cache.get(veh.name)
                if hit is None or hit[0] is not veh:
                    hit = cache[veh.name] = (veh, vehicle_fields(veh))
                fields = hit[1]
                if part in fields:
                    return fields[part]
                return self.err("STL103", f"vehicle `{veh.name}` ({veh.kind}) has no field "
                                f"`{part}`", span, did_you_mean(part, fields) or
                                "fields: " + ", ".join(sorted(fields)))
            case HumanV(h):
                fields = human_fields(h, self._regions_of(h.name))
                if part in fields:
                    return fields[part]
                return self.err("STL103", f"human `{h.name}` has no field or region `{part}`",
                                span, did_you_mean(part, fields) or
                                "fields: " + ", ".join(sorted(fields)))
            case Sym(items, dim, True, labels):
                idx = _component(part, len(items))
                if idx is None:
                    return self.err("STL103", f"`{prefix}` has no component `{part}`", span,
                                    "use .x/.y/.z or an index 1.." + str(len(items)))
                return Sym((items[idx],), dim, False, (labels[idx],))
            case Num(arr, dim) if arr.ndim == 1:
                idx = _component(part, arr.size)
                if idx is None:
                    return self.err("STL103", f"`{prefix}` has no component `{part}`", span)
                return Num(np.array(arr[idx]), dim)
            case RegionV(name, box) if box.placed is not None and part in (
                    "lo", "hi", "center", "centre"):  # the centre is a parameter
                faces = [box_faces(box, k) for k in range(3)]
                items = tuple(ir.Param(f"{box.placed}.center.{a}") for a in "xyz") \
                    if part in ("center", "centre") else \
                    tuple(f[0 if part == "lo" else 1] for f in faces)
                return Sym(items, units.LENGTH, True, tuple(f"{prefix}.{a}" for a in "xyz"))
            case RegionV(name, box):
                fields = {"lo": Num(np.array(box.lo), units.LENGTH),
                          "hi": Num(np.array(box.hi), units.LENGTH)}
                if box.shape is not None and part == "radius":
                    return Num(np.array(box.shape.radius), units.LENGTH)
                if box.frame is None and part in ("center", "centre"):
                    return Num((np.array(box.lo) + np.array(box.hi)) / 2, units.LENGTH)
                if part in fields and box.frame is None:
                    return fields[part]
                return self.err("STL103", f"region `{name}` has no field `{part}`", span)
        return self.err("STL103", f"`{prefix}` ({kind_name(v)}) has no field `{part}`", span)

    def _regions_of(self, human: str) -> dict[str, RegionV]:
        return self.human_regions.get(human, {})

    # ------------------------------------------------------------ arithmetic
    def _v_unary(self, n: ast.Unary, scope: Scope) -> Value:
        v = self.value(n.arg, scope)
        if n.op == "+" or isinstance(v, ErrorV):
            return v
        match v:
            case Num():
                return Num(-v.v, v.dim)
            case Sym():
                return Sym(tuple(neg(e) for e in v.items), v.dim, v.vector, v.labels)
            case Form():
                return self.err("STL202", "expected a number, found a formula", n.arg.span,
                                "use `not` to negate a formula")
        return self.err("STL202", f"cannot negate {kind_name(v)}", n.span)

    def _v_binary(self, n: ast.Binary, scope: Scope) -> Value:
        a, b = self.value(n.left, scope), self.value(n.right, scope)
        if isinstance(a, ErrorV) or isinstance(b, ErrorV):
            return ERROR
        for v, node in ((a, n.left), (b, n.right)):
            if isinstance(v, Form):
                return self.err("STL202", "expected a number, found a formula", node.span,
                                "arithmetic works on numbers and signals; combine formulas "
                                "with `and`, `or`, `implies`")
            if not isinstance(v, (Num, Sym)):
                return self.err("STL202", f"expected a number, found {kind_name(v)}", node.span)
        if n.op in "+-":
            if not units.compatible(a.dim, b.dim):  # type: ignore[union-attr]
                verb = "add" if n.op == "+" else "subtract"
                return self.err("STL204", f"unit mismatch: cannot {verb} "
                                f"{units.describe(a.dim)} and {units.describe(b.dim)}",  # type: ignore
                                n.span)
            dim = units.join(a.dim, b.dim)  # type: ignore[union-attr]
        elif n.op == "*":
            dim = units.mul(a.dim, b.dim)  # type: ignore[union-attr]
        elif n.op == "/":
            dim = units.div(a.dim, b.dim)  # type: ignore[union-attr]
        else:  # ^
            if not (isinstance(b, Num) and b.is_scalar):
                return self.err("STL210", "an exponent must be a constant number", n.right.span)
            k = float(b.v)
            if not math.isfinite(k) and a.dim not in (None, units.DIMLESS):  # type: ignore
                return self.err("STL207", f"the exponent of {units.describe(a.dim)} must be a "  # type: ignore
                                f"finite number, found {k:g}", n.right.span)
            try:
                dim = units.power(a.dim, k)  # type: ignore[union-attr]
            except units.UnitError as e:
                code = "STL207" if isinstance(e, units.UnitRangeError) else "STL204"
                return self.err(code, f"{e} ({units.describe(a.dim)} to the power "  # type: ignore
                                f"{k:g})", n.span)
        if isinstance(a, Num) and isinstance(b, Num):
            try:
                with np.errstate(all="ignore"):
                    r = {"+": np.add, "-": np.subtract, "*": np.multiply, "/": np.divide,
                         "^": np.power}[n.op](a.v, b.v)
            except ValueError:
                return self.err("STL205", "vector sizes do not match", n.span)
            return Num(np.asarray(r, dtype=float), dim)
        sa, sb = (to_sym(a) if isinstance(a, Num) else a), (to_sym(b) if isinstance(b, Num) else b)
        items = broadcast(sa, sb)
        if items is None:
            return self.err("STL205", f"vector sizes do not match ({len(sa.items)} and "
                            f"{len(sb.items)})", n.span)
        fn = {"+": add, "-": sub, "*": mul, "/": div,
              "^": lambda x, y: ir.Bin("^", x, y)}[n.op]
        out = tuple(fn(x, y) for x, y in items)
        vector = sa.vector or sb.vector
        labels = tuple(self.text(n.span) for _ in out)
        return Sym(out, dim, vector, labels)

    # ------------------------------------------------------------ calls
    def _v_call(self, n: ast.Call, scope: Scope) -> Value:
        fn = self.functions.get(n.fn)
        if fn is None:
            return self.err("STL107", f"unknown function `{n.fn}`", _head_span_call(n),
                            hints.unknown_function(n.fn) or did_you_mean(n.fn, self.functions) or
                            "functions: " + ", ".join(sorted(self.functions)))
        return fn(self, n, scope)


def vehicle_fields(v: model.Vehicle) -> dict[str, Value]:
    """The fields a formula may read from a vehicle, as IR signal expressions."""
    n = v.name

    def vec(field_: str, dim, names=("x", "y", "z")) -> Sym:
        return Sym(tuple(ir.Sig(f"{n}.{field_}.{a}") for a in names), dim, True,
                   tuple(f"{n}.{field_}.{a}" for a in names))

    def scal(e: ir.Expr, dim, label: str) -> Sym:
        return Sym((e,), dim, False, (label,))

    vx, vy, vz = (ir.Sig(f"{n}.vel.{a}") for a in "xyz")
    speed = ir.Call("sqrt", (add(add(mul(vx, vx), mul(vy, vy)), mul(vz, vz)),))
    hspeed = ir.Call("sqrt", (add(mul(vx, vx), mul(vy, vy)),))
    out: dict[str, Value] = {
        "pos": vec("pos", units.LENGTH), "vel": vec("vel", units.SPEED),
        "speed": scal(speed, units.SPEED, f"{n}.speed"),
        "horizontal_speed": scal(hspeed, units.SPEED, f"{n}.horizontal_speed"),
        "course": scal(ir.Call("atan2", (vy, vx)), units.ANGLE, f"{n}.course"),
        "radius": Num(np.asarray(float(getattr(v, "radius", 0.0))), units.LENGTH),  # a constant
    }
    for name, fld in model_of(v).formula_fields(v).items():  # the model's own fields
        items = tuple(ir.Sig(c) if fld.sqrt_of_ratio is None
                      else ir.Call("sqrt", (div(ir.Sig(c), const(fld.sqrt_of_ratio)),))
                      for c in fld.channels)
        out[name] = Sym(items, fld.dim, fld.vector, fld.labels)
    return out


def human_fields(h: model.Human, regions: dict[str, RegionV]) -> dict[str, Value]:
    n = h.name
    out: dict[str, Value] = {
        "pos": Sym(tuple(ir.Param(f"{n}.pos.{a}") for a in "xyz"), units.LENGTH, True,
                   tuple(f"{n}.pos.{a}" for a in "xyz")),
        "att": Sym(tuple(ir.Param(f"{n}.att.{a}") for a in "xyz"), units.ANGLE, True,
                   tuple(f"{n}.att.{a}" for a in "xyz")),
        "heading": Sym((ir.Param(f"{n}.att.z"),), units.ANGLE, False, (f"{n}.heading",)),
    }
    out.update(regions)
    return out


def _component(part: str, size: int) -> int | None:
    if part in AXIS_NAMES and size == 3:
        return AXIS_NAMES[part]
    if part.isdigit() and len(part) < 10 and 1 <= int(part) <= size:
        return int(part) - 1
    return None


def _common_dim(dims):
    known = {d for d in dims if d is not None}
    if len(known) > 1:
        return False
    return known.pop() if known else None


def _defined(ctx: Context, v: Value, node: ast.Node) -> Value:
    """``v``, or STL207 where constant arithmetic first produced NaN (``inf - inf``)."""
    if isinstance(v, Num) and np.isnan(v.v).any():
        return ctx.err("STL207", "this value is not a number (NaN)", node.span,
                       "check the arithmetic: `inf - inf`, `0 * inf` and `inf / inf` "
                       "are undefined")
    if isinstance(v, DistV) and not (np.all(np.isfinite(v.mean)) and
                                     np.all(np.isfinite(v.cov))):
        return ctx.err("STL207", "a distribution must have a finite mean and covariance",
                       node.span)
    return v


def _head_span(n: ast.Path) -> Span:
    s = n.span
    return Span(s.file, s.line, s.col, s.line, s.col + len(n.parts[0])) if s.known else s


def _head_span_call(n: ast.Call) -> Span:
    s = n.span
    return Span(s.file, s.line, s.col, s.line, s.col + len(n.fn)) if s.known else s
