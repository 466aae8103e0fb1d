"""Parsing: `.stl` source text → ``stlc.frontend.ast.File`` (Lark LALR, one cached parser).

The grammar lives in ``grammar/stl.lark`` (shipped inside the package as
``stlc/grammar/stl.lark``).  A small post-lexer (``stlc.frontend.postlex``) makes the language
line-oriented without making formulas painful.  Syntax errors become diagnostics
(``STL001``–``STL006``); nothing here raises anything but ``StlcError``.
"""

from __future__ import annotations

import functools
import os
from importlib import resources
from pathlib import Path as FsPath

from lark import Lark, Token, Transformer, Tree, v_args
from lark.exceptions import UnexpectedCharacters, UnexpectedEOF, UnexpectedInput, VisitError

from stlc import settings
from stlc.diagnostics import Diagnostic, Span, StlcError, normalize_newlines, source_lines
from stlc.frontend import ast
from stlc.frontend.postlex import MAX_DEPTH, DepthError, PostLex
from stlc.frontend.typos import keyword_typo

MAX_TREE_DEPTH = 200  # parse-tree nesting (`not not …`, `a ^ b ^ …`, long `+` chains)
MAX_LINE = 10_000  # characters per line


def grammar_text() -> str:
    packaged = resources.files("stlc") / "grammar" / "stl.lark"
    if packaged.is_file():
        return packaged.read_text(encoding="utf-8")
    repo = FsPath(__file__).resolve().parents[2] / "grammar" / "stl.lark"
    return repo.read_text(encoding="utf-8")


_POSTLEX = PostLex()


@functools.cache
def _parser() -> Lark:
    """The LALR parser; its tables are kept in the cache directory (lark's own ``cache``:
    checked against the grammar and lark's version, rebuilt when they differ or cannot be
    read; 0.08 s to build, a few ms to load)."""
    d = settings.writable_cache_dir()
    cache = os.path.join(d, "grammar.lark-tables") if d else False
    return Lark(grammar_text(), parser="lalr", lexer="contextual", postlex=_POSTLEX,
                propagate_positions=True, maybe_placeholders=True, cache=cache)


# ---------------------------------------------------------------- parse tree → AST


class _Builder(Transformer):
    def __init__(self, file: str):
        super().__init__()
        self.file = file

    def _span(self, meta) -> Span:
        if getattr(meta, "empty", True):
            return Span.none()
        return Span(self.file, meta.line, meta.column, meta.end_line, meta.end_column)

    def _tok_span(self, tok: Token) -> Span:
        return Span(self.file, tok.line, tok.column, tok.end_line, tok.end_column)

    # members
    @v_args(meta=True)
    def field(self, meta, c):
        return ast.Field(str(c[0]), c[1], self._span(meta), self._tok_span(c[0]))

    @v_args(meta=True)
    def named(self, meta, c):
        return ast.Named(str(c[0]), str(c[1]), c[2], self._span(meta), self._tok_span(c[1]))

    @v_args(meta=True)
    def typed_block(self, meta, c):
        return ast.Block(str(c[0]), str(c[1]), str(c[2]), c[3], self._span(meta),
                         self._tok_span(c[1]))

    @v_args(meta=True)
    def named_block(self, meta, c):
        return ast.Block(str(c[0]), str(c[1]), None, c[2], self._span(meta), self._tok_span(c[1]))

    @v_args(meta=True)
    def anon_block(self, meta, c):
        return ast.Block(str(c[0]), None, None, c[1], self._span(meta), self._tok_span(c[0]))

    def block(self, c):
        return tuple(c)

    @v_args(meta=True)
    def require(self, meta, c):
        return ast.Require(c[0], self._span(meta))

    @v_args(meta=True)
    def minimize(self, meta, c):
        return ast.Objective("minimize", c[0], self._span(meta))

    @v_args(meta=True)
    def maximize(self, meta, c):
        return ast.Objective("maximize", c[0], self._span(meta))

    @v_args(meta=True)
    def signals(self, meta, c):
        return ast.Signals(tuple(str(t) for t in c), self._span(meta))

    @v_args(meta=True)
    def uncertain(self, meta, c):
        return ast.Uncertain(c[0], c[1], self._span(meta))

    @v_args(meta=True)
    def list(self, meta, c):
        return ast.List(tuple(x for x in c if x is not None), self._span(meta))

    # formulas
    @v_args(meta=True)
    def implies(self, meta, c):
        return ast.Logic("implies", c[0], c[1], self._span(meta))

    @v_args(meta=True)
    def or_(self, meta, c):
        return ast.Logic("or", c[0], c[1], self._span(meta))

    @v_args(meta=True)
    def and_(self, meta, c):
        return ast.Logic("and", c[0], c[1], self._span(meta))

    @v_args(meta=True)
    def until(self, meta, c):
        return ast.Until(c[1], c[0], c[2], self._span(meta))

    @v_args(meta=True)
    def not_(self, meta, c):
        return ast.Not(c[0], self._span(meta))

    @v_args(meta=True)
    def always(self, meta, c):
        return ast.Temporal("always", c[0], c[1], self._span(meta))

    @v_args(meta=True)
    def eventually(self, meta, c):
        return ast.Temporal("eventually", c[0], c[1], self._span(meta))

    @v_args(meta=True)
    def next_(self, meta, c):
        return ast.Temporal("next", None, c[0], self._span(meta))

    def _quant(self, kind, meta, c):
        names = tuple(str(t) for t in c[:-2])
        return ast.Quant(kind, names, c[-2], c[-1], self._span(meta))

    @v_args(meta=True)
    def forall(self, meta, c):
        return self._quant("forall", meta, c)

    @v_args(meta=True)
    def exists(self, meta, c):
        return self._quant("exists", meta, c)

    @v_args(meta=True)
    def interval(self, meta, c):
        return ast.Interval(c[0], c[1], self._span(meta))

    @v_args(meta=True)
    def compare(self, meta, c):
        return ast.Compare(str(c[1]), c[0], c[2], self._span(meta))

    @v_args(meta=True)
    def in_(self, meta, c):
        return ast.In(c[0], c[1], False, self._span(meta))

    @v_args(meta=True)
    def not_in(self, meta, c):
        return ast.In(c[0], c[1], True, self._span(meta))

    @v_args(meta=True)
    def range(self, meta, c):
        return ast.Range(c[0], c[1], self._span(meta))

    def _bin(op):  # noqa: N805 - factory used in the class body
        @v_args(meta=True)
        def f(self, meta, c):
            return ast.Binary(op, c[0], c[1], self._span(meta))

        return f

    add, sub, mul, div, pow = _bin("+"), _bin("-"), _bin("*"), _bin("/"), _bin("^")

    @v_args(meta=True)
    def neg(self, meta, c):
        return ast.Unary("-", c[0], self._span(meta))

    @v_args(meta=True)
    def pos(self, meta, c):
        return ast.Unary("+", c[0], self._span(meta))

    @v_args(meta=True)
    def quantity(self, meta, c):
        return ast.Quantity(c[0], str(c[1]), self._span(meta))

    @v_args(meta=True)
    def number(self, meta, c):
        return ast.Number(float(c[0]), str(c[0]), self._span(meta))

    @v_args(meta=True)
    def path(self, meta, c):
        return ast.Path(tuple(str(t) for t in c), self._span(meta))

    @v_args(meta=True)
    def call(self, meta, c):
        args, kwargs = [], []
        for a in c[1:]:
            if a is None:
                continue
            if isinstance(a, tuple) and len(a) == 2 and isinstance(a[0], str):
                kwargs.append(a)
            else:
                args.append(a)
        return ast.Call(str(c[0]), tuple(args), tuple(kwargs), self._span(meta))

    def kwarg(self, c):
        return (str(c[0]), c[1])

    @v_args(meta=True)
    def tuple(self, meta, c):
        return ast.Tuple(tuple(x for x in c if x is not None), self._span(meta))

    @v_args(meta=True)
    def true(self, meta, c):
        return ast.Bool(True, self._span(meta))

    @v_args(meta=True)
    def false(self, meta, c):
        return ast.Bool(False, self._span(meta))

    @v_args(meta=True)
    def string(self, meta, c):
        return ast.String(str(c[0])[1:-1], self._span(meta))

    def start(self, c):
        return tuple(c)


# ---------------------------------------------------------------- errors

_TOKEN_NAMES = {
    "_NL": "end of line", "$END": "end of file", "LPAR": "`(`", "RPAR": "`)`", "LSQB": "`[`",
    "RSQB": "`]`", "LBRACE": "`{`", "RBRACE": "`}`", "COMMA": "`,`", "COLON": "`:`",
    "EQUAL": "`=`", "TILDE": "`~`", "PLUS": "`+`", "MINUS": "`-`", "STAR": "`*`",
    "SLASH": "`/`", "CIRCUMFLEX": "`^`", "DOT": "`.`", "CMP": "a comparison", "NAME": "a name",
    "NUMBER": "a number", "INT": "an integer", "UNIT": "a unit", "STRING": "a string",
}


def _describe(term: str) -> str:
    if term in _TOKEN_NAMES:
        return _TOKEN_NAMES[term]
    return f"`{term.lower()}`"


def _token_text(tok: Token) -> str:
    if tok.type == "_NL":
        return "end of line"
    if tok.type == "$END":
        return "end of file"
    text = str(tok)
    return f"`{text[:30]}`"


def _syntax_diag(e: UnexpectedInput, file: str, text: str) -> Diagnostic:
    line = getattr(e, "line", 1) or 1
    col = getattr(e, "column", 1) or 1
    if line < 1:
        line = max(1, text.count("\n") + 1)
        col = 1
    if isinstance(e, UnexpectedCharacters):
        ch = text[e.pos_in_stream] if 0 <= e.pos_in_stream < len(text) else "?"
        shown = ch if ch.isprintable() else f"\\x{ord(ch):02x}" if ord(ch) < 256 else repr(ch)
        help_ = "units follow a number directly, e.g. `2.25 kg`, `0.4 m/s`"
        if ch in "=!&|":
            help_ = ("write `and`, `or`, `not`; comparisons are `<`, `<=`, `>`, `>=`")
        return Diagnostic("STL001", f"unexpected character `{shown}`",
                          Span(file, line, col, line, col + 1), help_)
    tok = getattr(e, "token", None)
    expected = sorted({_describe(t) for t in (getattr(e, "expected", None) or ())})
    exp = ", ".join(expected[:8]) + (", …" if len(expected) > 8 else "")
    help_ = f"expected {exp}" if exp else None
    if isinstance(e, UnexpectedEOF) or (tok is not None and tok.type == "$END"):
        return _eof_diag(file, text, help_)
    if tok is not None and getattr(tok, "line", None):
        line, col = tok.line, tok.column
        width = max(1, len(str(tok))) if tok.type != "_NL" else 1
        span = Span(file, line, col, line, col + width)
    else:
        span = Span(file, line, col, line, col + 1)
    what = _token_text(tok) if tok is not None else "input"
    if tok is not None and tok.type == "_NL":
        msg = "unexpected end of line"
        help_ = (help_ + "; " if help_ else "") + "a line ends a declaration; wrap long formulas " \
            "in parentheses or end the line with an operator"
    else:
        msg = f"unexpected {what}"
    typo = keyword_typo(text, line, col,
                        str(tok) if tok is not None and tok.type == "NAME" else None)
    if typo:
        help_ = typo
    return Diagnostic("STL002", msg, span, help_)


def _eof_diag(file: str, text: str, expected: str | None) -> Diagnostic:
    """The file ends inside a member: point just after its last token (a line that exists),
    and name the bracket or brace that is still open."""
    last = _POSTLEX.last
    if last is not None and last.end_line:
        line, col = last.end_line, last.end_column
    else:
        lines = source_lines(text) or [""]
        line = max((i for i, s in enumerate(lines, 1) if s.strip()), default=1)
        col = len(lines[line - 1].rstrip()) + 1
    help_ = expected
    if _POSTLEX.open:
        o = _POSTLEX.open[-1]
        close = {"LBRACE": "}", "LPAR": ")", "LSQB": "]"}[o.type]
        help_ = (f"the `{o}` on line {o.line}, column {o.column} is never closed; "
                 f"add `{close}`")
    return Diagnostic("STL003", "unexpected end of file", Span(file, line, col, line, col + 1),
                      help_ or "a block or bracket is not closed")


_MEMBERS = {"field", "named", "typed_block", "named_block", "anon_block", "require", "minimize",
            "maximize", "signals", "uncertain"}


def _deepest_member(tree) -> Token | Tree | None:
    """The innermost member around the most deeply nested node of a parse tree (iteratively:
    it is called when recursion has already failed)."""
    best, best_depth = None, -1
    stack = [(tree, 0, None)]
    while stack:
        node, d, member = stack.pop()
        if not isinstance(node, Tree):
            continue
        if node.data in _MEMBERS:
            member = node
        if d > best_depth and member is not None:
            best, best_depth = member, d
        stack.extend((c, d + 1, member) for c in node.children)
    return best


def _tree_depth(tree) -> int:
    """Depth of a parse tree (iteratively)."""
    best, stack = 0, [(tree, 1)]
    while stack:
        node, d = stack.pop()
        if isinstance(node, Tree):
            best = max(best, d)
            stack.extend((c, d + 1) for c in node.children)
    return best


def _too_deep(file: str, tree) -> Diagnostic:
    member = _deepest_member(tree) if tree is not None else None
    meta = getattr(member, "meta", None)
    if meta is not None and not getattr(meta, "empty", True):
        span = Span(file, meta.line, meta.column, meta.line,
                    meta.end_column if meta.end_line == meta.line else meta.column + 1)
    elif _POSTLEX.last is not None:  # parsing itself gave up: where it was
        t = _POSTLEX.last
        span = Span(file, t.line, t.column, t.line, t.column + 1)
    else:
        span = Span(file, 1, 1, 1, 2)
    return Diagnostic("STL004", "formula nested too deeply", span,
                      "name sub-formulas with `spec` instead")


# ---------------------------------------------------------------- entry points


def decode(data: bytes, file: str) -> str:
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as e:
        line = data[: e.start].count(b"\n") + 1
        col = e.start - (data.rfind(b"\n", 0, e.start) + 1) + 1
        raise StlcError([Diagnostic("STL005", "file is not valid UTF-8 text",
                                    Span(file, line, col, line, col + 1),
                                    "save the mission file as UTF-8")]) from None
    return text.removeprefix("\ufeff")


def parse(text: str, file: str = "<input>") -> ast.File:
    """Parse source text into an AST or raise ``StlcError`` with diagnostics.

    Line ends are ``\\n``, ``\\r\\n`` or a lone ``\\r`` (``diagnostics.source_lines``, which the
    renderer uses too); the text is normalised to ``\\n`` first, which keeps every column."""
    text = normalize_newlines(text)
    for i, line in enumerate(source_lines(text), 1):
        if len(line) > MAX_LINE:
            raise StlcError([Diagnostic(
                "STL006", f"line is {len(line)} characters long (limit {MAX_LINE})",
                Span(file, i, MAX_LINE + 1, i, MAX_LINE + 2),
                "split the line; newlines are allowed inside brackets and after operators")])
    tree = None
    try:
        parser = _parser()
        _POSTLEX.text = text
        tree = parser.parse(text)
        if _tree_depth(tree) > MAX_TREE_DEPTH:  # an explicit limit, not the recursion limit
            raise StlcError([_too_deep(file, tree)])
        members = _Builder(file).transform(tree)
    except DepthError as e:
        t = e.token
        raise StlcError([Diagnostic("STL004", f"brackets nested more than {MAX_DEPTH} deep",
                                    Span(file, t.line, t.column, t.line, t.column + 1),
                                    "name sub-formulas with `spec` instead")]) from None
    except UnexpectedInput as e:
        raise StlcError([_syntax_diag(e, file, text)]) from None
    except RecursionError:
        raise StlcError([_too_deep(file, tree)]) from None
    except VisitError as e:  # Lark wraps what the transformer raises (a RecursionError)
        if isinstance(e.orig_exc, RecursionError):
            raise StlcError([_too_deep(file, tree)]) from None
        raise
    return ast.File(members, file, text)


def parse_file(path: str) -> ast.File:
    from stlc.limits import MAX_SOURCE_BYTES, read_limited

    data = read_limited(path, MAX_SOURCE_BYTES, "file",
                        "check the path; it must be a readable .stl file")
    return parse(decode(data, path), path)
