"""Readable predicate labels, and what the report learns from a mission's predicates.

The monitor names a binding predicate by its source text plus the face it binds on, with
the negations of the normal form spelled out: ``not (uav1.pos not in operator.behind (y <=
hi))`` is the face constraint of being *outside* ``operator.behind`` past its ``y = hi``
face.  The predicate under the ``not`` is the membership face ``y <= hi`` (box membership
is six face predicates, each labelled with the source text ``uav1.pos not in
operator.behind``), and the normal form pushed the negation of ``not in`` down onto it.
``readable`` turns such labels into ``uav1.pos outside operator.behind (y > hi)`` without
changing what they mean; the raw label stays in the view for the tooltip.
"""

from __future__ import annotations

import re

from stlc.planning.bounds import stated_bounds
from stlc.semantics import ir

#: ``<point> in|not in <region> (<axis> <=|>= lo|hi)``: a face of a box membership
_FACE = re.compile(r"^(?P<p>.+?) (?P<neg>not in|in) (?P<r>[^\s()\[\]]+) "
                   r"\((?P<axis>[xyz]) (?P<op><=|>=) (?P<side>lo|hi)\)$", re.S)
#: ``<expr> in|not in [<lo>, <hi>] (lower|upper)``: one side of a range
_RANGE = re.compile(r"^(?P<x>.+?) (?P<neg>not in|in) \[(?P<body>.*)\] \((?P<side>lower|upper)\)$",
                    re.S)
_FLIP = {"<=": ">", ">=": "<", "<": ">=", ">": "<=", "==": "!=", "!=": "=="}
_PRETTY = (("<=", "≤"), (">=", "≥"), ("!=", "≠"))


def _balanced(s: str) -> bool:
    depth = 0
    for ch in s:
        depth += (ch == "(") - (ch == ")")
        if depth < 0:
            return False
    return depth == 0


def _strip_not(label: str) -> tuple[str, int]:
    """Remove enclosing ``not ( … )`` layers; returns (inner text, number removed)."""
    s, n = label.strip(), 0
    while s.startswith("not (") and s.endswith(")") and _balanced(s[5:-1]):
        s, n = s[5:-1].strip(), n + 1
    return s, n


def _top_level(s: str, sep: str) -> list[int]:
    """Offsets of ``sep`` in ``s`` outside any brackets."""
    out, depth = [], 0
    for i, ch in enumerate(s):
        if ch in "([":
            depth += 1
        elif ch in ")]":
            depth -= 1
        elif depth == 0 and s.startswith(sep, i):
            out.append(i)
    return out


def _pretty(s: str) -> str:
    for a, b in _PRETTY:
        s = s.replace(f" {a} ", f" {b} ")
    return s


def readable(label: str) -> str:
    """A friendlier rendering of a monitor predicate label (same meaning)."""
    if not label:
        return "—"
    core, nots = _strip_not(label)
    negated = nots % 2 == 1
    m = _FACE.match(core)
    if m:
        inside = not negated  # the face predicate is membership; `not in` is source text
        op = m["op"] if inside else _FLIP[m["op"]]
        where = "in" if inside else "outside"
        return _pretty(f"{m['p']} {where} {m['r']} ({m['axis']} {op} {m['side']})")
    m = _RANGE.match(core)
    if m:
        cuts = _top_level(m["body"], ",")
        if len(cuts) == 1:
            lo, hi = m["body"][:cuts[0]].strip(), m["body"][cuts[0] + 1:].strip()
            inside = not negated
            lower = m["side"] == "lower"
            op = (">=" if lower else "<=") if inside else ("<" if lower else ">")
            return _pretty(f"{m['x']} {op} {lo if lower else hi}")
    if negated:
        ops = [(i, op) for op in ("<=", ">=", "==", "!=", "<", ">")
               for i in _top_level(core, f" {op} ")]
        if len(ops) == 1:
            i, op = ops[0]
            core = f"{core[:i]} {_FLIP[op]} {core[i + len(op) + 2:]}"
        else:
            return _pretty(f"not ({core})")
    return _pretty(core)


def hover_speed(formula: ir.Formula | None) -> float | None:
    """The ``horizontal_speed <= c`` of a heading requirement (below it the vehicle counts
    as hovering and its direction of motion is undefined), if the mission states one."""
    if formula is None:
        return None
    return stated_bounds(formula).get("hover_speed")


def mentioned(formulas: list[ir.Formula], names: list[str]) -> set[str]:
    """The names (regions, …) that appear as whole words in some predicate label."""
    text = "\n".join(p.label for f in formulas for p in ir.predicates(f))
    return {n for n in names
            if re.search(rf"(?<![\w.]){re.escape(n)}(?![\w])", text)}
