"""The one verdict rule: a robustness ρ satisfies a margin κ iff ρ ≥ κ.

Every command that says "satisfied" or "violated" asks this module: ``compile`` and the
API (``stlc.planning.verify``), ``monitor`` (and ``--fail-on-violation``), ``simulate``
and ``fly`` (the flight loops' kept specs), ``sweep`` (its rows come from ``compile``)
and ``risk`` (a realisation violates iff ρ < κ).

* Inside a mission, κ is the mission's ``threshold`` (a margin ≥ 0 the plan must keep).
* Outside a mission (a top-level spec monitored on a trace, a risk realisation with no
  mission threshold), κ = 0 and the rule is ρ ≥ 0: a trace that touches a boundary
  (ρ = 0 exactly) satisfies it.  This is the closed reading of the predicates
  ``x ≤ c``/``x ≥ c`` as written, the same convention that ``compile`` applies at κ = 0.
* An undefined robustness (NaN, e.g. the square root of a negative value) is neither:
  ``judge`` returns ``None`` and the commands say "undefined".
"""

from __future__ import annotations

import math

import numpy as np

#: The margin of a spec outside any mission.
DEFAULT_KAPPA = 0.0

RULE = "satisfied iff robustness ρ ≥ κ (κ: the mission's threshold; 0 outside a mission)"


def satisfied(rho: float, kappa: float = DEFAULT_KAPPA) -> bool:
    """``ρ ≥ κ`` (``False`` for NaN).  ``κ`` must be a finite number ≥ 0."""
    check_kappa(kappa)
    return bool(rho >= kappa)


def judge(rho: float, kappa: float = DEFAULT_KAPPA) -> bool | None:
    """``True`` (ρ ≥ κ), ``False`` (ρ < κ) or ``None`` (ρ undefined: NaN)."""
    check_kappa(kappa)
    r = float(rho)
    return None if math.isnan(r) else bool(r >= kappa)


def violated(rho, kappa: float = DEFAULT_KAPPA) -> np.ndarray:
    """Element-wise ``ρ < κ`` for an array of realisations (NaN counts as a violation:
    it is not satisfied)."""
    check_kappa(kappa)
    r = np.asarray(rho, dtype=float)
    return ~(r >= kappa)


def check_kappa(kappa: float) -> None:
    """A ``ValueError`` naming the rule when ``κ`` is not a finite number ≥ 0."""
    try:
        k = float(kappa)
    except (TypeError, ValueError):
        k = math.nan
    if not (math.isfinite(k) and k >= 0):
        raise ValueError(f"the threshold κ must be a finite number >= 0, got {kappa!r} "
                         f"({RULE})")


def margins(program, mission: str | None = None) -> dict[str, float]:
    """The κ of every formula ``stlc monitor`` evaluates (``program``: a checked
    ``stlc.semantics.model.Program``): a top-level spec 0, a mission's named specs and its
    requirement (under the mission's name) the mission's threshold.  With ``mission``
    only that mission's specs and requirement, all at its threshold."""
    out: dict[str, float] = {}
    if mission is None:
        out.update({name: DEFAULT_KAPPA for name in program.specs})
    for m in program.missions.values():
        if mission is not None and m.name != mission:
            continue
        kappa = float(m.threshold)
        for name in m.specs:
            if mission is not None:
                out[name] = kappa
            else:
                out.setdefault(name, kappa)
        out.setdefault(m.name, kappa)
    return out
