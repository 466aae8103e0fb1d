"""``--set NAME=VALUE``: one instance of a program, changed in its structure, not its text.

Settable names (``settable``):

* a ``const`` (``--set 'T_vr=4 s'``): applied to the *AST* (the declaration's value node is
  replaced) before checking, since the checker inlines constants everywhere (intervals,
  bounds); a const may therefore change the structure of the mission;
* a human's pose field ``H.pos.{x,y,z}`` / ``H.att.{x,y,z}`` (lengths / angles): applied to
  the checked program — ``Program.params`` (what formulas read as ``Param`` leaves), the
  ``Human`` itself (the report draws it) and the mean of every declared ``normal(...)``
  over that field, moved by the same amount (an uncertainty is *about* the nominal pose);
* a vehicle's start ``V.start.pos.{x,y,z}`` (and ``V.start.att.{x,y,z}`` for a multirotor):
  applied to the checked vehicle;
* the placement of a world region ``R.center.{x,y,z}`` (an obstacle, target, station, home
  or `region`; not the workspace, and not a human's region, which moves with its human): the
  box keeps its size and moves to the new centre.  The file is checked again with ``R``
  *placed* — its faces are ``Param`` leaves ``R.center.*`` ∓ the half-size instead of
  constants (``check.values.box_faces``) — so, like a pose, the centre is an NLP parameter
  and one build serves every value.

VALUE is written as in the language, a number with its unit (``30 deg``, ``-0.2 m``; a
const declared without a unit takes a plain number).  Problems are diagnostics: an unknown
name is STL101 with a did-you-mean, a malformed value STL201, a wrong or missing unit
STL204, the same name twice STL102.  Errors point at the declaration the name refers to
(or the file's start) and say ``--set NAME``.
"""

from __future__ import annotations

import math
import re
from dataclasses import replace

from stlc.diagnostics import Diagnostic, Span, StlcError, did_you_mean
from stlc.frontend import ast
from stlc.semantics import model
from stlc.semantics.check import units
from stlc.semantics.instance import Setting, apply_values

_NUMBER = re.compile(r"\s*([-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)\s*(\S.*?)?\s*$")
_POSE = re.compile(r"([A-Za-z_]\w*)\.(pos|att)\.([xyz])$")
_START = re.compile(r"([A-Za-z_]\w*)\.start\.(pos|att)\.([xyz])$")
PLACEABLE = ("obstacle", "region", "target", "station", "home")  # world regions


def split(items: list[str] | tuple[str, ...]) -> list[tuple[str, str]]:
    """``NAME=VALUE`` strings → (name, value text); a missing ``=`` is an error later."""
    return [(a.strip(), b.strip()) if sep else (item.strip(), "")
            for item in items for a, sep, b in [item.partition("=")]]


def _file_span(path: str) -> Span:
    return Span(path, 1, 1, 1, 2)


def _quantity(text: str) -> tuple[float, str | None, units.Dim | None] | str:
    """(value in SI, unit text, dimension) of ``12.5 deg``, or why it is not one."""
    m = _NUMBER.fullmatch(text)
    if not m:
        return f"`{text}` is not a number with a unit (e.g. `30 deg`, `0.2 m`)"
    x = float(m.group(1))
    if not math.isfinite(x):
        return f"`{text}` is not finite"
    unit = m.group(2)
    if not unit:
        return x, None, None
    try:
        scale, dim = units.parse_unit(unit)
    except units.UnitError as e:
        return f"unknown unit in `{text}`: {e}"
    return x * scale, unit, dim


def settable(tree: ast.File, program: model.Program) -> dict[str, tuple[str, Span]]:
    """Every name ``--set`` accepts → (kind, the span of its declaration)."""
    out: dict[str, tuple[str, Span]] = {}
    for m in tree.members:
        if isinstance(m, ast.Named) and m.kind == "const":
            out[m.name] = ("const", m.name_span)
    for h in program.scenario.humans:
        for f in ("pos", "att"):
            for a in "xyz":
                out[f"{h.name}.{f}.{a}"] = ("human", h.span)
    for v in program.vehicles.values():
        for f in ("pos", "att") if hasattr(v, "start_att") else ("pos",):
            for a in "xyz":
                out[f"{v.name}.start.{f}.{a}"] = ("start", v.span)
    for r in program.scenario.regions:
        if r.kind in PLACEABLE and r.box.frame is None:
            for a in "xyz":
                out[f"{r.name}.center.{a}"] = ("region", r.span)
    return out


def resolve(path: str, tree: ast.File, program: model.Program, const_dims: dict,
            items: list[tuple[str, str]]) -> list[Setting]:
    """Check every (name, value text) against the program; raise ``StlcError`` with all
    problems.  ``const_dims``: each const's dimension (None for a plain number)."""
    names = settable(tree, program)
    diags: list[Diagnostic] = []
    out: list[Setting] = []
    seen: set[str] = set()
    for name, text in items:
        kind, span = names.get(name, ("", _file_span(path)))
        where = span if span.known else _file_span(path)
        if not kind:
            hint = did_you_mean(name, names) or ("settable: " + ", ".join(list(names)[:8])
                                                 + (", ..." if len(names) > 8 else "")
                                                 if names else "this file has nothing to set")
            why = ""
            m = _START.match(name) or _POSE.match(name)
            if m and m.group(1) in program.vehicles and m.group(2) == "att":
                why = " (a point mass has no attitude)"
            reg = program.scenario.region(name.split(".")[0])
            if reg is not None and reg.span.known:
                where = reg.span
            if reg is not None and f"{reg.name}.center.x" in names and not name.startswith(
                    f"{reg.name}.center."):
                hint = f"a region is placed by its centre: `{reg.name}.center.x` (.y, .z)"
            elif reg is not None and f"{reg.name}.center.x" not in names:
                why = (" (the workspace is not placeable)" if reg.kind == "workspace" else
                       f" (a region of `{reg.box.frame}` moves with it: set "
                       f"`{reg.box.frame}.pos.x`)" if reg.box.frame else "")
            diags.append(Diagnostic("STL101", f"--set {name}: no constant, human pose field, "
                                    f"vehicle start or region centre called `{name}`{why}",
                                    where, hint))
            continue
        if name in seen:
            diags.append(Diagnostic("STL102", f"--set {name} is given twice", where,
                                    "give each name once"))
            continue
        seen.add(name)
        q = _quantity(text)
        if isinstance(q, str):
            diags.append(Diagnostic("STL201", f"--set {name}: {q}", where,
                                    f"write it as in the language: `--set '{name}=VALUE UNIT'`"))
            continue
        value, unit, dim = q
        want = const_dims.get(name) if kind == "const" else (
            units.ANGLE if ".att." in name and kind != "region" else units.LENGTH)
        if dim != want:
            got = "no unit" if dim is None else units.describe(dim)
            need = "a plain number" if want is None else units.describe(want)
            diags.append(Diagnostic("STL204", f"--set {name}: expected {need}, found {got}",
                                    where, f"e.g. `--set '{name}=1 {units.example_unit(want)}'`"
                                    if want is not None else f"e.g. `--set '{name}=1'`"))
            continue
        out.append(Setting(name, text, value, kind))
    if diags:
        raise StlcError(diags)
    return out


def apply_consts(tree: ast.File, settings: list[Setting]) -> ast.File:
    """The AST with each set const's value node replaced (same spans: diagnostics about
    the new value point at the declaration)."""
    consts = {s.name: s for s in settings if s.kind == "const"}
    if not consts:
        return tree
    members = []
    for m in tree.members:
        s = consts.get(m.name) if isinstance(m, ast.Named) and m.kind == "const" else None
        if s is not None:
            q = _quantity(s.text)
            assert not isinstance(q, str)
            _, unit, _ = q
            num_text = _NUMBER.fullmatch(s.text).group(1)  # type: ignore[union-attr]
            num = ast.Number(float(num_text), num_text, m.value.span)
            m = replace(m, value=ast.Quantity(num, unit, m.value.span) if unit else num)
        members.append(m)
    return replace(tree, members=tuple(members))


def base(tree: ast.File) -> tuple[model.Program, dict]:
    """``tree`` checked as written, and each const's dimension (None for a plain number):
    what every instance's ``--set`` items are resolved against (``checked``).  A sweep's
    worker keeps it between tasks: a pose or a start changes no part of it."""
    from stlc.semantics.check import check
    from stlc.semantics.check.program import Checker
    from stlc.semantics.check.values import Num

    ck = Checker(tree)
    try:
        program = ck.run()
    except RecursionError:
        program = check(tree)  # reports STL004 as ``check`` does
    return program, {n: v.dim for n, v in ck.globals.names.items() if isinstance(v, Num)}


def checked(tree: ast.File, items: list[tuple[str, str]] | None = None,
            checked_base: tuple[model.Program, dict] | None = None
            ) -> tuple[model.Program, dict[str, float]]:
    """Check ``tree`` and apply the ``--set`` items: the instance's checked program and the
    values set (SI, by name).  ``checked_base``: ``base(tree)``, when the caller keeps it
    (a const or a region's placement still checks the file again: they change the AST)."""
    from stlc.semantics.check import check

    if not items:
        return (checked_base[0] if checked_base is not None else check(tree)), {}
    program, dims = checked_base if checked_base is not None else base(tree)
    settings = resolve(tree.path, tree, program, dims, items)
    placed = frozenset(s.name.split(".")[0] for s in settings if s.kind == "region")
    if placed or any(s.kind == "const" for s in settings):
        program = check(apply_consts(tree, settings), placed=placed)
    return apply_values(program, settings), {s.name: s.value for s in settings}
