"""Surface syntax tree of a `.stl` file, with a source span on every node.

Produced by ``stlc.frontend.syntax.parse``; consumed by ``stlc.semantics.check`` (which never
writes back onto these nodes) and by ``stlc.frontend.printer`` (which prints them back as
source text).  Spans do not take part in equality, so a printed-then-reparsed tree compares
equal to the original.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from stlc.diagnostics import Span

NOSPAN = Span.none()


def _span() -> Span:
    return field(default=NOSPAN, compare=False, repr=False)


# ---------------------------------------------------------------- expressions / formulas


@dataclass(frozen=True, slots=True)
class Number:
    value: float
    text: str
    span: Span = _span()


@dataclass(frozen=True, slots=True)
class Quantity:
    """``expr UNIT``: a number, tuple or call followed by a unit (``2.25 kg``, ``(0,0,1) m``)."""

    arg: Node
    unit: str
    span: Span = _span()


@dataclass(frozen=True, slots=True)
class Path:
    """A dotted name: ``x``, ``uav1.pos``, ``operator.visibility``, ``uav1.force.3``."""

    parts: tuple[str, ...]
    span: Span = _span()

    @property
    def text(self) -> str:
        return ".".join(self.parts)


@dataclass(frozen=True, slots=True)
class Call:
    fn: str
    args: tuple[Node, ...]
    kwargs: tuple[tuple[str, Node], ...] = ()
    span: Span = _span()


@dataclass(frozen=True, slots=True)
class Tuple:
    items: tuple[Node, ...]
    span: Span = _span()


@dataclass(frozen=True, slots=True)
class List:
    items: tuple[Node, ...]
    span: Span = _span()


@dataclass(frozen=True, slots=True)
class Bool:
    value: bool
    span: Span = _span()


@dataclass(frozen=True, slots=True)
class String:
    value: str
    span: Span = _span()


@dataclass(frozen=True, slots=True)
class Unary:
    """Arithmetic ``-x`` / ``+x``."""

    op: str
    arg: Node
    span: Span = _span()


@dataclass(frozen=True, slots=True)
class Binary:
    """Arithmetic ``+ - * / ^``."""

    op: str
    left: Node
    right: Node
    span: Span = _span()


@dataclass(frozen=True, slots=True)
class Compare:
    op: str  # < <= > >=
    left: Node
    right: Node
    span: Span = _span()


@dataclass(frozen=True, slots=True)
class Range:
    """``[lo, hi]`` on the right of ``in``."""

    lo: Node
    hi: Node
    span: Span = _span()


@dataclass(frozen=True, slots=True)
class In:
    arg: Node
    region: Node
    negated: bool = False
    span: Span = _span()


@dataclass(frozen=True, slots=True)
class Interval:
    lo: Node
    hi: Node
    span: Span = _span()


@dataclass(frozen=True, slots=True)
class Not:
    arg: Node
    span: Span = _span()


@dataclass(frozen=True, slots=True)
class Logic:
    """``and`` / ``or`` / ``implies``."""

    op: str
    left: Node
    right: Node
    span: Span = _span()


@dataclass(frozen=True, slots=True)
class Temporal:
    """``always`` / ``eventually`` (optional interval) and ``next`` (no interval)."""

    op: str
    interval: Interval | None
    arg: Node
    span: Span = _span()


@dataclass(frozen=True, slots=True)
class Until:
    interval: Interval | None
    left: Node
    right: Node
    span: Span = _span()


@dataclass(frozen=True, slots=True)
class Quant:
    """``forall d in team: body`` / ``exists q in targets: body``; several names range over
    distinct unordered combinations (``forall d, e in team`` — every pair once)."""

    kind: str  # forall | exists
    names: tuple[str, ...]
    domain: Node
    body: Node
    span: Span = _span()


Node = (Number | Quantity | Path | Call | Tuple | List | Bool | String | Unary | Binary | Compare
        | Range | In | Not | Logic | Temporal | Until | Quant)

# ---------------------------------------------------------------- members


@dataclass(frozen=True, slots=True)
class Field:
    """``name = value``"""

    name: str
    value: Node
    span: Span = _span()
    name_span: Span = _span()


@dataclass(frozen=True, slots=True)
class Named:
    """``kind name = value``: ``spec phi = ...``, ``obstacle pole = box(...)``,
    ``const T = 17 s``."""

    kind: str
    name: str
    value: Node
    span: Span = _span()
    name_span: Span = _span()


@dataclass(frozen=True, slots=True)
class Block:
    """``kind [name] [: model] { members }``."""

    kind: str
    name: str | None
    model: str | None
    members: tuple[Member, ...]
    span: Span = _span()
    name_span: Span = _span()


@dataclass(frozen=True, slots=True)
class Require:
    value: Node
    span: Span = _span()


@dataclass(frozen=True, slots=True)
class Objective:
    sense: str  # minimize | maximize
    value: Node
    span: Span = _span()


@dataclass(frozen=True, slots=True)
class Signals:
    names: tuple[str, ...]
    span: Span = _span()


@dataclass(frozen=True, slots=True)
class Uncertain:
    """``operator.pos ~ normal(mean, cov)``"""

    target: Path
    value: Node
    span: Span = _span()


Member = Field | Named | Block | Require | Objective | Signals | Uncertain


@dataclass(frozen=True, slots=True)
class File:
    members: tuple[Member, ...]
    path: str = field(default="", compare=False)
    source: str = field(default="", compare=False, repr=False)


def node_children(n) -> tuple:
    """Direct child nodes of an AST node (used by generic walkers)."""
    out = []
    for name in n.__dataclass_fields__:
        if name in ("span", "name_span"):
            continue
        v = getattr(n, name)
        if isinstance(v, tuple):
            for x in v:
                if isinstance(x, tuple):
                    out.extend(y for y in x if hasattr(y, "__dataclass_fields__"))
                elif hasattr(x, "__dataclass_fields__"):
                    out.append(x)
        elif hasattr(v, "__dataclass_fields__"):
            out.append(v)
    return tuple(out)
