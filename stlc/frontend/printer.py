"""Print an AST back as `.stl` source text.

Formulas and expressions are printed fully parenthesised, so that ``parse(print(tree))``
gives back the same tree whatever the precedence rules are (the round-trip property test
relies on this).  Blocks are indented by two spaces.
"""

from __future__ import annotations

from stlc.frontend import ast


def fmt_number(n: ast.Number) -> str:
    return n.text


def expr(n: ast.Node) -> str:
    match n:
        case ast.Number():
            return fmt_number(n)
        case ast.Quantity(arg, unit):
            # a list takes a unit as it is (`[[1, 0], [0, 1]] m^2`, in value position only)
            return f"{expr(arg) if isinstance(arg, ast.List) else atom(arg)} {unit}"
        case ast.Path(parts):
            return ".".join(parts)
        case ast.Call(fn, args, kwargs):
            items = [value(a) for a in args] + [f"{k} = {value(v)}" for k, v in kwargs]
            return f"{fn}({', '.join(items)})"
        case ast.Tuple(items):
            inner = ", ".join(expr(i) for i in items)
            return f"({inner},)" if len(items) == 1 else f"({inner})"
        case ast.List(items):
            return "[" + ", ".join(value(i) for i in items) + "]"
        case ast.Bool(v):
            return "true" if v else "false"
        case ast.String(v):
            return f'"{v}"'
        case ast.Unary(op, arg):
            return f"{op}{atom(arg)}"
        case ast.Binary("^", left, right):
            # the base of `^` is a postfix expression: `-x ^ 2` would mean `-(x ^ 2)`
            return f"({atom(left)} ^ {expr(right)})"
        case ast.Binary(op, left, right):
            return f"({expr(left)} {op} {expr(right)})"
        case ast.Compare(op, left, right):
            return f"({expr(left)} {op} {expr(right)})"
        case ast.Range(lo, hi):
            return f"[{expr(lo)}, {expr(hi)}]"
        case ast.In(arg, region, negated):
            kw = "not in" if negated else "in"
            reg = expr(region) if isinstance(region, ast.Range) else atom(region)
            return f"({expr(arg)} {kw} {reg})"
        case ast.Not(arg):
            return f"(not {expr(arg)})"
        case ast.Logic(op, left, right):
            return f"({expr(left)} {op} {expr(right)})"
        case ast.Temporal(op, interval, arg):
            return f"({op}{_interval(interval)} {expr(arg)})"
        case ast.Until(interval, left, right):
            return f"({expr(left)} until{_interval(interval)} {expr(right)})"
        case ast.Quant(kind, names, domain, body):
            dom = expr(domain) if isinstance(domain, ast.List) else atom(domain)
            return f"({kind} {', '.join(names)} in {dom}: {expr(body)})"
    raise TypeError(f"cannot print {n!r}")


def atom(n: ast.Node) -> str:
    """Print so that the result can stand where an atom is expected."""
    s = expr(n)
    if isinstance(n, (ast.Number, ast.Path, ast.Call, ast.Tuple, ast.Bool, ast.String)):
        return s
    if s.startswith("(") and _balanced_outer(s):
        return s
    return f"({s})"


def _balanced_outer(s: str) -> bool:
    depth = 0
    for i, ch in enumerate(s):
        depth += ch == "("
        depth -= ch == ")"
        if depth == 0 and i < len(s) - 1:
            return False
    return True


def _interval(i: ast.Interval | None) -> str:
    return "" if i is None else f"[{expr(i.lo)}, {expr(i.hi)}]"


def value(n: ast.Node) -> str:
    return expr(n)


def member(m: ast.Member, indent: int = 0) -> str:
    pad = "  " * indent
    match m:
        case ast.Field(name, v):
            return f"{pad}{name} = {value(v)}"
        case ast.Named(kind, name, v):
            return f"{pad}{kind} {name} = {value(v)}"
        case ast.Block(kind, name, model, members):
            head = kind + (f" {name}" if name else "") + (f" : {model}" if model else "")
            body = "\n".join(member(x, indent + 1) for x in members)
            return f"{pad}{head} {{\n{body}\n{pad}}}" if members else f"{pad}{head} {{ }}"
        case ast.Require(v):
            return f"{pad}require {value(v)}"
        case ast.Objective(sense, v):
            return f"{pad}{sense} {value(v)}"
        case ast.Signals(names):
            return f"{pad}signal {', '.join(names)}"
        case ast.Uncertain(target, v):
            return f"{pad}{target.text} ~ {value(v)}"
    raise TypeError(f"cannot print {m!r}")


def print_file(f: ast.File) -> str:
    return "\n".join(member(m) for m in f.members) + "\n"
