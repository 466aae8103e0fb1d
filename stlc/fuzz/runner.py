"""Running fuzz inputs (``stlc.fuzz``) in worker processes with a time limit, and the report.

Every input is classified by ``classify`` the way a user would meet it: ``stlc check`` for a
file alone, ``stlc monitor --json`` for a file with a trace.  Workers are separate
processes, so a hang is ended by killing its worker (which is then replaced).
"""

from __future__ import annotations

import contextlib
import io
import json
import multiprocessing as mp
import os
import tempfile
import time
import traceback
from dataclasses import dataclass, field
from multiprocessing.connection import wait

from stlc import fuzz

WEIGHTS = {"grammar": 0.34, "mutation": 0.29, "deep": 0.05, "trace": 0.20, "example": 0.09,
           "simulate": 0.01, "team": 0.01, "resource": 0.01, "coords": 0.001,
           "boundary": 0.001, "roundtrip": 0.001, "fmt": 0.02, "lsp": 0.02}
#: whole commands solve: their time limit is at least this (s)
MIN_TIMEOUT = {"simulate": 60.0, "team": 120.0, "resource": 30.0, "coords": 120.0,
               "boundary": 60.0, "roundtrip": 120.0}
#: peak resident memory of one input above this is ``mem`` (the address space is capped
#: a few GB above it, so that a runaway allocation fails instead of swapping)
MEM_CAP = 1 << 30


def _cap_memory() -> None:  # pragma: no cover - runs in a worker process
    import resource

    with contextlib.suppress(ValueError, OSError):
        hard = MEM_CAP + (4 << 30)
        resource.setrlimit(resource.RLIMIT_AS, (hard, hard))


def _reset_peak() -> bool:
    """Reset the kernel's high-water mark of this process's resident size (Linux)."""
    try:
        with open("/proc/self/clear_refs", "w") as fh:
            fh.write("5")
        return True
    except OSError:
        return False


def _peak() -> int:
    with contextlib.suppress(OSError, ValueError):
        with open("/proc/self/status") as fh:
            for line in fh:
                if line.startswith("VmHWM:"):
                    return int(line.split()[1]) * 1024
    return 0


def _no_constant(name: str):
    raise ValueError(f"not strict JSON: {name}")


def _located(diags, text: str, path: str) -> str | None:
    """Why a diagnostic is not located at a real place in ``path`` (None if all are)."""
    from stlc.diagnostics import source_lines

    n = len(source_lines(text))
    for d in diags:
        s = d.span
        if s.file != path or not (1 <= s.line <= n + 1) or s.col < 1:
            return f"{d.code} at {s.file}:{s.line}:{s.col} (file has {n} lines): {d.message}"
    return None


def classify(case: dict) -> tuple[str, str]:
    """``(class, detail)`` of one input (see ``stlc.fuzz``)."""
    from stlc import cli
    from stlc.analysis.trace import read_trace
    from stlc.diagnostics import StlcError, render_all
    from stlc.pipeline import load, monitor_trace

    if "command" in case:
        from stlc.fuzz.missions import run_command

        return run_command(case)
    if "check" in case:
        from stlc.fuzz.numerics import run_check

        return run_check(case)
    with tempfile.TemporaryDirectory(prefix="stlc-fuzz-") as d:
        path, csv = os.path.join(d, "in.stl"), os.path.join(d, "in.csv")
        stl = case["stl"]
        data = stl if isinstance(stl, bytes) else stl.encode("utf-8", "surrogatepass")
        with open(path, "wb") as fh:
            fh.write(data)
        if case["trace"] is not None:
            with open(csv, "w", encoding="utf-8", newline="") as fh:
                fh.write(case["trace"])
        try:
            program = load(path).program
            if case["trace"] is None:
                return "accepted", ""
            monitor_trace(program, read_trace(csv))
        except StlcError as e:
            texts = {path: data.decode("utf-8", "replace").removeprefix("\ufeff")}
            if case["trace"] is not None:
                with open(csv, "rb") as fh:
                    texts[csv] = fh.read().decode("utf-8", "replace").removeprefix("\ufeff")
            render_all(e.diagnostics, texts)  # the renderer must cope with every location
            for f, text in texts.items():
                why = _located([x for x in e.diagnostics if x.span.file == f], text, f)
                if why:
                    return "unlocated", why
            if any(x.span.file not in texts for x in e.diagnostics):
                return "unlocated", f"diagnostic in another file: {e.diagnostics[0]}"
            return "diagnosed", e.diagnostics[0].code
        except Exception as e:  # noqa: BLE001 - what the fuzzer is looking for
            return "internal", "".join(traceback.format_exception(e)[-3:])
        out, err = io.StringIO(), io.StringIO()
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            rc = cli.main(["monitor", path, "--trace", csv, "--json"])
        if rc != 0:
            return "internal", f"monitor --json exited {rc}: {err.getvalue()[-500:]}"
        try:
            json.loads(out.getvalue(), parse_constant=_no_constant)
        except ValueError as e:
            return "badjson", f"{e}: {out.getvalue()[:300]}"
        return "accepted", ""


def _worker(conn, seeds: list[str]) -> None:  # pragma: no cover - runs in a subprocess
    from stlc import interrupt

    _cap_memory()
    while True:
        msg = conn.recv()
        if msg is None:
            return
        kind, seed = msg
        t0 = time.process_time()
        case = fuzz.make_input(kind, seed, seeds)
        measured = _reset_peak()
        try:
            cls, detail = interrupt.run(lambda c=case: classify(c))
        except MemoryError:
            cls, detail = "mem", "MemoryError"
        except BaseException as e:  # noqa: BLE001
            cls, detail = "internal", f"{type(e).__name__}: {e}"
        peak = _peak() if measured else 0
        if peak > MEM_CAP and cls not in fuzz.BAD:
            cls, detail = "mem", f"peak resident size {peak / 2**20:.0f} MB"
        conn.send((cls, detail, time.process_time() - t0))


def _died(kind: str, code: int | None) -> tuple[str, str, float]:
    """A worker that ended while running an input: a whole command whose time-limit
    watchdog found the planning thread inside one long C call writes the fallback plan and
    ends the process with the command's exit code (0 or 3, ``stlc.deadline``) — the limit
    kept, its outputs written (the user files are not checked then); anything else is a
    crash."""
    if kind in MIN_TIMEOUT and code in (0, 3):
        return "accepted", f"ended by the time-limit watchdog (exit {code})", 0.0
    return "internal", f"worker process died (exit code {code})", 0.0


@dataclass
class Report:
    counts: dict[str, dict[str, int]] = field(default_factory=dict)
    failures: list[tuple[str, int, str, str]] = field(default_factory=list)
    seconds: float = 0.0
    cpu: dict[str, float] = field(default_factory=dict)
    slowest: tuple[float, str, int] = (0.0, "", 0)

    def add(self, kind: str, seed: int, cls: str, detail: str, cpu: float) -> None:
        row = self.counts.setdefault(kind, dict.fromkeys(fuzz.CLASSES, 0))
        row[cls] += 1
        self.cpu[kind] = self.cpu.get(kind, 0.0) + cpu
        self.slowest = max(self.slowest, (cpu, kind, seed))
        if cls in fuzz.BAD:
            self.failures.append((kind, seed, cls, detail))

    @property
    def total(self) -> int:
        return sum(sum(r.values()) for r in self.counts.values())

    def bad(self) -> int:
        return len(self.failures)

    def table(self) -> str:
        cols = ["kind", *fuzz.CLASSES, "total", "cpu_s"]
        rows = [[k, *(str(r[c]) for c in fuzz.CLASSES), str(sum(r.values())),
                 f"{self.cpu.get(k, 0):.1f}"] for k, r in self.counts.items()]
        tot = [sum(r[c] for r in self.counts.values()) for c in fuzz.CLASSES]
        rows.append(["all", *map(str, tot), str(self.total), f"{sum(self.cpu.values()):.1f}"])
        w = [max(len(x) for x in col) for col in zip(cols, *rows)]
        line = lambda r: "| " + " | ".join(x.rjust(n) for x, n in zip(r, w)) + " |"  # noqa
        sep = "|" + "|".join("-" * (n + 2) for n in w) + "|"
        return "\n".join([line(cols), sep, *map(line, rows)])


def plan(n: int, seed: int = 0, kinds: tuple[str, ...] | None = None
         ) -> list[tuple[str, int]]:
    """``n`` (kind, seed) pairs, split over the kinds by ``WEIGHTS``, interleaved (only
    ``kinds``, evenly, when given)."""
    out = []
    if kinds:
        counts = {k: n // len(kinds) + (i < n % len(kinds)) for i, k in enumerate(kinds)}
    else:
        counts = {k: max(1, round(n * w)) for k, w in WEIGHTS.items()}
        counts["grammar"] += n - sum(counts.values())
    for k, c in counts.items():
        out += [(k, seed + i) for i in range(c)]
    out.sort(key=lambda ks: (ks[1], ks[0]))
    return out


def run(n: int = 10_000, seed: int = 0, jobs: int = 1, timeout: float = 10.0,
        save: str | None = None, progress=None, kinds: tuple[str, ...] | None = None
        ) -> Report:
    """Run ``n`` inputs; ``progress(done, report)`` is called now and then."""
    ctx = mp.get_context("spawn")
    seeds = fuzz.seed_files()
    todo = plan(n, seed, kinds)
    report = Report()
    t_start = time.perf_counter()

    def start():
        a, b = ctx.Pipe()
        p = ctx.Process(target=_worker, args=(b, seeds), daemon=True)
        p.start()
        return {"proc": p, "conn": a, "job": None, "since": 0.0}

    workers = [start() for _ in range(max(1, jobs))]
    pos = 0
    try:
        while pos < len(todo) or any(w["job"] for w in workers):
            for w in workers:
                if w["job"] is None and pos < len(todo):
                    w["job"], w["since"] = todo[pos], time.monotonic()
                    w["conn"].send(todo[pos])
                    pos += 1
            busy = [w for w in workers if w["job"] is not None]
            ready = wait([w["conn"] for w in busy], timeout=0.2)
            for i, w in enumerate(workers):
                if w["job"] is None:
                    continue
                kind, s = w["job"]
                if w["conn"] in ready:
                    try:
                        cls, detail, cpu = w["conn"].recv()
                    except EOFError:  # the worker died (a crash in C code)
                        w["proc"].join(5)
                        cls, detail, cpu = _died(kind, w["proc"].exitcode)
                        w["proc"].kill()
                        workers[i] = w = {**start(), "job": w["job"]}
                elif time.monotonic() - w["since"] > max(timeout, MIN_TIMEOUT.get(kind, 0)):
                    w["proc"].kill()
                    limit = max(timeout, MIN_TIMEOUT.get(kind, 0))
                    cls, detail, cpu = "hang", f"over {limit:g} s", limit
                    workers[i] = w = {**start(), "job": w["job"]}
                else:
                    continue
                report.add(kind, s, cls, detail, cpu)
                if cls in fuzz.BAD and save:
                    _save(save, fuzz.make_input(kind, s, seeds), cls, detail)
                w["job"] = None
                if progress and report.total % (500 if not kinds else 20) == 0:
                    progress(report.total, report)
    finally:
        for w in workers:
            with contextlib.suppress(Exception):
                w["conn"].send(None)
            w["proc"].join(1)
            if w["proc"].is_alive():
                w["proc"].kill()
    report.seconds = time.perf_counter() - t_start
    return report


def _save(directory: str, case: dict, cls: str, detail: str) -> None:
    os.makedirs(directory, exist_ok=True)
    base = os.path.join(directory, f"{case['kind']}-{case['seed']}")
    stl = case["stl"]
    with open(base + ".stl", "wb") as fh:
        fh.write(stl if isinstance(stl, bytes) else stl.encode("utf-8", "surrogatepass"))
    if case["trace"] is not None:
        with open(base + ".csv", "w", encoding="utf-8", newline="") as fh:
            fh.write(case["trace"])
    with open(base + ".txt", "w", encoding="utf-8") as fh:
        fh.write(f"{cls}\n{detail}\n")
