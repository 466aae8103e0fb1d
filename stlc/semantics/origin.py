"""Where an atomic predicate came from, as data (``ir.Pred.origin``).

The checker knows what each predicate it writes *is*: one side of a comparison, one face
of a box membership (which region, which axis, which bound), one side of a range; the
normal form knows whether it pushed a negation onto it.  That knowledge rides on the
predicate as an ``Origin`` so that later passes (the report's readable predicate, which
regions a mission mentions) read fields instead of parsing the label back with regular
expressions; the label stays the source text, for tooltips and the CLI.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

__all__ = ["COMPARE", "FACE", "RANGE", "Origin"]

COMPARE, FACE, RANGE = "compare", "face", "range"


@dataclass(frozen=True, slots=True)
class Origin:
    """``kind`` is ``compare`` (``left op right``, one component of a vector comparison
    when ``component`` > 0), ``face`` (``subject in region``: the face ``axis`` ≥ lo or
    ≤ hi, ``side`` ``lo``/``hi``) or ``range`` (``subject in [lo, hi]``: ``side``
    ``lower``/``upper``, ``bound_text`` that side's bound).  Texts are as written in the
    source; ``region`` is the declared name of the region (empty for a ``box(…)`` literal);
    ``regions`` every declared region the construct reads (a face's own, or those named in
    a comparison such as ``dist(p, target1.center)``).  ``negated``: the predicate is the
    negation of the construct (``not``, ``not in``, the left side of ``implies``)."""

    kind: str
    text: str = ""  # the whole construct as written
    subject: str = ""  # face / range: the point or value tested
    op: str = ""  # compare: the operator as written
    left: str = ""
    right: str = ""
    component: int = 0
    region: str = ""
    region_text: str = ""
    axis: str = ""
    side: str = ""
    bound_text: str = ""
    regions: tuple[str, ...] = ()
    negated: bool = False
    unit: str = ""  # the unit its robustness is measured in ("m", "m/s", "rad", "Hz", …)

    def negation(self) -> Origin:
        return replace(self, negated=not self.negated)
