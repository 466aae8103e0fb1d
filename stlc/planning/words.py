"""The verdict's words: one vocabulary for the terminal, ``solution.json``'s notes, the
report and the Python API.

A verdict is named with the exact robustness ρ (the monitor's, on the plan's numbers) and
the mission's threshold κ: *satisfied* means ρ ≥ κ.  The planner's smooth robustness ρ̃ is
the quantity the optimiser climbs; it is shown as such ("planner ρ̃"), never beside a
verdict.  A value that is not a number is "undefined", never ``nan``; an iterate that does
not yet obey the dynamics is "not yet flyable", never "infeasible" (a word kept for a
mission proved impossible).
"""

from __future__ import annotations

import math

#: what each ``Solution.status`` is called where a person reads it
STATUS_WORDS = {"satisfied": "satisfied", "violated": "violated",
                "solver_failed": "solver failed", "infeasible": "no plan exists",
                "stopped": "stopped by the time limit"}

#: an NLP iterate whose dynamics defect is above the tolerance: not judged by the monitor
NOT_FLYABLE = "— (iterate not yet flyable: dynamics not met)"


def number(x: float | None, digits: int = 4, signed: bool = True) -> str:
    """A robustness for a person: ``+0.0545``, ``+∞``, ``undefined`` (NaN or missing)."""
    if x is None:
        return "undefined"
    v = float(x)
    if math.isnan(v):
        return "undefined"
    if math.isinf(v):
        return "+∞" if v > 0 else "−∞"
    return f"{v:+.{digits}f}" if signed else f"{v:.{digits}f}"


def status_word(status: str) -> str:
    return STATUS_WORDS.get(str(status), str(status))


def comparison(rho: float, kappa: float) -> str:
    """``ρ = +0.0545 ≥ κ = 0.05`` (the exact robustness against the threshold)."""
    sign = "≥" if rho == rho and rho >= kappa else "<"
    if rho != rho:
        return f"ρ undefined, κ = {kappa:g}"
    return f"ρ = {number(rho)} {sign} κ = {kappa:g}"


def verdict_line(status: str, rho: float, kappa: float) -> str:
    """The verdict with its evidence: ``satisfied (exact ρ = +0.0545 ≥ κ = 0.05)``; a
    mission proved impossible shows its best attempt's ρ as such."""
    word = status_word(status)
    if str(status) == "infeasible":
        return f"{word} (proved; best attempt: exact {comparison(rho, kappa)})"
    return f"{word} (exact {comparison(rho, kappa)})"


def iterate_exact(exact: float | None) -> str:
    """The exact robustness of an NLP iterate, in words when it was not judged."""
    return NOT_FLYABLE if exact is None else number(exact)


def impossibility_note(info: dict | None) -> str:
    """What the impossibility check said of a mission without a satisfying plan, from
    ``solver["infeasibility"]``: whether it ran and why it proved nothing."""
    if not info:
        return ("impossibility was not checked (the time limit had run out), so this does "
                "not show that no plan exists")
    if info.get("proved"):
        return ""
    why = str(info.get("why") or "the check found no proof")
    return f"impossibility could not be proved: {why}; a plan may exist"
