"""Checking the risk levels of a mission's ``risk`` block::

    risk {
      K = 1000; beta = [0.9]
      require cvar(0.9) >= 0.0 m        # the mean robustness of the worst 10 % ≥ 0
      require var(0.8) >= 0.01 m        # robustness ≥ 1 cm with probability 0.8
      require p_violation <= 0.05       # P(ρ ≤ 0) ≤ 5 % (judged by its upper bound)
      case ... { ... }
    }

Each ``require`` is a comparison of one measure with a constant: ``var(β)`` or ``cvar(β)``
(β in (0, 1)) with a length or a plain number (robustness), ``p_violation`` with a
probability.  ``stlc fly --runs`` judges the flown robustness against them.  Part of the
checker (``stlc.semantics.check``); imports only ``context`` and lower layers.
"""

from __future__ import annotations

from stlc.frontend import ast
from stlc.semantics import model
from stlc.semantics.check import units
from stlc.semantics.check.context import Context

MEASURES = ("var", "cvar", "p_violation")
OPS = (">=", ">", "<=", "<")
_HELP = ("write `require cvar(0.9) >= 0 m`, `require var(0.8) >= 0.01 m` or "
         "`require p_violation <= 0.05`")


def with_levels(ck: Context, b: ast.Block, risk: model.RiskConfig | None
                ) -> model.RiskConfig | None:
    """The mission's checked risk block (``mission``) with the levels of its ``risk``
    block ``b`` added."""
    blocks = [m for m in b.members if isinstance(m, ast.Block) and m.kind == "risk"]
    if risk is None or not blocks:
        return risk
    from dataclasses import replace

    return replace(risk, levels=risk_levels(ck, blocks[0]))


def risk_levels(ck: Context, rb: ast.Block) -> tuple[model.RiskLevel, ...]:
    out = []
    for m in rb.members:
        if isinstance(m, ast.Require):
            lv = _level(ck, m)
            if lv is not None:
                out.append(lv)
    return tuple(out)


def _level(ck: Context, m: ast.Require) -> model.RiskLevel | None:
    node = m.value
    if not isinstance(node, ast.Compare) or node.op not in OPS:
        ck.d.error("STL108", "a risk level compares a risk measure with a constant",
                   node.span, _HELP)
        return None
    left = node.left
    if isinstance(left, ast.Path) and left.parts == ("p_violation",):
        p = ck.number(node.right, ck.globals, units.DIMLESS, "a probability")
        if p is None:
            return None
        if not 0.0 <= p <= 1.0:
            ck.d.error("STL207", f"a probability is between 0 and 1, found {p:g}",
                       node.right.span)
            return None
        return model.RiskLevel("p_violation", None, node.op, p, ck.text(m.value.span), m.span)
    if not (isinstance(left, ast.Call) and left.fn in ("var", "cvar") and len(left.args) == 1
            and not left.kwargs):
        ck.d.error("STL108", "a risk level reads `var(β)`, `cvar(β)` or `p_violation`",
                   left.span, _HELP)
        return None
    beta = ck.number(left.args[0], ck.globals, units.DIMLESS, "β")
    if beta is not None and not 0.0 < beta < 1.0:
        ck.d.error("STL207", f"β is strictly between 0 and 1, found {beta:g}",
                   left.args[0].span)
        return None
    bound = ck.number(node.right, ck.globals, None, "a robustness level")
    if beta is None or bound is None:
        return None
    return model.RiskLevel(left.fn, beta, node.op, bound, ck.text(m.value.span), m.span)
