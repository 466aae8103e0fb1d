"""Hints for names the checker does not know, where a common slip explains them better
than a "did you mean": ``team`` outside a mission, a unit written apart from its number
(``m / s``), a keyword misspelt as a function (``eventualy (…)``)."""

from __future__ import annotations

import difflib

from stlc.semantics.check import units

#: temporal and logical operators a misspelt call may have meant
OPERATORS = ("always", "eventually", "until", "next", "forall", "exists", "implies")


def unknown_name(name: str, in_mission: bool) -> str | None:
    """A hint for an unknown name, or None."""
    if name == "team" and not in_mission:
        return ("`team` is the vehicles of a mission: it is defined only inside "
                "`mission NAME { … }` — declare the spec there, or name the vehicles")
    if name in units.UNITS:
        return (f"`{name}` is a unit: write a unit right after its number, without spaces, "
                f"e.g. `1.5 m/s` or `9.81 m/s^2` (not `m / s`)")
    return None


def unknown_function(name: str) -> str | None:
    """``eventualy (…)`` parses as a call: name the operator it was meant to be."""
    near = difflib.get_close_matches(name.lower(), OPERATORS, n=1, cutoff=0.75)
    if near and name not in OPERATORS:
        return f"`{name}` is not a function: did you mean the operator `{near[0]}`?"
    return None
