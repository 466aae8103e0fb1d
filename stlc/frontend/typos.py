"""Misspelt keywords in a syntax error: ``eventualy[0, 5] (…)`` fails at its ``[``, and the
name before it (or the unexpected name itself) close to a keyword gets a "did you mean"."""

from __future__ import annotations

import difflib
import re

#: the language's keywords a misspelling may have meant (operators and mission clauses)
KEYWORDS = ("always", "eventually", "until", "next", "forall", "exists", "implies", "and",
            "or", "not", "require", "minimize", "maximize", "signal")


def keyword_typo(text: str, line: int, col: int, name: str | None) -> str | None:
    """``eventualy[0, 5] …`` fails at its ``[``: the name just before the unexpected token
    (or the token itself) close to a keyword → "did you mean `eventually`?"."""
    lines = text.splitlines()
    if not 1 <= line <= len(lines):
        return None
