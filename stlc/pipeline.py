"""The pipeline: the one place that orders the passes.

load (parse → check) → planning problem → backend chain → verification (exact monitor) →
risk → outputs.  ``stlc compile``, ``stlc risk``, ``stlc monitor`` and the benchmarks all
go through here; each function only calls passes in order and times them, the work is in
the passes.  Outputs are written once, after everything they contain exists.
"""

from __future__ import annotations

import json
import os
import sys
import time
from dataclasses import dataclass, field, replace

from stlc.diagnostics import Diagnostic, Span, StlcError
from stlc.exitcodes import EXIT_OK, EXIT_UNSAT
from stlc.frontend.syntax import parse_file
from stlc.semantics import ir, model
from stlc.semantics.check import check


@dataclass
class Loaded:
    program: model.Program
    timing: dict[str, float] = field(default_factory=dict)


def load(path: str) -> Loaded:
    """Parse and check a file; raises ``StlcError`` with every diagnostic."""
    t0 = time.perf_counter()
    tree = parse_file(path)
    t1 = time.perf_counter()
    program = check(tree)
    t2 = time.perf_counter()
    return Loaded(program, {"parse_s": t1 - t0, "check_s": t2 - t1})


def check_paths(paths: list[str]) -> tuple[list[Diagnostic], dict[str, str]]:
    """Check several files; returns all diagnostics and the sources (for rendering)."""
    diags: list[Diagnostic] = []
    sources: dict[str, str] = {}
    for p in paths:
        try:
            loaded = load(p)
            sources[p] = loaded.program.source
        except StlcError as e:
            diags.extend(e.diagnostics)
            try:
                sources[p] = open(p, encoding="utf-8", errors="replace").read()
            except OSError:
                pass
    return diags, sources


def monitored_formulas(program: model.Program) -> dict[str, ir.Formula]:
    """What ``stlc monitor`` evaluates: top-level specs, then each mission's named specs and
    its requirement (as ``<mission>``)."""
    out: dict[str, ir.Formula] = dict(program.specs)
    for m in program.missions.values():
        for name, f in m.specs.items():
            out.setdefault(name, f)
        out.setdefault(m.name, m.requirement)
    return out


def monitor_trace(program: model.Program, trace) -> dict[str, dict]:
    """Exact robustness of every monitored formula on a trace (``stlc.analysis.trace.Trace``)."""
    from stlc.analysis import monitor_demand
    from stlc.analysis.trace import check_signals

    formulas = monitored_formulas(program)
    # all at once: named specs share subformulas (a chain of hundreds of specs, each using
    # the previous one, is evaluated in linear time and without recursion)
    check_signals(trace, ir.signals(ir.And(tuple(formulas.values()))))
    values = monitor_demand.robustness_many(list(formulas.values()), trace.dt,
                                            trace.channels, program.params, n=trace.n)
    out = {}
    for name, v in zip(formulas, values):
        r = float(v)
        out[name] = {"robustness": r, "satisfied": bool(r > 0)}
    return out


# ---------------------------------------------------------------- planning


def backend_chain(problem, quiet: bool = True, backend: str | None = None) -> list:
    """The backends that plan ``problem``, in order (seed first), chosen from the registry
    by capabilities (``stlc.backends.select``) or forced by ``backend``."""
    from stlc.backends.select import select

    return select(problem, backend, quiet).backends


def _team_comparisons(sols: list) -> None:
    """A team plan is shown beside its seed ("MILP only", paper B Fig. 8), first; the
    refinement already added the standard plan of a ``compare`` variant (Fig. 11)."""
    from stlc.planning.solution import Comparison

    seed, final = sols[0], sols[-1]
    final.comparisons.insert(0, Comparison("MILP only", dict(seed.channels)))
    final.timing.update({k: v for k, v in seed.timing.items() if k in ("milp_s", "seed_s")})
    final.solver["seed"] = dict(seed.solver)
    if seed.solver.get("assignment") == "greedy":
        final.notes.append("the task-assignment MILP stopped on its time budget (not "
                           "converged): the routes come from the heuristic (greedy start + "
                           "local search, own station per drone), not optimal")


def plan(program: model.Program, mission: model.Mission, *, quiet: bool = True,
         step: float | None = None, horizon: float | None = None,
         backend: str | None = None):
    """Plan one mission and verify the plan: returns (PlanningProblem, Solution)."""
    from stlc.backends.base import run_chain
    from stlc.backends.select import chain_record, select
    from stlc.planning.problem import from_mission
    from stlc.planning.verify import verify

    problem = from_mission(program, mission, step=step, horizon=horizon)
    chain = select(problem, backend, quiet)
    if not quiet:
        print(f"{mission.name}: chain `{chain.name}`"
              f"{' (forced)' if chain.forced else ''}: "
              + " → ".join(b.name for b in chain.backends), file=sys.stderr)
    sol, sols = run_chain(problem, chain.backends)
    if len(sols) > 1 and sols[0].routes:
        _team_comparisons(sols)
    sol.solver["chain"] = chain_record(chain, sols)
    t0 = time.perf_counter()
    verify(problem, sol)
    sol.timing["verify_s"] = time.perf_counter() - t0
    if sol.status != "satisfied":
        from stlc.backends.milp_conflict import explain_infeasible

        explain_infeasible(problem, sol, quiet=quiet)
    return problem, sol


def assess_risk(program: model.Program, mission: model.Mission, sol) -> None:
    """Run the mission's risk cases on the plan; results go onto the Solution (in memory)."""
    from stlc.analysis.assess import run_risk

    t0 = time.perf_counter()
    sol.risk, sol.risk_results = run_risk(program, mission, sol)
    sol.timing["risk_s"] = time.perf_counter() - t0


def mission_span(path: str, m: model.Mission) -> Span:
    """Where diagnostics about a mission point: its declaration, else the file's start."""
    return m.span if m.span.known else Span(path, 1, 1, 1, 2)


def select_missions(path: str, program: model.Program, name: str | None) -> list:
    if name is not None:
        from stlc.semantics.specs import mission_named

        return [mission_named(path, program, name)]
    if not program.missions:
        raise StlcError([Diagnostic("STL109", f"{path} declares no mission to compile",
                                    Span(path, 1, 1, 1, 2),
                                    "add `mission NAME { ... }`, or use `stlc monitor`")])
    return list(program.missions.values())


def compile_file(path: str, out: str | None = None, mission: str | None = None,
                 quiet: bool = False, risk: bool = True, backend: str | None = None) -> int:
    """``stlc compile``: every selected mission planned, verified, assessed, written."""
    from stlc.output import compile as outputs

    t0 = time.perf_counter()
    loaded = load(path)
    program = loaded.program
    missions = select_missions(path, program, mission)
    several = len(missions) > 1
    base = out if out is not None else "reports"
    outdirs = {m.name: os.path.join(base, m.name) if (several or out is None) else base
               for m in missions}
    from stlc.output.directory import preflight

    for m in missions:  # before any solve: can the outputs be written at all?
        span = mission_span(path, m)
        if out == "":  # not "the current directory" (nor `-o ""` + mission name)
            preflight(out, span)
        preflight(outdirs[m.name], span)
    code = EXIT_OK
    for m in missions:
        t1 = time.perf_counter()
        _, sol = plan(program, m, quiet=quiet, backend=backend)
        sol.timing.update(loaded.timing)
        if risk and m.risk is not None:
            assess_risk(program, m, sol)
        sol.timing["total_s"] = time.perf_counter() - t1 + sum(loaded.timing.values())
        outdir = outdirs[m.name]
        outputs.write_outputs(outdir, program, m, sol)
        if not quiet or sol.status != "satisfied":
            outputs.summary(sol, outdir)
        if sol.status != "satisfied":
            code = EXIT_UNSAT
    if not quiet:
        print(f"done in {time.perf_counter() - t0:.1f} s", file=sys.stderr)
    return code


def risk_file(path: str, trajectory: str, mission: str | None = None,
              out: str | None = None) -> int:
    """``stlc risk``: assess the plan in ``trajectory`` (a ``trajectory.csv``) under the risk
    cases of ``mission``; writes ``risk.json`` and ``risk_samples.npz`` into ``out``
    (default: the trajectory's directory) and prints a table."""
    from stlc.analysis.assess import risk_table, run_risk, select_mission
    from stlc.analysis.risk import RiskError, SamplingError, save_samples
    from stlc.analysis.trace import check_signals, read_trace
    from stlc.planning.solution import Solution
    from stlc.semantics.specs import mission_specs

    program = load(path).program
    m = select_mission(path, program, mission)
    trace = read_trace(trajectory)
    needed = set(ir.signals(m.requirement))
    for s in mission_specs(program, m).values():
        needed |= ir.signals(s.formula)
    check_signals(trace, needed)
    sol = Solution(m.name, "satisfied", 0.0, 0.0, {}, 0.0, trace.times, trace.channels)
    try:
        risk_json, results = run_risk(program, m, sol, dt=trace.dt)
    except (RiskError, SamplingError) as e:
        raise StlcError([Diagnostic("STL209", f"cannot assess the risk cases of `{m.name}`: "
                                    f"{e}", m.span, "check the risk block's distributions")]
                        ) from None
    outdir = out or os.path.dirname(os.path.abspath(trajectory))
    from stlc.output.directory import staged
    from stlc.strictjson import strict

    target = os.path.join(outdir, "risk.json")
    with staged(outdir, mission_span(path, m),
                complete=False) as tmp:
        with open(os.path.join(tmp, "risk.json"), "w") as fh:
            json.dump(strict(risk_json), fh, indent=2, allow_nan=False)
        save_samples(os.path.join(tmp, "risk_samples.npz"), results)
    print(risk_table(risk_json, trace.path))
    print(f"→ {target}")
    if trace.n > 1 and abs(trace.dt - m.step) > 1e-9 * m.step:
        print(f"note: the trajectory's step is {trace.dt:g} s, the mission's {m.step:g} s; "
              "windows were taken at the trajectory's step", file=sys.stderr)
    return 0


# ---------------------------------------------------------------- simulation (replanning)


def simulation_events(path: str, program: model.Program, m: model.Mission,
                      disturbances: list | None, failures: list | None) -> tuple[list, list]:
    """The events of ``stlc simulate``: those given on the command line (``--disturb``,
    ``--fail``) replace the file's ``simulate`` block; each is checked like the file's
    (reported at the mission's name, exit 1)."""
    from stlc.semantics.specs import reads_payload
    from stlc.semantics.check.events import event_problems

    span = mission_span(path, m)
    cli = disturbances or failures
    dist = list(disturbances or []) if cli else list(m.simulate.disturbances if m.simulate else ())
    fails = list(failures or []) if cli else list(m.simulate.failures if m.simulate else ())
    diags = []
    if cli:
        only = m.vehicles[0] if len(m.vehicles) == 1 else None
        dist = [replace(d, vehicle=d.vehicle or only or "") for d in dist]
        delay = (m.replan or model.ReplanConfig()).takeover_delay
        for ev in [*dist, *fails]:
            for code, msg, hint in event_problems(program.vehicles, m.vehicles, m.horizon,
                                                  ev, delay):
                diags.append(Diagnostic(code, f"command line: {msg}", span, hint))
    if not dist and not fails:
        diags.append(Diagnostic("STL104", f"nothing to simulate for mission `{m.name}`", span,
                                "add `simulate { disturb uav1 { time = 6 s; displacement = "
                                "(1, 0, 0) m } }` to the mission, or pass --disturb/--fail"))
    elif dist and fails:
        diags.append(Diagnostic("STL401", "a simulation has disturbances or a failure, not "
                                "both", span, "simulate them one at a time"))
    elif fails and not reads_payload(m.requirement):
        diags.append(Diagnostic("STL401", f"a backup-drone takeover needs a team mission "
                                f"with payloads (paper B); `{m.name}` has none", span,
                                "simulate disturbances on this mission instead"))
    elif len(fails) > 1:
        diags.append(Diagnostic("STL401", "one drone failure per simulation", span,
                                "simulate the failures one at a time"))
    if diags:
        raise StlcError(diags)
    return dist, fails


def _check_kept(program: model.Program, m: model.Mission, cfg: model.ReplanConfig) -> None:
    """Before any solve: can a replanning segment keep the specs of ``keep = [...]``?"""
    from stlc.planning.problem import from_mission
    from stlc.planning.kept import KeptSpecError, kept_clauses

    problem = from_mission(program, m)
    try:
        for v in problem.vehicles():
            kept_clauses(problem, cfg.specs, v)
    except KeptSpecError as e:
        span = m.spec_spans.get(e.spec) or program.spec_spans.get(e.spec) or m.span
        raise StlcError([Diagnostic("STL401", str(e), span, "a replanning segment keeps "
                                    "`always` specs over the vehicle's own state, like "
                                    "`safety`; keep only those")]) from None


def simulate_file(path: str, out: str | None = None, mission: str | None = None,
                  disturbances: list | None = None, failures: list | None = None,
                  quiet: bool = False) -> int:
    """``stlc simulate``: compile the mission, fly it through its events (disturbances with
    event-triggered replanning, or a drone failure with a backup's takeover), verify the
    executed trajectory and write the compile outputs plus ``replan.json`` and
    ``executed.csv``.  Exit 0 when every triggered replan was accepted and the executed
    trajectory satisfies the kept specs, 3 otherwise."""
    from stlc.output.directory import preflight
    from stlc.output.simulate import simulation_summary, write_simulation

    t0 = time.perf_counter()
    loaded = load(path)
    program = loaded.program
    missions = select_missions(path, program, mission)
    if len(missions) > 1:
        raise StlcError([Diagnostic("STL104", f"{path} has {len(missions)} missions: say "
                                    "which to simulate", Span(path, 1, 1, 1, 2),
                                    "pass --mission " + " | ".join(x.name for x in missions))])
    m = missions[0]
    dist, fails = simulation_events(path, program, m, disturbances, failures)
    outdir = out if out is not None else os.path.join("reports", m.name)
    preflight(outdir, mission_span(path, m))
    cfg = m.replan or model.ReplanConfig()
    if dist:
        _check_kept(program, m, cfg)
    problem, sol = plan(program, m, quiet=quiet)
    sol.timing.update(loaded.timing)
    t1 = time.perf_counter()
    try:
        if fails:
            from stlc.backends.backup import BackupPlanner
            from stlc.replan.takeover import simulate_failure

            sim = simulate_failure(problem, sol, fails[0], cfg, planner=BackupPlanner())
        else:
            from stlc.backends.segment import SegmentBackend
            from stlc.replan.disturb import simulate_disturbances

            sim = simulate_disturbances(problem, sol, dist, cfg, segment=SegmentBackend)
    except ValueError as e:  # the replanning modules' input errors (subclasses)
        if type(e) is ValueError:
            raise
        span = getattr(getattr(e, "disturbance", None), "span", None)
        raise StlcError([Diagnostic("STL401", f"cannot simulate `{m.name}`: {e}",
                                    span if span is not None and span.known else m.span,
                                    "see `stlc simulate` in the README")]) from None
    # what the replanning promises: the kept specs (paper A: `safety`); a takeover keeps the
    # whole mission, judged over the executed team
    sim.kept = ("mission",) if fails else (tuple(cfg.specs) or ("mission",))
    sol.timing["simulate_s"] = time.perf_counter() - t1
    sol.timing["total_s"] = time.perf_counter() - t0
    write_simulation(outdir, program, m, sol, sim)
    ok = simulation_summary(sim, outdir, quiet)
    if not quiet:
        print(f"done in {time.perf_counter() - t0:.1f} s", file=sys.stderr)
    return EXIT_OK if ok else EXIT_UNSAT
