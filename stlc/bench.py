"""Benchmarks, kept apart from the tests: ``python -m stlc.bench <command>``.

``monitor`` times the exact monitor (and the numpy smooth reference) on a 10,000-sample
trace at dt = 0.1 s for the formula used by RTAMT's published offline benchmark,

    always[0,17] ((x >= 0) and (x <= 5)) and eventually[0,12] (always[0,5] (y >= 1))

and prints a plain-text table: samples, median and best time in ms and the ratio to
RTAMT's ~97 ms.  No timing is asserted anywhere; this is a report.

Subcommands register themselves in ``COMMANDS`` (name -> (help, add_arguments, run)), so
another benchmark is one function pair away.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from collections.abc import Callable

import numpy as np

from stlc.ir import Always, And, Bin, Const, Eventually, Formula, Pred, Sig
from stlc.monitor import robustness
from stlc.smooth import smooth_robustness

RTAMT_MS = 97.0
BENCH_TEXT = ("always[0,17] ((x >= 0) and (x <= 5)) and "
              "eventually[0,12] (always[0,5] (y >= 1))")


def bench_formula() -> Formula:
    x, y = Sig("x"), Sig("y")
    safe = And((Pred(Bin("-", x, Const(0.0)), "x >= 0"), Pred(Bin("-", Const(5.0), x), "x <= 5")))
    reach = Eventually(0.0, 12.0, Always(0.0, 5.0, Pred(Bin("-", y, Const(1.0)), "y >= 1")))
    return And((Always(0.0, 17.0, safe), reach))


def bench_trace(n: int, dt: float, seed: int = 0) -> dict[str, np.ndarray]:
    rng = np.random.default_rng(seed)
    t = np.arange(n) * dt
    return {"x": 2.5 + 2.4 * np.sin(0.3 * t) + rng.normal(0.0, 0.05, n),
            "y": 1.0 + np.sin(0.05 * t) + rng.normal(0.0, 0.5, n)}


def time_ms(fn: Callable[[], object], repeats: int) -> list[float]:
    fn()  # warm-up
    out = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        out.append((time.perf_counter() - t0) * 1e3)
    return out


def table(header: list[str], rows: list[list[str]]) -> str:
    widths = [max(len(r[i]) for r in [header, *rows]) for i in range(len(header))]

    def line(r: list[str]) -> str:
        return "  ".join(c.ljust(w) if i == 0 else c.rjust(w)
                         for i, (c, w) in enumerate(zip(r, widths)))
    return "\n".join([line(header), "  ".join("-" * w for w in widths), *map(line, rows)])


# --------------------------------------------------------------------------- monitor


def _monitor_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("--samples", type=int, default=10_000, help="trace length (default 10000)")
    p.add_argument("--dt", type=float, default=0.1, help="sampling period in s (default 0.1)")
    p.add_argument("--repeats", type=int, default=50, help="timed runs (default 50, min 20)")
    p.add_argument("--lam", type=float, default=10.0, help="λ of the smooth reference")
    p.add_argument("--seed", type=int, default=0)


def _monitor_run(args: argparse.Namespace) -> int:
    repeats = max(20, args.repeats)
    f, ch = bench_formula(), bench_trace(args.samples, args.dt, args.seed)
    cases = [
        ("exact monitor", lambda: robustness(f, args.dt, ch)),
        (f"smooth GKL (λ={args.lam:g})",
         lambda: smooth_robustness(f, args.dt, ch, lam=args.lam)),
        (f"smooth LSE (λ={args.lam:g})",
         lambda: smooth_robustness(f, args.dt, ch, lam=args.lam, method="lse")),
    ]
    rows = []
    for name, fn in cases:
        ms = time_ms(fn, repeats)
        med = statistics.median(ms)
        rows.append([name, f"{args.samples}", f"{med:.3f}", f"{min(ms):.3f}",
                     f"{med / RTAMT_MS:.4f}", f"{fn():.4f}"])
    print(f"formula: {BENCH_TEXT}")
    print(f"trace:   {args.samples} samples, dt = {args.dt:g} s; {repeats} timed runs each\n")
    print(table(["semantics", "samples", "median ms", "min ms", f"/ RTAMT {RTAMT_MS:g} ms",
                 "robustness"], rows))
    return 0


#: name -> (help, add_arguments, run)
COMMANDS: dict[str, tuple[str, Callable[[argparse.ArgumentParser], None],
                          Callable[[argparse.Namespace], int]]] = {
    "monitor": ("time the exact monitor and the smooth reference", _monitor_args, _monitor_run),
}


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="python -m stlc.bench", description=__doc__.split(
        "\n\n")[0])
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for name, (help_text, add_arguments, run) in COMMANDS.items():
        p = sub.add_parser(name, help=help_text, description=help_text)
        add_arguments(p)
        p.set_defaults(run=run)
    return parser


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    return args.run(args)


if __name__ == "__main__":
    sys.exit(main())
