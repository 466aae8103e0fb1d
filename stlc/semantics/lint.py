"""Warnings about a checked file (``warning[STLWxx]``): the classic STL slips that parse
and check but rarely mean what they say.  ``stlc check``/``compile`` print them and exit
0; ``--deny-warnings`` makes them errors (exit 1); the report lists them.

* ``STLW01`` — ``always[a,b] p and q``: by the precedence contract the ``and`` is outside
  the ``always`` (``(always[a,b] p) and q``), so ``q`` is checked at t = 0 only.  Reported
  when an unparenthesised ``always``/``eventually`` is the left operand of ``and``/``or``
  and the right operand has no temporal operator (a state condition that was most likely
  meant inside).  Parenthesise either way to silence it.
* ``STLW03`` — a world-frame region (target, station, home, plain region) that does not
  meet the workspace box: no plan inside the workspace reaches it.
* ``STLW04`` — declared and never used: a mission's named spec that neither its
  ``require``, another spec nor its ``replan { keep }`` reads; an obstacle or plain region
  (also a human's region) that no formula mentions (by name or through a quantifier over
  its kind) — an obstacle no formula mentions is not avoided.

* ``STLW05`` — one unitless ``threshold`` κ > 0 over predicates measured in different
  units (m, m/s, rad, Hz): κ = 0.05 asks 5 cm of a position, 0.05 m/s of a speed and 2.9°
  of an angle at once.  Give a margin per unit instead (``margin = [0.05 m, 0.05 m/s,
  1 deg]``, ``stlc.semantics.check.margins``).

``STLW02`` (an implication that holds only vacuously on the plan) needs the plan:
``stlc.analysis.vacuity``.
"""

from __future__ import annotations

from stlc.diagnostics import Diagnostic, Span
from stlc.frontend import ast
from stlc.semantics import model, nnf
from stlc.semantics.check.margins import units_of

_TEMPORAL = (ast.Temporal, ast.Until)
#: quantifier domains and the region kinds they range over
_DOMAINS = {"obstacles": ("obstacle",), "regions": ("region",), "targets": ("target",),
            "stations": ("station",), "homes": ("home",)}


def _walk(n):
    yield n
    for c in ast.node_children(n):
        yield from _walk(c)


def _has_temporal(n) -> bool:
    return any(isinstance(x, _TEMPORAL) for x in _walk(n))


def _formulas(tree: ast.File):
    """(owner, node) for every formula-bearing member: top-level specs, missions' specs and
    requires (owner = the mission block or None)."""
    for m in tree.members:
        if isinstance(m, ast.Named) and m.kind == "spec":
            yield None, m.value
        elif isinstance(m, ast.Block) and m.kind == "mission":
            for x in m.members:
                if isinstance(x, ast.Named) and x.kind == "spec":
                    yield m, x.value
                elif isinstance(x, ast.Require):
                    yield m, x.value


def precedence(tree: ast.File, spec_names: set[str]) -> list[Diagnostic]:
    out = []
    for _, f in _formulas(tree):
        for n in _walk(f):
            if not (isinstance(n, ast.Logic) and n.op in ("and", "or")):
                continue
            left = n.left
            if not isinstance(left, ast.Temporal) or left.op == "next":
                continue
            if (left.span.line, left.span.col) != (n.span.line, n.span.col):
                continue  # `(always[a,b] p) and q`: parenthesised, meant
            right = n.right
            if _has_temporal(right) or any(isinstance(x, ast.Path) and x.parts[0] in spec_names
                                           for x in _walk(right)):
                continue
            out.append(Diagnostic(
                "STLW01", f"`{n.op}` binds looser than `{left.op}`: only the left operand is "
                f"under `{left.op}`, the right one is checked at the start alone",
                n.span, f"write `{left.op}[...] (p {n.op} q)` if both belong under it, or "
                f"`({left.op}[...] p) {n.op} q` to keep this meaning", severity="warning"))
    return out


def _box_meets(a: model.Box, b: model.Box) -> bool:
    return all(a.lo[i] <= b.hi[i] and b.lo[i] <= a.hi[i] for i in range(3))


def unreachable(program: model.Program) -> list[Diagnostic]:
    ws = program.scenario.by_kind("workspace")
    if not ws or ws[0].box.frame is not None:
        return []
    out = []
    for r in program.scenario.regions:
        if r.kind in ("workspace", "obstacle") or r.box.frame is not None:
            continue
        if not _box_meets(r.box, ws[0].box):
            out.append(Diagnostic(
                "STLW03", f"{r.kind} `{r.name}` lies outside the workspace: no plan that "
                "stays in the workspace can reach it", r.span,
                "check its corners (and units) against `workspace`", severity="warning"))
    return out


def _refs(tree: ast.File) -> tuple[set[str], set[tuple[str, str]], set[str]]:
    """Names read by any formula: first parts, (first, second) parts, quantifier domains."""
    first: set[str] = set()
    pairs: set[tuple[str, str]] = set()
    domains: set[str] = set()
    for _, f in _formulas(tree):
        for n in _walk(f):
            if isinstance(n, ast.Path):
                first.add(n.parts[0])
                if len(n.parts) > 1:
                    pairs.add((n.parts[0], n.parts[1]))
            elif isinstance(n, ast.Quant) and isinstance(n.domain, ast.Path):
                domains.add(n.domain.parts[0])
    return first, pairs, domains


def unused(tree: ast.File, program: model.Program) -> list[Diagnostic]:
    out = []
    first, pairs, domains = _refs(tree)
    kinds_used = {k for d in domains for k in _DOMAINS.get(d, ())}
    for r in program.scenario.regions:
        if r.kind not in ("obstacle", "region") or r.kind in kinds_used:
            continue
        if r.box.frame is not None:
            if (r.box.frame, r.name.rpartition(".")[2]) in pairs:
                continue
        elif r.name in first:
            continue
        what = "is not avoided by any plan" if r.kind == "obstacle" else "constrains nothing"
        out.append(Diagnostic("STLW04", f"{r.kind} `{r.name}` is declared but no formula "
                              f"uses it: it {what}", r.span,
                              "use it in a spec, or remove it", severity="warning"))
    for m in tree.members:
        if not (isinstance(m, ast.Block) and m.kind == "mission"):
            continue
        used: set[str] = set()
        for x in m.members:
            if isinstance(x, ast.Require) or (isinstance(x, ast.Named) and x.kind == "spec"):
                used |= {n.parts[0] for n in _walk(x.value) if isinstance(n, ast.Path)}
            elif isinstance(x, ast.Block) and x.kind == "replan":
                used |= {n.parts[0] for f in x.members if isinstance(f, ast.Field)
                         for n in _walk(f.value) if isinstance(n, ast.Path)}
        for x in m.members:
            if isinstance(x, ast.Named) and x.kind == "spec" and x.name not in used:
                out.append(Diagnostic(
                    "STLW04", f"spec `{x.name}` of mission `{m.name}` is never used: the "
                    "plan does not have to satisfy it", x.name_span if x.name_span.line
                    else x.span, f"add it to `require` (e.g. `require ... and {x.name}`), "
                    "or remove it", severity="warning"))
    return out


def mixed_units(tree: ast.File, program: model.Program) -> list[Diagnostic]:
    out = []
    for m in tree.members:
        mis = program.missions.get(m.name) if isinstance(m, ast.Block) and \
            m.kind == "mission" else None
        if mis is None or mis.threshold <= 0 or "margins" in mis.options:
            continue
        used = units_of(nnf.normalize(mis.requirement))
        field = next((x for x in m.members if isinstance(x, ast.Field)
                      and x.name == "threshold"), None)
        if len(used) < 2 or field is None:
            continue
        names = ", ".join(f"{u} ({n})" for u, n in sorted(used.items(), key=lambda x: -x[1]))
        span = Span(field.span.file, field.span.line, field.span.col,
                     field.value.span.end_line, field.value.span.end_col)
        out.append(Diagnostic(
            "STLW05", f"one threshold κ = {mis.threshold:g} is asked of predicates in "
            f"different units: {names} predicate(s)", span,
            "give a margin per unit, e.g. `margin = ["
            + ", ".join(f"{mis.threshold:g} {u}" for u in sorted(used)) + "]`",
            severity="warning"))
    return out


def lint(tree: ast.File, program: model.Program) -> list[Diagnostic]:
    """Every warning about a checked file, in source order."""
    specs = set(program.specs) | {s for m in program.missions.values() for s in m.specs}
    out = precedence(tree, specs) + unreachable(program) + unused(tree, program) + \
        mixed_units(tree, program)
    return sorted(out, key=Diagnostic.sort_key)
