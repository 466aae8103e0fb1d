"""The checker of stlc: a parsed file (``stlc.frontend.ast.File``) →
``stlc.semantics.model.Program``.

Layout (imports go one way, downwards; ``tests/test_import_graph.py`` keeps it so):

* ``program``      — ``check``: runs a pass, composes the modules below;
* ``declarations`` — vehicles, scenario, humans, uncertain poses, names for formulas;
* ``mission``      — mission blocks: time grid, team, requirement, objective, risk, replan;
* ``elaborate``    — expressions (constants, units, signal arithmetic, member access);
* ``formulas``     — comparisons, regions, logic, temporal operators, quantifiers;
* ``builtins``     — built-in functions (``norm``, ``box``, ``normal``, ``hexarotor``, ...);
* ``context``      — the shared ``Context`` (diagnostics, scopes, field helpers);
* ``values``, ``units`` — checked values and IR constructors; units and dimensions.
"""

from stlc.semantics import model
from stlc.semantics.check.program import check

__all__ = ["check", "mission_for_team"]


def mission_for_team(program: model.Program, mission: str, team: tuple[str, ...]
                     ) -> model.Mission:
    """The mission ``mission`` of ``program`` checked again with ``team`` as its vehicles
    (the declared ones first, then the added ones in order): its quantifiers over the team
    range over the added vehicles too.  Used to judge the executed trajectory of a
    backup-drone takeover with the mission's own formula."""
    from stlc.frontend.syntax import parse

    declared = program.missions[mission].vehicles
    extra = tuple(v for v in team if v not in declared)
    checked = check(parse(program.source, program.file), {mission: extra})
    return checked.missions[mission]
