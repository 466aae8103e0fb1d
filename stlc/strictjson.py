"""Strict JSON and trace CSV text, used by the writers of every layer.

``json_number``/``strict``/``strict_dumps`` never write NaN or Infinity (RFC 8259 has
neither): finite numbers stay numbers, ±∞ become ``"inf"``/``"-inf"``, NaN becomes
``null``.  ``channels_csv`` writes a trace (``t`` and one column per channel).
"""

from __future__ import annotations

import csv
import io
import json
import math

import numpy as np


def channels_csv(times, channels: dict[str, np.ndarray]) -> str:
    """A trace as CSV: ``t`` and one column per channel (``trajectory.csv``,
    ``executed.csv``).  Every number is written round-trip exact (``repr``: the shortest
    text that reads back as the same float64), so the plan in the file is the plan the
    exact monitor verified, at any coordinate (1e-9 m at a UTM northing of 5.4e6 m)."""
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    names = list(channels)
    w.writerow(["t", *names])
    for k, t in enumerate(times):
        w.writerow([repr(float(t)), *(repr(float(channels[c][k])) for c in names)])
    return buf.getvalue()


def json_number(x) -> float | str | None:
    """A number as strict JSON (RFC 8259 has no NaN or Infinity): finite values as numbers,
    +∞ and −∞ as the strings ``"inf"`` and ``"-inf"`` (``float()`` reads them back), an
    undefined value (NaN) as ``null``."""
    if x is None:
        return None
    x = float(x)
    if math.isfinite(x):
        return x
    return None if math.isnan(x) else ("inf" if x > 0 else "-inf")


def strict(o):
    """``o`` with every float (also numpy scalars and arrays) made strict JSON by
    ``json_number``; containers are copied, other values kept."""
    if isinstance(o, dict):
        return {k: strict(v) for k, v in o.items()}
    if isinstance(o, (list, tuple)):
        return [strict(v) for v in o]
    if isinstance(o, np.ndarray):
        return strict(o.tolist())
    if isinstance(o, np.generic):
        o = o.item()
    if isinstance(o, float):
        return json_number(o)
    return o


def strict_dumps(o, **kw) -> str:
    """``json.dumps`` that never writes NaN or Infinity (see ``json_number``)."""
    return json.dumps(strict(o), allow_nan=False, default=_json_default, **kw)


def _json_default(o):
    if isinstance(o, np.generic):
        return o.item()
    if isinstance(o, np.ndarray):
        return o.tolist()
    raise TypeError(f"not JSON serialisable: {type(o)}")
