"""The instances of a sweep: ``--vary 'NAME=LO:HI:N'`` axes (a grid, ends included) or
``--random N`` draws from the same box; each instance is a list of ``--set`` items whose
values are written in the unit of the axis' LO, so that a worker applies exactly the value
in the CSV (SI) through the same ``--set`` path as ``stlc compile``."""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np

from stlc.diagnostics import Diagnostic, Span, StlcError
from stlc.semantics import overrides
from stlc.semantics.check import units

MAX_INSTANCES = 100_000


@dataclass(frozen=True)
class Axis:
    name: str
    lo: float  # in ``unit``
    hi: float
    n: int
    unit: str | None
    scale: float  # unit → SI

    def text(self, x: float) -> str:
        return f"{x!r} {self.unit}" if self.unit else repr(x)

    def shown(self, si: float) -> float:
        """An SI value of this axis in the unit it was given in (degrees stay degrees),
        to 12 significant digits (the round trip through SI is not exact)."""
        return float(f"{si / self.scale:.12g}")

    @property
    def label(self) -> str:
        """``operator.att.z (deg)``: the name with the unit it was given in."""
        return f"{self.name} ({self.unit})" if self.unit else self.name


def _err(path: str, msg: str, hint: str) -> StlcError:
    return StlcError([Diagnostic("STL201", msg, Span(path, 1, 1, 1, 2), hint)])


def parse_axis(path: str, text: str) -> Axis:
    """``NAME=LO:HI:N``; LO and HI carry units (HI is converted to LO's unit)."""
    name, sep, rest = text.partition("=")
    parts = rest.split(":")
    hint = "write `--vary 'operator.att.z=-30 deg:30 deg:6'` (LO:HI:N, ends included)"
    if not sep or len(parts) != 3 or not name.strip():
        raise _err(path, f"--vary {text!r}: expected NAME=LO:HI:N", hint)
    name = name.strip()
    try:
        n = int(parts[2])
    except ValueError:
        raise _err(path, f"--vary {name}: N = {parts[2]!r} is not a whole number", hint) from None
    if not 1 <= n <= MAX_INSTANCES:
        raise _err(path, f"--vary {name}: N = {n} is out of range 1..{MAX_INSTANCES}", hint)
    q = [overrides._quantity(p) for p in parts[:2]]
    for p, x in zip(parts[:2], q):
        if isinstance(x, str):
            raise _err(path, f"--vary {name}: {x}", hint)
    (lo_si, lo_u, lo_d), (hi_si, hi_u, hi_d) = q  # type: ignore[misc]
    if lo_d != hi_d:
        raise StlcError([Diagnostic("STL204", f"--vary {name}: LO is {units.describe(lo_d)}, "
                                    f"HI is {units.describe(hi_d)}", Span(path, 1, 1, 1, 2),
                                    hint)])
    scale = units.parse_unit(lo_u)[0] if lo_u else 1.0
    lo = float(overrides._NUMBER.fullmatch(parts[0]).group(1))  # type: ignore[union-attr]
    return Axis(name, lo, hi_si / scale, n, lo_u, scale)


def instances(axes: list[Axis], random: int | None = None, seed: int = 0
              ) -> list[list[tuple[str, float, str]]]:
    """Each instance: [(name, SI value, --set value text)] per axis."""
    if random is not None:
        rng = np.random.default_rng(seed)
        pts = [[a.lo + (a.hi - a.lo) * float(rng.random()) for a in axes] for _ in range(random)]
    else:
        total = int(np.prod([a.n for a in axes]))
        if total > MAX_INSTANCES:
            raise ValueError(f"{total} instances (limit {MAX_INSTANCES})")
        grids = [np.linspace(a.lo, a.hi, a.n).tolist() if a.n > 1 else [a.lo] for a in axes]
        pts = [list(p) for p in itertools.product(*grids)]
    return [[(a.name, x * a.scale, a.text(x)) for a, x in zip(axes, p)] for p in pts]
