"""Risk assessment pass: a plan (a ``Solution``'s channels, or a trajectory CSV) and a
mission's risk cases → ``risk.json`` data and per-realisation samples (paper A §4.3).

``run_risk`` samples each case's uncertain human pose, re-evaluates the *fixed* plan's exact
and smooth robustness for the requirement and each named spec, and summarises VaR/CVaR with
DKW bounds and the violation probability (``stlc.risk``).  ``risk_file`` is ``stlc risk``.
"""

from __future__ import annotations

import json
import os

from stlc import ir, model
from stlc.compile import mission_specs
from stlc.diagnostics import Diagnostic, Span, StlcError
from stlc.solution import Solution

EXIT_OK = 0


def run_risk(program: model.Program, mission: model.Mission, sol: Solution):
    """Risk cases of the mission on the plan of ``sol``; returns (risk dict, results)."""
    from stlc import risk as riskmod

    cfg = mission.risk
    if cfg is None:
        return None, None
    specs = {k: ir.normalize(f) for k, (f, _) in mission_specs(program, mission).items()}
    base = tuple(d for h in program.scenario.humans for d in h.uncertain)
    results = riskmod.run_cases(cfg, ir.normalize(mission.requirement), specs, mission.step,
                                sol.channels, program.params, mission.smoothing.lam,
                                mission.smoothing.method, base=base)
    return {"cases": [r.to_json() for r in results]}, results


def risk_file(path: str, trajectory: str, mission: str | None = None,
              out: str | None = None) -> int:
    from stlc.pipeline import load
    from stlc.trace import check_signals, read_trace

    program = load(path).program
    names = [mission] if mission else [m for m, mm in program.missions.items() if mm.risk]
    if not names or any(n not in program.missions for n in names):
        raise StlcError([Diagnostic("STL109", "no mission with a `risk` block to assess",
                                    Span(path, 1, 1, 1, 2), "pass --mission NAME")])
    trace = read_trace(trajectory)
    for name in names:
        m = program.missions[name]
        check_signals(trace, ir.signals(m.requirement))
        sol = Solution(m.name, "satisfied", 0.0, 0.0, {}, 0.0, trace.times, trace.channels)
        risk_json, results = run_risk(program, m, sol)
        if risk_json is None:
            continue
        outdir = out or os.path.dirname(os.path.abspath(trajectory))
        os.makedirs(outdir, exist_ok=True)
        with open(os.path.join(outdir, "risk.json"), "w") as fh:
            json.dump(risk_json, fh, indent=2, allow_nan=False)
        from stlc.risk import save_samples

        save_samples(os.path.join(outdir, "risk_samples.npz"), results)
        _print_risk(risk_json)
    return EXIT_OK


def _print_risk(risk_json: dict) -> None:
    for c in risk_json["cases"]:
        var = "  ".join(f"VaR{b}={v['value']:+.3f}" for b, v in c["var"].items())
        print(f"{c['name']}: K={c['K']}  p_violation={c['p_violation']['value']:.3f}  {var}")
