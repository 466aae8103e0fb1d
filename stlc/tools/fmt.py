"""``stlc fmt``: the canonical layout of a `.stl` file, comments kept.

Layout: two spaces per block level; one member per line, except members the source wrote
on one line (``start { pos = ...; att = ... }``, ``K = 15000; delta = 0.01``), which stay
joined with ``; `` while they fit; the ``=`` of a run of adjacent fields (or of
declarations of one kind: ``const``, ``region``, ...) aligned; trailing comments of
adjacent lines aligned; at most one blank line where the source had blank lines;
formulas with the fewest parentheses the grammar needs (the user's own parentheses around
a formula are kept) and broken at the loosest operator past 100 columns
(``stlc.tools.layout``).

Comments are captured with Lark's lexer callbacks (``lexer_callbacks={"COMMENT": ...}``, as
miniwdl does).  A comment on a line of its own stays there (at the block's indentation); a
comment after code stays at the end of the line that holds the code it followed.

The result is checked before anything is written: it must parse to the same AST as the
input (else an internal error, and the file is not touched).  Files are replaced
atomically (``stlc.tools.fmt_command``: a temporary file in the same folder, then
``os.replace``).
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

from lark import Lark

from stlc.diagnostics import StlcError, normalize_newlines
from stlc.frontend import ast
from stlc.frontend.postlex import PostLex
from stlc.frontend.syntax import grammar_text, parse
from stlc.tools.layout import IMPLIES, LIMIT, Printer, leaves_in_order, strip, width


@dataclass
class Comment:
    pos: int
    line: int
    text: str


@functools.cache
def _comment_parser() -> tuple[Lark, list]:
    found: list = []
    parser = Lark(grammar_text(), parser="lalr", lexer="contextual", postlex=PostLex(),
                  propagate_positions=True, maybe_placeholders=True,
                  lexer_callbacks={"COMMENT": found.append})
    return parser, found


def parse_with_comments(text: str, file: str = "<stdin>") -> tuple[ast.File, list[Comment]]:
    """The AST and every comment of ``text`` in one parse (Lark lexer callback); raises
    ``StlcError`` as ``stlc.frontend.syntax.parse`` does."""
    from stlc.frontend import syntax

    text = normalize_newlines(text.removeprefix("\ufeff"))
    parser, found = _comment_parser()
    found.clear()
    parser.options.postlex.text = text
    try:
        tree = parser.parse(text)
        if syntax._tree_depth(tree) > syntax.MAX_TREE_DEPTH or \
                any(len(x) > syntax.MAX_LINE for x in text.split("\n")):
            raise ValueError("limits")
        members = syntax._Builder(file).transform(tree)
    except Exception:  # noqa: BLE001 - the parser of the compiler says what is wrong
        found.clear()
        parse(text, file)  # raises the diagnostic
        raise
    comments = [Comment(t.start_pos, t.line, str(t).rstrip()) for t in found]
    found.clear()
    return ast.File(members, file, text), comments


def comments_of(text: str) -> list[Comment]:
    """Every comment of a source that parses, in order."""
    return parse_with_comments(text)[1]


class FormatError(Exception):
    """The formatted text would not mean the same as the input (a bug in the formatter)."""


def format_text(text: str, file: str = "<stdin>") -> str:
    """The canonical layout of ``text``; raises ``StlcError`` when it does not parse."""
    text = normalize_newlines(text.removeprefix("\ufeff"))
    tree, comments = parse_with_comments(text, file)
    out = _Formatter(text, comments).file(tree.members)
    for _ in range(ROUNDS):  # the layout of the layout: a fixed point (idempotence)
        again, kept = parse_with_comments(out, file)
        if again.members != tree.members:
            raise FormatError(f"{file}: formatting would change the program (a bug in "
                              "stlc fmt)")
        if _words(kept) != _words(comments):
            raise FormatError(f"{file}: formatting would lose a comment (a bug in stlc fmt)")
        nxt = _Formatter(out, kept).file(again.members)
        if nxt == out:
            break
        out = nxt
    return out


#: a layout decision can depend on the input's line breaks (members the source joined with
#: `;` are not aligned; one that no longer fits is split off, and is aligned next time):
#: ``format_text`` formats its own output again until nothing changes, at most this often
ROUNDS = 3


def _words(cs: list[Comment]) -> list[str]:
    return " ".join(c.text for c in cs).split()


class _Formatter:
    def __init__(self, text: str, comments: list[Comment]):
        self.text = text
        self.comments = comments
        self.p = Printer(text)
        self.masked = _mask(text, comments)

    def pos(self, line: int, col: int) -> int:
        return self.p.pos(line, col)

    def own_line(self, c: Comment) -> bool:
        """The comment stands on a line of its own in the source."""
        return not self.masked[self.text.rfind("\n", 0, c.pos) + 1:c.pos].strip()

    def line_of(self, pos: int) -> int:
        return self.text.count("\n", 0, pos) + 1

    def code_end(self, m) -> int:
        """Just after the last character of the member's code (not its `;` or comment)."""
        sp = m.span
        i = self.pos(sp.end_line, sp.end_col) if sp.end_line <= len(self.p.starts) \
            else len(self.text)
        i = min(i, len(self.text))
        if isinstance(m, ast.Block):
            return i
        while i > 0 and self.masked[i - 1] in " \t\f\r\n;":
            i -= 1
        return i

    # ------------------------------------------------------------ a list of members
    def file(self, members) -> str:
        rows = self.members(members, 0, 0, len(self.text), None)
        while rows and rows[0] is None:
            rows.pop(0)
        return _render(rows)

    def members(self, members, depth: int, lo: int, hi: int, head_line: int | None) -> list:
        """Rows for the members between text positions lo and hi: each row is
        ``[indent, code, [comments], align_key]`` or None for a blank line."""
        ind = "  " * depth
        spans = [(self.pos(m.span.line, m.span.col), self.code_end(m)) for m in members]
        cs = [c for c in self.comments if lo <= c.pos < hi]
        rows: list = []
        head_comments = []
        prev_end_line = None  # source line where the previous item ended
        prev_member_row = None
        ci = 0
        pad = self._pads(members, spans, cs)
        for k, m in enumerate(members):
            s, e = spans[k]
            while ci < len(cs) and cs[ci].pos < s:  # comments before this member
                c = cs[ci]
                ci += 1
                if head_line is not None and c.line == head_line and not rows:
                    head_comments.append(c.text)
                    continue
                if prev_end_line is not None and c.line == prev_end_line and rows \
                        and rows[-1] is not None:
                    rows[-1][2].append(c.text)
                    continue
                if prev_end_line is not None and c.line - prev_end_line > 1 and rows:
                    rows.append(None)
                rows.append([ind, "", [c.text], None])
                prev_end_line, prev_member_row = c.line, None
            inner = [c for c in cs if s <= c.pos < e]
            ci += len(inner)
            start_line = self.line_of(s)
            if prev_end_line is not None and start_line - prev_end_line > 1 and rows:
                rows.append(None)
            new = self.member(m, depth, pad.get(k, 0), inner)
            joinable = (prev_member_row is not None and start_line == prev_end_line
                        and len(new) == 1 and not new[0][2] and not prev_member_row[2]
                        and width(prev_member_row[0] + prev_member_row[1]) + 2
                        + len(new[0][1]) <= LIMIT)
            if joinable:
                prev_member_row[1] += "; " + new[0][1]
                prev_member_row[3] = None
            else:
                rows.extend(new)
            prev_member_row = rows[-1] if len(new) == 1 and rows and rows[-1] is not None \
                else None
            prev_end_line = self.line_of(e)
        for c in cs[ci:]:  # comments after the last member
            if head_line is not None and c.line == head_line and not rows:
                head_comments.append(c.text)
            elif prev_end_line is not None and c.line == prev_end_line and rows \
                    and rows[-1] is not None:
                rows[-1][2].append(c.text)
            else:
                if prev_end_line is not None and c.line - prev_end_line > 1 and rows:
                    rows.append(None)
                rows.append([ind, "", [c.text], None])
                prev_end_line = c.line
        self.head_comments = head_comments
        return rows

    def _pads(self, members, spans, cs) -> dict[int, int]:
        """Name padding for runs of adjacent fields / declarations of one kind."""
        out: dict[int, int] = {}
        run: list[int] = []

        def flush():
            if len(run) > 1:
                w = max(len(members[i].name) for i in run)
                for i in run:
                    out[i] = w - len(members[i].name)
            run.clear()

        lines = [(self.line_of(s), self.line_of(e)) for s, e in spans]
        for k, m in enumerate(members):
            key = _align_key(m)
            shared = (k > 0 and lines[k - 1][1] == lines[k][0]) or \
                (k + 1 < len(members) and lines[k + 1][0] == lines[k][1])
            if shared:  # members joined on one line are not aligned
                key = None
            adjacent = False
            if run and key is not None and key == _align_key(members[run[-1]]):
                pe, s = spans[run[-1]][1], spans[k][0]
                gap_lines = self.line_of(s) - self.line_of(pe)
                no_comment_line = not any(pe <= c.pos < s and c.line != self.line_of(pe)
                                          for c in cs)
                adjacent = gap_lines == 1 and no_comment_line
            if not adjacent:
                flush()
            if key is not None:
                run.append(k)
        flush()
        return out

    # ------------------------------------------------------------ one member
    def member(self, m, depth: int, pad: int, inner: list[Comment]) -> list:
        ind = "  " * depth
        if isinstance(m, ast.Block):
            return self.block(m, depth, inner)
        match m:
            case ast.Field(name, v):
                head, value = f"{name}{' ' * pad} = ", v
            case ast.Named(kind, name, v):
                head, value = f"{kind} {name}{' ' * pad} = ", v
            case ast.Require(v):
                head, value = "require ", v
            case ast.Objective(sense, v):
                head, value = f"{sense} ", v
            case ast.Uncertain(target, v):
                head, value = f"{'.'.join(target.parts)} ~ ", v
            case ast.Signals(names):
                rows, cur = [], ind + "signal "
                for i, nm in enumerate(names):
                    item = nm + ("," if i < len(names) - 1 else "")
                    if cur.strip() != "signal" and len(cur) + 1 + len(item) > LIMIT:
                        rows.append(cur)
                        cur = ind + "       " + item
                    else:
                        cur += ("" if cur.endswith("signal ") else " ") + item
                rows.append(cur)
                out = [[ind, rows[0][len(ind):], [], None]] + [["", r, [], None]
                                                               for r in rows[1:]]
                out[-1][2] = [c.text for c in inner]
                return out
            case _:
                raise TypeError(f"cannot format {m!r}")
        leaves = leaves_in_order(value)
        self.p.leaves = {id(x): i for i, x in enumerate(leaves)}
        ends = [self.pos(x.span.end_line, x.span.end_col) for x in leaves]
        attach = [sum(1 for e in ends if e <= c.pos) - 1 for c in inner]
        breaks = {a for a in attach if 0 <= a < len(leaves) - 1}
        lines = self.p.lay(value, IMPLIES, len(ind) + len(head), breaks)
        if any(width(ln) > LIMIT for ln in lines[1:]) or len(ind) + width(head + lines[0]) \
                > LIMIT:  # aligned under the operands does not fit: a fixed hanging indent
            hung = self.p.lay(value, IMPLIES, len(ind) + len(head), breaks, len(ind) + 4)
            if max(map(width, hung)) < max(map(width, lines)):
                lines = hung
        lines[0] = head + lines[0]
        rows = [[ind, ln, [], None] if i == 0 else ["", ln, [], None]
                for i, ln in enumerate(lines)]
        own: dict[int, list[str]] = {}  # comments on lines of their own, after row i
        for c, a in zip(inner, attach):
            at = 0
            if a >= 0:
                tag = f"\ue000{a}\ue001"
                at = next((i for i, ln in enumerate(lines) if tag in ln), 0)
            if a >= 0 and self.own_line(c):
                own.setdefault(at, []).append(c.text)
            else:
                rows[at][2].append(c.text)
        for r in rows:
            r[1] = strip(r[1])
        for at in sorted(own, reverse=True):  # at the indentation of the line that follows
            nxt = rows[at + 1][1] if at + 1 < len(rows) else rows[at][0] + rows[at][1]
            lead = (rows[at + 1][0] if at + 1 < len(rows) else "") \
                + nxt[:len(nxt) - len(nxt.lstrip(" "))]
            rows[at + 1:at + 1] = [[lead, "", [t], None] for t in own[at]]
        self.p.leaves = {}
        rows[0][3] = _align_key(m) if len(rows) == 1 else None
        return rows

    def block(self, b: ast.Block, depth: int, inner: list[Comment]) -> list:
        ind = "  " * depth
        head = b.kind + (f" {b.name}" if b.name else "") + (f" : {b.model}" if b.model else "")
        close = self.pos(b.span.end_line, b.span.end_col) - 1
        open_ = self.masked.rfind("{", 0, self.pos(b.members[0].span.line,
                                                   b.members[0].span.col)) \
            if b.members else self.masked.rfind("{", 0, close)
        head_line = self.line_of(open_)
        rows = self.members(b.members, depth + 1, open_ + 1, close, head_line)
        head_comments = self.head_comments
        outside = [c.text for c in inner if c.pos < open_]  # between the head and `{`
        one_line = head_line == self.line_of(close)
        if not b.members and not head_comments and not outside:
            return [[ind, head + " { }", [], None]]
        simple = all(r is not None and not r[2] and r[1] for r in rows)
        if one_line and simple and not head_comments and not outside:
            flat = f"{head} {{ {'; '.join(r[1] for r in rows)} }}"
            if len(ind) + len(flat) <= LIMIT:
                return [[ind, flat, [], None]]
        return [[ind, head + " {", outside + head_comments, None], *rows, [ind, "}", [], None]]


def _align_key(m):
    if isinstance(m, ast.Field):
        return ("field",)
    if isinstance(m, ast.Named):
        return ("named", m.kind)
    return None


def _mask(text: str, comments: list[Comment]) -> str:
    chars = list(text)
    for c in comments:
        for i in range(c.pos, min(len(chars), c.pos + len(c.text))):
            chars[i] = " "
    return "".join(chars)


def _render(rows: list) -> str:
    """Rows → text, trailing comments of adjacent rows aligned two spaces past the
    longest code among them (each on its own when that would pass the line limit)."""
    while rows and rows[-1] is None:
        rows.pop()
    out: list[str] = []
    i = 0
    while i < len(rows):
        r = rows[i]
        if r is None:
            out.append("")
            i += 1
            continue
        if not (r[2] and r[1]):
            out.append((r[0] + r[1] + ("  " if r[1] and r[2] else "")
                        + " ".join(r[2])).rstrip())
            i += 1
            continue
        j = i
        while j < len(rows) and rows[j] is not None and rows[j][2] and rows[j][1]:
            j += 1
        col = max(len(x[0]) + len(x[1]) for x in rows[i:j]) + 2
        fits = all(col + len(" ".join(x[2])) <= LIMIT for x in rows[i:j])
        for x in rows[i:j]:
            code = x[0] + x[1]
            gap = col - len(code) if fits else 2
            out.append(code + " " * gap + " ".join(x[2]))
        i = j
    return "\n".join(out) + "\n" if out else ""
