"""What the Python API takes in: a program with some constants replaced
(``with_constants``) and a trace given as arrays (``trace_of``)."""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import replace

from stlc.diagnostics import Diagnostic, Span, StlcError, did_you_mean


def load_program(program):
    """A checked program: ``program`` itself, or the file at that path, parsed and checked."""
    import os

    if isinstance(program, (str, os.PathLike)):
        from stlc.pipeline import load

        return load(os.fspath(program)).program
    return program


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
        raise StlcError(diags)
    members = []
    for m in tree.members:
        if m in consts.values() and m.name in values:
            v = values[m.name]
            text = repr(float(v)) if isinstance(v, (int, float)) else str(v)
            expr = parse(f"const {m.name} = {text}\n", f"<set {m.name}>").members[0].value
            m = replace(m, value=expr)
        members.append(m)
    return check(replace(tree, members=tuple(members)))


def trace_of(data: Mapping):
    """A mapping of channel name → array (with ``"t"``) as a checked ``Trace``."""
    import numpy as np

    from stlc.analysis.trace import Trace

    where = Span("<trace>", 1, 1, 1, 2)

    def bad(code: str, msg: str, hint: str):
        return StlcError([Diagnostic(code, msg, where, hint)])

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


def with_settings(program, values: Mapping[str, object]):
    """``--set`` from Python: constants, a human's pose field (``operator.pos.x``), a
    vehicle's start (``uav1.start.pos.y``) or a region's placement, each with its unit
    (``{"operator.att.z": "20 deg"}``; a number is unitless).  Returns (program, the values
    set in SI by name); only constants: ``with_constants`` (values empty)."""
    from stlc.frontend import ast
    from stlc.frontend.syntax import parse
    from stlc.semantics import overrides

    tree = parse(program.source, program.file)
    consts = {m.name for m in tree.members if isinstance(m, ast.Named) and m.kind == "const"}
    if all(k in consts for k in values):
        return with_constants(program, values), {}
    items = [(k, repr(float(v)) if isinstance(v, (int, float)) else str(v))
             for k, v in values.items()]
    return overrides.checked(tree, items)
