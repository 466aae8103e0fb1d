"""Canonical layout of formulas and expressions for ``stlc fmt``.

The printer of ``stlc.frontend.printer`` (fully parenthesised, for round trips) with the
grammar's precedence ladder: a sub-formula gets parentheses only where the grammar needs
them, or where the user wrote them (a parenthesised formula stays parenthesised; a
parenthesised name or number does not).  Long formulas break at the loosest operator,
continuation lines aligned under the first operand (inside the brackets) or starting with
the operator (``and``/``or``/``implies``/``until`` at a line start continues the line).

Every leaf (number, name, ``true``/``false``, string) is printed with an invisible marker
carrying its index in source order, so the formatter can put each comment of a member at
the end of the output line that holds the leaf the comment followed.
"""

from __future__ import annotations

import re

from stlc.frontend import ast

LIMIT = 100  # the project's line length
MARK = re.compile("\ue000[0-9]+\ue001")

# the grammar's ladder, loosest first
IMPLIES, OR, AND, UNTIL, PREFIX, COMPARE, SUM, PRODUCT, UNARY, POWER, POSTFIX, ATOM = range(1, 13)
_ATOMS = (ast.Number, ast.Path, ast.Call, ast.Tuple, ast.Bool, ast.String, ast.List)


def width(s: str) -> int:
    return len(MARK.sub("", s))


def strip(s: str) -> str:
    return MARK.sub("", s)


def level(n) -> int:
    match n:
        case ast.Logic("implies"):
            return IMPLIES
        case ast.Logic("or"):
            return OR
        case ast.Logic():
            return AND
        case ast.Until():
            return UNTIL
        case ast.Not() | ast.Temporal() | ast.Quant():
            return PREFIX
        case ast.Compare() | ast.In():
            return COMPARE
        case ast.Binary("+" | "-"):
            return SUM
        case ast.Binary("*" | "/"):
            return PRODUCT
        case ast.Unary():
            return UNARY
        case ast.Binary("^"):
            return POWER
        case ast.Quantity():
            return POSTFIX
    return ATOM


class Printer:
    """Prints the nodes of one source file (``text``: for the user's parentheses)."""

    def __init__(self, text: str, leaves: dict[int, int] | None = None):
        self.text = text
        self.leaves = leaves or {}
        self.starts = _line_starts(text)
        self.match = _matching_parens(text)

    # ------------------------------------------------------------ positions
    def pos(self, line: int, col: int) -> int:
        return self.starts[line - 1] + col - 1 if 0 < line <= len(self.starts) else 0

    def user_parens(self, n) -> bool:
        """Did the source put this node in parentheses of its own?"""
        sp = getattr(n, "span", None)
        if sp is None or not sp.known or isinstance(n, _ATOMS):
            return False
        s, e = self.pos(sp.line, sp.col), self.pos(sp.end_line, sp.end_col)
        i, t = s - 1, self.text
        while i >= 0 and t[i] in " \t\n\r\f":
            i -= 1
        j = e
        while j < len(t) and t[j] in " \t\n\r\f":
            j += 1
        return i >= 0 and t[i] == "(" and self.match.get(i) == j

    # ------------------------------------------------------------ flat printing
    def leaf(self, n, s: str) -> str:
        i = self.leaves.get(id(n))
        return s if i is None else f"\ue000{i}\ue001{s}"

    def wrap(self, n, minlvl: int) -> str:
        s = self.flat(n)
        return f"({s})" if level(n) < minlvl or self.user_parens(n) else s

    def flat(self, n) -> str:  # noqa: C901 - one case per node kind
        w = self.wrap
        match n:
            case ast.Number():
                return self.leaf(n, n.text)
            case ast.Quantity(arg, unit):
                inner = self.value(arg) if isinstance(arg, ast.List) else w(arg, ATOM)
                return f"{inner} {unit}"
            case ast.Path(parts):
                return self.leaf(n, ".".join(parts))
            case ast.Call(fn, args, kwargs):
                items = [self.value(a) for a in args]
                items += [f"{k} = {self.value(v)}" for k, v in kwargs]
                return f"{fn}({', '.join(items)})"
            case ast.Tuple(items):
                inner = ", ".join(self.value(i) for i in items)
                return f"({inner},)" if len(items) == 1 else f"({inner})"
            case ast.List(items):
                return "[" + ", ".join(self.value(i) for i in items) + "]"
            case ast.Bool(v):
                return self.leaf(n, "true" if v else "false")
            case ast.String(v):
                return self.leaf(n, f'"{v}"')
            case ast.Unary(op, arg):
                return f"{op}{w(arg, UNARY)}"
            case ast.Binary("^", left, right):
                return f"{w(left, POSTFIX)} ^ {w(right, UNARY)}"
            case ast.Binary(op, left, right):
                lv = level(n)
                return f"{w(left, lv)} {op} {w(right, lv + 1)}"
            case ast.Compare(op, left, right):
                return f"{w(left, SUM)} {op} {w(right, SUM)}"
            case ast.Range(lo, hi):
                return f"[{self.value(lo)}, {self.value(hi)}]"
            case ast.In(arg, region, negated):
                kw = "not in" if negated else "in"
                reg = self.flat(region) if isinstance(region, ast.Range) else w(region, SUM)
                return f"{w(arg, SUM)} {kw} {reg}"
            case ast.Not(arg):
                return f"not {w(arg, PREFIX)}"
            case ast.Logic(op, left, right):
                lv = level(n)
                if op == "implies":
                    return f"{w(left, OR)} implies {w(right, IMPLIES)}"
                return f"{w(left, lv)} {op} {w(right, lv + 1)}"
            case ast.Temporal(op, interval, arg):
                return f"{op}{self.interval(interval)} {w(arg, PREFIX)}"
            case ast.Until(interval, left, right):
                return f"{w(left, PREFIX)} until{self.interval(interval)} {w(right, PREFIX)}"
            case ast.Quant(kind, names, domain, body):
                dom = self.flat(domain) if isinstance(domain, ast.List) else w(domain, POSTFIX)
                return f"{kind} {', '.join(names)} in {dom}: {w(body, PREFIX)}"
        raise TypeError(f"cannot print {n!r}")

    def interval(self, i) -> str:
        return "" if i is None else f"[{self.value(i.lo)}, {self.value(i.hi)}]"

    def value(self, n) -> str:
        """A node in value position (a field's value, an argument, a list item)."""
        return self.wrap(n, IMPLIES) if not isinstance(n, ast.List) else self.flat(n)

    # ------------------------------------------------------------ broken layout
    def lay(self, n, minlvl: int, col: int, breaks: set[int], hang: int | None = None,
            tail: int = 0) -> list[str]:
        """Lines for ``n`` starting at column ``col`` (the first line without indentation).
        ``breaks``: leaf indices a comment follows (a line must end after them); ``hang``:
        the column of every continuation line (else under the chain's first operand); ``tail``:
        how many closing brackets follow on the last line."""
        flat = self.wrap(n, minlvl) if not isinstance(n, ast.List) else self.flat(n)
        if col + width(flat) + tail <= LIMIT and not _has(flat, breaks):
            return [flat]
        if level(n) < minlvl or self.user_parens(n):
            lines = self._lay_inner(n, col + 1, breaks, hang, tail + 1)
            if hang is not None and col + 1 + width(lines[0]) > LIMIT and col > hang:
                # break after the bracket: the operand starts the next line
                lines = self._lay_inner(n, hang, breaks, hang, tail + 1)
                lines[0] = " " * hang + lines[0]
                lines.insert(0, "")
            lines[0] = "(" + lines[0]
            lines[-1] += ")"
            return lines
        return self._lay_inner(n, col, breaks, hang, tail)

    def _lay_inner(self, n, col: int, breaks: set[int], hang: int | None, tail: int
                   ) -> list[str]:
        lay = self.lay
        match n:
            case ast.Logic() | ast.Until():
                parts = _chain(n)
                lines = lay(parts[0][1], parts[0][2], col, breaks, hang)
                at = col if hang is None else hang
                broken = len(lines) > 1  # an operand took several lines: the next starts one
                for k, (op, x, ml) in enumerate(parts[1:], 2):
                    op = op if op != "until" else "until" + self.interval(n.interval)
                    t = tail if k == len(parts) else 0
                    sub = lay(x, ml, at + len(op) + 1, breaks, hang, t)
                    cand = f"{lines[-1]} {op} {sub[0]}"
                    end = width(cand) + (col if len(lines) == 1 else 0) + t
                    fits = len(sub) == 1 and end <= LIMIT and not broken
                    broken = len(sub) > 1
                    if fits and not _has(lines[-1], breaks):
                        lines[-1] = cand
                    else:
                        lines.append(" " * at + f"{op} {sub[0]}")
                        lines.extend(sub[1:])
                return lines
            case ast.Temporal(op, interval, arg):
                head = f"{op}{self.interval(interval)} "
                return _prefix(head, lay(arg, PREFIX, col + width(head), breaks, hang, tail))
            case ast.Not(arg):
                return _prefix("not ", lay(arg, PREFIX, col + 4, breaks, hang, tail))
            case ast.Quant(kind, names, domain, body):
                dom = self.flat(domain) if isinstance(domain, ast.List) else \
                    self.wrap(domain, POSTFIX)
                head = f"{kind} {', '.join(names)} in {dom}: "
                return _prefix(head, lay(body, PREFIX, col + width(head), breaks, hang, tail))
        return [self.flat(n)]


def _prefix(head: str, lines: list[str]) -> list[str]:
    return [head + lines[0]] + lines[1:]


def _has(s: str, breaks: set[int]) -> bool:
    return bool(breaks) and any(int(m.group()[1:-1]) in breaks for m in MARK.finditer(s))


def _chain(n) -> list[tuple[str, object, int]]:
    """A chain of one loosest operator: [(op, operand, its minimum level)], the first op ''."""
    match n:
        case ast.Logic("implies", left, right):  # right-associative
            rest = _chain(right) if isinstance(right, ast.Logic) and right.op == "implies" \
                else [("", right, IMPLIES)]
            rest[0] = ("implies", rest[0][1], rest[0][2])
            return [("", left, OR)] + rest
        case ast.Logic(op, left, right):
            lv = level(n)
            head = _chain(left) if isinstance(left, ast.Logic) and left.op == op \
                else [("", left, lv)]
            return head + [(op, right, lv + 1)]
        case ast.Until(_, left, right):
            return [("", left, PREFIX), ("until", right, PREFIX)]
    return [("", n, ATOM)]


def leaves_in_order(node) -> list:
    """The leaves (numbers, names, booleans, strings) under ``node`` in source order."""
    out, stack = [], [node]
    while stack:
        n = stack.pop()
        if isinstance(n, (ast.Number, ast.Path, ast.Bool, ast.String)):
            out.append(n)
            continue
        stack.extend(ast.node_children(n))
    out.sort(key=lambda x: (x.span.line, x.span.col))
    return out


def _line_starts(text: str) -> list[int]:
    starts = [0]
    for i, ch in enumerate(text):
        if ch == "\n":
            starts.append(i + 1)
    return starts


def _matching_parens(text: str) -> dict[int, int]:
    """Position of every ``(`` → position of its ``)`` (outside comments and strings)."""
    out, stack, i, n = {}, [], 0, len(text)
    while i < n:
        ch = text[i]
        if ch == "#":
            j = text.find("\n", i)
            i = n if j < 0 else j
            continue
        if ch == '"':
            j = text.find('"', i + 1)
            i = n if j < 0 else j + 1
            continue
        if ch == "(":
            stack.append(i)
        elif ch == ")" and stack:
            out[stack.pop()] = i
        i += 1
    return out
