"""The risk-driven re-plan decision of paper A §6: the human moves during the mission.

``simulate_move(problem, sol, move)``: at ``move.time`` the human's pose becomes
``move.pos``/``move.att``.  The current plan is judged at the new pose — its exact
robustness (the mission's requirement, all of it, with the new pose for the whole
trajectory: the pose is a constant of the formula) and, when the mission declares risk
cases, VaR/CVaR of that robustness under each case's distribution moved to the new pose.
They are recorded (``risk_ok``: VaR_β ≥ 0 at the largest β).  The plan is kept and flown
when it still meets κ and every risk level of the mission's ``risk`` block (``require
cvar(0.9) >= 0 m``, …; ``stlc.analysis.risk_levels``) holds in every case at the new pose.
Otherwise the rest of the mission is replanned from the current state:
the same parametric NLP (``nlp_cache``: the new pose is a parameter value, nothing is
rebuilt) with every sample up to the event fixed to what was flown, warm-started from the
current plan — or from the nearest plan of ``library`` (a sweep's ``plans/`` directory:
``--library DIR``) — and the whole λ/energy schedule (``backends.replan.move``, handed in
by the pipeline).  The new plan is flown when its
exact robustness at the new pose is ≥ κ; the record says what the decision was made on.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from stlc.analysis import verdict
from stlc.replan.result import ReplanEvent, SimulationResult


@dataclass(frozen=True)
class Move:
    """``--move HUMAN@T:X,Y,Z[:YAW_DEG]`` or ``move operator { time; pos; att }``."""

    human: str
    time: float  # s
    pos: tuple[float, float, float]  # m
    att: tuple[float, float, float] | None = None  # rad (None: unchanged)


def moved_program(program, move: Move):
    from stlc.semantics.instance import Setting, apply_values

    sets = [Setting(f"{move.human}.pos.{a}", "", float(move.pos[i]), "human")
            for i, a in enumerate("xyz")]
    if move.att is not None:
        sets += [Setting(f"{move.human}.att.{a}", "", float(move.att[i]), "human")
                 for i, a in enumerate("xyz")]
    return apply_values(program, sets)


def _risk(program, mission, channels, times, problem) -> dict | None:
    """VaR/CVaR of the plan at the (moved) pose under the mission's risk cases."""
    if mission.risk is None:
        return None
    from stlc.analysis.assess import run_risk
    from stlc.planning.solution import Solution

    s = Solution(mission.name, "satisfied", 0.0, 0.0, {}, 0.0, times, channels)
    risk_json, _ = run_risk(program, mission, s, problem=problem)
    return risk_json


def _risk_ok(risk: dict | None) -> bool | None:
    """Every case's VaR of the robustness at its largest β is ≥ 0 (None: no risk cases)."""
    vals = []
    for case in (risk or {}).get("cases", []):
        var = case.get("var") or {}
        if var:
            vals.append(float(var[max(var, key=float)]["value"]))
    return all(v >= 0 for v in vals) if vals else None


def simulate_move(problem, sol, move: Move, library: str | None = None, *,
                  replanner) -> SimulationResult:
    """``replanner(problem, flown, k_e, library, pose) -> (channels, info)`` plans the rest
    of the mission (the problem at the new pose; the pipeline passes
    ``backends.replan.move.replan_rest``)."""
    from stlc.analysis import monitor

    m, grid = problem.mission, problem.grid
    kappa = problem.threshold
    program = moved_program(problem.program, move)
    dt, times = grid.dt, grid.times()
    k_e = min(int(np.ceil(move.time / dt - 1e-9)), grid.n - 1)
    before = float(monitor.robustness(problem.requirement, dt, sol.channels, program.params))
    risk = _risk(program, m, sol.channels, times, problem)
    risk_ok = _risk_ok(risk)
    failed = [f"{case}: {lv['level']}" for case, lvs in ((risk or {}).get("levels") or {}).items()
              for lv in lvs if not lv["holds"]]
    replan = before < kappa or bool(failed)  # κ, then the mission's risk levels
    vehicle = problem.team[0]
    detail: dict = {"human": move.human, "pos": list(move.pos),
                    "att_deg": None if move.att is None else list(np.rad2deg(move.att)),
                    "robustness_nominal_pose": float(sol.robustness_exact),
                    "robustness_new_pose": before, "threshold": kappa,
                    "risk": risk, "risk_ok": risk_ok, "risk_levels_failed": failed,
                    "decision": "replan" if replan else "keep",
                    "decided_by": "threshold" if before < kappa else
                    "risk level" if failed else "threshold and risk levels"}
    ev = ReplanEvent(move.time, vehicle, 0.0, replan, kind="move", detail=detail)
    executed = dict(sol.channels)
    if replan:
        pose = {f"{move.human}.{f}.{a}": v[i] for f, v in (("pos", move.pos), ("att", move.att))
                if v is not None for i, a in enumerate("xyz")}
        new, info = replanner(replace(problem, program=program), sol.channels, k_e, library,
                              pose)
        ev.solve_s = info["solve_s"]
        after = float(monitor.robustness(problem.requirement, dt, new, program.params))
        ev.status = info["status"]
        ev.accepted = verdict.satisfied(after, kappa)
        ev.within_budget = None
        ev.segment = (float(times[k_e]), float(times[-1]))
        ev.kept = {"mission": after}
        ev.times, ev.channels = times[k_e:], {k: v[k_e:] for k, v in new.items()}
        detail.update({"warm_start": info["warm_start"], "nlp_built": info["built"],
                       "iterations": info["iterations"], "robustness_replanned": after})
        if ev.accepted:
            executed = new
    rob = {"mission": float(monitor.robustness(problem.requirement, dt, executed,
                                               program.params))}
    for name, s in problem.specs.items():
        rob[name] = float(monitor.robustness(s.normal, dt, executed, program.params))
    res = SimulationResult(m.name, times, dict(sol.channels), executed, [ev],
                           float((m.replan.compute_budget if m.replan else 0.4)), rob, kappa)
    res.notes.append(f"{move.human} moves at t = {move.time:g} s; the plan "
                     f"{'is replanned' if replan else 'is kept'} (exact robustness at the new "
                     f"pose {before:+.4f}, κ = {kappa:g}"
                     + (f"; risk levels not met: {', '.join(failed)}" if failed else "") + ")")
    return res


def check_moves(path: str, program, mission, moves: list[Move]) -> None:
    """Input errors before any solve: an unknown human (STL101), a time outside the
    horizon (STL306), more than one move (STL401)."""
    from stlc.diagnostics import Diagnostic, Span, StlcError, did_you_mean

    span = mission.span if mission.span.known else Span(path, 1, 1, 1, 2)
    humans = {h.name for h in program.scenario.humans}
    diags = []
    if len(moves) > 1:
        diags.append(Diagnostic("STL401", "one move per simulation", span,
                                "simulate the moves one at a time"))
    for mv in moves:
        if mv.human not in humans:
            diags.append(Diagnostic("STL101", f"command line: --move: no human `{mv.human}`",
                                    span, did_you_mean(mv.human, humans) or
                                    ("humans: " + ", ".join(sorted(humans)) if humans
                                     else "the scenario declares no human")))
        if not 0 < mv.time < mission.horizon:
            diags.append(Diagnostic("STL306", f"command line: --move at {mv.time:g} s is "
                                    f"outside the mission (0, {mission.horizon:g}) s", span,
                                    "give a time inside the horizon"))
    if diags:
        raise StlcError(diags)
