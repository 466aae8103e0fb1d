"""``stlc compile`` and ``stlc risk``: order the planning passes and write the outputs.

load (parse + check) → for each mission: TimeGrid → ``casadi_nlp.build`` → kinematic guess →
λ schedule → ``invert`` (exact monitor re-evaluates every plan) → ``Solution`` →
``solution.json``, ``trajectory.csv``, ``report.html`` (+ ``risk.json``, ``risk_samples.npz``).
Outputs of a mission are written only after its plan exists, by ``stlc.outputs`` (only
stlc's own files, each replaced atomically; the directory is checked before any solve).
"""

from __future__ import annotations

import json
import os
import sys
import time
from dataclasses import replace

import numpy as np

from stlc import dynamics, ir, model
from stlc.diagnostics import Diagnostic, Span, StlcError
from stlc.solution import Solution, SpecResult
from stlc.timegrid import TimeGrid

EXIT_OK, EXIT_UNSAT = 0, 3
KAPPA_TOL = 1e-5  # IPOPT meets ρ̃ ≥ κ to its constraint tolerance


def mission_specs(program: model.Program, mission: model.Mission) -> dict[str, tuple]:
    """Named specs reported for a mission: top-level specs about its vehicles, then its own.
    Values: (formula, span)."""
    out: dict[str, tuple] = {}
    team = set(mission.vehicles)
    for name, f in program.specs.items():
        used = {s.split(".")[0] for s in ir.signals(f)}
        if used and used <= team:
            out[name] = (f, program.spec_spans.get(name, Span.none()))
    for name, f in mission.specs.items():
        out[name] = (f, mission.spec_spans.get(name, Span.none()))
    return out


def plan(program: model.Program, mission: model.Mission, *, quiet: bool = True,
         step: float | None = None, horizon: float | None = None):
    """Compute a plan; returns (Solution, raw result, inverse data, problem)."""
    from stlc.backends import casadi_nlp, schedule
    from stlc.backends.smooth_casadi import LoweringError

    if step is not None or horizon is not None:
        mission = replace(mission, step=step or mission.step, horizon=horizon or mission.horizon)
    grid = TimeGrid.from_horizon(mission.horizon, mission.step)
    integrator = str(mission.options.get("integrator", "rk4"))
    try:
        prob, inv = casadi_nlp.build(program, mission, grid, integrator, quiet=quiet)
    except LoweringError as e:
        raise StlcError([Diagnostic("STL401", f"cannot plan mission `{mission.name}`: {e}",
                                    mission.span)]) from None
    if not quiet:
        print(f"{mission.name}: {grid.n} samples, {prob.n_vars} variables, {prob.n_cons} "
              f"constraints (built in {prob.build_s:.2f} s)", file=sys.stderr)
    t0 = time.perf_counter()
    kin = schedule.kinematic_guess(program, mission, grid, inv.formula)
    w0 = schedule.full_guess(program, prob, inv, kin, mission.smoothing.lam)
    guess_s = time.perf_counter() - t0
    if not quiet:
        print(f"  initial guess: {guess_s:.2f} s", file=sys.stderr)
    raw = schedule.solve_mission(program, mission, prob, inv, w0, quiet)
    sol = invert(program, mission, raw, inv, prob)
    sol.timing.update({"build_s": prob.build_s, "guess_s": guess_s,
                       "solve_s": sum(s.solve_s for s in raw.stages)})
    return sol, raw, inv, prob


def _channels_with_derived(program, inv, w) -> dict[str, np.ndarray]:
    from stlc.backends.casadi_nlp import state_matrix, trajectory_channels

    ch = trajectory_channels(w, inv)
    for L in inv.layouts:
        X = state_matrix(w, L, inv.grid.n)
        ch.update(dynamics.derived_channels(L.vehicle, X))
    return ch


def _energy(inv, w) -> tuple[float, np.ndarray]:
    from stlc.backends.casadi_nlp import state_matrix

    n = inv.grid.n
    prof = np.zeros(n)
    for L in inv.layouts:
        if isinstance(L.vehicle, model.Multirotor):
            X = state_matrix(w, L, n)
            per = np.array([dynamics.energy(L.vehicle, X[k:k + 1], inv.grid.dt, normalize=False)
                            for k in range(n)])
            prof += per
    return float(prof.sum()), prof


def invert(program: model.Program, mission: model.Mission, raw, inv, prob) -> Solution:
    """Raw solver output → Solution in mission-level names, judged by the exact monitor
    (and satisfied only if the plan also obeys the discrete dynamics)."""
    from stlc import monitor, smooth
    from stlc.backends import casadi_nlp

    dt = inv.grid.dt
    lam = raw.lam
    w = raw.w
    ch = _channels_with_derived(program, inv, w)
    params = program.params
    method = mission.smoothing.method
    exact = float(monitor.robustness(inv.formula, dt, ch, params))
    smooth_v = float(smooth.smooth_robustness(inv.formula, dt, ch, params, lam, method))
    specs: dict[str, SpecResult] = {}
    for name, (f, span) in mission_specs(program, mission).items():
        nf = ir.normalize(f)
        r, k, pred = monitor.binding(nf, dt, ch, params)
        specs[name] = SpecResult(
            robustness=float(r),
            smooth=float(smooth.smooth_robustness(nf, dt, ch, params, lam, method)),
            satisfied=bool(r > 0),
            tightest_time=None if k is None else float(k * dt),
            binding_predicate=pred.label if pred is not None else "",
            line=span.line)
    energy, profile = _energy(inv, w)
    last = raw.stages[-1] if raw.stages else None
    defect = casadi_nlp.dynamics_defect(w, inv, str(mission.options.get("integrator", "rk4")))
    feasible = defect <= casadi_nlp.FEASIBLE_DEFECT
    failed = not feasible or all(s.status == "failed" for s in raw.stages)
    status = "satisfied" if exact > 0 and feasible else ("solver_failed" if failed else "violated")
    sol = Solution(
        mission=mission.name, status=status, robustness_exact=exact,
        robustness_smooth=smooth_v, specs=specs, energy=energy,
        times=inv.grid.times(), channels=ch,
        solver={"name": "ipopt (casadi)", "iterations": sum(s.iterations for s in raw.stages),
                "return_status": last.status if last else "not_run",
                "max_dynamics_defect": defect,
                "stages": [vars(s) for s in raw.stages]},
        smoothing={"method": method, "lambda": mission.smoothing.lam, "lambda_final": lam,
                   "threshold": mission.threshold},
        problem_size={"samples": inv.grid.n, "variables": prob.n_vars,
                      "constraints": prob.n_cons, "aux": inv.aux_slice.stop -
                      inv.aux_slice.start})
    if not feasible:
        sol.notes.append(f"the solver found no dynamically feasible plan (largest dynamics "
                         f"defect {defect:.2e} > {casadi_nlp.FEASIBLE_DEFECT:g})")
    if lam != mission.smoothing.lam:
        sol.notes.append(f"the smoothing λ was raised from {mission.smoothing.lam:g} to {lam:g} "
                         "(the smooth robustness under-estimates by up to ln(n)/λ)")
    if smooth_v < mission.threshold - KAPPA_TOL:
        sol.notes.append(f"smooth robustness {smooth_v:.6f} is below the threshold κ = "
                         f"{mission.threshold:g}")
    sol.extra["energy_profile"] = profile.tolist()
    comps = []
    for label, wc in raw.comparisons.items():
        chc = _channels_with_derived(program, inv, wc)
        ec, pc = _energy(inv, wc)
        comps.append({"label": label, "energy": ec,
                      "robustness_exact": float(monitor.robustness(inv.formula, dt, chc, params)),
                      "peak_speed": _peak(chc, ".speed"),
                      "peak_rotor_speed": _peak(chc, ".rotor_speed."),
                      "energy_profile": pc.tolist()})
    if comps:
        sol.extra["comparisons"] = comps
    sol.extra["bounds"] = _bounds(program, mission)
    sol.extra["windows"] = _windows(program, mission)
    return sol


def _peak(ch: dict[str, np.ndarray], key: str) -> float:
    vals = [np.max(v) for k, v in ch.items() if key in k]
    return float(max(vals)) if vals else float("nan")


def _bounds(program: model.Program, mission: model.Mission) -> dict:
    """Limits the report draws on its signal plots: the vehicles' own limits, and the
    bounds that the mission's predicates put on speed, rotor speed and heading."""
    out: dict = {}
    for name in mission.vehicles:
        v = program.vehicles[name]
        if isinstance(v, model.Multirotor):
            out["force"] = [v.force_min, v.force_max]
        else:
            out["speed_axis"] = list(v.vel_max)
    for p in ir.predicates(ir.normalize(mission.requirement)):
        lab = p.label
        const = _const_side(p.expr)
        if const is None:
            continue
        if ".speed <=" in lab:
            out["speed"] = [0.0, const]
        elif ".rotor_speed in" in lab:
            lo, hi = out.get("rotor_speed", [None, None])
            out["rotor_speed"] = [const, hi] if "(lower)" in lab else [lo, const]
        elif "angdiff" in lab and "<=" in lab and "deg" in lab:
            out["heading_margin_deg"] = round(float(np.degrees(const)), 6)
        elif ("norm(" in lab or "dist(" in lab) and ">=" in lab:
            out["distance_min"] = const
    return out


def _const_side(e: ir.Expr) -> float | None:
    """``c - x`` or ``x - c`` → c (the bound of a simple predicate)."""
    if isinstance(e, ir.Bin) and e.op == "-":
        for side in (e.left, e.right):
            if isinstance(side, ir.Const):
                return abs(side.value)
    return None


def _windows(program: model.Program, mission: model.Mission) -> list[dict]:
    """The outermost time window of each named spec (shaded on the report's plots)."""
    out = []
    for name, (f, _) in mission_specs(program, mission).items():
        g = f
        while isinstance(g, ir.And) and len(g.args) == 1:
            g = g.args[0]
        if isinstance(g, (ir.Always, ir.Eventually, ir.Until)):
            hi = min(g.hi, mission.horizon)
            out.append({"spec": name, "start": g.lo, "end": hi})
    return out


# ---------------------------------------------------------------- outputs


def write_outputs(outdir: str, program: model.Program, mission: model.Mission, sol: Solution,
                  risk: dict | None = None, risk_results=None) -> None:
    """Write every output of one mission into ``outdir`` (``stlc.outputs``: only stlc's own
    files, each replaced atomically, as one set under a lock on the directory)."""
    from stlc.outputs import staged
    from stlc.report import write_report

    with staged(outdir, mission.span) as tmp:
        with open(os.path.join(tmp, "solution.json"), "w") as fh:
            fh.write(sol.to_json())
        with open(os.path.join(tmp, "trajectory.csv"), "w") as fh:
            fh.write(sol.trajectory_csv())
        if risk is not None:
            with open(os.path.join(tmp, "risk.json"), "w") as fh:
                json.dump(risk, fh, indent=2, allow_nan=False)
            if risk_results is not None:
                from stlc.risk import save_samples

                save_samples(os.path.join(tmp, "risk_samples.npz"), risk_results)
            sol.extra["risk"] = risk
        write_report(os.path.join(tmp, "report.html"), program, mission, sol)


def compile_file(path: str, out: str | None = None, mission: str | None = None,
                 quiet: bool = False, risk: bool = True) -> int:
    from stlc.pipeline import load

    t0 = time.perf_counter()
    loaded = load(path)
    program = loaded.program
    missions = list(program.missions.values())
    if mission is not None:
        if mission not in program.missions:
            from stlc.diagnostics import did_you_mean

            raise StlcError([Diagnostic("STL101", f"no mission `{mission}` in {path}",
                                        Span(path, 1, 1, 1, 2),
                                        did_you_mean(mission, program.missions) or
                                        "missions: " + ", ".join(program.missions))])
        missions = [program.missions[mission]]
    if not missions:
        raise StlcError([Diagnostic("STL109", f"{path} declares no mission to compile",
                                    Span(path, 1, 1, 1, 2),
                                    "add `mission NAME { ... }`, or use `stlc monitor`")])
    several = len(missions) > 1
    base = out if out is not None else "reports"
    outdirs = {m.name: os.path.join(base, m.name) if (several or out is None) else base
               for m in missions}
    from stlc.outputs import preflight

    for m in missions:  # before any solve: can the outputs be written at all?
        span = m.span if m.span.known else Span(path, 1, 1, 1, 2)
        if out == "":  # not "the current directory" (nor `-o ""` + mission name)
            preflight(out, span)
        preflight(outdirs[m.name], span)
    code = EXIT_OK
    for m in missions:
        t1 = time.perf_counter()
        sol, *_ = plan(program, m, quiet=quiet)
        sol.timing.update(loaded.timing)
        risk_json = results = None
        if risk and m.risk is not None:
            tr = time.perf_counter()
            from stlc.assess import run_risk

            risk_json, results = run_risk(program, m, sol)
            sol.timing["risk_s"] = time.perf_counter() - tr
        sol.timing["total_s"] = time.perf_counter() - t1 + sum(loaded.timing.values())
        outdir = outdirs[m.name]
        write_outputs(outdir, program, m, sol, risk_json, results)
        if not quiet or sol.status != "satisfied":
            _summary(sol, outdir)
        if sol.status != "satisfied":
            code = EXIT_UNSAT
    if not quiet:
        print(f"done in {time.perf_counter() - t0:.1f} s", file=sys.stderr)
    return code


def _summary(sol: Solution, outdir: str) -> None:
    print(f"{sol.mission}: {sol.status}  exact robustness {sol.robustness_exact:+.4f}  "
          f"smooth {sol.robustness_smooth:+.4f}  energy {sol.energy:.1f} J  "
          f"→ {outdir}/report.html")
    if sol.status != "satisfied":
        worst = min(sol.specs.items(), key=lambda kv: kv[1].robustness, default=None)
        if worst is not None:
            name, s = worst
            at = f" at t = {s.tightest_time:g} s" if s.tightest_time is not None else ""
            print(f"  error[STL501]: spec `{name}` (line {s.line}) is violated{at} by "
                  f"{-s.robustness:.4f}: {s.binding_predicate}", file=sys.stderr)
