"""Record (or compare) the results an architecture refactor must not change: exact
robustness of the three shipped handovers, both bird-diverter specs and the stlpy
benchmarks (``specs/benchmarks``), and the replanning events of the ``simulate`` demos of both papers.

    python scripts/arch_equivalence.py --write OUT.json        # record
    python scripts/arch_equivalence.py --compare BEFORE.json   # re-run and compare (1e-9)
    python scripts/arch_equivalence.py --frozen-clock --write OUT.json  # load-independent events

Each case runs the CLI in a subprocess (the public behaviour), reading ``solution.json``
and ``replan.json``."""

from __future__ import annotations

import argparse
import json
import math
import os
import subprocess
import sys
import tempfile

CASES = [
    ("compile", "specs/handover.stl", "handover_left_tb"),
    ("compile", "specs/handover.stl", "handover_front"),
    ("compile", "specs/handover.stl", "handover_left"),
    ("compile", "specs/bird_diverter_2x7.stl", "bird_diverter_2x7"),
    ("compile", "specs/bird_diverter_4x11.stl", "bird_diverter_4x11"),
    # the stlpy benchmarks
    ("compile", "specs/benchmarks/door_puzzle.stl", "door_puzzle"),
    ("compile", "specs/benchmarks/either_or.stl", "either_or"),
    ("compile", "specs/benchmarks/narrow_passage.stl", "narrow_passage"),
    ("compile", "specs/benchmarks/random_multitarget.stl", "random_multitarget"),
    ("compile", "specs/benchmarks/reach_avoid.stl", "reach_avoid"),
    ("compile", "specs/benchmarks/stepping_stones.stl", "stepping_stones"),
    ("simulate", "specs/handover.stl", "handover_left_tb"),
    ("simulate", "specs/bird_diverter_2x7.stl", "bird_diverter_2x7"),
    # a small takeover (the backup joins the executed team), and the same with a --set
    # value that the judgement of the executed team must read (a placed region)
    ("simulate", "tests/missions/takeover_cross.stl", "cross",
     ("--fail", "uav1@2", "--backup", "uav3")),
    ("simulate", "tests/missions/takeover_cross.stl", "cross",
     ("--fail", "uav1@2", "--backup", "uav3", "--set", "tb.center.y=3.5 m")),
]

EVENT_KEYS = ("time", "vehicle", "kind", "deviation", "triggered", "status", "accepted",
              "segment", "kept")


def _num(x):
    return None if x is None else float(x)


FROZEN = os.path.join(os.path.dirname(os.path.abspath(__file__)), "frozen_clock.py")


def run_case(cmd: str, path: str, mission: str, frozen: bool = False,
             extra: tuple[str, ...] = ()) -> dict:
    with tempfile.TemporaryDirectory() as out:
        head = [sys.executable, FROZEN] if frozen else [sys.executable, "-m", "stlc"]
        argv = [*head, cmd, path, "--mission", mission, "-o", out, "-q", *extra]
        if cmd == "compile":
            argv.append("--no-risk")
        p = subprocess.run(argv, capture_output=True, text=True)
        rec: dict = {"exit": p.returncode}
        with open(os.path.join(out, "solution.json")) as fh:
            sol = json.load(fh)
        rec["status"] = sol["status"]
        rec["exact"] = _num(sol["robustness"]["exact"])
        rec["specs"] = {k: _num(v["robustness"]) for k, v in sorted(sol["specs"].items())}
        rec["energy"] = _num(sol["energy"])
        rec["comparisons"] = {c["label"]: _num(c["robustness_exact"])
                              for c in sol.get("comparisons", [])}
        if cmd == "simulate":
            with open(os.path.join(out, "replan.json")) as fh:
                rp = json.load(fh)
            rec["ok"] = rp["ok"]
            rec["events"] = [{k: e.get(k) for k in EVENT_KEYS} for e in rp["events"]]
            rec["executed"] = rp["executed"]
        return rec


def record(frozen: bool = False, only: str | None = None) -> dict:
    """Every case (or the ``only`` command's); with ``frozen`` only the ``simulate`` ones,
    with the segment's clock frozen (``frozen_clock.py``: events decided by the
    mathematics, not the load)."""
    res = {}
    for cmd, path, mission, *rest in CASES:
        extra = tuple(rest[0]) if rest else ()
        if (frozen and cmd != "simulate") or (only and cmd != only):
            continue
        key = " ".join((cmd, path, mission, *extra))
        print(key, file=sys.stderr, flush=True)
        res[key] = run_case(cmd, path, mission, frozen, extra)
    return res


def diff(a, b, path="", tol=1e-9) -> list[str]:
    out = []
    if isinstance(a, dict) and isinstance(b, dict):
        for k in sorted(set(a) | set(b)):
            if k not in a or k not in b:
                out.append(f"{path}/{k}: only in {'before' if k in a else 'after'}")
            else:
                out += diff(a[k], b[k], f"{path}/{k}", tol)
    elif isinstance(a, list) and isinstance(b, list):
        if len(a) != len(b):
            out.append(f"{path}: {len(a)} vs {len(b)} items")
        for i, (x, y) in enumerate(zip(a, b)):
            out += diff(x, y, f"{path}[{i}]", tol)
    elif isinstance(a, (int, float)) and isinstance(b, (int, float)) \
            and not isinstance(a, bool) and not isinstance(b, bool):
        if not (a == b or abs(a - b) <= tol or (math.isnan(a) and math.isnan(b))):
            out.append(f"{path}: {a!r} vs {b!r} (Δ {b - a:.3g})")
    elif a != b:
        out.append(f"{path}: {a!r} vs {b!r}")
    return out


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--write", metavar="OUT")
    ap.add_argument("--compare", metavar="BEFORE")
    ap.add_argument("--frozen-clock", action="store_true",
                    help="simulate cases only, the replanning segment's clock frozen")
    ap.add_argument("--only", choices=("compile", "simulate"))
    args = ap.parse_args()
    res = record(args.frozen_clock, args.only)
    if args.write:
        with open(args.write, "w") as fh:
            json.dump(res, fh, indent=1, sort_keys=True)
    if args.compare:
        with open(args.compare) as fh:
            before = json.load(fh)
        d = diff({k: v for k, v in before.items() if k in res}, res)
        print("\n".join(d) if d else "identical (exact robustness to 1e-9, same events)")
        return 1 if d else 0
    return 0


if __name__ == "__main__":
    sys.exit(main())
