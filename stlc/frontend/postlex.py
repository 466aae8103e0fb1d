"""The post-lexer of the parser (``stlc.frontend.syntax``): line handling between the lexer and the
LALR parser.

It makes the language line-oriented without making formulas painful: it drops line ends
inside brackets, after binary operators and before continuation keywords, collapses blank
lines, and inserts the line ends that a closing ``}`` or the end of the file imply (not
after a trailing ``{`` or operator: that file ends too early).  Brackets nested deeper than
``MAX_DEPTH`` raise ``DepthError`` (the parser turns it into a diagnostic).
"""

from __future__ import annotations

import re

from lark import Token

MAX_DEPTH = 100  # bracket nesting

# possessive (no backtracking): a run of `#` characters can be split into comments in
# exponentially many ways, and the old `(?:\s|#[^\n]*)*` tried them all
CONTINUE_BEFORE = re.compile(r"(?:\s++|#[^\n]*+)*+(?:and|or|implies|until)\b")
CONTINUE_AFTER = {"AND", "OR", "IMPLIES", "UNTIL", "NOT", "ALWAYS", "EVENTUALLY", "NEXT",
                  "EQUAL", "COMMA", "COLON", "TILDE", "PLUS", "MINUS", "STAR", "SLASH",
                  "CIRCUMFLEX", "CMP", "IN", "LBRACE", "REQUIRE", "MINIMIZE", "MAXIMIZE"}
OPEN = {"LPAR", "LSQB"}
CLOSE = {"RPAR", "RSQB"}


class DepthError(Exception):
    """Brackets nested deeper than ``MAX_DEPTH`` (at ``token``)."""

    def __init__(self, token: Token):
        self.token = token


class PostLex:
    """Line handling between the lexer and the LALR parser (see the module docstring)."""

    always_accept = ("_NL", "RBRACE")

    def __init__(self) -> None:
        self.text = ""  # the source being parsed, for looking past a line end
        self.last: Token | None = None  # the last real token, for errors at the end of file
        self.open: list[Token] = []  # brackets and braces not closed yet, innermost last

    def _continues(self, nl: Token) -> bool:
        """Does the next line start with `and`, `or`, `implies` or `until`?"""
        return CONTINUE_BEFORE.match(self.text, nl.end_pos or 0) is not None

    def process(self, stream):
        depth = 0
        prev: Token | None = None
        self.last, self.open = None, []

        def nl_like(tok: Token) -> Token:
            return Token.new_borrow_pos("_NL", "\n", tok)

        for tok in stream:
            if tok.type == "_NL":
                if depth > 0 or prev is None or prev.type == "_NL":
                    continue
                if prev.type in CONTINUE_AFTER or self._continues(tok):
                    continue
                yield tok
                prev = tok
                continue
            self.last = tok
            if tok.type == "RBRACE":
                if prev is not None and prev.type not in ("_NL", "LBRACE"):
                    yield nl_like(tok)
                if self.open and self.open[-1].type == "LBRACE":
                    self.open.pop()
                yield tok
                # A `}` ends its member at once: the contextual lexer reads the next token in
                # the parser state after this line end, where a name may start a member
                # (`a { } b { }`).  A real line end that follows is then dropped above.
                prev = nl_like(tok)
                yield prev
                continue
            if tok.type == "LBRACE":
                self.open.append(tok)
            elif tok.type in OPEN:
                self.open.append(tok)
                depth += 1
                if depth > MAX_DEPTH:
                    raise DepthError(tok)
            elif tok.type in CLOSE:
                depth = max(0, depth - 1)
                if self.open and self.open[-1].type in OPEN:
                    self.open.pop()
            yield tok
            prev = tok
        # the end of the file ends the last line, unless that line asks for more (a trailing
        # `{`, `,` or operator): then the parser reports an unexpected end of file
        if prev is not None and prev.type != "_NL" and prev.type not in CONTINUE_AFTER:
            yield Token.new_borrow_pos("_NL", "\n", prev)
