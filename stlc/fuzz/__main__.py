"""``python -m stlc.fuzz``: the long fuzz profile (see ``stlc.fuzz``); exit 1 on any
internal error, hang, memory over the cap, lost user file, unlocated diagnostic or
invalid JSON."""

from __future__ import annotations

import argparse
import sys

from stlc.fuzz.runner import run


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="python -m stlc.fuzz", description=__doc__)
    p.add_argument("-n", type=int, default=10_000, help="number of inputs (default 10000)")
    p.add_argument("--seed", type=int, default=0, help="first seed of every input kind")
    p.add_argument("--jobs", type=int, default=1, help="worker processes")
    p.add_argument("--timeout", type=float, default=10.0, help="seconds per input")
    p.add_argument("--save", metavar="DIR", default=None, help="write failing inputs here")
    p.add_argument("--kinds", default=None, help="comma-separated input kinds, evenly "
                   "(default: all, weighted)")
    a = p.parse_args(argv)
    kinds = tuple(a.kinds.split(",")) if a.kinds else None

    def progress(done, report):
        print(f"  {done} inputs, {report.bad()} failures", file=sys.stderr, flush=True)

    report = run(a.n, a.seed, a.jobs, a.timeout, a.save, progress, kinds)
    print(report.table())
    cpu, kind, seed = report.slowest
    print(f"\n{report.total} inputs in {report.seconds:.0f} s wall; slowest input "
          f"{kind}:{seed} took {cpu:.2f} s CPU")
    for kind, seed, cls, detail in report.failures[:30]:
        print(f"\n{cls}: {kind}:{seed}\n  {detail.strip()[:600]}")
    return 1 if report.bad() else 0


if __name__ == "__main__":
    sys.exit(main())
