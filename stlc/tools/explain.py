"""``stlc explain STLxxx``: the long explanation of an error code, with a wrong and a fixed
example (as rustc's ``--explain``).  The texts are in ``stlc.tools.explanations``."""

from __future__ import annotations

import sys
import textwrap

from stlc.diagnostics import CODES, did_you_mean
from stlc.tools.explanations import EXPLANATIONS


def normalize(code: str) -> str:
    c = code.strip().upper()
    return f"STL{c}" if c.isdigit() else c


def explain(code: str) -> str | None:
    """The text of ``stlc explain CODE``, or None for an unknown code."""
    code = normalize(code)
    if code not in CODES or code not in EXPLANATIONS:
        return None
    text, wrong, fixed = EXPLANATIONS[code]
    body = textwrap.fill(text, 88)
    wrong, fixed = (textwrap.indent(x.rstrip(), "    ") for x in (wrong, fixed))
    return f"{code}: {CODES[code]}\n\n{body}\n\nWrong:\n\n{wrong}\n\nFixed:\n\n{fixed}\n"


def run(code: str) -> int:
    out = explain(code)
    if out is None:
        hint = did_you_mean(normalize(code), CODES) or "codes: " + ", ".join(CODES)
        print(f"stlc: no error code `{code}`; {hint}", file=sys.stderr)
        return 2
    print(out, end="")
    return 0
