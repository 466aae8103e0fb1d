"""Risk assessment pass: a plan (a ``Solution``'s channels, or a trajectory CSV) and a
mission's risk cases → ``risk.json`` data and per-realisation samples (paper A §4.3).

``run_risk`` samples each case's uncertain human pose and re-evaluates the *fixed* plan's
exact and smooth robustness of the requirement and of each named spec for all K
realisations in one shared evaluation (``stlc.analysis.risk.shared_robustness``), then summarises
VaR/CVaR with DKW bounds, the violation probability, the spec that drives the violations
and a histogram (``stlc.analysis.risk``).  ``select_mission`` picks the mission
that ``stlc risk FILE --trajectory CSV`` assesses and ``risk_table`` prints its summary (the
command itself is ordered by ``stlc.pipeline.risk_file``).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any, Protocol

import numpy as np

from stlc.diagnostics import Diagnostic, Span, StlcError
from stlc.semantics import model, nnf
from stlc.semantics.specs import mission_named, mission_specs


class Plan(Protocol):
    """What the risk pass reads of a plan: its named channels (a ``Solution`` is one; the
    analysis layer sits below the planning layer and never imports it)."""

    channels: Mapping[str, np.ndarray]


class Planned(Protocol):
    """What the risk pass reads of a planning problem (``stlc.planning.problem``, a layer
    above): the requirement in NNF, the named specs, the smoothing and the grid."""

    requirement: Any
    specs: Mapping[str, Any]  # name -> NamedSpec
    smoothing: model.Smoothing
    grid: Any


def run_risk(program: model.Program, mission: model.Mission, sol: Plan, *,
             dt: float | None = None, shared=None, problem: Planned | None = None):
    """Risk cases of the mission on the plan of ``sol``; returns (risk dict, results), or
    (None, None) without a ``risk`` block.  ``dt`` is the plan's sample period (default:
    the problem's, else the mission's step).  With ``problem`` (the plan's planning
    problem) its requirement, named specs and smoothing are assessed, not rebuilt from the
    mission as written."""
    from stlc.analysis import risk as riskmod

    cfg = mission.risk
    if cfg is None:
        return None, None
    if problem is not None:
        requirement, named, smoothing = problem.requirement, problem.specs, problem.smoothing
        dt = problem.grid.dt if dt is None else dt
    else:
        requirement, named = nnf.normalize(mission.requirement), mission_specs(program, mission)
        smoothing = mission.smoothing
    specs = {k: s.normal for k, s in named.items()}
    base = tuple(d for h in program.scenario.humans for d in h.uncertain)
    results = riskmod.run_cases(cfg, requirement, specs,
                                mission.step if dt is None else dt, sol.channels,
                                program.params, smoothing.lam,
                                smoothing.method, base=base, shared=shared,
                                kappa=float(mission.threshold))
    out = {"mission": mission.name, "cases": [r.to_json() for r in results]}
    if cfg.levels:  # the mission's risk levels, judged per case (``risk_levels``)
        from stlc.analysis.risk_levels import judge_levels

        out["levels"] = {r.name: judge_levels(cfg.levels, r.exact["requirement"], cfg.delta)
                         for r in results}
    return out, results


def select_mission(path: str, program: model.Program, mission: str | None) -> model.Mission:
    """The mission to assess: ``mission``, or the only one with a ``risk`` block."""
    where = Span(path, 1, 1, 1, 2)
    with_risk = [m for m, mm in program.missions.items() if mm.risk is not None]
    if mission is not None:
        m = mission_named(path, program, mission)
        if m.risk is None:
            raise StlcError([Diagnostic(
                "STL109", f"mission `{mission}` has no `risk` block to assess", m.span,
                "add `risk { K = ...; case NAME { ... } }` to the mission"
                + (f", or use --mission {with_risk[0]}" if with_risk else ""))])
        return m
    if len(with_risk) == 1:
        return program.missions[with_risk[0]]
    if not with_risk:
        raise StlcError([Diagnostic("STL109", f"{path} has no mission with a `risk` block",
                                    where, "add `risk { ... }` to a mission")])
    raise StlcError([Diagnostic("STL109", f"{path} has {len(with_risk)} missions with a "
                                "`risk` block: which one planned this trajectory?", where,
                                "pass --mission NAME (one of " + ", ".join(with_risk) + ")")])


def risk_table(risk_json: dict, source: str = "") -> str:
    """A short text table: per case, P(violation) with its upper bound, VaR_β and CVaR_β of
    the exact robustness (bounds are in ``risk.json``) and the driving spec."""
    cases = risk_json.get("cases", [])
    if not cases:
        return "no risk cases"
    betas = list(cases[0]["var"])
    head = [f"mission {risk_json.get('mission', '?')}"
            + (f" on {source}" if source else "")
            + f": K = {cases[0]['K']}, δ = {cases[0]['delta']:g}, seed {cases[0]['seed']}"]
    cols = (["case", "P(viol)", "≤ upper"] + [f"VaR{b}" for b in betas]
            + [f"CVaR{b}" for b in betas] + ["driver"])
    rows = []
    for c in cases:
        pv = c["p_violation"]
        rows.append([c["name"], _fmt(pv["value"]), _fmt(pv["upper"])]
                    + [_fmt(c["var"][b]["value"], signed=True) for b in betas]
                    + [_fmt(c["cvar"][b]["value"], signed=True) for b in betas]
                    + [c.get("driver") or "-"])
    widths = [max(len(r[i]) for r in [cols, *rows]) for i in range(len(cols))]
    lines = ["  ".join(x.ljust(w) if i in (0, len(cols) - 1) else x.rjust(w)
                       for i, (x, w) in enumerate(zip(r, widths, strict=True))).rstrip()
             for r in [cols, *rows]]
    return "\n".join(head + lines)


def _fmt(x, signed: bool = False) -> str:
    if x is None:
        return "-"
    return f"{x:+.4f}" if signed else f"{x:.4f}"
