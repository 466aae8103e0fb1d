"""Command line: ``stlc check | monitor | compile | simulate | fly | risk | bench | fmt |
lsp | explain`` (the language tools live in ``stlc.tools``).

Exit codes (contract): 0 success, 1 the input is wrong (diagnostics printed, nothing
written), 2 bad command-line usage, 3 ``compile`` found no satisfying plan, or
``simulate``'s executed trajectory did not keep its specs (report still written), 130
interrupted by Ctrl-C (nothing written, earlier outputs left as they were; SIGTERM 143 and
SIGHUP 129 alike), 141 the reader of stdout went away.  Bad input never shows a Python
traceback; an internal error prints one line (``STLC_DEBUG=1``: the traceback), exits 4.

Every command runs in a worker thread with a large stack (``stlc.interrupt.run``): deep
formulas recurse safely and Ctrl-C stops a running solve at once.
"""

from __future__ import annotations

import argparse
import contextlib
import math
import os
import sys
import threading
import time
import traceback

from stlc.diagnostics import StlcError, count_text, render_all, to_json
from stlc.exitcodes import (EXIT_BROKEN_PIPE, EXIT_INPUT, EXIT_INTERNAL, EXIT_INTERRUPTED,
                            EXIT_OK, EXIT_UNSAT)
from stlc.limits import source_text

_STARTED = time.monotonic()  # `--time-limit` counts from here (the imports before are ~0.3 s)


class _Once(argparse._StoreAction):
    """An option that cannot be repeated: given twice it is a usage error (exit 2), never
    a silently dropped value (`--fail uav1@5 --fail uav2@6`)."""

    def __call__(self, parser, namespace, values, option_string=None):
        seen = namespace.__dict__.setdefault("_given", set())
        if option_string is not None and self.dest in seen:
            parser.error(f"{'/'.join(self.option_strings)} given more than once; it takes "
                         "one value")
        seen.add(self.dest)
        super().__call__(parser, namespace, values, option_string)


class _Sub(argparse.ArgumentParser):
    def __init__(self, *a, **k):
        super().__init__(*a, **k)
        self.register("action", None, _Once)
        self.register("action", "store", _Once)


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="stlc", description="STL mission compiler for multirotor "
                                "drones: check, monitor, compile (plan), assess risk.")
    from stlc import __version__

    p.add_argument("--version", action="version", version=f"stlc {__version__}",
                   help="print the version and exit")
    sub = p.add_subparsers(dest="cmd", required=True, metavar="COMMAND", parser_class=_Sub)

    c = sub.add_parser("check", help="parse and type-check .stl files")
    c.add_argument("files", nargs="+", metavar="FILE", help="the .stl files to check")
    c.add_argument("--format", choices=("text", "json"), default="text",
                   help="diagnostics as text (default) or one JSON object")
    c.add_argument("--deny-warnings", action="store_true", help="warnings are errors")
    _set_option(c)

    m = sub.add_parser("monitor", help="exact robustness of a file's specs on a trace")
    m.add_argument("file", metavar="FILE", help="the .stl file whose specs are monitored")
    from stlc.flying import add_log_options
    add_log_options(m)
    m.add_argument("--json", action="store_true", help="print one JSON object")
    m.add_argument("--resample", metavar="DT", type=_seconds, default=None,
                   help="interpolate a log with a non-uniform time column onto steps of DT s")
    m.add_argument("--fail-on-violation", action="store_true",
                   help="exit 3 when a spec is violated (ρ < κ) or undefined")
    m.add_argument("--mission", metavar="NAME", default=None,
                   help="judge only this mission's specs and requirement, at its threshold κ")
    _set_option(m)

    k = sub.add_parser("compile", help="plan a trajectory for each mission and write a report")
    k.add_argument("file", metavar="FILE", help="the .stl file")
    k.add_argument("-o", "--out", metavar="OUTDIR", default=None,
                   help="where the outputs go (default: reports/<mission>/)")
    k.add_argument("--mission", metavar="NAME", default=None,
                   help="the mission to compile (default: every mission of the file)")
    k.add_argument("-q", "--quiet", action="store_true", help="no progress output")
    k.add_argument("--no-risk", action="store_true", help="skip the mission's risk cases")
    _budget_option(k)
    k.add_argument("--backend", metavar="NAME", default=None,
                   help="force a backend chain: milp | nlp | kinematic | team (or a "
                   "backend's name); default: chosen by capabilities")
    k.add_argument("--time-limit", metavar="SECONDS", type=_seconds, default=None,
                   help="stop planning after SECONDS and write the best verified plan")
    k.add_argument("--deny-warnings", action="store_true", help="warnings are errors "
                   "(exit 1 before planning; a plan's own warnings: exit 3)")
    k.add_argument("--keep-on-interrupt", action="store_true", help="Ctrl-C stops planning "
                   "and writes the best verified plan (exit 130); a second one stops at once")
    _set_option(k)

    s = sub.add_parser("simulate", help="fly a compiled plan through disturbances or a drone "
                       "failure, with online replanning")
    s.add_argument("file", metavar="FILE", help="the .stl file")
    s.add_argument("--mission", metavar="NAME", default=None,
                   help="the mission to fly (needed when the file has several)")
    s.add_argument("-o", "--out", metavar="OUTDIR", default=None,
                   help="where the outputs go (default: reports/<mission>/)")
    s.add_argument("-q", "--quiet", action="store_true", help="no progress output")
    s.add_argument("--disturb", metavar="[DRONE@]T:DX,DY,DZ", action="append", default=[],
                   type=_disturbance, help="push the vehicle by (DX, DY, DZ) m at T s "
                   "(repeatable; replaces the file's simulate block)")
    s.add_argument("--fail", metavar="DRONE@T", type=_failure, default=None,
                   help="DRONE fails at T s (needs --backup)")
    s.add_argument("--backup", metavar="DRONE", default=None,
                   help="the declared drone that takes over after --fail")
    s.add_argument("--time-limit", metavar="SECONDS", type=_seconds, default=None,
                   help="stop planning the nominal plan after SECONDS (best verified plan)")
    _budget_option(s)
    s.add_argument("--move", metavar="HUMAN@T:X,Y,Z[:YAW]", type=_move, default=None,
                   help="the human moves to (X, Y, Z) m [turned to YAW deg] at T s: keep the "
                   "plan or replan the rest (paper A §6)")
    s.add_argument("--library", metavar="DIR", default=None,
                   help="warm-start a replan from the nearest plan of a sweep's DIR")
    _set_option(s)

    from stlc.flying import add_parser as add_fly
    add_fly(sub, _set_option, _seconds)

    r = sub.add_parser("risk", help="risk analysis of an existing plan")
    r.add_argument("file", metavar="FILE", help="the .stl file with the risk cases")
    r.add_argument("--trajectory", required=True, metavar="CSV",
                   help="the plan to assess (a trajectory.csv of `stlc compile`)")
    r.add_argument("--mission", metavar="NAME", default=None,
                   help="the mission whose risk cases run (default: the only one with any)")
    r.add_argument("-o", "--out", metavar="OUTDIR", default=None,
                   help="where risk.json goes (default: the trajectory's directory)")
    _budget_option(r)
    _set_option(r)
    rg = r.add_mutually_exclusive_group()
    rg.add_argument("--workers", metavar="K", type=int, default=None,
                    help="evaluate the realisations in batches on a local Dask cluster")
    rg.add_argument("--scheduler", metavar="ADDRESS", default=None,
                    help="... or on an existing Dask cluster")

    w = sub.add_parser("sweep", help="plan one mission over a grid of --set values, on Dask")
    w.add_argument("file", metavar="FILE", help="the .stl file")
    w.add_argument("--mission", metavar="NAME", default=None,
                   help="the mission to sweep (needed when the file has several)")
    w.add_argument("--vary", metavar="NAME=LO:HI:N", action="append", default=[],
                   help="an axis: N values from LO to HI (units as in the language)")
    w.add_argument("--random", metavar="N", type=int, default=None,
                   help="N uniform draws from the box of the --vary axes instead of a grid")
    w.add_argument("--seed", type=int, default=0, help="seed of the --random draws")
    _set_option(w)
    g = w.add_mutually_exclusive_group()
    g.add_argument("--workers", metavar="K", type=int, default=None,
                   help="local cluster of K worker processes (default: the cores)")
    g.add_argument("--scheduler", metavar="ADDRESS", default=None,
                   help="an existing Dask cluster, e.g. tcp://host:8786")
    w.add_argument("-o", "--out", metavar="DIR", default=None,
                   help="where the sweep's outputs go (default: reports/<mission>-sweep/)")
    w.add_argument("-q", "--quiet", action="store_true", help="no progress output")
    w.add_argument("--time-limit", metavar="SECONDS", type=_seconds, default=None,
                   help="each instance's limit: a stopped instance is a `stopped` row")

    b = sub.add_parser("bench", help="benchmarks (monitor, compile, suite)")
    b.add_argument("args", nargs=argparse.REMAINDER,
                   help="`monitor`, `compile FILE.stl ...` or `suite` (see `stlc bench -h`)")

    f = sub.add_parser("fmt", help="format .stl files in place (`-`: stdin to stdout)")
    f.add_argument("files", nargs="+", metavar="FILE",
                   help="the .stl files to format in place (`-`: stdin to stdout)")
    f.add_argument("--check", action="store_true", help="write nothing; exit 1 and name "
                   "the files that would change")
    sub.add_parser("lsp", help="the language server (LSP over stdio, for editors)")
    e = sub.add_parser("explain", help="the long explanation of an error code")
    e.add_argument("code", metavar="STLxxx", help="an error code, e.g. STL101")
    return p


def _budget_option(p: argparse.ArgumentParser) -> None:
    p.add_argument("--max-memory", metavar="SIZE", type=_size, default=None,
                   help="memory budget of a planning problem, e.g. 4G (default: half the "
                   "machine's memory, at most 16G); larger problems are refused (STL606)")


def _size(text: str) -> int:
    from stlc.limits import parse_size

    try:
        return parse_size(text)
    except ValueError as e:
        raise argparse.ArgumentTypeError(str(e)) from None


def _set_option(p: argparse.ArgumentParser) -> None:
    p.add_argument("--set", metavar="NAME=VALUE", action="append", default=[], dest="sets",
                   help="give a const, a human's pose field (operator.pos.x) or a vehicle's "
                   "start (uav1.start.pos.y) another value, with its unit (repeatable)")


def _number(text: str, what: str) -> float:
    try:
        x = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{what} {text!r} is not a number") from None
    if not math.isfinite(x):
        raise argparse.ArgumentTypeError(f"{what} {text!r} is not finite")
    return x


def _seconds(text: str) -> float:
    x = _number(text, "seconds")
    if x <= 0:
        raise argparse.ArgumentTypeError(f"{text!r} must be a positive number of seconds")
    return x


def _disturbance(text: str):
    """``[DRONE@]T:DX,DY,DZ`` → ``model.Disturbance`` (vehicle "" = the mission's only one)."""
    from stlc.semantics.model import Disturbance

    drone, _, rest = text.rpartition("@")
    t, sep, vec = rest.partition(":")
    parts = vec.split(",")
    if not sep or len(parts) != 3:
        raise argparse.ArgumentTypeError(f"{text!r}: expected [DRONE@]T:DX,DY,DZ, "
                                         "e.g. 6:1.1,0,0 (seconds, metres)")
    d = tuple(_number(x, "displacement") for x in parts)
    return Disturbance(drone, _number(t, "time"), d)  # type: ignore[arg-type]


def _move(text: str):
    from stlc.replan.move import Move

    human, sep, rest = text.partition("@")
    parts = rest.split(":")
    xyz = parts[1].split(",") if len(parts) in (2, 3) else []
    if not sep or not human or len(xyz) != 3:
        raise argparse.ArgumentTypeError(f"{text!r}: expected HUMAN@T:X,Y,Z[:YAW], e.g. "
                                         "operator@8:0.3,0.2,0:20 (s, m, deg)")
    yaw = math.radians(_number(parts[2], "yaw")) if len(parts) == 3 else None
    return Move(human, _number(parts[0], "time"), tuple(_number(x, "position") for x in xyz),
                None if yaw is None else (0.0, 0.0, yaw))


def _failure(text: str) -> tuple[str, float]:
    drone, sep, t = text.partition("@")
    if not sep or not drone:
        raise argparse.ArgumentTypeError(f"{text!r}: expected DRONE@T, e.g. uav1@60")
    return drone, _number(t, "time")


def main(argv: list[str] | None = None) -> int:
    from stlc import interrupt, settings

    settings.limit_solver_threads()  # one MUMPS/BLAS thread each, before they load

    parser = _parser()
    args = parser.parse_args(argv)
    if args.cmd == "simulate" and (args.fail is None) != (args.backup is None):
        parser.error("--fail and --backup go together")
    if args.cmd == "lsp":  # asyncio on the main thread; it never returns an input error
        from stlc.tools.lsp import serve

        return serve()
    from stlc import limits

    limits.set_max_memory(getattr(args, "max_memory", None))
    cmd = {"check": cmd_check, "monitor": cmd_monitor, "compile": cmd_compile,
           "simulate": cmd_simulate, "risk": cmd_risk, "bench": cmd_bench,
           "fmt": cmd_fmt, "explain": cmd_explain, "sweep": cmd_sweep,
           "fly": cmd_fly}[args.cmd]
    if threading.current_thread() is threading.main_thread():
        interrupt.on_termination()  # SIGTERM/SIGHUP: Ctrl-C's contract, exit 143/129
    try:
        # a big-stack worker thread: deep formulas recurse safely, Ctrl-C stops at once
        return interrupt.run(lambda: cmd(args))
    except StlcError as e:
        _print_diags(e, None)
        return EXIT_INPUT
    except KeyboardInterrupt:
        code = interrupt.exit_code()
        print("stlc: interrupted" if code == EXIT_INTERRUPTED else
              f"stlc: terminated by signal {code - 128}", file=sys.stderr)
        if interrupt.abandoned():  # the solver did not stop in time: leave without finalising
            sys.stdout.flush()
            sys.stderr.flush()
            os._exit(code)
        return code
    except BrokenPipeError:  # `stlc monitor ... | head`: the reader left; nothing to say
        with contextlib.suppress(OSError):
            os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return EXIT_BROKEN_PIPE
    except Exception as e:  # noqa: BLE001 - the last line of defence
        if settings.debug():
            traceback.print_exc()
        print(f"stlc: internal error: {type(e).__name__}: {e}\n"
              "  = help: this is a bug in stlc; rerun with STLC_DEBUG=1 for details",
              file=sys.stderr)
        return EXIT_INTERNAL
    finally:  # an in-process call (tests, the API) must not leave its budget behind
        limits.set_max_memory(None)


def _sources(diags) -> dict[str, str]:
    out = {}
    for d in diags:
        f = d.span.file
        if f and f not in out:
            with contextlib.suppress(StlcError):
                out[f] = source_text(f)
    return out


def _print_diags(e: StlcError, sources: dict[str, str] | None) -> None:
    srcs = sources if sources is not None else _sources(e.diagnostics)
    print(render_all(e.diagnostics, srcs), file=sys.stderr)
    print(f"stlc: {count_text(e.diagnostics)}", file=sys.stderr)


def cmd_check(args) -> int:
    from stlc.pipeline import check_paths

    from dataclasses import replace

    diags, sources = check_paths(args.files, args.sets)
    if args.deny_warnings:
        diags = [replace(d, severity="error") for d in diags]
    errors = [d for d in diags if d.severity == "error"]
    if args.format == "json":
        print(to_json(diags))
    elif diags:
        _print_diags(StlcError(diags), sources)
    if args.format != "json" and not errors:
        for f in args.files:
            print(f"{f}: ok")
    return EXIT_INPUT if errors else EXIT_OK


def cmd_monitor(args) -> int:
    from stlc.analysis.trace import read_trace
    from stlc.analysis.vacuity import vacuous
    from stlc.diagnostics import emit_warnings
    from stlc.pipeline import load, monitor_trace, monitored_formulas
    from stlc.semantics.specs import mission_named
    from stlc.strictjson import strict_dumps

    loaded = load(args.file, args.sets)
    program = loaded.program
    if args.mission is not None:
        mission_named(args.file, program, args.mission)
    if args.log is not None:
        from stlc.flying import monitor_log  # the flight-log readers load only for --log
        trace, res = monitor_log(args, program)
    else:
        trace = read_trace(args.trace, resample=args.resample)
        res = monitor_trace(program, trace, args.mission)
    found = vacuous(monitored_formulas(program, args.mission), trace.dt, trace.channels,
                    program.params, trace.n)
    emit_warnings(loaded.warnings + found, False, {args.file: program.source})
    if trace.resampled is not None:
        r = trace.resampled
        print(f"note: resampled {r['samples_in']} samples onto steps of {r['dt']:g} s "
              f"(linear interpolation); the largest gap in the log is {r['largest_gap']:g} s "
              f"after t = {r['gap_at']:g} s", file=sys.stderr)
    if args.json:  # strict JSON: ±∞ as "inf"/"-inf", undefined (NaN) as null
        print(strict_dumps({"specs": res, **({"resampled": trace.resampled}
                                             if trace.resampled is not None else {})}))
    else:
        width = max((len(k) for k in res), default=4)
        print(f"{'spec':<{width}}  {'robustness':>12}  {'κ':>8}  satisfied (ρ ≥ κ)")
        for k, v in res.items():
            sat = {True: "yes", False: "no", None: "undefined"}[v["satisfied"]]
            print(f"{k:<{width}}  {v['robustness']:>12.6g}  {v['kappa']:>8.6g}  {sat}")
    if args.fail_on_violation and any(v["satisfied"] is not True for v in res.values()):
        return EXIT_UNSAT
    return EXIT_OK


def cmd_compile(args) -> int:
    from stlc.pipeline import compile_file

    return compile_file(args.file, out=args.out, mission=args.mission, quiet=args.quiet,
                        risk=not args.no_risk, time_limit=args.time_limit, started=_STARTED,
                        deny_warnings=args.deny_warnings, backend=args.backend,
                        sets=args.sets, keep=args.keep_on_interrupt)


def cmd_simulate(args) -> int:
    from stlc.simulation import simulate_file
    from stlc.semantics.model import Failure

    fails = [Failure(args.fail[0], args.fail[1], args.backup)] if args.fail else None
    return simulate_file(args.file, out=args.out, mission=args.mission,
                         disturbances=args.disturb or None, failures=fails, quiet=args.quiet,
                         time_limit=args.time_limit, sets=args.sets,
                         moves=[args.move] if args.move else None, library=args.library)


def cmd_fly(args) -> int:
    from stlc.flying import command

    return command(args)


def cmd_risk(args) -> int:
    from stlc.pipeline import risk_file

    if args.workers is None and args.scheduler is None:
        return risk_file(args.file, args.trajectory, mission=args.mission, out=args.out,
                         sets=args.sets)
    from stlc.analysis.risk_parallel import distributed
    from stlc.sweeping.run import dask_session

    with dask_session(args.workers, args.scheduler, args.file) as client:
        return risk_file(args.file, args.trajectory, mission=args.mission, out=args.out,
                         sets=args.sets, shared=distributed(client))


def cmd_sweep(args) -> int:
    from stlc.sweeping.run import sweep

    return sweep(args.file, args.mission, args.vary, args.sets, args.out, args.workers,
                 args.scheduler, args.random, args.seed, args.quiet,
                 time_limit=args.time_limit)


def cmd_bench(args) -> int:
    from stlc import bench

    return bench.main(args.args)


def cmd_fmt(args) -> int:
    from stlc.tools import fmt_command

    return fmt_command.run(args.files, check=args.check)


def cmd_explain(args) -> int:
    from stlc.tools import explain

    return explain.run(args.code)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
