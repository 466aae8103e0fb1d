"""The risk section: per case, the distribution of the plan's exact robustness under the
uncertain human pose, VaR/CVaR with their DKW bounds, P(violation) and the driving spec.

The summary numbers come from ``risk.json`` (``Solution.risk``).  The histograms
need the per-realisation robustness, which ``risk.json`` does not hold: they are computed
from the ``risk_samples.npz`` arrays (``<case>/exact/requirement``) when the report is given
them, else from a ``histogram`` entry of the case; without either the table stands alone.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from stlc.semantics.model import Mission, Normal

from .common import anchor, fmt, fmt_vec, num, nums

#: histogram bins: numpy's "auto" rule, clipped to this range
MIN_BINS, MAX_BINS = 12, 60


def histogram(values: np.ndarray) -> dict | None:
    """Bin centres, widths and counts of the finite values (``None`` if there are none)."""
    x = np.asarray(values, float).ravel()
    x = x[np.isfinite(x)]
    if x.size == 0:
        return None
    lo, hi = float(x.min()), float(x.max())
    try:
        n = int(np.clip(len(np.histogram_bin_edges(x, bins="auto")) - 1, MIN_BINS, MAX_BINS))
    except (ValueError, MemoryError):  # a range too narrow for its magnitude
        n = MIN_BINS
    from stlc.analysis.risk import histogram_range

    lo, hi = histogram_range(lo, hi, n)
    counts, edges = np.histogram(x, bins=n, range=(lo, hi))
    return {"centers": nums((edges[:-1] + edges[1:]) / 2), "widths": nums(np.diff(edges)),
            "counts": [int(c) for c in counts]}


def _given_histogram(hist: object) -> dict | None:
    if not isinstance(hist, dict):
        return None
    edges = np.asarray(hist.get("edges") or [], float)
    counts = list(hist.get("counts") or [])
    if edges.size < 2 or len(counts) != edges.size - 1:
        return None
    return {"centers": nums((edges[:-1] + edges[1:]) / 2), "widths": nums(np.diff(edges)),
            "counts": nums(counts)}


def distribution_text(dists: tuple[Normal, ...]) -> str:
    """``operator.pos ~ N((0, 0, 0) m, diag(0.125, 0.125, 0) m²)`` (SI units)."""
    parts = []
    for d in dists:
        stems = {p.rsplit(".", 1)[0] for p in d.params}
        name = stems.pop() if len(stems) == 1 else ", ".join(d.params)
        cov = np.asarray(d.cov, float)
        if cov.size and np.allclose(cov, np.diag(np.diag(cov))):
            cov_text = "diag" + fmt_vec(np.diag(cov))
        else:
            cov_text = "[" + "; ".join(fmt_vec(r)[1:-1] for r in cov) + "]"
        m, m2 = (" m", " m²") if name.endswith(".pos") else ("", "")
        parts.append(f"{name} ~ N({fmt_vec(d.mean)}{m}, {cov_text}{m2})")
    return "; ".join(parts)


def _driver(c: dict, specs: list[dict]) -> str:
    driver = c.get("driver")
    if isinstance(driver, dict):
        driver = driver.get("spec") or driver.get("name")
    drivers = c.get("drivers") or {}
    if not driver and drivers:
        best = max(drivers.items(), key=lambda kv: (kv[1] or {}).get("count", 0))
        driver = best[0] if (best[1] or {}).get("count") else None
    if not driver and specs and specs[0]["p"]:
        driver = specs[0]["name"]
    return str(driver) if driver else ""


def _case(i: int, c: dict, mission: Mission | None, n_lines: int,
          samples: Mapping[str, np.ndarray] | None) -> dict:
    name = str(c.get("name", f"case {i + 1}"))
    var, cvar = c.get("var") or {}, c.get("cvar") or {}
    betas = sorted(set(var) | set(cvar), key=float)
    rows = []
    for b in betas:
        v, cv = var.get(b) or {}, cvar.get(b) or {}
        rows.append({"beta": str(b),
                     "var_text": fmt(v.get("value"), signed=True),
                     "var_lower_text": fmt(v.get("lower"), signed=True),
                     "var_upper_text": fmt(v.get("upper"), signed=True),
                     "cvar_text": fmt(cv.get("value"), signed=True),
                     "cvar_lower_text": fmt(cv.get("lower"), signed=True),
                     "cvar_upper_text": fmt(cv.get("upper"), signed=True),
                     "var": num(v.get("value")), "cvar": num(cv.get("value"))})
    drivers = c.get("drivers") or {}
    specs = []
    for k, sp in (c.get("specs") or {}).items():
        sp = sp if isinstance(sp, dict) else {"p_violation": sp}
        share = sp.get("driver_fraction", (drivers.get(k) or {}).get("fraction"))
        specs.append({"name": str(k), "p": num(sp.get("p_violation")),
                      "p_text": fmt(sp.get("p_violation")),
                      "p_upper_text": fmt(sp.get("p_violation_upper")),
                      "share_text": "—" if share is None else f"{100 * float(share):.0f} %"})
    specs.sort(key=lambda r: -(r["p"] if r["p"] is not None else -1.0))
    hist = None
    key = f"{name}/exact/requirement"
    if samples is not None and key in samples:
        hist = histogram(samples[key])
    if hist is None:
        hist = _given_histogram(c.get("histogram"))
    decl = next((rc for rc in (mission.risk.cases if mission and mission.risk else ())
                 if rc.name == name), None)
    line = decl.span.line if decl is not None and decl.span.known else 0
    pv = c.get("p_violation") or {}
    top = rows[-1] if rows else None
    return {
        "id": f"risk-{i}", "name": name,
        "distribution": distribution_text(decl.distributions) if decl else "",
        "line": line, "anchor": anchor(line, n_lines),
        "K": str(c.get("K", "—")), "delta": fmt(c.get("delta")),
        "seed": str(c.get("seed", "—")),
        "rows": rows,
        "var_lines": [{"beta": r["beta"], "value": r["var"], "cvar": r["cvar"],
                       "var_text": r["var_text"], "cvar_text": r["cvar_text"]} for r in rows
                      if r["var"] is not None],
        "p_violation": num(pv.get("value")),
        "p_violation_text": fmt(pv.get("value")),
        "p_violation_upper_text": fmt(pv.get("upper")),
        "count_text": f"{pv['count']} of {c.get('K', '?')}" if "count" in pv else "",
        "specs": specs,
        "driver": _driver(c, specs),
        "epsilon_text": fmt(c.get("epsilon")),
        "nominal": num(c.get("nominal_robustness")),
        "nominal_text": fmt(c.get("nominal_robustness"), signed=True),
        "range_text": (f"mean {fmt(c.get('mean'), signed=True)}, min "
                       f"{fmt(c.get('min'), signed=True)}, max "
                       f"{fmt(c.get('max'), signed=True)}") if "mean" in c else "",
        "top_beta": top["beta"] if top else "",
        "top_var_text": top["var_text"] if top else "—",
        "top_cvar_text": top["cvar_text"] if top else "—",
        "histogram": hist,
    }


def risk(data: object, mission: Mission | None = None, n_lines: int = 0,
         samples: Mapping[str, np.ndarray] | None = None) -> dict | None:
    """The ``risk`` section of the view model; ``None`` without a risk analysis."""
    if not isinstance(data, dict) or not data.get("cases"):
        return None
    cases = [_case(i, c, mission, n_lines, samples) for i, c in enumerate(data["cases"])
             if isinstance(c, dict)]
    betas = {c["top_beta"] for c in cases}
    return {"cases": cases, "top_beta": betas.pop() if len(betas) == 1 else "max β"}
