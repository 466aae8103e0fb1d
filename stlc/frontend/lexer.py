"""A Pygments lexer for `.stl` mission files (alias ``stlc``), registered by the entry point
``pygments.lexers: stlc = stlc.frontend.lexer:StlcLexer`` (``pygmentize -l stlc``, Sphinx,
MkDocs), and the per-line HTML of the report's Source section (``highlight_lines``).

Tokens follow ``grammar/stl.lark``: comments, strings, numbers (a unit that follows a
number or a closing bracket is ``Keyword.Type``), keywords (formula operators, member
keywords), declaration kinds at the start of a member, built-in functions, names and
member access, operators and punctuation.  Nothing the grammar accepts is an ``Error``.
"""

from __future__ import annotations

from html import escape

from pygments.lexer import RegexLexer, bygroups, words
from pygments.token import (Comment, Error, Keyword, Name, Number, Operator, Punctuation,
                            String, Whitespace)

FORMULA_WORDS = ("and", "or", "not", "implies", "until", "always", "eventually", "next",
                 "forall", "exists", "in")
MEMBER_WORDS = ("require", "minimize", "maximize", "signal")
DECLARATIONS = ("vehicle", "scenario", "mission", "human", "region", "obstacle", "target",
                "station", "home", "const", "spec", "risk", "case", "replan", "simulate",
                "compare", "disturb", "fail", "move", "start", "rotor")
FUNCTIONS = ("abs", "sqrt", "norm", "dist", "dot", "min", "max", "sin", "cos", "exp", "log",
             "atan2", "angdiff", "box", "cylinder", "sphere", "capsule", "diag", "normal",
             "hexarotor", "quadrotor")
_UNIT = r"[A-Za-z\u00b0\u00b5][A-Za-z\u00b0\u00b5]*(?:\^-?[0-9]+)?" \
        r"(?:[*/][A-Za-z\u00b0\u00b5]+(?:\^-?[0-9]+)?)*"
_NUM = r"(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][+-]?[0-9]+)?"
_NOT_WORD = r"(?!(?:and|or|not|implies|until|in)\b)"


class StlcLexer(RegexLexer):
    """The stlc mission language (`.stl`)."""

    name = "stlc"
    aliases = ["stlc", "stl-mission"]
    filenames = ["*.stl"]
    mimetypes = ["text/x-stlc"]
    url = "https://example.invalid/stlc"

    tokens = {
        "root": [
            (r"[ \t\f\r]+", Whitespace),
            (r"\n", Whitespace),
            (r"#[^\n]*", Comment.Single),
            (r'"[^"\n]*"', String.Double),
            (rf"({_NUM})([ \t]*)({_NOT_WORD}{_UNIT})\b",
             bygroups(Number.Float, Whitespace, Keyword.Type)),
            (_NUM, Number.Float),
            (rf"([)\]])([ \t]*)({_NOT_WORD}{_UNIT})\b",
             bygroups(Punctuation, Whitespace, Keyword.Type)),
            (words(("true", "false", "inf"), suffix=r"\b"), Keyword.Constant),
            (words(FORMULA_WORDS, suffix=r"\b"), Operator.Word),
            (words(MEMBER_WORDS, suffix=r"\b"), Keyword),
            (words(DECLARATIONS, suffix=r"\b(?=[ \t]*[A-Za-z_{])"), Keyword.Declaration),
            (words(FUNCTIONS, suffix=r"\b(?=[ \t]*\()"), Name.Builtin),
            (r"[A-Za-z_][A-Za-z0-9_]*(?=[ \t]*\()", Name.Function),
            (r"(\.)([A-Za-z_][A-Za-z0-9_]*|[0-9]+)", bygroups(Punctuation, Name.Attribute)),
            (r"[A-Za-z_][A-Za-z0-9_]*", Name),
            (r"<=|>=|[<>+\-*/^=~:]", Operator),
            (r"[(){}\[\],;]", Punctuation),
            (r".", Error),
        ],
    }


_CLASSES = {Comment: "cm", String: "st", Number: "nu", Keyword.Type: "un",
            Keyword.Constant: "kc", Operator.Word: "kw", Keyword.Declaration: "kd",
            Keyword: "kw", Name.Builtin: "fn", Name.Function: "fn", Name.Attribute: "at",
            Operator: "op", Error: "err"}


def _cls(tok) -> str:
    while tok is not None:
        if tok in _CLASSES:
            return _CLASSES[tok]
        tok = tok.parent
    return ""


def highlight_lines(text: str) -> list[str]:
    """The HTML of each source line (``<span class="hl-kw">and</span>``, escaped), for the
    report's Source section."""
    lines: list[list[str]] = [[]]
    for tok, value in StlcLexer(stripnl=False).get_tokens(text):
        parts = value.split("\n")
        for i, part in enumerate(parts):
            if i:
                lines.append([])
            if part:
                c = _cls(tok)
                lines[-1].append(f'<span class="hl-{c}">{escape(part)}</span>' if c
                                 else escape(part))
    out = ["".join(x) for x in lines]
    if out and out[-1] == "":  # the lexer ends the text with a line end
        out.pop()
    return out

