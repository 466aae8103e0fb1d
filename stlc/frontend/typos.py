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
    before = re.search(r"([A-Za-z_]\w*)\s*$", lines[line - 1][:max(col - 1, 0)])
    words = [name] if name else []
    if before:
        words.insert(0, before.group(1))
    for w in words:
        if w in KEYWORDS:
            continue
        near = difflib.get_close_matches(w.lower(), KEYWORDS, n=1, cutoff=0.75)
        if near:
            return f"`{w}` is not a keyword: did you mean `{near[0]}`?"
    return None
