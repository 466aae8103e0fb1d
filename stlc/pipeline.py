"""The pipeline: the one place that orders the passes.

load (parse → check) → planning problem → backend chain → verification (exact monitor) →
risk → outputs.  ``stlc compile``, ``stlc risk``, ``stlc monitor`` and the benchmarks all
go through here; each function only calls passes in order and times them, the work is in
the passes.  Outputs are written once, after everything they contain exists.
"""

from __future__ import annotations

import contextlib
import json
import os
import sys
import time
from dataclasses import dataclass, field, replace


from stlc import deadline
from stlc.diagnostics import Diagnostic, Span, StlcError, emit_warnings
from stlc.exitcodes import EXIT_OK, EXIT_UNSAT
from stlc.frontend.syntax import parse_file
from stlc.limits import source_text
from stlc.semantics import ir, model
from stlc.semantics.check import check


@dataclass
class Loaded:
    program: model.Program
    timing: dict[str, float] = field(default_factory=dict)
    warnings: list[Diagnostic] = field(default_factory=list)  # STLWxx (stlc.semantics.lint)
    values: dict[str, float] = field(default_factory=dict)  # the --set values (SI)


def load(path: str, sets: list[str] | tuple[str, ...] = ()) -> Loaded:
    """Parse and check a file; raises ``StlcError`` with every diagnostic.  ``sets`` are
    ``--set NAME=VALUE`` items, applied to the checked program (``semantics.overrides``)."""
    from stlc.semantics import overrides
    from stlc.semantics.lint import lint

    t0 = time.perf_counter()
    tree = parse_file(path)
    t1 = time.perf_counter()
    program, values = overrides.checked(tree, overrides.split(sets)) if sets \
        else (check(tree), {})
    t2 = time.perf_counter()
    return Loaded(program, {"parse_s": t1 - t0, "check_s": t2 - t1}, lint(tree, program),
                  values)


def check_paths(paths: list[str], sets: list[str] | tuple[str, ...] = ()
                ) -> tuple[list[Diagnostic], dict[str, str]]:
    """Check several files; returns all diagnostics and the sources (for rendering)."""
    diags: list[Diagnostic] = []
    sources: dict[str, str] = {}
    for p in paths:
        try:
            loaded = load(p, sets)
            diags.extend(loaded.warnings)
            from stlc.analysis.hopeless import hopeless

            diags.extend(hopeless(loaded.program))  # a start below κ: no plan exists
            sources[p] = loaded.program.source
        except StlcError as e:
            diags.extend(e.diagnostics)
            with contextlib.suppress(StlcError):
                sources[p] = source_text(p)
    return diags, sources


def monitored_formulas(program: model.Program, mission: str | None = None
                       ) -> dict[str, ir.Formula]:
    """What ``stlc monitor`` evaluates: top-level specs, then each mission's named specs and
    its requirement (as ``<mission>``); with ``mission`` only that mission's."""
    out: dict[str, ir.Formula] = dict(program.specs) if mission is None else {}
    for m in program.missions.values():
        if mission is not None and m.name != mission:
            continue
        for name, f in m.specs.items():
            out.setdefault(name, f)
        out.setdefault(m.name, m.requirement)
    return out


def monitor_trace(program: model.Program, trace, mission: str | None = None
                  ) -> dict[str, dict]:
    """Exact robustness of every monitored formula on a trace (``stlc.analysis.trace.Trace``)
    and its verdict by the one rule (``stlc.analysis.verdict``) at its κ."""
    from stlc.analysis import monitor_demand, verdict
    from stlc.analysis.trace import check_signals

    formulas = monitored_formulas(program, mission)
    kappas = verdict.margins(program, mission)
    # all at once: named specs share subformulas (a chain of hundreds of specs, each using
    # the previous one, is evaluated in linear time and without recursion)
    check_signals(trace, ir.signals(ir.And(tuple(formulas.values()))))
    values = monitor_demand.robustness_many(list(formulas.values()), trace.dt,
                                            trace.channels, program.params, n=trace.n)
    out = {}
    for name, v in zip(formulas, values):
        r, k = float(v), kappas[name]
        out[name] = {"robustness": r, "satisfied": verdict.judge(r, k), "kappa": k}
    return out


# ---------------------------------------------------------------- planning


def backend_chain(problem, quiet: bool = True, backend: str | None = None) -> list:
    """The backends that plan ``problem``, in order (seed first), chosen from the registry
    by capabilities (``stlc.backends.strategy``) or forced by ``backend``."""
    from stlc.backends.strategy import select

    return select(problem, backend, quiet).backends


def plan(program: model.Program, mission: model.Mission, *, quiet: bool = True,
         step: float | None = None, horizon: float | None = None,
         backend: str | None = None, values: dict[str, float] | None = None,
         chain: list | None = None):
    """Plan one mission and verify the plan: returns (PlanningProblem, Solution).  ``values``
    are the instance's ``--set`` values (recorded on the problem); ``chain`` replaces the
    chosen backend chain (a sweep's warm start from its plan library).  A caller without a
    time limit (the API, a sweep's instance) plans under the default one (``stlc.deadline``):
    no solve runs unbounded.  The first planning in a process pins one solver thread, as the
    command line does (``settings.limit_solver_threads``): MUMPS's thread count changes
    IPOPT's path, and a plan must be the same from the API, a sweep and the CLI."""
    from stlc import settings

    settings.limit_solver_threads()
    with deadline.serial(), deadline.bounded():  # one planning at a time per process
        return _plan(program, mission, quiet=quiet, step=step, horizon=horizon,
                     backend=backend, values=values, chain=chain)


def _plan(program, mission, *, quiet, step, horizon, backend, values, chain):
    from stlc.analysis.vacuity import plan_warnings
    from stlc.backends import strategy
    from stlc.planning.fallback import time_limited
    from stlc.planning.problem import from_mission

    problem = from_mission(program, mission, step=step, horizon=horizon, values=values)
    chain = strategy.select(problem, backend, quiet) if chain is None else \
        strategy.Chain("library", list(chain), True)
    sol = strategy.plan(problem, chain, quiet)
    time_limited(sol)
    sol.diagnostics.extend(plan_warnings(problem, sol))
    return problem, sol


def plan_in_time(program: model.Program, mission: model.Mission, *, quiet: bool = True,
                 backend: str | None = None, values: dict[str, float] | None = None):
    """``plan`` under the run's time limit: when the watchdog's ``TimeLimitReached`` lands
    outside the backend chain (an import, the problem's construction), the fallback plan
    is verified and returned all the same (``stlc.deadline``)."""
    try:
        return plan(program, mission, quiet=quiet, backend=backend, values=values)
    except deadline.TimeLimitReached:
        from stlc.planning.fallback import judged_fallback
        from stlc.planning.problem import from_mission

        deadline.caught()
        problem = from_mission(program, mission, values=values)
        return problem, judged_fallback(problem)


def assess_risk(program: model.Program, mission: model.Mission, sol, problem=None) -> None:
    """Run the mission's risk cases on the plan (of ``problem``, whose requirement and named
    specs are assessed); results go onto the Solution (in memory)."""
    from stlc.analysis.assess import run_risk

    t0 = time.perf_counter()
    sol.risk, sol.risk_results = run_risk(program, mission, sol, problem=problem)
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


def one_mission(path: str, program: model.Program, name: str | None, verb: str):
    """The one mission a command that takes a single mission runs (``select_missions``;
    STL104 when the file has several and none is named)."""
    chosen = select_missions(path, program, name)
    if len(chosen) > 1:
        raise StlcError([Diagnostic("STL104", f"{path} has {len(chosen)} missions: say "
                                    f"which to {verb}", Span(path, 1, 1, 1, 2),
                                    "pass --mission " + " | ".join(m.name for m in chosen))])
    return chosen[0]


def compile_file(path: str, out: str | None = None, mission: str | None = None,
                 quiet: bool = False, risk: bool = True, time_limit: float | None = None,
                 started: float | None = None, deny_warnings: bool = False,
                 backend: str | None = None, sets: list[str] | tuple[str, ...] = (),
                 keep: bool = False) -> int:
    """``stlc compile``: every selected mission planned, verified, assessed, written.
    ``time_limit`` (s, from the start of the command; shared by the missions in turn)
    stops the search and writes the best verified plan (``stlc.deadline``); ``backend``
    forces a chain (``stlc.backends.strategy``); ``keep``: a Ctrl-C while planning stops
    the search as a time limit does, writes the best verified plan and exits 130."""
    from stlc import interrupt
    from stlc.output import compile as outputs

    if keep:
        interrupt.soften(deadline.cut)

    t0 = time.perf_counter()
    start = time.monotonic() if started is None else started
    loaded = load(path, sets)
    program = loaded.program
    missions = select_missions(path, program, mission)
    emit_warnings(loaded.warnings, deny_warnings, {path: program.source})
    from stlc.analysis.hopeless import hopeless

    doomed = hopeless(program, missions)  # before any planning: a start below κ
    if doomed:
        raise StlcError(doomed)
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
    for i, m in enumerate(missions):
        t1 = time.perf_counter()
        # the last (or only) mission ends with the command's limit; earlier ones get an
        # equal part of what is left
        last = i == len(missions) - 1
        share = None if time_limit is None else time_limit if last else \
            (time_limit - (time.monotonic() - start)) / (len(missions) - i)
        with deadline.limited(deadline.mission_limit(m.options, time_limit, share),
                              start=start if time_limit is not None and last else None,
                              overrun=outputs.overrun_writer(program, m, outdirs[m.name], code,
                                                               quiet)):
            problem, sol = plan_in_time(program, m, quiet=quiet, backend=backend,
                                        values=loaded.values)
            sol.timing.update(loaded.timing)
            if risk and m.risk is not None and sol.solver.stopped_by is not None:
                sol.notes.append("the risk cases were not assessed: planning was stopped "
                                 "(`stlc risk` assesses them on trajectory.csv)")
            elif risk and m.risk is not None:
                assess_risk(program, m, sol, problem)
        sol.timing["total_s"] = time.perf_counter() - t1 + sum(loaded.timing.values())
        outdir = outdirs[m.name]
        # the plan's own warnings (STLW02); its errors (STL504) are in the summary
        found = [d for d in sol.diagnostics if d.severity == "warning"]
        sol.diagnostics[:0] = loaded.warnings  # the report lists the file's too
        outputs.write_outputs(outdir, program, m, sol)
        if not quiet or sol.status != "satisfied":
            outputs.summary(sol, outdir)
        if sol.status != "satisfied" or outputs.risk_levels_failed(sol):
            code = EXIT_UNSAT  # a risk level of the mission not met counts as unsatisfied
        if found:  # after the outputs: with --deny-warnings the plan is not accepted (exit 3)
            emit_warnings([replace(w, severity="error") for w in found] if deny_warnings
                          else found, False, {path: program.source})
            if deny_warnings:
                code = EXIT_UNSAT
        if interrupt.softened():
            print(f"stlc: interrupted: the best verified plan found is in {outdir}",
                  file=sys.stderr)
            return interrupt.exit_code()  # the missions after it are not planned
    if not quiet:
        print(f"done in {time.perf_counter() - t0:.1f} s", file=sys.stderr)
    return code


def risk_file(path: str, trajectory: str, mission: str | None = None,
              out: str | None = None, sets: list[str] | tuple[str, ...] = (),
              shared=None) -> int:
    """``stlc risk``: assess the plan in ``trajectory`` (a ``trajectory.csv``) under the risk
    cases of ``mission``; writes ``risk.json`` and ``risk_samples.npz`` into ``out``
    (default: the trajectory's directory) and prints a table."""
    from stlc.analysis.assess import risk_table, run_risk, select_mission
    from stlc.analysis.risk import RiskError, SamplingError, save_samples
    from stlc.analysis.trace import check_signals, read_trace
    from stlc.planning.solution import Solution
    from stlc.semantics.specs import mission_specs

    program = load(path, sets).program
    m = select_mission(path, program, mission)
    trace = read_trace(trajectory)
    needed = set(ir.signals(m.requirement))
    for s in mission_specs(program, m).values():
        needed |= ir.signals(s.formula)
    check_signals(trace, needed)
    sol = Solution(m.name, "satisfied", 0.0, 0.0, {}, 0.0, trace.times, trace.channels)
    try:
        risk_json, results = run_risk(program, m, sol, dt=trace.dt, shared=shared)
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
    from stlc.output.compile import levels_failed

    return EXIT_UNSAT if levels_failed(risk_json) else EXIT_OK  # a risk level not met: 3
