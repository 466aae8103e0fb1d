"""``stlc simulate``: compile the mission (``stlc.pipeline``), then fly it through its events
— disturbances with event-triggered replanning (paper A), a drone failure with a backup's
takeover (paper B), an operator move (paper A §6) — verify the executed trajectory and
write the compile outputs plus ``replan.json``.  The flight loops live in ``stlc/replan``;
this module orders them and hands them their planners."""

from __future__ import annotations

import os
import sys
import time
from dataclasses import replace

import numpy as np

from stlc import deadline
from stlc.diagnostics import Diagnostic, StlcError
from stlc.exitcodes import EXIT_OK, EXIT_UNSAT
from stlc.pipeline import load, mission_span, one_mission, plan_in_time
from stlc.semantics import model


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


def _file_move(program: model.Program, mv: model.HumanMove):
    """A checked ``move`` block as the flight loop's ``Move``: a part it does not give is
    the human's pose in the program (after ``--set``)."""
    from stlc.replan.move import Move

    h = next(x for x in program.scenario.humans if x.name == mv.human)
    pos = mv.pos if mv.pos is not None else tuple(float(x) for x in h.pos)
    return Move(mv.human, mv.time, pos, mv.att)  # type: ignore[arg-type]


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


def _replan_defaults(program: model.Program, m: model.Mission, cfg: model.ReplanConfig
                     ) -> model.ReplanConfig:
    """T_g from the vehicles' acceleration limits when the mission does not give it."""
    from stlc import vehicles
    from stlc.replan.explain import default_waypoint_period

    if "waypoint_period" in cfg.given or not m.vehicles:
        return cfg
    acc = np.min([vehicles.model_of(program.vehicles[v]).kinematic_limits(
        program.vehicles[v])[1] for v in m.vehicles], axis=0)
    return replace(cfg, waypoint_period=default_waypoint_period(cfg.threshold, acc, m.step))


def simulate_file(path: str, out: str | None = None, mission: str | None = None,
                  disturbances: list | None = None, failures: list | None = None,
                  quiet: bool = False, time_limit: float | None = None,
                  sets: list[str] | tuple[str, ...] = (), moves: list | None = None,
                  library: str | None = None) -> int:
    """``stlc simulate``: compile the mission, fly it through its events (disturbances with
    event-triggered replanning, or a drone failure with a backup's takeover), verify the
    executed trajectory and write the compile outputs plus ``replan.json`` and
    ``executed.csv``.  Exit 0 when the nominal plan satisfies its mission, every
    triggered replan was accepted and the executed trajectory satisfies the kept specs, 3
    otherwise (an STL501 line says when the nominal plan is violated)."""
    from stlc.output import compile as outputs
    from stlc.output.directory import preflight
    from stlc.output.simulate import simulation_summary, write_simulation

    t0 = time.perf_counter()
    loaded = load(path, sets)
    program = loaded.program
    m = one_mission(path, program, mission, "simulate")
    events = flight_events(program, m, disturbances, failures, moves)
    outdir = out if out is not None else os.path.join("reports", m.name)
    preflight(outdir, mission_span(path, m))
    program, _, sol, sim = fly(program, m, events, values=loaded.values,
                               library=library, time_limit=time_limit, quiet=quiet,
                               started=t0)
    sol.timing.update(loaded.timing)
    sol.timing["total_s"] = time.perf_counter() - t0
    write_simulation(outdir, program, m, sol, sim)
    if sol.status != "satisfied":  # the nominal plan's verdict counts, as in `compile`
        outputs.summary(sol, outdir)
    ok = simulation_summary(sim, outdir, quiet) and sol.status == "satisfied"
    if not quiet:
        print(f"done in {time.perf_counter() - t0:.1f} s", file=sys.stderr)
    return EXIT_OK if ok else EXIT_UNSAT


def flight_events(program: model.Program, m: model.Mission, disturbances: list | None,
                  failures: list | None, moves: list | None) -> tuple:
    """The checked events of a simulation (raises ``StlcError`` before any solve):
    (moves, disturbances, failures, replanning configuration)."""
    from stlc.analysis.hopeless import hopeless

    path = program.file
    doomed = hopeless(program, [m])  # a start below κ: no nominal plan exists
    if doomed:
        raise StlcError(doomed)
    if not (moves or disturbances or failures) and m.simulate and m.simulate.moves:
        moves = [_file_move(program, mv) for mv in m.simulate.moves]  # checked with the file
    elif moves:  # an operator move (paper A §6): replan.move, not disturbances
        from stlc.replan.move import check_moves

        check_moves(path, program, m, moves)
    if moves:
        dist, fails = [], []
    else:
        dist, fails = simulation_events(path, program, m, disturbances, failures)
    cfg = _replan_defaults(program, m, m.replan or model.ReplanConfig())
    if dist:
        _check_kept(program, m, cfg)
    return list(moves or []), dist, fails, cfg


def fly(program: model.Program, m: model.Mission, events: tuple, *, values=None,
        library: str | None = None, time_limit: float | None = None, quiet: bool = True,
        started: float | None = None):
    """Plan ``m`` and fly it through ``events`` (``flight_events``): returns (program —
    moved when a human moved —, PlanningProblem, Solution, SimulationResult)."""
    moves, dist, fails, cfg = events
    t0 = time.perf_counter() if started is None else started
    # the time limit bounds planning the nominal plan (replans have their budget t_c)
    with deadline.limited(deadline.mission_limit(m.options, time_limit, time_limit or 0.0),
                          start=time.monotonic() - (time.perf_counter() - t0)):
        problem, sol = plan_in_time(program, m, quiet=quiet, values=values)
    t1 = time.perf_counter()
    # replans solve too: under the default limit (stlc.deadline), no watchdog
    with deadline.bounded():
        try:
            if moves:
                from stlc.backends import strategy
                from stlc.replan.move import moved_program, simulate_move

                sim = simulate_move(problem, sol, moves[0], library,
                                    replanner=strategy.replanner("move"))
                program = moved_program(program, moves[0])
            elif fails:
                from stlc.backends import strategy
                from stlc.replan.takeover import simulate_failure

                sim = simulate_failure(problem, sol, fails[0], cfg,
                                       planner=strategy.replanner("takeover"))
            else:
                from stlc.backends import strategy
                from stlc.replan.disturb import simulate_disturbances

                sim = simulate_disturbances(problem, sol, dist, cfg,
                                            segment=strategy.replanner("segment"))
        except ValueError as e:  # the replanning modules' input errors (subclasses)
            if type(e) is ValueError:
                raise
            span = getattr(getattr(e, "disturbance", None), "span", None)
            raise StlcError([Diagnostic("STL401", f"cannot simulate `{m.name}`: {e}",
                                        span if span is not None and span.known else m.span,
                                        "see `stlc simulate` in docs/cli.md")]) from None
    # what the replanning promises: the kept specs (paper A: `safety`); a takeover keeps the
    # whole mission, judged over the executed team
    sim.kept = ("mission",) if fails or moves else (tuple(cfg.specs) or ("mission",))
    sol.timing["simulate_s"] = time.perf_counter() - t1
    return program, problem, sol, sim
