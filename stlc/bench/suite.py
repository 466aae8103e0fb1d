"""``stlc bench suite``: the current performance table, with the machine it ran on.

Each case is a whole command as a user runs it (``stlc compile … --no-risk -q``, ``stlc
risk …``) in a child process: its wall time, its CPU time (the child's and the processes it
forked) and, read back from the ``solution.json`` it wrote, its status, exact robustness and
solver iterations.  The exact monitor is timed in process (median of repeated runs).  The
table is Markdown, headed by the date, the commit, the machine (CPU model, cores, memory,
OS, Python) and the load average before and after, so a table says where it was measured.
``--update FILE`` replaces the text between ``<!-- bench:start -->`` and ``<!-- bench:end
-->`` in FILE (``docs/performance.md``) instead of printing.  Nothing is asserted.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from datetime import datetime, timezone
from pathlib import Path

START, END = "<!-- bench:start -->", "<!-- bench:end -->"


@dataclass(frozen=True)
class Case:
    name: str
    args: tuple[str, ...]       # after ``stlc``; ``{out}`` is the case's output folder
    reference: str = "—"


HANDOVER = "specs/handover.stl"
CASES: tuple[Case, ...] = (
    Case("handover_left_tb", ("compile", HANDOVER, "--mission", "handover_left_tb"),
         "paper A ≈ 660 s"),
    Case("handover_front", ("compile", HANDOVER, "--mission", "handover_front"),
         "paper A ≈ 660 s"),
    Case("handover_left", ("compile", HANDOVER, "--mission", "handover_left"),
         "paper A ≈ 660 s"),
    Case("handover_impossible", ("compile", "tests/missions/handover_impossible.stl",
                                 "--mission", "handover_left_tb"),
         "proved infeasible"),
    Case("risk, handover_left_tb", ("risk", HANDOVER, "--mission", "handover_left_tb",
                                    "--trajectory", "{plan}"), "K = 15,000 per case"),
    Case("bird_diverter_2x7", ("compile", "specs/bird_diverter_2x7.stl"),
         "paper B 14 min 37 s"),
    Case("patrol_60s (0.5 s)", ("compile", "tests/missions/patrol_60s.stl")),
    Case("stlpy reach_avoid", ("compile", "specs/benchmarks/reach_avoid.stl")),
    Case("stlpy either_or", ("compile", "specs/benchmarks/either_or.stl")),
    Case("stlpy door_puzzle", ("compile", "specs/benchmarks/door_puzzle.stl")),
    Case("stlpy stepping_stones", ("compile", "specs/benchmarks/stepping_stones.stl")),
)


def machine() -> str:
    cpu = platform.processor() or platform.machine()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    mem = ""
    try:
        kb = int(Path("/proc/meminfo").read_text().split()[1])
        mem = f", {kb / 2**20:.0f} GiB"
    except (OSError, ValueError, IndexError):
        pass
    return (f"{cpu}, {os.cpu_count()} cores{mem}; {platform.system()} {platform.release()}; "
            f"Python {platform.python_version()}")


def commit() -> str:
    try:
        out = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True,
                             text=True, timeout=10, check=True)
        return out.stdout.strip()
    except (OSError, subprocess.SubprocessError):
        return "unknown"


def load() -> str:
    try:
        return " / ".join(f"{x:.1f}" for x in os.getloadavg())
    except OSError:
        return "n/a"


def run_case(case: Case, out: str, plan: str) -> list[str]:
    args = [a.format(out=out, plan=plan) for a in case.args]
    if args[0] == "compile":
        args += ["--no-risk", "-q", "-o", out]
    else:
        args += ["-o", out]
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    proc = subprocess.run([sys.executable, "-m", "stlc", *args], capture_output=True,
                          text=True)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    status, rho, its = f"exit {proc.returncode}", "—", "—"
    sol = Path(out) / "solution.json"
    if args[0] == "compile" and sol.is_file():
        data = json.loads(sol.read_text())
        status = data.get("status", status)
        exact = data.get("robustness", {}).get("exact")
        rho = f"{float(exact):+.3f}" if exact is not None else "—"
        its = str(data.get("solver", {}).get("iterations", "—"))
    elif args[0] == "risk" and proc.returncode == 0:
        status = "done"
    command = "stlc " + " ".join(case.args).replace("{plan}", "PLAN.csv")
    return [case.name, f"`{command}`", status, rho, its, f"{wall:.1f}", f"{cpu:.1f}",
            case.reference]


def monitor_row(repeats: int = 20) -> list[str]:
    from stlc.analysis.monitor import robustness
    from stlc.bench.tables import RTAMT_MS, bench_formula, bench_trace, time_ms

    f, ch = bench_formula(), bench_trace(10_000, 0.1)
    ms = statistics.median(time_ms(lambda: robustness(f, 0.1, ch), repeats))
    return ["exact monitor, 10,000 samples", "`stlc bench monitor`", "—",
            f"{robustness(f, 0.1, ch):+.3f}", "—", f"{ms:.2f} ms", "—",
            f"RTAMT ≈ {RTAMT_MS:g} ms"]


def render(rows: list[list[str]], started: str, load0: str, load1: str) -> str:
    head = ["case", "command", "status", "exact ρ", "iterations", "wall s", "CPU s",
            "reference"]
    lines = [f"Measured {started} by `stlc bench suite` at commit `{commit()}` on: "
             f"{machine()}. Load average (1/5/15 min) {load0} before, {load1} after.", "",
             "| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    lines += ["| " + " | ".join(r) + " |" for r in rows]
    return "\n".join(lines) + "\n"


def update(path: str, table: str) -> None:
    text = Path(path).read_text(encoding="utf-8")
    i, j = text.find(START), text.find(END)
    if i < 0 or j < i:
        raise SystemExit(f"bench: {path} has no {START} … {END} block")
    Path(path).write_text(text[:i + len(START)] + "\n" + table + text[j:], encoding="utf-8")


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--cases", metavar="NAMES", default=None,
                   help="comma-separated case names (default: all; `monitor` is one)")
    p.add_argument("--update", metavar="FILE", default=None,
                   help="write the table into FILE between the bench:start/end markers")


def run(args: argparse.Namespace) -> int:
    wanted = None if args.cases is None else {c.strip() for c in args.cases.split(",")}
    started = datetime.now(timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    load0 = load()
    rows = [monitor_row()] if wanted is None or "monitor" in wanted else []
    with tempfile.TemporaryDirectory(prefix="stlc-bench-") as tmp:
        plan = str(Path(tmp) / "handover_left_tb" / "trajectory.csv")
        for k, case in enumerate(CASES):
            if wanted is not None and case.name not in wanted:
                continue
            out = str(Path(tmp) / (case.name if case.name == "handover_left_tb" else str(k)))
            if "{plan}" in " ".join(case.args) and not Path(plan).is_file():
                run_case(CASES[0], str(Path(tmp) / "handover_left_tb"), plan)
            rows.append(run_case(case, out, plan))
            print(f"  {case.name}: {rows[-1][2]}, {rows[-1][5]} s", file=sys.stderr,
                  flush=True)
    table = render(rows, started, load0, load())
    if args.update:
        update(args.update, table)
    else:
        print(table, end="")
    return 0


COMMAND = ("the performance table of docs/performance.md, with the machine it ran on",
           add_arguments, run)
