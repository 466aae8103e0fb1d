"""Elaboration of formulas: comparisons, region membership, logic, temporal operators with
their intervals, and quantifiers over groups of vehicles and regions → typed IR.

``FormulaElaborator`` is one half of the checker's elaborator; the other half,
``stlc.semantics.check.elaborate.ExpressionElaborator``, evaluates the expressions that formulas
compare (both are ``Context`` subclasses, put together by ``stlc.semantics.check.program``).  Every
predicate must compare finite numbers: ``x <= inf`` is STL207 where it is written.
"""

from __future__ import annotations

import dataclasses
import itertools
import math
from dataclasses import dataclass

from stlc.diagnostics import Span
from stlc.frontend import ast
from stlc.limits import MAX_EXPANSION
from stlc.semantics import ir
from stlc.semantics.check import units
from stlc.semantics.check.context import Context, Scope, misaligned, nearest_hint
from stlc.semantics.check.values import (
    ERROR,
    ErrorV,
    Form,
    GroupV,
    HumanV,
    Num,
    RegionV,
    Sym,
    Value,
    VehicleV,
    add,
    box_faces,
    broadcast,
    distance_expr,
    finite_expr,
    kind_name,
    neg,
    sub,
    to_sym,
    world_to_frame,
)
from stlc.semantics.origin import COMPARE, FACE, RANGE, Origin

DOMAIN_HINT = ("range over `team`, `vehicles`, `targets`, `stations`, `homes`, `obstacles`, "
               "`regions` or a list like [uav1, uav2]")




def _size(node: ast.Node) -> int:
    """The number of AST nodes of ``node`` (iterative)."""
    count, stack = 0, [node]
    while stack:
        count += 1
        stack.extend(ast.node_children(stack.pop()))
    return count

class FormulaElaborator(Context):
    """The formula half of the elaborator (``value`` is ``ExpressionElaborator``'s)."""

    def formula(self, node: ast.Node, scope: Scope) -> ir.Formula | None:
        v = self.value(node, scope)
        if isinstance(v, Form):
            return v.f
        if isinstance(v, ErrorV):
            return None
        if isinstance(v, (Num, Sym)):
            self.err("STL201", "expected a formula, found a number", node.span,
                     "compare it with something, e.g. `... >= 0`")
        else:
            self.err("STL201", f"expected a formula, found {kind_name(v)}", node.span)
        return None

    def _v_not(self, n: ast.Not, scope: Scope) -> Value:
        f = self.formula(n.arg, scope)
        return ERROR if f is None else Form(ir.Not(f, n.span))

    def _v_logic(self, n: ast.Logic, scope: Scope) -> Value:
        a, b = self.formula(n.left, scope), self.formula(n.right, scope)
        if a is None or b is None:
            return ERROR
        if n.op == "implies":
            return Form(ir.Implies(a, b, n.span))
        cls = ir.And if n.op == "and" else ir.Or
        return Form(cls((a, b), n.span))

    def interval(self, iv: ast.Interval | None, scope: Scope) -> tuple[float, float] | None:
        if iv is None:
            return 0.0, math.inf
        lo = self.number(iv.lo, scope, units.TIME, "a time bound")
        hi = self.number(iv.hi, scope, units.TIME, "a time bound")
        if lo is None or hi is None:
            return None
        ok = True
        for t, node in ((lo, iv.lo), (hi, iv.hi)):
            if math.isnan(t):
                self.err("STL207", "time bound is not a number", node.span,
                         "check the arithmetic: `0 * inf` and `inf - inf` are undefined")
                ok = False
            elif t < 0:
                self.err("STL301", f"negative time bound {t:g} s", node.span,
                         "time bounds are relative to now and must be >= 0")
                ok = False
        if ok and math.isinf(lo):
            self.err("STL207", "the lower time bound must be finite", iv.lo.span,
                     "only the upper bound may be `inf` (unbounded)")
            ok = False
        if ok and lo > hi:
            self.err("STL302", f"interval bounds out of order: [{lo:g}, {hi:g}]", iv.span,
                     f"did you mean [{hi:g}, {lo:g}]?")
            ok = False
        step = self.step
        if ok and step:
            for t, node in ((lo, iv.lo), (hi, iv.hi)):
                if misaligned(t, step):
                    self.err("STL303", f"time bound {t:g} s is not a multiple of the mission "
                             f"step {step:g} s", node.span, nearest_hint(t, step))
                    ok = False
        return (lo, hi) if ok else None

    def _v_temporal(self, n: ast.Temporal, scope: Scope) -> Value:
        f = self.formula(n.arg, scope)
        if n.op == "next":
            return ERROR if f is None else Form(ir.Next(f, n.span))
        iv = self.interval(n.interval, scope)
        if f is None or iv is None:
            return ERROR
        cls = ir.Always if n.op == "always" else ir.Eventually
        return Form(cls(iv[0], iv[1], f, n.span))

    def _v_until(self, n: ast.Until, scope: Scope) -> Value:
        a, b = self.formula(n.left, scope), self.formula(n.right, scope)
        iv = self.interval(n.interval, scope)
        if a is None or b is None or iv is None:
            return ERROR
        return Form(ir.Until(iv[0], iv[1], a, b, n.span))

    def _v_quant(self, n: ast.Quant, scope: Scope) -> Value:
        dom = self.value(n.domain, scope)
        if isinstance(dom, ErrorV):
            return dom
        if not isinstance(dom, GroupV):
            return self.err("STL208", f"cannot range over {kind_name(dom)}", n.domain.span,
                            DOMAIN_HINT)
        bad = [v for v in dom.items if not isinstance(v, (VehicleV, RegionV, HumanV))]
        if bad:  # an explicit list `[uav1, uav2]` may hold anything
            return self.err("STL208", f"a quantifier ranges over vehicles, regions or humans, "
                            f"the list holds {kind_name(bad[0])}", n.domain.span, DOMAIN_HINT)
        if len(set(n.names)) != len(n.names):
            return self.err("STL102", "the same name is bound twice", n.span)
        outer = getattr(self, "_quant_outer", 1)
        before = getattr(self, "_quant_total", 0)
        if len(dom.items) < len(n.names):
            if n.kind == "forall":  # vacuously true: `forall d, e in team` for one drone
                return Form(self.team_quant(n, scope, dom, ir.TrueF(n.span), (), before))
            what = "no element" if not dom.items else f"only {len(dom.items)} element(s)"
            return self.err("STL212", f"`exists` ranges over {what} ({len(n.names)} "
                            "distinct one(s) needed): the formula could never hold",
                            n.domain.span, "declare what it ranges over (e.g. a `station` "
                            "region for `stations`), or remove the quantifier")
        count = math.comb(len(dom.items), len(n.names))
        size = _size(n.body)  # the work of one instance: the body's source nodes
        total = before + count * size  # nodes elaborated so far
        if outer * count * size > MAX_EXPANSION or total > MAX_EXPANSION:
            need = max(outer * count * size, total)
            return self.err("STL606", f"quantifier expansion needs at least {need:,} source "
                            f"nodes (limit {MAX_EXPANSION:,}): {outer * count:,} instances "
                            f"of a {size}-node body ({count:,} here, nested inside "
                            f"{outer:,})",
                            n.span, "quantify over fewer vehicles or regions, bind fewer "
                            "names, or nest fewer quantifiers")
        self._quant_total = total
        self._quant_outer = outer * count
        parts, combos = [], list(itertools.combinations(dom.items, len(n.names)))
        try:
            for combo in combos:
                f = self.formula(n.body, scope.child(dict(zip(n.names, combo))))
                if f is None:
                    return ERROR
                parts.append(f)
        finally:
            self._quant_outer = outer
        self.closed_quant.update({name: n.span for name in n.names})
        out = parts[0] if len(parts) == 1 else \
            (ir.And if n.kind == "forall" else ir.Or)(tuple(parts), n.span)
        # over `team`: kept for another team too (`stlc.semantics.teamform`)
        return Form(self.team_quant(n, scope, dom, out, tuple(zip(combos, parts)), before))

    def _v_compare(self, n: ast.Compare, scope: Scope) -> Value:
        a, b = self.value(n.left, scope), self.value(n.right, scope)
        pair = self._numeric_pair(a, b, n)
        if pair is None:
            return ERROR
        sa, sb = pair
        items = broadcast(sa, sb)
        if items is None:
            return self.err("STL205", f"cannot compare {len(sa.items)} with {len(sb.items)} "
                            "components", n.span)
        if not all(finite_expr(x) and finite_expr(y) for x, y in items):
            return self._infinite(n.span)
        label = self.text(n.span)
        preds = []
        la, lb = _labels(sa, len(items)), _labels(sb, len(items))
        origin = Origin(COMPARE, label, op=n.op, left=self.text(n.left.span),
                        right=self.text(n.right.span), regions=self._regions_read(n, scope),
                        unit=units.unit_name(units.join(sa.dim, sb.dim)))
        for k, (x, y) in enumerate(items):
            e = sub(x, y) if n.op in (">", ">=") else sub(y, x)
            lab = label if len(items) == 1 else f"{label} [{k + 1}]"
            upper = n.op in ("<", "<=")
            bound = None
            if isinstance(y, ir.Const) and not isinstance(x, ir.Const):
                bound = ir.Bound(la[k], "upper" if upper else "lower", y.value, x,
                                 _ast_calls(n.left))
            elif isinstance(x, ir.Const) and not isinstance(y, ir.Const):
                bound = ir.Bound(lb[k], "lower" if upper else "upper", x.value, y,
                                 _ast_calls(n.right))
            o = origin if len(items) == 1 else dataclasses.replace(origin, component=k + 1)
            preds.append(ir.Pred(e, lab, n.span, bound, o))
        return Form(preds[0] if len(preds) == 1 else ir.And(tuple(preds), n.span))

    def _regions_read(self, n: ast.Node, scope: Scope) -> tuple[str, ...]:
        """The declared regions a comparison reads (``dist(p, target1.center)``), found by
        resolving the paths of its syntax tree (a pure lookup: no diagnostics)."""
        out: list[str] = []
        stack: list[object] = [n]
        while stack:
            x = stack.pop()
            if isinstance(x, tuple):
                stack.extend(x)
            elif isinstance(x, ast.Path):
                v = scope.get(x.parts[0])
                if isinstance(v, HumanV) and len(x.parts) > 1:
                    v = self.human_regions.get(v.human.name, {}).get(x.parts[1])
                if isinstance(v, RegionV) and v.name and v.name not in out:
                    out.append(v.name)
            elif dataclasses.is_dataclass(x) and not isinstance(x, type):
                stack.extend(getattr(x, f.name) for f in dataclasses.fields(x)
                             if f.name != "span")
        return tuple(out)

    def _infinite(self, span: Span) -> ErrorV:
        return self.err("STL207", "a comparison needs finite numbers on both sides", span,
                        "`inf` may only be the upper bound of a time interval; drop a "
                        "comparison with `inf` (it always holds or never does)")

    def _numeric_pair(self, a: Value, b: Value, n) -> tuple[Sym, Sym] | None:
        if isinstance(a, ErrorV) or isinstance(b, ErrorV):
            return None
        for v, node in ((a, n.left), (b, getattr(n, "right", None) or n)):
            if isinstance(v, Form):
                self.err("STL202", "expected a number, found a formula", node.span,
                         "comparisons take numbers or signals on both sides")
                return None
            if not isinstance(v, (Num, Sym)):
                self.err("STL202", f"expected a number, found {kind_name(v)}", node.span)
                return None
        if not units.compatible(a.dim, b.dim):  # type: ignore[union-attr]
            self.err("STL204", f"unit mismatch: comparing {units.describe(a.dim)} with "  # type: ignore
                     f"{units.describe(b.dim)}", n.span,  # type: ignore[union-attr]
                     _unit_hint(b.dim, a.dim))  # type: ignore[union-attr]
            return None
        sa = to_sym(a) if isinstance(a, Num) else a
        sb = to_sym(b) if isinstance(b, Num) else b
        return sa, sb  # type: ignore[return-value]

    def _v_in(self, n: ast.In, scope: Scope) -> Value:
        v = self.value(n.arg, scope)
        if isinstance(v, ErrorV):
            return v
        if isinstance(n.region, ast.Range):
            lo, hi = self.value(n.region.lo, scope), self.value(n.region.hi, scope)
            p1 = self._numeric_pair(v, lo, _Pair(n.arg, n.region.lo, n.span))
            p2 = self._numeric_pair(v, hi, _Pair(n.arg, n.region.hi, n.span))
            if p1 is None or p2 is None:
                return ERROR
            i1, i2 = broadcast(*p1), broadcast(*p2)
            if i1 is None or i2 is None:
                return self.err("STL205", "range and value sizes do not match", n.span)
            if not all(finite_expr(e) for pair in i1 + i2 for e in pair):
                return self._infinite(n.span)
            label = self.text(n.span)
            preds = []
            lv = _labels(v, len(i1)) if isinstance(v, Sym) else [label] * len(i1)
            calls = _ast_calls(n.arg)
            side = Origin(RANGE, label, subject=self.text(n.arg.span),
                          unit=units.unit_name(units.join(p1[0].dim, p1[1].dim)))
            o_lo = dataclasses.replace(side, side="lower", bound_text=self.text(n.region.lo.span))
            o_hi = dataclasses.replace(side, side="upper", bound_text=self.text(n.region.hi.span))
            for k, ((x, lo_e), (_, hi_e)) in enumerate(zip(i1, i2)):
                b_lo = (ir.Bound(lv[k], "lower", lo_e.value, x, calls)
                        if isinstance(lo_e, ir.Const) else None)
                b_hi = (ir.Bound(lv[k], "upper", hi_e.value, x, calls)
                        if isinstance(hi_e, ir.Const) else None)
                preds.append(ir.Pred(sub(x, lo_e), f"{label} (lower)", n.span, b_lo, o_lo))
                preds.append(ir.Pred(sub(hi_e, x), f"{label} (upper)", n.span, b_hi, o_hi))
            f: ir.Formula = ir.And(tuple(preds), n.span)
        else:
            reg = self.value(n.region, scope)
            if isinstance(reg, ErrorV):
                return reg
            if not isinstance(reg, RegionV):
                return self.err("STL208", f"expected a region after `in`, found {kind_name(reg)}",
                                n.region.span, "regions are boxes and round shapes: workspace, "
                                "obstacles, targets, a human's regions, box(lo, hi), "
                                "cylinder(...), sphere(...), capsule(...)")
            if isinstance(v, Num):
                v = to_sym(v)
            if not isinstance(v, Sym) or len(v.items) != 3:
                return self.err("STL205", "only a 3-D position can be in a region",
                                n.arg.span, "e.g. `uav1.pos in workspace`")
            if not units.compatible(v.dim, units.LENGTH):
                return self.err("STL204", "a region holds positions, found "
                                f"{units.describe(v.dim)}", n.arg.span)
            if n.negated:  # `pos not in R` keeps the vehicle's radius: R inflated by it
                reg = inflated(reg, self._radius_of(v.items))
            f = box_membership(v.items, reg, self.text(n.span), n.span,
                               Origin(FACE, self.text(n.span), subject=self.text(n.arg.span),
                                      region=reg.name, region_text=self.text(n.region.span),
                                      regions=(reg.name,) if reg.name else (), unit="m"))
        return Form(ir.Not(f, n.span) if n.negated else f)

    def _radius_of(self, items: tuple[ir.Expr, ...]) -> float:
        """The radius of the vehicle whose position ``items`` are (0 for any other point)."""
        names = {e.name.rpartition(".pos.")[0] for e in items
                 if isinstance(e, ir.Sig) and ".pos." in e.name}
        if len(names) != 1 or len(items) != 3 or not all(isinstance(e, ir.Sig) for e in items):
            return 0.0
        name = names.pop()
        holes = self.__dict__.get("_hole_reads")
        if holes and name in holes:  # a team template's placeholder reads its radius
            holes[name].add("radius")
        v = self.vehicles.get(name)
        return float(getattr(v, "radius", 0.0) or 0.0)

    def _v_range(self, n: ast.Range, scope: Scope) -> Value:
        return self.err("STL208", "a range [lo, hi] may only follow `in`", n.span)

    def _v_interval(self, n: ast.Interval, scope: Scope) -> Value:  # pragma: no cover
        return self.err("STL208", "unexpected interval", n.span)


@dataclass
class _Pair:
    left: ast.Node
    right: ast.Node
    span: Span


# ---------------------------------------------------------------- shared helpers


def _ast_calls(node: object) -> frozenset[str]:
    """Names of the functions called anywhere in an expression's syntax tree."""
    out: set[str] = set()
    stack = [node]
    while stack:
        x = stack.pop()
        if isinstance(x, tuple):
            stack.extend(x)
        elif dataclasses.is_dataclass(x) and not isinstance(x, type):
            if isinstance(x, ast.Call):
                out.add(x.fn)
            stack.extend(getattr(x, f.name) for f in dataclasses.fields(x)
                         if f.name != "span")
    return frozenset(out)


def _labels(v: Sym, n: int) -> list[str]:
    """Component names of a signal value, one per compared component."""
    labels = list(v.labels) or [""]
    return labels if len(labels) == n else [labels[0]] * n


def inflated(reg: RegionV, r: float) -> RegionV:
    """The region grown by ``r`` on every face (in its own frame).  Outside it, a point is
    at least ``r`` from the region along one axis, so its distance is ≥ r; boxes that touch
    overlap by 2r once inflated, so no seam between them is left open."""
    if r <= 0:
        return reg
    b = reg.box
    box = dataclasses.replace(b, lo=tuple(x - r for x in b.lo), hi=tuple(x + r for x in b.hi),
                              shape=b.shape.grown(r) if b.shape is not None else None)
    return dataclasses.replace(reg, box=box)


def box_membership(p: tuple[ir.Expr, ...], reg: RegionV, label: str, span: Span,
                   origin: Origin | None = None) -> ir.Formula:
    """``p in box`` as six predicates, in the human's frame when the box is attached to one;
    each face's ``origin`` (``origin`` with its axis and side) says which face it is.  A
    round region is one predicate, ``−dist(p, R) ≥ 0`` (origin side ``surface``)."""
    box = reg.box
    o = origin or Origin(FACE, label, region=reg.name, regions=(reg.name,) if reg.name else (),
                         unit="m")
    if box.shape is not None:  # a round region: −(signed distance) ≥ 0, one predicate
        sd = distance_expr(p, box, world_to_frame)
        return ir.Pred(neg(sd), label, span, origin=dataclasses.replace(o, side="surface"))
    if box.frame is not None:
        p = world_to_frame(p, box.frame)
    preds = []
    for k, axis in enumerate("xyz"):
        lo, hi = box_faces(box, k)
        preds.append(ir.Pred(sub(p[k], lo), f"{label} ({axis} >= lo)", span,
                             origin=dataclasses.replace(o, axis=axis, side="lo")))
        preds.append(ir.Pred(sub(hi, p[k]), f"{label} ({axis} <= hi)", span,
                             origin=dataclasses.replace(o, axis=axis, side="hi")))
    return ir.And(tuple(preds), span)



def _unit_hint(want, got) -> str | None:
    u = units.example_unit(got)
    return f"write the right-hand side in {u}" if u else None
