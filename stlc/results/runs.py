"""The commands beyond ``compile`` from Python: ``simulate``, ``sweep``, ``risk`` and ``fly``
(what ``stlc simulate``, ``stlc sweep``, ``stlc risk`` and ``stlc fly`` do, returning data).

``simulate`` returns a ``Simulation`` (the nominal ``Plan``, the executed trajectory, the
event log and the executed verdict); ``sweep`` returns a table, one row per instance, with
the varied values in the units the axes were given in (a pandas ``DataFrame`` when pandas is
installed, else a list of dicts); ``risk`` returns the contents of ``risk.json``.
"""

from __future__ import annotations

import html
import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

from stlc.diagnostics import Diagnostic, Span, StlcError
from stlc.planning import words
from stlc.results.plan import Plan, needs_pandas


def _one_mission(program, mission: str | None, verb: str):
    from stlc.pipeline import one_mission

    return one_mission(program.file, program, mission, verb)


# ---------------------------------------------------------------- simulate


@dataclass
class Simulation:
    """A flown mission (``stlc.simulate``): the nominal ``plan``, what was flown and the
    verdict on it."""

    plan: Plan
    result: object  # ``stlc.replan.result.SimulationResult``

    @property
    def ok(self) -> bool:
        """Every triggered replan was flown and the executed trajectory keeps the kept specs
        (exact ρ ≥ κ); ``stlc simulate`` exits 0 when this and the nominal plan hold."""
        return bool(self.result.ok()) and self.plan.satisfied

    @property
    def robustness(self) -> dict[str, float]:
        """Exact robustness on the executed trajectory: ``mission`` and each named spec."""
        return {k: float(v) for k, v in self.result.executed_robustness.items()}

    @property
    def executed(self) -> dict:
        """What was flown: channel name → array (``"t"``: the sample times)."""
        return {"t": self.result.times, **self.result.executed}

    @property
    def events(self) -> list[dict]:
        """The event log (``replan.json``'s ``events``)."""
        return [e.to_json_dict() for e in self.result.events]

    def to_json(self) -> dict:
        """The contents of ``replan.json``."""
        return self.result.to_json_dict()

    def to_dataframe(self):
        """The executed trajectory as a pandas ``DataFrame`` (needs pandas)."""
        return needs_pandas("simulation.to_dataframe()").DataFrame(self.executed)

    def write(self, outdir: str | os.PathLike) -> str:
        """Write the files of ``stlc simulate -o OUTDIR``; returns ``outdir``."""
        from stlc.output.directory import preflight
        from stlc.output.simulate import write_simulation

        out = os.fspath(outdir)
        preflight(out, self.plan.mission.span)
        write_simulation(out, self.plan.program, self.plan.mission, self.plan.solution,
                         self.result)
        return out

    def _repr_html_(self) -> str:
        r = self.result
        kept = ", ".join(f"{k} {words.number(self.robustness.get(k))}" for k in r.kept)
        return (f"<div class='stlc-simulation'><h4>{html.escape(r.mission)}: executed "
                f"trajectory {'keeps' if r.ok() else 'does not keep'} its specs</h4>"
                f"<p>{len(r.triggered)} replans over {len(r.events)} event instants; "
                f"exact ρ on what was flown (κ = {r.threshold:g}): {html.escape(kept)}</p>"
                + self.plan._repr_html_() + "</div>")


def _events(items, kind):
    """Disturbances / failures / a move given as model objects or plain tuples."""
    from stlc.replan.move import Move
    from stlc.semantics.model import Disturbance, Failure

    if items is None:
        return None
    if kind == "move":
        if isinstance(items, Move):
            return [items]
        human, t, pos, *yaw = items
        import math

        att = (0.0, 0.0, math.radians(float(yaw[0]))) if yaw and yaw[0] is not None else None
        return [Move(str(human), float(t), tuple(float(x) for x in pos), att)]
    out = []
    for it in items:
        if isinstance(it, (Disturbance, Failure)):
            out.append(it)
        elif kind == "disturb":
            drone, t, d = it if len(it) == 3 else ("", *it)
            out.append(Disturbance(str(drone), float(t), tuple(float(x) for x in d)))
        else:
            drone, t, backup = it
            out.append(Failure(str(drone), float(t), str(backup)))
    return out


def simulate(program, mission: str | None = None, *, disturb=None, fail=None, move=None,
             library: str | os.PathLike | None = None, time_limit: float | None = None,
             set: Mapping | None = None, quiet: bool = True) -> Simulation:  # noqa: A002
    """Plan ``mission`` and fly it through its events, as ``stlc simulate``: the file's
    ``simulate`` block, or ``disturb=[("uav1", 6.0, (1.1, 0, 0))]`` (drone, time s,
    displacement m), ``fail=[("uav1", 60.0, "uav3")]`` (drone, time s, backup) or
    ``move=("operator", 8.0, (0.3, 0.2, 0.0), 20)`` (human, time s, position m, yaw deg).
    ``time_limit`` bounds the nominal plan; replans keep their budget t_c."""
    from stlc.results.inputs import load_program, with_settings
    from stlc.simulation import flight_events, fly

    program = load_program(program)
    values: dict = {}
    if set:
        program, values = with_settings(program, set)
    m = _one_mission(program, mission, "simulate")
    events = flight_events(program, m, _events(disturb, "disturb"), _events(fail, "fail"),
                           _events(move, "move"))
    flown, _, sol, sim = fly(program, m, events, values=values or None,
                             library=None if library is None
                             else os.fspath(library), time_limit=time_limit, quiet=quiet)
    return Simulation(Plan(flown, m, sol), sim)


# ---------------------------------------------------------------- sweep


def _axes_texts(vary) -> list[str]:
    """``--vary`` items from ``{"name": (lo, hi, n)}`` (lo/hi as text with units, or
    numbers) or a list of ``"NAME=LO:HI:N"`` strings."""
    if isinstance(vary, str):
        return [vary]
    if isinstance(vary, Mapping):
        return [f"{k}={v[0]}:{v[1]}:{int(v[2])}" for k, v in vary.items()]
    return [str(v) for v in vary]


def _table(axes, rows: list[dict]):
    """One record per instance: the varied values in the axes' own units."""
    recs = []
    for r in sorted(rows, key=lambda r: r["instance"]):
        rec = {"instance": r["instance"]}
        for a in axes:
            rec[a.name] = a.shown(r["values"][a.name])
        rec.update(status=r["status"], robustness=float(r["robustness"]),
                   **{f"spec.{k}": float(v) for k, v in sorted(r["specs"].items())},
                   iterations=r["iterations"], solve_s=r["solve_s"], total_s=r["total_s"],
                   error=r.get("error", ""))
        recs.append(rec)
    units = {a.name: a.unit or "" for a in axes}
    try:
        import pandas as pd
    except ImportError:
        return SweepTable(recs, units)
    df = pd.DataFrame.from_records(recs)
    df.attrs["units"] = units
    return df


class SweepTable(list):
    """A sweep's rows (dicts) without pandas; ``units``: each varied name's unit."""

    def __init__(self, rows: Sequence[dict], units: dict[str, str]):
        super().__init__(rows)
        self.units = units


def sweep(program, mission: str | None = None, vary=(), *, random: int | None = None,
          seed: int = 0, set: Mapping | None = None,  # noqa: A002
          time_limit: float | None = None, workers: int | None = None,
          scheduler: str | None = None, out: str | os.PathLike | None = None,
          quiet: bool = True):
    """Plan ``mission`` over a grid (or ``random`` draws) of values, as ``stlc sweep``:
    ``vary={"operator.att.z": ("-30 deg", "30 deg", 3)}`` or ``["NAME=LO:HI:N", ...]``.
    Without ``workers``/``scheduler`` the instances run here, one after another, each
    warm-started from the plans solved before it; with them, on Dask as the CLI does
    (writing its files into ``out``).  Returns the table (see the module)."""
    from stlc.semantics import overrides
    from stlc.sweeping import axes as axes_mod

    path = os.fspath(program) if isinstance(program, (str, os.PathLike)) else program.file
    sets = [f"{k}={v}" for k, v in (set or {}).items()]
    texts = _axes_texts(vary)
    if workers is not None or scheduler is not None or out is not None:
        from stlc.sweeping.run import sweep as run

        rows: list[dict] = []
        run(path, mission, texts, sets, None if out is None else os.fspath(out), workers,
            scheduler, random, seed, quiet, time_limit=time_limit, collect=rows)
        return _table([axes_mod.parse_axis(path, v) for v in texts], rows)
    from stlc.frontend.syntax import parse, parse_file
    from stlc.sweeping.task import run_instance

    tree = parse_file(path) if isinstance(program, (str, os.PathLike)) else \
        parse(program.source, program.file)
    axes = [axes_mod.parse_axis(path, v) for v in texts]
    if not axes:
        raise StlcError([Diagnostic("STL104", "nothing to sweep: give vary={NAME: (LO, HI, N)}",
                                    Span(path, 1, 1, 1, 2),
                                    "e.g. vary={'operator.att.z': ('-30 deg', '30 deg', 6)}")])
    fixed = overrides.split(sets)
    insts = axes_mod.instances(axes, random, seed)
    for corner in (insts[0], insts[-1]):  # names, units and the mission, before any solve
        checked, _ = overrides.checked(tree, fixed + [(n, t) for n, _, t in corner])
        name = _one_mission(checked, mission, "sweep").name
    rows = []
    for i, inst in enumerate(insts):
        row = run_instance(tree.source, path, name, fixed + [(n, t) for n, _, t in inst],
                           {n: v for n, v, _ in inst}, i, time_limit=time_limit)
        row.pop("plan_csv", None)
        row.pop("channels", None)
        rows.append(row)
    return _table(axes, rows)


# ---------------------------------------------------------------- risk


def risk(program, mission: str | None = None, trajectory=None, *,
         set: Mapping | None = None) -> dict:  # noqa: A002
    """The mission's risk cases on a plan, as ``stlc risk``: ``trajectory`` is a ``Plan``,
    a ``trajectory.csv`` path or a mapping of channel → array with ``"t"``.  Returns the
    contents of ``risk.json`` (per case: VaR/CVaR of the exact robustness, the violation
    probability, …)."""
    from stlc.analysis.assess import run_risk, select_mission
    from stlc.analysis.trace import read_trace
    from stlc.planning.solution import Solution
    from stlc.results.inputs import load_program, trace_of, with_settings

    program = load_program(program)
    if set:
        program, _ = with_settings(program, set)
    if isinstance(trajectory, Plan):
        mission = mission or trajectory.mission.name
        sol, dt = trajectory.solution, None
    elif trajectory is None:
        raise TypeError("risk() needs trajectory= (a Plan, a CSV path or a mapping)")
    else:
        tr = trace_of(trajectory) if isinstance(trajectory, Mapping) else \
            read_trace(os.fspath(trajectory))
        sol = Solution(str(mission or ""), "satisfied", 0.0, 0.0, {}, 0.0, tr.times,
                       tr.channels)
        dt = tr.dt
    m = select_mission(program.file, program, mission)
    out, _ = run_risk(program, m, sol, dt=dt)
    if out is None:
        raise StlcError([Diagnostic("STL104", f"mission `{m.name}` declares no risk cases",
                                    m.span, "add `risk { K = 1000; case ... }` to the "
                                    "mission")])
    return out


# ---------------------------------------------------------------- fly


def fly(program, mission: str | None = None, out=None, *, wind=None,
        turbulence: str | None = None, runs: int | None = None, seed: int = 0, noise=None,
        time_limit: float | None = None) -> dict:
    """Plan the mission and fly it closed loop, as ``stlc fly`` (``program``: a ``.stl``
    path or a loaded program, flown as its file is written).  Writes the command's files
    into ``out`` (default: a new temporary folder) and returns ``flight.json``'s contents:
    ``plan``/``flown`` robustness, ``tracking`` errors and, with ``runs``, P(violation),
    VaR and CVaR of the flown robustness."""
    import json
    import tempfile

    from stlc.flying import fly_file

    path = os.fspath(getattr(program, "file", program))
    outdir = os.fspath(out) if out is not None else tempfile.mkdtemp(prefix="stlc-fly-")
    fly_file(path, outdir, mission, wind=wind, turbulence=turbulence, runs=runs, seed=seed,
             noise=noise, quiet=True, time_limit=time_limit)
    record = os.path.join(outdir, "flight.json")
    if not os.path.exists(record):  # no plan to fly: the plan's files say why
        raise StlcError([Diagnostic("STL503", f"{path}: no plan to fly (see {outdir})",
                                    Span(path, 1, 1, 1, 2), "plan it with stlc.compile first")])
    with open(record, encoding="utf-8") as fh:
        return json.load(fh)
