"""Small helpers shared by the view-model modules: rounding, number formatting, channel
lookup in a ``Solution`` and source-line anchors.

Every float that reaches the page goes through ``num`` (about five significant digits,
``None`` for missing or non-finite values), so the view model is strict JSON.
"""

from __future__ import annotations

import math
from collections.abc import Iterable

import numpy as np

from stlc.planning.solution import Solution
from stlc.semantics.model import Mission


def num(x: object, digits: int = 5) -> float | None:
    """Round to ``digits`` significant digits; ``None`` for missing or non-finite values."""
    if x is None:
        return None
    try:
        v = float(x)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        return None
    if not math.isfinite(v):
        return None
    return float(f"{v:.{digits}g}")


def nums(xs: Iterable[object], digits: int = 5) -> list[float | None]:
    """``num`` of every element (arrays are flattened)."""
    arr = xs if isinstance(xs, np.ndarray) else np.asarray(
        [np.nan if x is None else x for x in xs], dtype=float)
    return [num(x, digits) for x in arr.ravel().tolist()]


def fmt(x: object, digits: int = 4, signed: bool = False, unit: str = "") -> str:
    """Human-readable number: ``—`` when missing or NaN, ``+∞``/``−∞`` for infinities."""
    if x is None:
        return "—"
    try:
        v = float(x)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        return str(x)
    if math.isnan(v):
        return "—"
    if math.isinf(v):
        return "+∞" if v > 0 else "−∞"
    s = f"{v:+.{digits}g}" if signed else f"{v:.{digits}g}"
    s = s.replace("-", "−")
    return f"{s} {unit}" if unit else s


def fmt_vec(xs: Iterable[object], digits: int = 4) -> str:
    """``(a, b, c)`` with ``fmt`` of each component."""
    return "(" + ", ".join(fmt(x, digits) for x in xs) + ")"


def channel(sol: Solution, name: str) -> np.ndarray | None:
    """A channel as a flat float array, or ``None`` when the solution has none by that name."""
    c = sol.channels.get(name)
    return None if c is None else np.asarray(c, dtype=float).ravel()


def indexed(sol: Solution, prefix: str) -> list[tuple[str, np.ndarray]]:
    """Channels ``prefix.1``, ``prefix.2``, … in numeric order."""
    found = []
    for name, arr in sol.channels.items():
        if name.startswith(prefix + ".") and name[len(prefix) + 1:].isdigit():
            found.append((int(name[len(prefix) + 1:]), name, np.asarray(arr, float).ravel()))
    return [(n, a) for _, n, a in sorted(found)]


def vehicles(mission: Mission, sol: Solution) -> list[str]:
    """The mission's vehicles, then any other vehicle with a position in the solution."""
    names = list(mission.vehicles)
    for ch in sol.channels:
        if ch.endswith(".pos.x") and ch[:-6] not in names:
            names.append(ch[:-6])
    return names


def speed(sol: Solution, v: str) -> np.ndarray | None:
    """``v.speed``, or ‖v.vel‖ when only the velocity was recorded."""
    c = channel(sol, f"{v}.speed")
    if c is not None:
        return c
    vel = [channel(sol, f"{v}.vel.{a}") for a in "xyz"]
    if all(x is not None for x in vel):
        return np.linalg.norm(np.stack(vel), axis=0)  # type: ignore[arg-type]
    return None


def pair(v: object) -> tuple[float | None, float | None]:
    """A bound as ``(lo, hi)``: a number is an upper bound; lists, tuples and
    ``{"min", "max"}`` dicts give both (a one-element list is an upper bound)."""
    if v is None:
        return None, None
    if isinstance(v, (int, float)):
        return None, float(v)
    if isinstance(v, dict):
        return v.get("min"), v.get("max")
    try:
        vals = list(v)  # type: ignore[call-overload]
    except TypeError:
        return None, None
    if not vals:
        return None, None
    if len(vals) == 1:
        return None, vals[0]
    return vals[0], vals[1]


def anchor(line: int, n_lines: int) -> str:
    """The id of a source line in the page (``L12``), or ``""`` when out of range."""
    return f"L{line}" if 0 < line <= n_lines else ""


#: one colour per drone, in the order of the mission's vehicles (scene and team plots)
DRONE_COLORS = ("#1f77b4", "#ff7f0e", "#17becf", "#e377c2", "#8c564b", "#bcbd22", "#7f7f7f",
                "#d62728", "#9467bd", "#2ca02c")


def drone_color(i: int) -> str:
    """The colour of the ``i``-th drone (cycled)."""
    return DRONE_COLORS[i % len(DRONE_COLORS)]
