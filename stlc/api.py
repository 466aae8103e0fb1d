"""The Python API: ``stlc.load``, ``stlc.loads``, ``stlc.compile``, ``stlc.monitor``,
``stlc.simulate``, ``stlc.sweep``, ``stlc.risk`` (the commands of the CLI, returning data).

For scripts and notebooks (the CLI is a thin layer over the same passes)::

    import stlc
    program = stlc.load("specs/handover.stl")          # parsed and checked
    plan = stlc.compile(program, "handover_left_tb", time_limit=60)  # planned and verified
    plan.status, plan.robustness, plan.threshold       # exact ρ against κ
    plan.vehicle("uav1").pos, plan.to_dataframe()      # N×3 array; pandas table
    plan.plot("speed")                                 # the report's figure (plotly)
    plan                                               # in Jupyter: the verdict, the specs
    plan.write("out/")                                 # the files of `stlc compile -o out/`
    stlc.monitor(program, "trajectory.csv")            # {name: exact robustness}
    stlc.simulate(program, "m"), stlc.sweep(program, "m", vary={...}), stlc.risk(...)

Invalid input raises ``stlc.StlError``; its ``.diagnostics`` carry ``.code``, ``.line``,
``.column`` (1-based) and ``.message``.  Nothing here imports CasADi until a plan is asked
for (``stlc.compile``).
"""

from __future__ import annotations

import os
from collections.abc import Mapping

from stlc.diagnostics import Diagnostic, Span, StlcError
from stlc.results.inputs import trace_of as _trace_of
from stlc.results.inputs import with_constants, with_settings
from stlc.results.plan import Plan, Track
from stlc.results.runs import Simulation, SweepTable, fly, risk, simulate, sweep

__all__ = ["Plan", "Simulation", "StlError", "SweepTable", "Track", "compile", "load",
           "loads", "monitor", "fly", "risk", "simulate", "sweep", "with_constants",
           "_trace_of"]

StlError = StlcError  # the public name; ``.diagnostics`` is a list of ``Diagnostic``


def load(path: str | os.PathLike):
    """Parse and check a ``.stl`` file → the checked program (``stlc.semantics.model``)."""
    from stlc.results.inputs import load_program

    return load_program(os.fspath(path))


def loads(text: str, filename: str = "<text>"):
    """Parse and check source text → the checked program."""
    from stlc.frontend.syntax import parse
    from stlc.semantics.check import check

    return check(parse(text.removeprefix("\ufeff"), filename))


def compile(program, mission: str | None = None, *, set: Mapping | None = None,  # noqa: A001,A002
            risk: bool = True, quiet: bool = True, time_limit: float | None = None,
            backend: str | None = None) -> Plan:
    """Plan ``mission`` (its name; optional when the program has one mission), verify the
    plan with the exact monitor and run its risk cases (``risk=False`` skips them).
    ``set``: what ``--set`` gives another value — constants (as ``with_constants``), a
    human's pose field, a vehicle's start, a region's placement, with units.
    ``quiet=False`` prints the solver's progress to stderr.  ``time_limit`` (s, as
    ``--time-limit``; else the mission's ``time_limit``, else the default limit) stops the
    search and returns the best verified plan (status ``stopped`` unless it is satisfied).
    ``backend`` forces a chain, as ``--backend``: ``milp``, ``nlp``, ``kinematic``, ``team``
    or a backend's name.  Safe under threads: plannings in one process run one at a time
    (``stlc.deadline.serial``; a second thread waits), so use processes to plan in
    parallel."""
    import time

    from stlc import deadline
    from stlc.pipeline import assess_risk, plan_in_time, select_missions

    if isinstance(program, (str, os.PathLike)):
        program = load(program)
    values: dict = {}
    if set:
        program, values = with_settings(program, set)
    chosen = select_missions(program.file, program, mission)
    if len(chosen) > 1:
        raise StlError([Diagnostic("STL104", f"{program.file} has {len(chosen)} missions: "
                                   "say which to compile", Span(program.file, 1, 1, 1, 2),
                                   "missions: " + ", ".join(m.name for m in chosen))])
    m = chosen[0]
    from stlc.analysis.hopeless import hopeless

    doomed = hopeless(program, [m])  # a start below κ: an error before any planning
    if doomed:
        raise StlError(doomed)
    if time_limit is not None and not (time_limit > 0):
        raise ValueError(f"time_limit must be a positive number of seconds, not {time_limit!r}")
    t0 = time.perf_counter()
    with deadline.limited(deadline.mission_limit(m.options, time_limit, time_limit or 0.0),
                          start=time.monotonic()):
        problem, sol = plan_in_time(program, m, quiet=quiet, backend=backend,
                                    values=values or None)
        if risk and m.risk is not None and sol.solver.stopped_by == "time_limit":
            sol.notes.append("the risk cases were not assessed: the time limit ran out "
                             "(`stlc.risk(program, mission, plan)` assesses them)")
        elif risk and m.risk is not None:
            assess_risk(program, m, sol, problem)
    sol.timing["total_s"] = time.perf_counter() - t0
    return Plan(program, m, sol)


def monitor(program, trace) -> dict[str, float]:
    """Exact robustness of the program's specs on ``trace`` (a CSV path, or a mapping of
    channel name → array with ``"t"``): name → robustness, the names of ``monitor --json``
    (top-level specs, each mission's named specs, each mission's requirement)."""
    from stlc.analysis.trace import read_trace
    from stlc.pipeline import monitor_trace

    if isinstance(program, (str, os.PathLike)):
        program = load(program)
    tr = _trace_of(trace) if isinstance(trace, Mapping) else read_trace(os.fspath(trace))
    return {k: v["robustness"] for k, v in monitor_trace(program, tr).items()}
