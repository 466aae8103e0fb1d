"""Units and dimensions: parse unit strings (``kg*m^2``, ``m/s``, ``deg``) into an SI scale
factor and a dimension vector, and name dimensions for diagnostics.

Dimensions are exponent tuples over (length, mass, time, angle).  Angles are a dimension of
their own so that ``30 deg`` cannot be compared with a length, but they are converted to
radians.  A number written without a unit has no fixed dimension (``None``): it takes the
dimension its context expects (a bare number in a time interval means seconds).
"""

from __future__ import annotations

import math
import re

Dim = tuple[int, int, int, int]  # L, M, T, A

DIMLESS: Dim = (0, 0, 0, 0)
LENGTH: Dim = (1, 0, 0, 0)
MASS: Dim = (0, 1, 0, 0)
TIME: Dim = (0, 0, 1, 0)
ANGLE: Dim = (0, 0, 0, 1)
SPEED: Dim = (1, 0, -1, 0)
ACCEL: Dim = (1, 0, -2, 0)
FORCE: Dim = (1, 1, -2, 0)
FREQ: Dim = (0, 0, -1, 0)
INERTIA: Dim = (2, 1, 0, 0)
AREA: Dim = (2, 0, 0, 0)
ANGLE2: Dim = (0, 0, 0, 2)

UNITS: dict[str, tuple[float, Dim]] = {
    "m": (1.0, LENGTH), "cm": (0.01, LENGTH), "mm": (0.001, LENGTH), "km": (1000.0, LENGTH),
    "s": (1.0, TIME), "ms": (0.001, TIME), "min": (60.0, TIME), "h": (3600.0, TIME),
    "kg": (1.0, MASS), "g": (0.001, MASS),
    "N": (1.0, FORCE), "J": (1.0, (2, 1, -2, 0)), "W": (1.0, (2, 1, -3, 0)),
    "Hz": (1.0, FREQ), "rpm": (1.0 / 60.0, FREQ),
    "rad": (1.0, ANGLE), "deg": (math.pi / 180.0, ANGLE), "°": (math.pi / 180.0, ANGLE),
}

_NAMES: dict[Dim, str] = {
    DIMLESS: "a plain number", LENGTH: "a length (m)", MASS: "a mass (kg)", TIME: "a time (s)",
    ANGLE: "an angle (rad, deg)", SPEED: "a speed (m/s)", ACCEL: "an acceleration (m/s^2)",
    FORCE: "a force (N)", FREQ: "a frequency (Hz)", INERTIA: "an inertia (kg*m^2)",
    AREA: "an area (m^2)", ANGLE2: "a squared angle (rad^2)",
}

_FACTOR = re.compile(r"([A-Za-z°µ]+)(?:\^(-?\d+))?")


MAX_EXPONENT = 12  # beyond this a unit power is a typo (and its scale may overflow)


class UnitError(ValueError):
    pass


class UnitRangeError(UnitError):
    """A unit that exists but with an exponent out of range (``km^400``)."""


def parse_unit(text: str) -> tuple[float, Dim]:
    """``"kg*m^2"`` → (1.0, (2, 1, 0, 0)); raises ``UnitError`` naming the unknown factor."""
    scale, dim = 1.0, [0, 0, 0, 0]
    sign = 1
    pos = 0
    while pos < len(text):
        m = _FACTOR.match(text, pos)
        if not m:
            raise UnitError(text[pos:])
        name, digits = m.group(1), m.group(2) or "1"
        if name not in UNITS:
            raise UnitError(name)
        exp = int(digits) if len(digits.lstrip("-")) <= 3 else MAX_EXPONENT + 1
        if abs(exp) > MAX_EXPONENT:
            raise UnitRangeError(f"unit exponent out of range in `{text}` "
                                 f"(at most {MAX_EXPONENT})")
        s, d = UNITS[name]
        scale *= s ** (sign * exp)
        for i in range(4):
            dim[i] += sign * exp * d[i]
        pos = m.end()
        if pos < len(text):
            sign = 1 if text[pos] == "*" else -1
            pos += 1
    return scale, tuple(dim)  # type: ignore[return-value]


def describe(d: Dim | None) -> str:
    if d is None:
        return "a plain number"
    if d in _NAMES:
        return _NAMES[d]
    parts = []
    for sym, e in zip(("m", "kg", "s", "rad"), d):
        if e:
            parts.append(sym if e == 1 else f"{sym}^{e}")
    return "a quantity in " + "*".join(parts)


def example_unit(d: Dim | None) -> str:
    return {LENGTH: "m", TIME: "s", ANGLE: "deg", SPEED: "m/s", ACCEL: "m/s^2", FORCE: "N",
            FREQ: "Hz", MASS: "kg", INERTIA: "kg*m^2", AREA: "m^2"}.get(d, "")


def mul(a: Dim | None, b: Dim | None) -> Dim | None:
    if a is None and b is None:
        return None
    a = a or DIMLESS
    b = b or DIMLESS
    return tuple(x + y for x, y in zip(a, b))  # type: ignore[return-value]


def div(a: Dim | None, b: Dim | None) -> Dim | None:
    if a is None and b is None:
        return None
    a = a or DIMLESS
    b = b or DIMLESS
    return tuple(x - y for x, y in zip(a, b))  # type: ignore[return-value]


def power(a: Dim | None, k: float) -> Dim | None:
    """The dimension of ``a ^ k``; ``UnitError`` unless every exponent stays a whole number
    (a non-finite ``k`` is an error for a quantity with a unit, never a crash)."""
    if a is None:
        return None
    if a == DIMLESS:
        return DIMLESS
    if not math.isfinite(k):
        raise UnitError("a unit raised to a non-finite power")
    if any(abs(x * k) > 100 * MAX_EXPONENT for x in a):
        raise UnitRangeError("unit exponent out of range")
    if any(x * k != round(x * k) for x in a):
        raise UnitError("fractional power of a unit")
    return tuple(int(round(x * k)) for x in a)  # type: ignore[return-value]


def compatible(a: Dim | None, b: Dim | None) -> bool:
    """Bare numbers (None) fit every dimension."""
    return a is None or b is None or a == b


def join(a: Dim | None, b: Dim | None) -> Dim | None:
    return a if a is not None else b


#: the unit a predicate's robustness is measured in, by dimension (``Origin.unit``)
UNIT_NAMES = {LENGTH: "m", SPEED: "m/s", ANGLE: "rad", FREQ: "Hz", TIME: "s",
              ACCEL: "m/s^2", FORCE: "N", MASS: "kg", DIMLESS: "1"}


def unit_name(dim: Dim | None) -> str:
    """The unit of a dimension ("" when unknown: a bare number compared with a bare one)."""
    if dim is None:
        return ""
    return UNIT_NAMES.get(dim) or describe(dim).removeprefix("a quantity in ")
