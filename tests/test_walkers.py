"""Every IR walker knows every node it may meet and raises on anything else (issue 18): a
new operator cannot be skipped silently.  Each walker is run on one instance of every node
type it accepts (its completeness) and on a foreign object (it raises)."""

from __future__ import annotations

import numpy as np
import pytest

from stlc.backends.nlp import choices
from stlc.backends.nlp import windows as smooth_windows
from stlc.backends.nlp.expr import LoweringError
from stlc.semantics import ir
from stlc.semantics.check.context import misaligned_intervals
from stlc.semantics.timegrid import TimeGrid

def _sample() -> ir.Formula:
    """One formula holding every node type of the IR."""
    from stlc.semantics.ir import (Always, And, Eventually, FalseF, Implies, Next, Not, Or,
                                   Release, TrueF, Until)

    p = _leaf()
    return And((Or((Not(p), Implies(p, TrueF()))), Always(0.0, 1.0, Next(p)),
                Eventually(0.0, 1.0, FalseF()), Until(0.0, 1.0, p, p),
                Release(0.0, 1.0, p, p)))


def _leaf() -> ir.Pred:
    return ir.Pred(ir.Sig("x"), "x >= 0")


class Foreign:
    """Not an IR node (a future operator nobody taught the walker)."""


def test_the_sample_holds_every_node_type():
    assert {type(g) for g in ir.nodes(_sample())} == set(ir.FORMULA_NODES)


@pytest.mark.parametrize("node", ir.FORMULA_NODES, ids=lambda c: c.__name__)
def test_map_children_and_children_know_every_node(node):
    g = next(x for x in ir.nodes(_sample()) if type(x) is node)
    assert ir.map_children(g, lambda c: c) == g
    assert len(ir.children(g)) >= 0


def test_walkers_raise_on_a_foreign_node():
    grid = TimeGrid.from_horizon(1.0, 0.5)
    with pytest.raises(TypeError):
        ir.map_children(Foreign(), lambda c: c)
    with pytest.raises(TypeError):
        ir.children(Foreign())
    with pytest.raises(TypeError):
        list(misaligned_intervals(ir.And((Foreign(),)), 0.5))
    with pytest.raises(LoweringError):
        smooth_windows.child_needs(Foreign(), np.array([0]), grid)

    class Ev:
        n = 3

    with pytest.raises(TypeError):
        choices._walk(Foreign(), np.array([0]), Ev(), {}, {})


def test_child_needs_knows_every_nnf_node():
    grid = TimeGrid.from_horizon(1.0, 0.5)
    for g in ir.nodes(_sample()):
        if isinstance(g, ir.NNF_NODES):
            smooth_windows.child_needs(g, np.array([0, 1]), grid)  # no TypeError


def test_windowed_nodes_are_one_list():
    assert set(ir.WINDOWED) == {ir.Always, ir.Eventually, ir.Until, ir.Release}
    assert all(hasattr(c, "__dataclass_fields__") and {"lo", "hi"} <= set(
        c.__dataclass_fields__) for c in ir.WINDOWED)
    others = set(ir.FORMULA_NODES) - set(ir.WINDOWED)
    assert not any({"lo", "hi"} <= set(c.__dataclass_fields__) for c in others)
