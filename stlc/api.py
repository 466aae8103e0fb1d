"""The Python API: ``stlc.load``, ``stlc.loads``, ``stlc.compile``, ``stlc.monitor``.

For scripts and notebooks (the CLI is a thin layer over the same passes)::

    import stlc
    program = stlc.load("specs/handover.stl")          # parsed and checked
    plan = stlc.compile(program, "handover_left_tb")  # planned and verified (exact monitor)
    plan.status, plan.robustness, plan.specs["safety"], plan.trajectory["uav1.pos.x"]
    plan.write("out/")                                 # the files of `stlc compile -o out/`
    stlc.monitor(program, "trajectory.csv")            # {name: exact robustness}

Invalid input raises ``stlc.StlError``; its ``.diagnostics`` carry ``.code``, ``.line``,
``.column`` (1-based) and ``.message``.  Nothing here imports CasADi until a plan is asked
for (``stlc.compile``).
"""

from __future__ import annotations

import math
import os
from collections.abc import Mapping
from dataclasses import dataclass, field, replace

from stlc.diagnostics import Diagnostic, Span, StlcError, did_you_mean

StlError = StlcError  # the public name; ``.diagnostics`` is a list of ``Diagnostic``


def load(path: str | os.PathLike):
    """Parse and check a ``.stl`` file → the checked program (``stlc.semantics.model``)."""
    from stlc.pipeline import load as _load

    return _load(os.fspath(path)).program


def loads(text: str, filename: str = "<text>"):
    """Parse and check source text → the checked program."""
    from stlc.frontend.syntax import parse
    from stlc.semantics.check import check

    return check(parse(text.removeprefix("\ufeff"), filename))


def with_constants(program, values: Mapping[str, object]):
    """The program checked again with some ``const`` declarations replaced: ``{"T_N": "20 s",
    "w": 0.3}`` (a value is source text or a number; the constant's unit rules apply)."""
    from stlc.frontend import ast
    from stlc.frontend.syntax import parse
    from stlc.semantics.check import check

    tree = parse(program.source, program.file)
    consts = {m.name: m for m in tree.members if isinstance(m, ast.Named) and m.kind == "const"}
    diags = [Diagnostic("STL101", f"no constant `{k}` to set", Span(program.file, 1, 1, 1, 2),
                        did_you_mean(k, consts) or "constants: " + (", ".join(consts) or "none"))
             for k in values if k not in consts]
    if diags:
        raise StlError(diags)
    members = []
    for m in tree.members:
        if m in consts.values() and m.name in values:
            v = values[m.name]
            text = repr(float(v)) if isinstance(v, (int, float)) else str(v)
            expr = parse(f"const {m.name} = {text}\n", f"<set {m.name}>").members[0].value
            m = replace(m, value=expr)
        members.append(m)
    return check(replace(tree, members=tuple(members)))


@dataclass
class Plan:
    """One planned and verified mission (``stlc.compile``)."""

    program: object
    mission: object
    solution: object  # the internal ``Solution``
    _written: list = field(default_factory=list, repr=False)

    @property
    def status(self) -> str:
        """``"satisfied"`` (exact robustness ≥ the mission's threshold), ``"violated"`` or
        ``"solver_failed"``."""
        return str(self.solution.status)

    @property
    def robustness(self) -> float:
        """The exact robustness of the mission's requirement (the monitor's, not the
        solver's)."""
        return float(self.solution.robustness_exact)

    @property
    def specs(self) -> dict[str, float]:
        """Exact robustness of every named spec."""
        return {k: float(v.robustness) for k, v in self.solution.specs.items()}

    @property
    def trajectory(self) -> dict:
        """Channel name → numpy array (``"t"``: the sample times)."""
        return {"t": self.solution.times, **self.solution.channels}

    def to_json(self) -> dict:
        """The ``solution.json`` of this plan, as a dict (strict JSON values)."""
        import json

        from stlc.output.solution import solution_json

        return json.loads(solution_json(self.solution))

    def write(self, outdir: str | os.PathLike) -> str:
        """Write the files of ``stlc compile -o OUTDIR`` (same contract: only stlc's own
        files, each replaced atomically, as one set); returns ``outdir``."""
        from stlc.output.compile import write_outputs
        from stlc.output.directory import preflight

        out = os.fspath(outdir)
        preflight(out, self.mission.span)
        write_outputs(out, self.program, self.mission, self.solution)
        return out


def compile(program, mission: str | None = None, *, set: Mapping | None = None,  # noqa: A001,A002
            risk: bool = True, quiet: bool = True) -> Plan:
    """Plan ``mission`` (its name; optional when the program has one mission), verify the
    plan with the exact monitor and run its risk cases (``risk=False`` skips them).
    ``set``: constants to override, as in ``with_constants``.  ``quiet=False`` prints the
    solver's progress to stderr.  Safe under threads: plannings in one process run one
    at a time (``stlc.deadline.serial``; a second thread waits), so use processes to plan
    in parallel."""
    import time

    from stlc.pipeline import assess_risk, plan, select_missions

    if isinstance(program, (str, os.PathLike)):
        program = load(program)
    if set:
        program = with_constants(program, set)
    chosen = select_missions(program.file, program, mission)
    if len(chosen) > 1:
        raise StlError([Diagnostic("STL104", f"{program.file} has {len(chosen)} missions: "
                                   "say which to compile", Span(program.file, 1, 1, 1, 2),
                                   "missions: " + ", ".join(m.name for m in chosen))])
    m = chosen[0]
    t0 = time.perf_counter()
    problem, sol = plan(program, m, quiet=quiet)
    if risk and m.risk is not None:
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


def _trace_of(data: Mapping):
    import numpy as np

    from stlc.analysis.trace import Trace

    where = Span("<trace>", 1, 1, 1, 2)

    def bad(code: str, msg: str, hint: str):
        return StlError([Diagnostic(code, msg, where, hint)])

    if "t" not in data:
        raise bad("STL602", "the trace has no `t`", "pass the sample times as trace['t']")
    try:
        cols = {str(k): np.asarray(v, dtype=float).reshape(-1) for k, v in data.items()}
    except (TypeError, ValueError) as e:
        raise bad("STL602", f"a trace column is not numeric: {e}",
                  "pass arrays of numbers") from None
    t = cols.pop("t")
    if any(len(c) != len(t) for c in cols.values()) or len(t) == 0:
        raise bad("STL602", "trace columns differ in length (or are empty)",
                  "every column needs one value per time")
    if not np.all(np.isfinite(t)):
        raise bad("STL602", "the trace's times are not finite", "pass finite times")
    dt = float(t[1] - t[0]) if len(t) > 1 else 1.0
    if len(t) > 1 and (dt <= 0 or not np.allclose(np.diff(t), dt, rtol=1e-6, atol=1e-9)):
        raise bad("STL604", "the trace's time column is not uniform",
                  "resample the trace to a uniform step")
    return Trace(t, dt if math.isfinite(dt) else 1.0, cols, "<trace>")
