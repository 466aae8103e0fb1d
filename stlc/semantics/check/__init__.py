"""The checker of stlc: a parsed file (``stlc.frontend.ast.File``) →
``stlc.semantics.model.Program``.

Layout (imports go one way, downwards; ``tests/test_import_graph.py`` keeps it so):

* ``program``      — ``check``: runs a pass, composes the modules below;
* ``declarations`` — vehicles, scenario, humans, uncertain poses, names for formulas;
* ``mission``      — mission blocks: time grid, team, requirement, objective, risk, replan;
* ``elaborate``    — expressions (constants, units, signal arithmetic, member access);
* ``formulas``     — comparisons, regions, logic, temporal operators, quantifiers;
* ``teams``        — quantifiers over a mission's team, kept (``Mission.team_form``);
* ``builtins``     — built-in functions (``norm``, ``box``, ``normal``, ``hexarotor``, ...);
* ``context``      — the shared ``Context`` (diagnostics, scopes, field helpers);
* ``values``, ``units`` — checked values and IR constructors; units and dimensions.
"""

from stlc.semantics.check.program import check

__all__ = ["check"]
