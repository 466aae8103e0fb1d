"""The pipeline: orders the passes (parse → check → backend → Solution → outputs).

Each function here only calls passes in order and times them; the work is in the passes.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from stlc import ir, model
from stlc.check import check
from stlc.diagnostics import Diagnostic, StlcError
from stlc.syntax import parse_file


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
    """Exact robustness of every monitored formula on a trace (``stlc.trace.Trace``)."""
    from stlc import monitor
    from stlc.trace import check_signals

    formulas = monitored_formulas(program)
    # all at once: named specs share subformulas (a chain of hundreds of specs, each using
    # the previous one, is evaluated in linear time and without recursion)
    check_signals(trace, ir.signals(ir.And(tuple(formulas.values()))))
    values = monitor.robustness_many(list(formulas.values()), trace.dt, trace.channels,
                                     program.params, n=trace.n)
    out = {}
    for name, v in zip(formulas, values):
        r = float(v)
        out[name] = {"robustness": r, "satisfied": bool(r > 0)}
    return out


def as_float(x) -> float:
    return float(np.asarray(x).reshape(-1)[0])
