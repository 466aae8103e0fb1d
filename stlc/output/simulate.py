"""The outputs of ``stlc simulate``: the compile outputs of the nominal plan plus
``replan.json`` (the event log and the verdict on the executed trajectory) and
``executed.csv`` (what was flown), written as one set (``stlc.output.directory``); the
report gets the simulation section.  ``simulation_summary`` prints the event table."""

from __future__ import annotations

import os
import sys

from stlc.analysis import verdict
from stlc.planning.solution import Solution
from stlc.replan.result import SimulationResult
from stlc.semantics import model


def write_simulation(outdir: str, program: model.Program, mission: model.Mission,
                     sol: Solution, sim: SimulationResult) -> None:
    from stlc.output.compile import write_files

    def extra(tmp: str) -> None:
        with open(os.path.join(tmp, "replan.json"), "w") as fh:
            fh.write(sim.to_json())
        with open(os.path.join(tmp, "executed.csv"), "w") as fh:
            fh.write(sim.executed_csv())

    write_files(outdir, program, mission, sol, extra=extra, simulation=sim)


def _f(x, fmt: str) -> str:
    return "—" if x is None else format(x, fmt)


def simulation_summary(sim: SimulationResult, outdir: str, quiet: bool = False) -> bool:
    """Print the triggered events and the verdict; returns ``sim.ok()``."""
    ok = sim.ok()
    out = sys.stdout
    if not quiet:
        trig = sim.triggered
        print(f"{sim.mission}: {len(sim.events)} event instants, {len(trig)} replans "
              f"(budget {sim.budget:g} s)", file=out)
        if trig:
            print(f"  {'time':>7}  {'vehicle':<8} {'dev (m)':>8}  {'solve (s)':>9}  "
                  f"{'status':<14} {'accepted':<8} kept", file=out)
        for e in trig:
            kept = ", ".join(f"{k} {v:+.3f}" for k, v in e.kept.items())
            print(f"  {e.time:7.2f}  {e.vehicle:<8} {e.deviation:8.3f}  "
                  f"{_f(e.solve_s, '9.3f')}  {e.status or '—':<14} "
                  f"{'yes' if e.accepted else 'no':<8} {kept}", file=out)
    for e in sim.triggered:
        rec = (e.detail or {}).get("recovery")
        if rec and not quiet:
            broken = ", ".join(f"`{k}` ({v:+.3f})" for k, v in rec["broken_at_start"].items())
            back = ("back to κ at " + format(rec["back_at"], "g") + " s"
                    if e.accepted and rec["back_at"] is not None else "not flown")
            print(f"  recovery: {e.vehicle} started the replan at {e.segment[0]:g} s inside "
                  f"the violation set of {broken}; the segment leaves it by the shortest way "
                  f"back: {back}", file=out)
    rhos = ", ".join(f"{k} {v:+.4f}" for k, v in sim.executed_robustness.items())
    print(f"{sim.mission}: executed trajectory: {rhos} → {outdir}/replan.json",
          file=out if ok else sys.stderr)
    if not ok:
        bad = [e for e in sim.triggered if not e.accepted]
        if bad:
            print(f"  error[STL502]: {len(bad)} replan(s) not accepted (first at t = "
                  f"{bad[0].time:g} s: {bad[0].status}, {_f(bad[0].solve_s, '.3f')} s)",
                  file=sys.stderr)
            why = bad[0].detail.get("reason") if bad[0].detail else None
            if why:
                print(f"  = why: {why}", file=sys.stderr)
        for k in sim.kept:
            r = sim.executed_robustness.get(k)
            if r is None or not verdict.satisfied(r, sim.threshold):
                print(f"  error[STL501]: `{k}` does not hold on the executed trajectory "
                      f"(robustness {_f(r, '+.4f')}, κ = {sim.threshold:g})", file=sys.stderr)
    return ok
