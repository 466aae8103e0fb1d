"""The report's view model: a plain, JSON-serialisable dict built from a ``Solution``.

``build_view(program, mission, solution)`` is the only place that looks at the program, the
mission and the solution; the templates and the page script see nothing but the dict it
returns (str, bool, int, float, None, lists and dicts).  Every float is rounded to about five
significant digits and non-finite numbers become ``None`` (the text fields say ``+∞``), so the
plot data can be written into the page with ``json.dumps(..., allow_nan=False)``.

Sections: ``summary``, ``banner`` (``None`` when the mission is satisfied), ``specs`` (the
requirements table), ``scene`` (``scene.py``), ``signals`` (``signals.py``), ``energy``,
``team`` (``team_view.py``; ``None`` unless the plan is a team plan), ``risk``
(``risk_view.py``; ``None`` without a risk analysis) and ``source`` (numbered
lines, diagnostics).

``energy``: ``Solution.energy_profile`` is the energy of each sample (J, summing to
``Solution.energy``); each of ``Solution.comparisons`` (from ``compare NAME { … }``)
carries its own energy, exact robustness, peaks and profile.  Energy is the rotor power of
multirotors; a mission of point masses has none, and the section says so.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np

from stlc.planning import words
from stlc.planning.solution import Solution
from stlc.semantics.model import Mission, Objective, Program
from stlc.vehicles import model_of

from .common import anchor, fmt, indexed, num, nums, speed, vehicles
from .flags import flags
from .predicates import readable
from .flight_view import flight as flight_section
from .replan_view import replan
from .risk_view import risk
from .scene import scene
from .signals import signals, spec_formulas, windows
from .team_view import team

STATUS_LABELS = {"satisfied": "Satisfied", "violated": "Violated",
                 "solver_failed": "Solver failed", "infeasible": "No plan exists",
                 "stopped": "Stopped (time limit)"}
STAGE_LABELS = {"lam": "λ", "solve_s": "solve (s)", "smooth": "planner ρ̃", "exact": "exact ρ"}
#: stage columns holding a robustness (shown with a sign)
SIGNED_STAGE_KEYS = ("smooth", "exact")
TIMING_ORDER = ("parse_s", "check_s", "build_s", "guess_s", "solve_s", "risk_s", "total_s")



def _plain(v) -> str:
    """A solver record's value as text: lists and mappings spelled out, not as Python."""
    if isinstance(v, dict):
        return "; ".join(f"{k}: {_plain(x)}" for k, x in v.items()) or "—"
    if isinstance(v, (list, tuple)):  # a list of records: one record per "; "
        sep = "; " if any(isinstance(x, (list, tuple, dict)) for x in v) else ", "
        return sep.join(_plain(x) for x in v) if v else "—"
    if isinstance(v, float):
        return fmt(v)
    return str(v)

def _cell(v: object, signed: bool = False) -> str:
    if isinstance(v, bool) or v is None or isinstance(v, str):
        return "—" if v is None else str(v)
    if isinstance(v, int):
        return str(v)
    return fmt(v, signed=signed)


def objective_text(obj: Objective) -> str:
    """The weights that tell the plans apart: ``w = 0.5`` (energy), ``η = 1`` (forward)."""
    parts = []
    if obj.energy_weight or not obj.forward_weight:
        parts.append(f"w = {fmt(obj.energy_weight)}")
    if obj.forward_weight:
        parts.append(f"η = {fmt(obj.forward_weight)}")
    return ", ".join(parts)


def _peak(arrays: list[np.ndarray]) -> float | None:
    vals = [float(np.nanmax(a)) for a in arrays if a.size and np.isfinite(a).any()]
    return max(vals) if vals else None


def energy(program: Program, mission: Mission, sol: Solution) -> dict:
    """The ``energy`` section of the view model."""
    t = np.asarray(sol.times, float)
    names = vehicles(mission, sol)
    modelled = any(model_of(program.vehicles[v]).has_rotor_energy(program.vehicles[v])
                   for v in names if v in program.vehicles) and num(sol.energy) is not None

    def axis(n: int) -> list[float | None]:
        return nums(t) if n == t.size else nums(np.arange(n) * mission.step)

    speeds = [s for v in names if (s := speed(sol, v)) is not None]
    rotor = [c for v in names for _, c in indexed(sol, f"{v}.rotor_speed")]
    variants = dict(mission.options.get("compare") or [])  # type: ignore[call-overload]
    plans = [{"label": f"this plan ({objective_text(mission.objective)})",
              "energy": sol.energy, "robustness_exact": sol.robustness_exact,
              "peak_speed": _peak(speeds), "peak_rotor_speed": _peak(rotor),
              "energy_profile": sol.energy_profile}]
    for comp in sol.comparisons:
        c = {"label": comp.label, "energy": comp.energy,
             "robustness_exact": comp.robustness_exact, "peak_speed": comp.peak_speed,
             "peak_rotor_speed": comp.peak_rotor_speed, "energy_profile": comp.energy_profile}
        label = str(c.get("label", ""))
        obj = variants.get(label)
        if isinstance(obj, Objective):
            label = f"{label} ({objective_text(obj)})"
        plans.append({**c, "label": label})
    base = num(sol.energy)
    columns, profiles = [], []
    for i, p in enumerate(plans):
        e = num(p.get("energy"))
        delta = "—"
        if i and e is not None and base:
            delta = (f"{fmt(e - base, signed=True, unit='J')} "
                     f"({fmt(100 * (e - base) / base, 3, signed=True)} %)")
        columns.append({"label": str(p.get("label", "")),
                        "energy_text": fmt(p.get("energy"), 5, unit="J") if modelled else "—",
                        "delta_text": delta if modelled else "—",
                        "robustness_text": fmt(p.get("robustness_exact"), signed=True),
                        "peak_speed_text": fmt(p.get("peak_speed"), unit="m/s"),
                        "peak_rotor_speed_text": fmt(p.get("peak_rotor_speed"), unit="Hz")})
        prof = p.get("energy_profile")
        if modelled and prof is not None and len(prof):  # type: ignore[arg-type]
            arr = np.asarray(prof, float).ravel()
            profiles.append({"name": str(p.get("label", "")), "x": axis(arr.size),
                             "y": nums(arr), "cumulative": nums(np.cumsum(arr))})
    return {
        "modelled": modelled,
        "per_vehicle": [{"name": k, "text": fmt(e, 5, unit="J")}
                        for k, e in sol.energy_by_vehicle.items()] if len(names) > 1 else [],
        "total": num(sol.energy) if modelled else None,
        "total_text": fmt(sol.energy, 5, unit="J") if modelled else "—",
        "has_profile": bool(profiles),
        "has_comparison": len(plans) > 1,
        "profiles": profiles,
        "columns": columns,
    }


def _objective(mission: Mission) -> str:
    """``minimise 0.5·E − ρ̃``: the mission's objective with its weights."""
    o = mission.objective
    terms = [f"{fmt(w)}·{sym}" for w, sym in ((o.energy_weight, "E"),
                                              (o.forward_weight, "Σ(1 − v/v*)²")) if w]
    text = " + ".join(terms)
    if o.robustness_weight:
        rho = "ρ̃" if o.robustness_weight == 1 else f"{fmt(o.robustness_weight)}·ρ̃"
        text = f"{text} − {rho}" if text else f"−{rho}"
    return f"minimise {text}" if text else "—"


def _summary(program: Program, mission: Mission, sol: Solution, energy_text: str) -> dict:
    smoothing = {"method": mission.smoothing.method, **sol.smoothing}
    declared = smoothing.get("lambda", smoothing.get("lam", mission.smoothing.lam))
    lam = smoothing.get("lambda_final", smoothing.get("lam", declared))
    lam_text = fmt(lam)
    if num(declared) is not None and num(lam) != num(declared):
        lam_text += f" (declared {fmt(declared)})"
    timing = [{"name": k.removesuffix("_s"), "text": fmt(sol.timing[k], 3, unit="s")}
              for k in (*TIMING_ORDER, *sorted(set(sol.timing) - set(TIMING_ORDER)))
              if k in sol.timing]
    solver_extra = [{"name": str(k), "text": _plain(v)} for k, v in sol.solver.items()
                    if k not in ("name", "iterations", "return_status", "stages", "chain")]
    chain = sol.solver.chain.to_json() if sol.solver.chain is not None else {}
    chain_text = (f"{chain.get('name', '?')}{' (forced)' if chain.get('forced') else ''}: "
                  + " → ".join(f"{st['backend']} ({st['status']})"
                               for st in chain.get("stages", []))) if chain else "—"
    stages = [s if isinstance(s, dict) else vars(s) for s in sol.solver.stages or []
              if isinstance(s, dict) or hasattr(s, "__dict__")]
    stage_keys = list(dict.fromkeys(k for s in stages for k in s))
    o = mission.objective
    return {
        "mission": sol.mission or mission.name,
        "file": program.file,
        "status": sol.status,
        "status_label": ("Stopped (Ctrl-C)" if sol.solver.stopped_by == "interrupted" else
                         STATUS_LABELS.get(sol.status, sol.status)),
        "robustness_exact": num(sol.robustness_exact),
        "robustness_exact_text": fmt(sol.robustness_exact, signed=True),
        "robustness_smooth": num(sol.robustness_smooth),
        "robustness_smooth_text": fmt(sol.robustness_smooth, signed=True),
        "threshold_text": fmt(mission.threshold),
        "verdict_text": words.verdict_line(sol.status, sol.robustness_exact, mission.threshold),
        "energy": num(sol.energy),
        "energy_text": energy_text,
        "vehicles": [{"name": v, "kind": getattr(program.vehicles.get(v), "kind", "?")}
                     for v in mission.vehicles],
        "horizon_text": fmt(mission.horizon, unit="s"),
        "step_text": fmt(mission.step, unit="s"),
        "samples": len(sol.times),
        "timing": timing,
        "solve_text": fmt(sol.timing.get("solve_s"), 3, unit="s"),
        "total_text": fmt(sol.timing.get("total_s"), 3, unit="s"),
        "solver_name": str(sol.solver.name or "—"),
        "iterations": str(_or_dash(sol.solver.iterations)),
        "return_status": str(_or_dash(sol.solver.return_status)),
        "solver_extra": solver_extra,
        "chain_text": chain_text,
        "smoothing_method": str(smoothing.get("method", "—")),
        "smoothing_lam_text": lam_text,
        "smoothing_schedule": ", ".join(fmt(x) for x in smoothing.get("schedule") or []),
        "problem_size": [{"name": str(k), "text": str(v)} for k, v in sol.problem_size.items()],
        "stages": {"columns": [STAGE_LABELS.get(k, k) for k in stage_keys],
                   "rows": [[_cell(s.get(k), k in SIGNED_STAGE_KEYS) for k in stage_keys]
                            for s in stages]},
        "objective": {
            "text": _objective(mission),
            "robustness_weight_text": fmt(o.robustness_weight),
            "energy_weight_text": fmt(o.energy_weight),
        },
        "notes": [str(x) for x in sol.notes],
    }


def _spec_line(program: Program, mission: Mission, name: str, given: int) -> tuple[int, int]:
    """First and last source line of a named spec (``given`` overrides the first).  A span
    ends where the next declaration starts and may take in the comments before it: those
    lines are not the spec's."""
    text = program.source.splitlines()
    for spans in (mission.spec_spans, program.spec_spans):
        sp = spans.get(name)
        if sp is not None and sp.known:
            first = given or sp.line
            last = sp.end_line - 1 if sp.end_col <= 1 else sp.end_line
            last = min(last, len(text))
            while last > first and _split_comment(text[last - 1])[0].strip() == "":
                last -= 1
            return first, max(first, last)
    return given, given


def _spec_rows(program: Program, mission: Mission, sol: Solution,
               wins: list[dict]) -> list[dict]:
    n_lines = len(program.source.splitlines())
    rows = []
    for name, r in sol.specs.items():
        line, end_line = _spec_line(program, mission, name, r.line)
        pline = r.binding_line
        win = [w for w in wins if w["spec"] == name]
        rows.append({
            "name": name,
            "robustness": num(r.robustness),
            "robustness_text": fmt(r.robustness, signed=True),
            "smooth_text": fmt(r.smooth, signed=True),
            "satisfied": bool(r.satisfied),
            "verdict": "satisfied" if r.satisfied else "violated",
            "tightest_time": num(r.tightest_time),
            "tightest_text": fmt(r.tightest_time, unit="s") if r.tightest_time is not None
            else "—",
            "binding_predicate": readable(r.binding_origin, r.binding_predicate),
            "binding_predicate_raw": r.binding_predicate or "",
            "line": line, "end_line": end_line,
            "anchor": anchor(line, n_lines),
            "predicate_line": pline,
            "predicate_anchor": anchor(pline, n_lines),
            "window_text": ", ".join(w["text"] for w in win) or "—",
            "window_color": win[0]["color"] if win else "",
        })
    worst = max((abs(row["robustness"]) for row in rows if row["robustness"] is not None),
                default=0.0) or 1.0
    for row in rows:
        rho = row["robustness"]
        row["bar"] = 0.0 if rho is None else round(min(1.0, abs(rho) / worst) * 100, 1)
    return rows


def _banner(sol: Solution, rows: list[dict], kappa: float) -> dict | None:
    if sol.status == "satisfied":
        return None
    failing = [r for r in rows if not r["satisfied"]]
    worst = min(failing or rows, key=lambda r: (r["robustness"] is None, r["robustness"] or 0),
                default=None)
    if sol.status == "infeasible":
        conflict = ", ".join(f"`{c}`" for c in sol.conflict)
        return {"status": sol.status, "title": "No plan exists", "spec": None,
                "lead": f"No plan can reach κ = {fmt(kappa)}: proved by a MILP over a "
                        f"relaxation containing every trajectory the vehicles can fly; the "
                        f"conflicting specs: {conflict}. The plan below is the best attempt "
                        f"(exact robustness ρ = {fmt(sol.robustness_exact, signed=True)})."}
    if sol.status == "solver_failed":
        title = "Solver failed"
        rec = sol.solver
        lead = (f"{rec.name if 'name' in rec else 'The solver'} stopped with return status "
                f"“{_or(rec.return_status, 'unknown')}” after "
                f"{_or(rec.iterations, '?')} iterations; the plan below is its last "
                f"iterate; {words.impossibility_note(rec.infeasibility)}.")
    elif sol.status == "stopped" and sol.solver.stopped_by == "interrupted":
        title = "Stopped by Ctrl-C"
        lead = (f"Ctrl-C (with --keep-on-interrupt) ended the search before a satisfying "
                f"plan was found; the plan below is the best verified one (exact robustness "
                f"ρ = {fmt(sol.robustness_exact, signed=True)} < κ = {fmt(kappa)}).")
    elif sol.status == "stopped":
        title = "Stopped by the time limit"
        lead = (f"The time limit of {_or(sol.solver.time_limit_s, '?')} s ended the search "
                f"before a satisfying plan was found; the plan below is the best verified one "
                f"(exact robustness ρ = {fmt(sol.robustness_exact, signed=True)} < κ = "
                f"{fmt(kappa)}); {words.impossibility_note(sol.solver.infeasibility)}.")
    else:
        title = "Mission violated"
        lead = (f"No satisfying plan was found: exact robustness ρ = "
                f"{fmt(sol.robustness_exact, signed=True)} < κ = {fmt(kappa)}; "
                f"{words.impossibility_note(sol.solver.infeasibility)}.")
    out = {"status": sol.status, "title": title, "lead": lead, "spec": None}
    if worst is not None and not worst["satisfied"]:
        out["spec"] = {k: worst[k] for k in ("name", "robustness_text", "tightest_text",
                                              "binding_predicate", "binding_predicate_raw",
                                              "anchor", "predicate_anchor")}
        out["spec"]["margin_text"] = fmt(-(worst["robustness"] or 0.0)) \
            if worst["robustness"] is not None else fmt(math.inf)
    return out


def _split_comment(text: str) -> tuple[str, str]:
    """Code and ``# comment`` of a source line (a ``#`` inside a string is code)."""
    quoted = False
    for i, ch in enumerate(text):
        if ch == '"':
            quoted = not quoted
        elif ch == "#" and not quoted:
            return text[:i], text[i:]
    return text, ""


def _source(program: Program, mission: Mission, sol: Solution, rows: list[dict]) -> dict:
    from stlc.frontend.lexer import highlight_lines

    text = program.source.splitlines()
    html = highlight_lines(program.source)  # escaped HTML per line (Pygments, `stlc` lexer)
    html = html if len(html) == len(text) else [""] * len(text)
    spec_lines = {n for r in rows if r["line"] for n in range(r["line"], r["end_line"] + 1)}
    fail_lines = {r["line"] for r in rows if not r["satisfied"]} | \
        {r["predicate_line"] for r in rows if not r["satisfied"]}
    binding = {r["predicate_line"] for r in rows if r["predicate_line"]}
    diags = []
    for d in sol.diagnostics:
        line = d.span.line if d.span.known else 0
        diags.append({"code": d.code, "severity": d.severity, "message": d.message,
                      "line": line, "anchor": anchor(line, len(text)), "help": d.help or ""})
    diag_lines = {d["line"] for d in diags}
    m_lo, m_hi = (mission.span.line, mission.span.end_line) if mission.span.known else (0, -1)
    lines = []
    for n, s in enumerate(text, start=1):
        cls = [c for c, on in (("in-mission", m_lo <= n <= m_hi), ("spec", n in spec_lines),
                               ("binding", n in binding), ("fail", n in fail_lines),
                               ("diag", n in diag_lines)) if on]
        code, comment = _split_comment(s)
        lines.append({"n": n, "id": f"L{n}", "code": code, "comment": comment,
                      "html": html[n - 1], "cls": " ".join(cls)})
    return {"file": program.file, "lines": lines, "diagnostics": diags}


def build_view(program: Program, mission: Mission, solution: Solution,
               risk_samples: Mapping[str, np.ndarray] | None = None,
               simulation=None, flight=None) -> dict:
    """Everything the report shows, as plain JSON-serialisable data.

    ``risk_samples``: the per-realisation arrays of ``risk_samples.npz`` (keys
    ``<case>/exact/requirement``, …), for the risk histograms.  ``simulation``: the
    ``stlc.replan.result.SimulationResult`` of ``stlc simulate``, for its section;
    ``flight``: ``stlc fly``'s record and flown channels (``flight_view``).
    """
    wins = windows(mission, solution, spec_formulas(program, mission, solution))
    rows = _spec_rows(program, mission, solution, wins)
    markers = [{"spec": r["name"], "t": r["tightest_time"], "label": f"{r['name']} fails"}
               for r in rows if not r["satisfied"] and r["tightest_time"] is not None]
    en = energy(program, mission, solution)
    summary = _summary(program, mission, solution, en["total_text"])
    summary["flags"] = flags(program, mission, solution)
    held = sum(r["satisfied"] for r in rows)
    summary["specs_text"] = (f"{held} of {len(rows)} specs hold" if rows
                             else f"κ = {summary['threshold_text']}")
    return {
        "title": f"{summary['mission']} — stlc mission report",
        "summary": summary,
        "banner": _banner(solution, rows, mission.threshold),
        "specs": rows,
        "scene": scene(program, mission, solution),
        "signals": signals(program, mission, solution, wins, rows, markers),
        "energy": en,
        "team": team(program, mission, solution),
        "replan": replan(program, mission, solution, simulation),
        "flight": flight_section(solution, flight),
        "risk": risk(solution.risk, mission, len(program.source.splitlines()),
                     risk_samples),
        "source": _source(program, mission, solution, rows),
    }


def _or_dash(value):
    return _or(value, "—")


def _or(value, default):
    return default if value is None else value
