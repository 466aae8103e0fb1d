"""Command line: ``stlc check | monitor | compile | simulate | risk | bench``.

Exit codes (contract): 0 success, 1 the input is wrong (diagnostics printed, nothing
written), 2 bad command-line usage, 3 ``compile`` found no satisfying plan, or
``simulate``'s executed trajectory did not keep its specs (report still written), 130
interrupted by Ctrl-C (nothing written, earlier outputs left as they were), 141 the reader
of stdout went away.  Bad input never shows a Python traceback; an internal error prints
one line (set ``STLC_DEBUG=1`` for the traceback) and exits 4.

Every command runs in a worker thread with a large stack (``stlc.interrupt.run``): deep
formulas recurse safely and Ctrl-C stops a running solve at once.
"""

from __future__ import annotations

import argparse
import contextlib
import math
import os
import sys
import traceback

from stlc.diagnostics import StlcError, render_all, to_json
from stlc.exitcodes import EXIT_BROKEN_PIPE, EXIT_INPUT, EXIT_INTERNAL, EXIT_INTERRUPTED, EXIT_OK


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="stlc", description="STL mission compiler for multirotor "
                                "drones: check, monitor, compile (plan), assess risk.")
    sub = p.add_subparsers(dest="cmd", required=True, metavar="COMMAND")

    c = sub.add_parser("check", help="parse and type-check .stl files")
    c.add_argument("files", nargs="+", metavar="FILE")
    c.add_argument("--format", choices=("text", "json"), default="text")

    m = sub.add_parser("monitor", help="exact robustness of a file's specs on a trace")
    m.add_argument("file", metavar="FILE")
    m.add_argument("--trace", required=True, metavar="CSV")
    m.add_argument("--json", action="store_true", help="print one JSON object")

    k = sub.add_parser("compile", help="plan a trajectory for each mission and write a report")
    k.add_argument("file", metavar="FILE")
    k.add_argument("-o", "--out", metavar="OUTDIR", default=None)
    k.add_argument("--mission", metavar="NAME", default=None)
    k.add_argument("-q", "--quiet", action="store_true", help="no progress output")
    k.add_argument("--no-risk", action="store_true", help="skip the mission's risk cases")
    k.add_argument("--backend", metavar="NAME", default=None,
                   help="force a backend chain: milp | nlp | team (or a backend's name); "
                   "default: chosen by capabilities")

    s = sub.add_parser("simulate", help="fly a compiled plan through disturbances or a drone "
                       "failure, with online replanning")
    s.add_argument("file", metavar="FILE")
    s.add_argument("--mission", metavar="NAME", default=None)
    s.add_argument("-o", "--out", metavar="OUTDIR", default=None)
    s.add_argument("-q", "--quiet", action="store_true", help="no progress output")
    s.add_argument("--disturb", metavar="[DRONE@]T:DX,DY,DZ", action="append", default=[],
                   type=_disturbance, help="push the vehicle by (DX, DY, DZ) m at T s "
                   "(repeatable; replaces the file's simulate block)")
    s.add_argument("--fail", metavar="DRONE@T", type=_failure, default=None,
                   help="DRONE fails at T s (needs --backup)")
    s.add_argument("--backup", metavar="DRONE", default=None,
                   help="the declared drone that takes over after --fail")

    r = sub.add_parser("risk", help="risk analysis of an existing plan")
    r.add_argument("file", metavar="FILE")
    r.add_argument("--trajectory", required=True, metavar="CSV")
    r.add_argument("--mission", metavar="NAME", default=None)
    r.add_argument("-o", "--out", metavar="OUTDIR", default=None)

    b = sub.add_parser("bench", help="benchmarks (monitor, compile)")
    b.add_argument("args", nargs=argparse.REMAINDER)
    return p


def _number(text: str, what: str) -> float:
    try:
        x = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{what} {text!r} is not a number") from None
    if not math.isfinite(x):
        raise argparse.ArgumentTypeError(f"{what} {text!r} is not finite")
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


def _failure(text: str) -> tuple[str, float]:
    drone, sep, t = text.partition("@")
    if not sep or not drone:
        raise argparse.ArgumentTypeError(f"{text!r}: expected DRONE@T, e.g. uav1@60")
    return drone, _number(t, "time")


def main(argv: list[str] | None = None) -> int:
    from stlc import interrupt

    parser = _parser()
    args = parser.parse_args(argv)
    if args.cmd == "simulate" and (args.fail is None) != (args.backup is None):
        parser.error("--fail and --backup go together")
    cmd = {"check": cmd_check, "monitor": cmd_monitor, "compile": cmd_compile,
           "simulate": cmd_simulate, "risk": cmd_risk, "bench": cmd_bench}[args.cmd]
    try:
        # a big-stack worker thread: deep formulas recurse safely, Ctrl-C stops at once
        return interrupt.run(lambda: cmd(args))
    except StlcError as e:
        _print_diags(e, None)
        return EXIT_INPUT
    except KeyboardInterrupt:
        print("stlc: interrupted", file=sys.stderr)
        if interrupt.abandoned():  # the solver did not stop in time: leave without finalising
            sys.stdout.flush()
            sys.stderr.flush()
            os._exit(EXIT_INTERRUPTED)
        return EXIT_INTERRUPTED
    except BrokenPipeError:  # `stlc monitor ... | head`: the reader left; nothing to say
        with contextlib.suppress(OSError):
            os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return EXIT_BROKEN_PIPE
    except Exception as e:  # noqa: BLE001 - the last line of defence
        if os.environ.get("STLC_DEBUG"):
            traceback.print_exc()
        print(f"stlc: internal error: {type(e).__name__}: {e}\n"
              "  = help: this is a bug in stlc; rerun with STLC_DEBUG=1 for details",
              file=sys.stderr)
        return EXIT_INTERNAL


def _sources(diags) -> dict[str, str]:
    out = {}
    for d in diags:
        f = d.span.file
        if f and f not in out:
            try:
                with open(f, encoding="utf-8", errors="replace") as fh:
                    out[f] = fh.read().removeprefix("\ufeff")
            except OSError:
                pass
    return out


def _print_diags(e: StlcError, sources: dict[str, str] | None) -> None:
    srcs = sources if sources is not None else _sources(e.diagnostics)
    print(render_all(e.diagnostics, srcs), file=sys.stderr)
    n = len(e.diagnostics)
    print(f"stlc: {n} error{'s' if n != 1 else ''}", file=sys.stderr)


def cmd_check(args) -> int:
    from stlc.pipeline import check_paths

    diags, sources = check_paths(args.files)
    if args.format == "json":
        print(to_json(diags))
    elif diags:
        _print_diags(StlcError(diags), sources)
    else:
        for f in args.files:
            print(f"{f}: ok")
    return EXIT_INPUT if diags else EXIT_OK


def cmd_monitor(args) -> int:
    from stlc.analysis.trace import read_trace
    from stlc.pipeline import load, monitor_trace

    program = load(args.file).program
    trace = read_trace(args.trace)
    res = monitor_trace(program, trace)
    for v in res.values():  # a NaN robustness (e.g. sqrt of a negative value) is undefined
        if math.isnan(v["robustness"]):
            v["satisfied"] = None
    if args.json:  # strict JSON: ±∞ as "inf"/"-inf", undefined (NaN) as null
        from stlc.strictjson import strict_dumps

        print(strict_dumps({"specs": res}))
    else:
        width = max((len(k) for k in res), default=4)
        print(f"{'spec':<{width}}  {'robustness':>12}  satisfied")
        for k, v in res.items():
            sat = {True: "yes", False: "no", None: "undefined"}[v["satisfied"]]
            print(f"{k:<{width}}  {v['robustness']:>12.6g}  {sat}")
    return EXIT_OK


def cmd_compile(args) -> int:
    from stlc.pipeline import compile_file

    return compile_file(args.file, out=args.out, mission=args.mission, quiet=args.quiet,
                        risk=not args.no_risk, backend=args.backend)


def cmd_simulate(args) -> int:
    from stlc.pipeline import simulate_file
    from stlc.semantics.model import Failure

    fails = [Failure(args.fail[0], args.fail[1], args.backup)] if args.fail else None
    return simulate_file(args.file, out=args.out, mission=args.mission,
                         disturbances=args.disturb or None, failures=fails, quiet=args.quiet)


def cmd_risk(args) -> int:
    from stlc.pipeline import risk_file

    return risk_file(args.file, args.trajectory, mission=args.mission, out=args.out)


def cmd_bench(args) -> int:
    from stlc import bench

    return bench.main(args.args)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
