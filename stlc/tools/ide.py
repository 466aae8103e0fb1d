"""What the language server knows about one document, without the protocol (``stlc lsp``
wires it to pygls): diagnostics, the declared symbols, hover, go to definition and
completion.  Lines and columns here are 1-based code points, as in ``Span``.

``analyze`` keeps going after a syntax error: the offending line is blanked (columns
kept) and the rest is parsed and checked again, so the checker's diagnostics of the other
lines still show while a line is being typed.  The last document that parsed is kept by
the server for completion (``operator.`` does not parse until a name follows the dot).
"""

from __future__ import annotations

import json
import os
import re
from dataclasses import dataclass, field

from stlc.diagnostics import Diagnostic, Span, StlcError
from stlc.frontend import ast
from stlc.frontend.lexer import DECLARATIONS, FORMULA_WORDS, FUNCTIONS, MEMBER_WORDS

REGION_KINDS = ("region", "obstacle", "target", "station", "home")
GROUPS = ("team", "vehicles", "targets", "stations", "homes", "obstacles", "regions")
HUMAN_FIELDS = {"pos": "position of the human, m (x, y, z)",
                "att": "attitude of the human, rad (roll, pitch, yaw)",
                "heading": "heading (yaw) of the human, rad"}
#: the fields every vehicle has, offered when the file does not check (else the model's
#: own fields are asked from the checker and the vehicle registry)
COMMON_FIELDS = ("pos", "vel", "speed", "horizontal_speed", "course", "radius")
MAX_RECOVERY = 5  # syntax errors skipped per analysis


@dataclass
class Symbol:
    name: str  # as written where it is used: `T_N`, `operator.handover`
    kind: str  # const spec signal vehicle human mission workspace region obstacle ...
    span: Span
    name_span: Span
    detail: str = ""  # the declaration's source text
    container: str | None = None  # the mission of a mission spec, the human of a region
    model: str | None = None  # a vehicle's model
    children: list[Symbol] = field(default_factory=list)


@dataclass
class Analysis:
    text: str
    path: str
    diagnostics: list[Diagnostic]
    tree: ast.File | None = None
    program: object | None = None
    symbols: list[Symbol] = field(default_factory=list)  # top level, with children

    def all_symbols(self) -> list[Symbol]:
        out, stack = [], list(reversed(self.symbols))
        while stack:
            s = stack.pop()
            out.append(s)
            stack.extend(reversed(s.children))
        return out


def analyze(text: str, path: str) -> Analysis:
    """Parse (recovering from syntax errors) and check ``text``; a file that checks gets
    the lint warnings of ``stlc check`` (severity "warning") and its STL505 (a start that
    cannot meet κ)."""
    from stlc.frontend.syntax import parse
    from stlc.semantics.check import check

    diags: list[Diagnostic] = []
    src, tree, lost = text, None, set()
    for _ in range(MAX_RECOVERY):
        try:
            tree = parse(src, path)
            break
        except StlcError as e:
            d = e.diagnostics[0]
            if not diags:
                diags.append(d)
            if d.code not in ("STL001", "STL002") or not d.span.known:
                break
            lost |= set(_DECLARED.findall(src.split("\n")[d.span.line - 1]))
            src = _blank_line(src, d.span.line)
        except RecursionError:
            break
    an = Analysis(text, path, diags)
    if tree is None:
        return an
    an.tree = tree
    an.symbols = symbols_of(tree, text)
    try:
        an.program = check(tree)
    except StlcError as e:  # not the cascade of a declaration on a skipped line
        diags.extend(d for d in e.diagnostics
                     if not (d.code == "STL101" and any(f"`{n}`" in d.message for n in lost)))
    except RecursionError:
        pass
    if an.program is not None and not diags:  # the warnings of `stlc check` (STLWxx)
        from stlc.semantics.lint import lint

        diags.extend(lint(tree, an.program))
        from stlc.analysis.hopeless import hopeless

        diags.extend(hopeless(an.program))  # a start below κ, as `stlc check` says
    return an


_DECLARED = re.compile(r"\b(?:spec|const|region|obstacle|target|station|home|vehicle|human|"
                       r"signal)\s+([A-Za-z_][A-Za-z0-9_]*)")


def _blank_line(text: str, line: int) -> str:
    lines = text.split("\n")
    if 0 < line <= len(lines):
        lines[line - 1] = " " * len(lines[line - 1])
    return "\n".join(lines)


# ---------------------------------------------------------------- symbols


def symbols_of(tree: ast.File, text: str) -> list[Symbol]:
    lines = text.split("\n")

    def decl(m) -> str:
        sp = m.span
        end = sp.end_line if sp.end_col > 1 else sp.end_line - 1
        chunk = lines[sp.line - 1:max(sp.line, end)]
        if not isinstance(m, ast.Block):
            return "\n".join(_code(x) for x in chunk).strip()
        return _code(chunk[0]).strip() if chunk else ""

    out: list[Symbol] = []
    for m in tree.members:
        if isinstance(m, ast.Named) and m.kind in ("const", "spec"):
            out.append(Symbol(m.name, m.kind, m.span, m.name_span, decl(m)))
        elif isinstance(m, ast.Signals):
            out.extend(Symbol(n, "signal", m.span, m.span, decl(m)) for n in m.names)
        elif isinstance(m, ast.Block) and m.kind == "vehicle" and m.name:
            out.append(Symbol(m.name, "vehicle", m.span, m.name_span, decl(m), model=m.model))
        elif isinstance(m, ast.Block) and m.kind == "scenario":
            out.extend(_scenario(m, decl))
        elif isinstance(m, ast.Block) and m.kind == "mission" and m.name:
            s = Symbol(m.name, "mission", m.span, m.name_span, decl(m))
            s.children = [Symbol(x.name, "spec", x.span, x.name_span, decl(x), m.name)
                          for x in m.members if isinstance(x, ast.Named) and x.kind == "spec"]
            out.append(s)
    return out


def _scenario(b: ast.Block, decl) -> list[Symbol]:
    out = []
    for m in b.members:
        if isinstance(m, ast.Field) and m.name == "workspace":
            out.append(Symbol("workspace", "workspace", m.span, m.name_span, decl(m)))
        elif isinstance(m, ast.Named) and m.kind in REGION_KINDS:
            out.append(Symbol(m.name, m.kind, m.span, m.name_span, decl(m)))
        elif isinstance(m, ast.Block) and m.kind == "human":
            name = m.name or "human"
            h = Symbol(name, "human", m.span, m.name_span, decl(m))
            h.children = [Symbol(f"{name}.{x.name}", "region", x.span, x.name_span, decl(x),
                                 name) for x in m.members
                          if isinstance(x, ast.Named) and x.kind == "region"]
            out.append(h)
    return out


def _code(line: str) -> str:
    """A source line without its comment (a `#` inside a string is code)."""
    quoted = False
    for i, ch in enumerate(line):
        if ch == '"':
            quoted = not quoted
        elif ch == "#" and not quoted:
            return line[:i].rstrip()
    return line.rstrip()


# ---------------------------------------------------------------- lookups


_WORD = re.compile(r"[A-Za-z0-9_.]")
_IDENT = re.compile(r"[A-Za-z0-9_]")


def path_at(text: str, line: int, col: int) -> list[str]:
    """The dotted name under (line, col), up to the part the cursor is on."""
    lines = text.split("\n")
    if not 0 < line <= len(lines):
        return []
    s = lines[line - 1]
    i = col - 1
    if not (0 <= i < len(s) and _WORD.match(s[i])):
        if 0 < i <= len(s) and _WORD.match(s[i - 1]):
            i -= 1
        else:
            return []
    lo = i
    while lo > 0 and _WORD.match(s[lo - 1]):
        lo -= 1
    hi = i
    while hi < len(s) and _IDENT.match(s[hi]):
        hi += 1
    word = s[lo:hi].strip(".")
    if not word or word[0].isdigit():
        return []
    return [p for p in word.split(".") if p]


def _enclosing_mission(an: Analysis, line: int) -> str | None:
    for s in an.symbols:
        if s.kind == "mission" and s.span.line <= line <= s.span.end_line:
            return s.name
    return None


def resolve(an: Analysis, parts: list[str], line: int) -> Symbol | None:
    """The declaration a (dotted) name refers to at ``line``."""
    if not parts:
        return None
    name = ".".join(parts[:2]) if len(parts) >= 2 else parts[0]
    mission = _enclosing_mission(an, line)
    best = None
    for s in an.all_symbols():
        if s.name != name:
            continue
        if s.container is not None and s.kind == "spec" and s.container != mission:
            continue
        if best is None or (s.container == mission and s.kind == "spec"):
            best = s
    return best


def vehicle_fields(an: Analysis, vehicle: str) -> dict[str, str]:
    """Field → description with its unit, asked from the checker when the file checks."""
    prog = an.program
    if prog is not None and vehicle in getattr(prog, "vehicles", {}):
        from stlc.semantics.check.elaborate import vehicle_fields as fields
        from stlc.semantics.check.units import describe, example_unit

        out = {}
        for k, v in fields(prog.vehicles[vehicle]).items():
            dim = getattr(v, "dim", None)
            unit = example_unit(dim) if dim is not None else "count"
            # a signal (`Sym`) has labels per component; a constant (`Num`: `radius`) none
            vector = getattr(v, "vector", False)
            comps = ", ".join(lb.rsplit(".", 1)[1] for lb in v.labels) if vector else ""
            desc = describe(dim) if dim is not None else "a number"
            if not hasattr(v, "labels"):
                desc += ", a constant"
            desc += "" if f"({unit})" in desc or f"{unit})" in desc else f", {unit}"
            out[k] = desc + (f"; components {comps}" if comps else "")
        return out
    return {k: "" for k in COMMON_FIELDS}


def spec_robustness(path: str, spec: str) -> str | None:
    """The spec's exact robustness in a ``solution.json`` beside the file, if any."""
    sol = os.path.join(os.path.dirname(os.path.abspath(path)), "solution.json")
    try:
        with open(sol, encoding="utf-8") as fh:
            data = json.load(fh)
        r = data["specs"][spec]["robustness"]
    except (OSError, ValueError, KeyError, TypeError):
        return None
    return f"last compile (`solution.json`, mission `{data.get('mission', '?')}`): exact " \
        f"robustness {r if isinstance(r, str) else format(r, '+.4g')}"


#: hover and completion text of the built-in functions that take regions
FUNCTION_DOCS = {
    "box": "box(lo, hi) m or box(center = ..., size = ...) m: an axis-aligned box",
    "cylinder": "cylinder(center = (x, y, z) m, radius = r m, height = h m[, axis = (ux, uy, "
                "uz)]): a cylinder, vertical unless `axis` is given; `center` is its "
                "mid-height point",
    "sphere": "sphere(center = (x, y, z) m, radius = r m): a ball",
    "capsule": "capsule(a, b, radius): every point within `radius` of the segment a–b",
    "dist": "dist(p, R): signed distance (m) from the point p to the surface of region R, "
            "negative inside; dist(p, q): the distance between two points",
}


def hover(an: Analysis, line: int, col: int) -> str | None:
    """Markdown for the name under the cursor."""
    parts = path_at(an.text, line, col)
    if not parts:
        return None
    s = resolve(an, parts, line)
    if s is not None and len(parts) <= 2 and not (len(parts) == 2 and s.kind == "vehicle"):
        text = f"```stlc\n{s.detail}\n```"
        if s.kind in REGION_KINDS + ("workspace",):
            box = _box(an, s)
            if box:
                text += f"\n\n{box}"
        if s.kind == "spec":
            r = spec_robustness(an.path, s.name)
            if r:
                text += f"\n\n{r}"
        return text
    if s is None and len(parts) == 1 and parts[0] in FUNCTION_DOCS:
        return f"`{parts[0]}`: {FUNCTION_DOCS[parts[0]]}"
    owner = resolve(an, parts[:1], line)
    if owner is None or len(parts) < 2:
        return None
    if owner.kind == "vehicle":
        desc = vehicle_fields(an, owner.name).get(parts[1])
        if desc is not None:
            comp = f".{parts[2]}" if len(parts) > 2 else ""
            return f"`{owner.name}.{parts[1]}{comp}`: {desc or 'vehicle field'} " \
                f"(vehicle `{owner.name}`, {owner.model})"
    if owner.kind == "human" and parts[1] in HUMAN_FIELDS:
        return f"`{owner.name}.{parts[1]}`: {HUMAN_FIELDS[parts[1]]}"
    return None


def _box(an: Analysis, s: Symbol) -> str | None:
    prog = an.program
    if prog is None:
        return None
    for r in prog.scenario.regions:
        if r.name == s.name:
            lo = ", ".join(f"{x:g}" for x in r.box.lo)
            hi = ", ".join(f"{x:g}" for x in r.box.hi)
            frame = f" in the frame of `{r.box.frame}`" if r.box.frame else ""
            if r.box.shape is not None:
                return f"{r.kind} {r.box.shape.describe()}{frame}, inside the box from " \
                    f"({lo}) m to ({hi}) m"
            return f"{r.kind} box from ({lo}) m to ({hi}) m{frame}"
    return None


def definition(an: Analysis, line: int, col: int) -> Span | None:
    s = resolve(an, path_at(an.text, line, col), line)
    return s.name_span if s is not None else None


_OWNER = re.compile(r"([A-Za-z_][A-Za-z0-9_]*(?:\.[A-Za-z0-9_]+)*)\.([A-Za-z0-9_]*)$")


def complete(an: Analysis, line_text: str, line: int) -> list[tuple[str, str, str]]:
    """(label, kind, detail) for the completion at the end of ``line_text``: after
    ``operator.`` the human's regions and fields, after ``uav1.`` the vehicle's fields,
    after ``uav1.pos.`` the components, else every visible name, keyword and function."""
    m = _OWNER.search(line_text)
    if m:
        owner = m.group(1).split(".")
        sym = resolve(an, owner[:1], line)
        if sym is None:
            return []
        if sym.kind == "human" and len(owner) == 1:
            out = [(c.name.split(".", 1)[1], "region", c.detail) for c in sym.children]
            return out + [(k, "field", v) for k, v in HUMAN_FIELDS.items()]
        if sym.kind == "vehicle" and len(owner) == 1:
            return [(k, "field", v) for k, v in vehicle_fields(an, sym.name).items()]
        if len(owner) == 2 and sym.kind in ("vehicle", "human"):
            return [(a, "field", "component") for a in ("x", "y", "z")]
        return []
    mission = _enclosing_mission(an, line)
    out = []
    for s in an.all_symbols():
        if s.kind == "spec" and s.container not in (None, mission):
            continue
        if "." in s.name or s.kind == "mission":
            continue
        out.append((s.name, s.kind, s.detail))
    out += [(w, "keyword", "") for w in FORMULA_WORDS + MEMBER_WORDS + DECLARATIONS]
    out += [(f, "function", FUNCTION_DOCS.get(f, "built-in function")) for f in FUNCTIONS]
    out += [(g, "group", "quantifier domain") for g in GROUPS]
    return out
