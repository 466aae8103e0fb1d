"""The outputs of ``stlc compile``: ``solution.json``, ``trajectory.csv``, ``report.html``
(+ ``risk.json``, ``risk_samples.npz``) of one verified ``Solution``, and the summary line.

The pipeline (``stlc.pipeline.compile_file``) orders the passes and calls this last, once
everything the outputs contain exists.  ``stlc.output.directory`` writes them: only stlc's own
files, each replaced atomically, as one set under a lock on the directory (checked before any
solve).  A team plan also gets one ``trajectory.<drone>.csv`` per drone for a tracker;
every plan its flight-stack outputs (``flight/``, ``rosbag2/``: ``stlc.flight.export``).
"""

from __future__ import annotations

import json
import math
import os
import sys

from stlc.output.solution import solution_json, trajectory_csv
from stlc.planning import words
from stlc.planning.solution import Solution
from stlc.semantics import model


# ---------------------------------------------------------------- outputs


def write_outputs(outdir: str, program: model.Program, mission: model.Mission, sol: Solution
                  ) -> None:
    """Write every output of one mission into ``outdir`` (see ``stlc.output.directory``)."""
    write_files(outdir, program, mission, sol)


def write_files(outdir: str, program: model.Program, mission: model.Mission, sol: Solution,
                extra=None, simulation=None, flight=None) -> None:
    """The compile outputs of ``sol``, plus what ``extra(stage_dir)`` writes, as one set;
    ``simulation`` (a ``stlc.replan.result.SimulationResult``) adds the report's section,
    and so does ``flight`` (``stlc fly``'s record and flown channels)."""
    from stlc.output.directory import staged
    from stlc.output.report import write_report

    with staged(outdir, mission.span) as tmp:
        if extra is not None:
            extra(tmp)
        with open(os.path.join(tmp, "solution.json"), "w") as fh:
            fh.write(solution_json(sol, mission))
        with open(os.path.join(tmp, "trajectory.csv"), "w") as fh:
            fh.write(trajectory_csv(sol))
        flight_done = None
        if sol.times.size:  # PX4 / MRS setpoints and a ROS 2 bag (``stlc.flight.export``),
            # written by a forked child while this process renders the report (≈ 0.12 s
            # each, most of it loading rosbags' message types and the templates)
            from stlc import apart
            from stlc.flight.export import write_flight_outputs

            flight_done = apart.start(write_flight_outputs, tmp, program, mission, sol.times,
                                      sol.channels)
        if sol.routes:
            from stlc.backends.strategy import team_plan
            from stlc.team.refine import per_drone_csv

            for drone, text in per_drone_csv(team_plan(sol)).items():
                with open(os.path.join(tmp, f"trajectory.{drone}.csv"), "w") as fh:
                    fh.write(text)
        if sol.risk is not None:
            from stlc.strictjson import strict

            with open(os.path.join(tmp, "risk.json"), "w") as fh:
                json.dump(strict(sol.risk), fh, indent=2, allow_nan=False)
            if sol.risk_results is not None:
                from stlc.analysis.risk import save_samples

                save_samples(os.path.join(tmp, "risk_samples.npz"), sol.risk_results)
        try:
            write_report(os.path.join(tmp, "report.html"), program, mission, sol,
                         simulation=simulation, flight=flight)
        except BaseException:
            if flight_done is not None:
                flight_done.cancel()
            raise
        if flight_done is not None:
            flight_done()


def summary(sol: Solution, outdir: str) -> None:
    """The verdict line (exact ρ against κ), then, without a satisfying plan, what fails and
    whether impossibility was proved — each said once."""
    energy = f"{sol.energy:.1f} J" if sol.energy == sol.energy else "not computed"
    if len(sol.energy_by_vehicle) > 1:
        energy += " (" + ", ".join(f"{k} {e:.1f} J" for k, e in sol.energy_by_vehicle.items()) + ")"
    kappa = float(sol.smoothing.get("threshold", 0.0) or 0.0)
    print(f"{sol.mission}: {words.verdict_line(sol.status, sol.robustness_exact, kappa)}  "
          f"energy {energy}  → {outdir}/report.html")
    # the plan's own errors, once: STL504 (no plan exists), STL503 (no plan found)
    for d in sol.diagnostics if sol.status != "satisfied" else ():
        if d.severity == "error":
            print(f"  error[{d.code}]: {d.message}"
                  + (f"\n  = help: {d.help}" if d.help else ""), file=sys.stderr)
    if sol.status not in ("satisfied", "infeasible"):
        worst = min(sol.specs.items(), key=lambda kv: kv[1].robustness, default=None)
        if worst is not None:
            name, s = worst
            at = f" at t = {s.tightest_time:g} s" if s.tightest_time is not None else ""
            if s.robustness < 0:
                by = (f" by {-s.robustness:.4f}" if math.isfinite(s.robustness) else
                      " whatever the plan (no predicate can make it hold)")
                pred = f": {s.binding_predicate}" if s.binding_predicate else ""
                print(f"  error[STL501]: {sol.mission}: spec `{name}` (line {s.line}) is "
                      f"violated{at}{by}{pred}", file=sys.stderr)
            else:
                print(f"  error[STL501]: {sol.mission}: spec `{name}` (line {s.line}) holds "
                      f"with margin {s.robustness:.4f}{at}, short of the threshold κ = {kappa:g}"
                      + (f": {s.binding_predicate}" if s.binding_predicate else ""),
                      file=sys.stderr)
        note = words.impossibility_note(sol.solver.infeasibility)
        if note:
            print(f"  note: {sol.mission}: {note}", file=sys.stderr)


def risk_levels_failed(sol: Solution) -> bool:
    """Print each risk level of the mission that a risk case does not meet (``risk.json``'s
    ``levels``); True if there is one (``stlc compile`` then exits 3)."""
    return levels_failed(sol.risk)


def levels_failed(risk: dict | None) -> bool:
    """``risk_levels_failed`` on the contents of a ``risk.json`` (``stlc risk`` alike)."""
    failed = [(case, lv) for case, lvs in ((risk or {}).get("levels") or {}).items()
              for lv in lvs if not lv["holds"]]
    for case, lv in failed:
        print(f"  risk level `{lv['level']}` (line {lv['line']}) does not hold in case "
              f"`{case}`: {lv['measure']} = {lv['value']:.4g}", file=sys.stderr)
    return bool(failed)


def overrun_writer(program: model.Program, m: model.Mission, outdir: str, code: int,
                   quiet: bool):
    """The watchdog's writer (``stlc.deadline``): the fallback plan, verified and written
    from the watchdog thread while the planning thread is stuck in a C call; returns the
    exit code."""
    def write() -> int:
        from stlc.planning.fallback import judged_fallback
        from stlc.planning.problem import from_mission

        sol = judged_fallback(from_mission(program, m))
        write_outputs(outdir, program, m, sol)
        if not quiet or sol.status != "satisfied":
            summary(sol, outdir)
        from stlc.exitcodes import EXIT_UNSAT

        return code if sol.status == "satisfied" else EXIT_UNSAT
    return write
