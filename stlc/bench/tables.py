"""Benchmarks, kept apart from the tests: ``python -m stlc.bench <command>``.

``monitor`` times the exact monitor (and the numpy smooth reference) on a 10,000-sample
trace at dt = 0.1 s for the formula used by RTAMT's published offline benchmark,

    always[0,17] ((x >= 0) and (x <= 5)) and eventually[0,12] (always[0,5] (y >= 1))

and prints a plain-text table: samples, median and best time in ms and the ratio to
RTAMT's ~97 ms.  No timing is asserted anywhere; this is a report.

``compile FILE [--mission NAME] [--repeats 3] [--step S]`` plans each mission of a file
``repeats`` times and prints, per mission, the medians of: samples, variables, constraints,
build / initial-guess / solve / total seconds, IPOPT iterations, exact and smooth robustness,
energy, how many runs were satisfied and ended on a converged final stage, the process CPU
time (robust to busy neighbours), and the ratio of the total to paper A's ~11 minutes (660 s)
per handover plan.  A stage table lists each solve stage of the median run: λ, iterations,
status, whether IPOPT's own convergence test ended it, and IPOPT's regularisation count.  A
second table splits IPOPT's time (summed over the solve stages) into function and derivative
evaluations (``t_wall_nlp_f/g/grad_f/jac_g/hess_l`` from the solver's stats), the iteration
callback (exact-monitor checks of iterates) and the rest (linear algebra + IPOPT overhead).

Subcommands register themselves in ``COMMANDS`` (name -> (help, add_arguments, run)), so
another benchmark is one function pair away.
"""

from __future__ import annotations

import argparse
import contextlib
import statistics
import sys
import time
from collections.abc import Callable, Iterator

import numpy as np

from stlc.analysis.monitor import robustness
from stlc.analysis.smooth import smooth_robustness
from stlc.semantics.ir import Always, And, Bin, Const, Eventually, Formula, Pred, Sig

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


# --------------------------------------------------------------------------- compile

PAPER_S = 660.0  # paper A: ~11 minutes per handover plan
#: IPOPT's evaluation timers (prob.solver.stats()), in table order
NLP_TIMERS = ("nlp_f", "nlp_g", "nlp_grad_f", "nlp_jac_g", "nlp_hess_l")


def _compile_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("file", metavar="FILE", help="a .stl file with missions")
    p.add_argument("--mission", metavar="NAME", default=None,
                   help="only this mission (default: every mission of the file)")
    p.add_argument("--repeats", type=int, default=3, help="timed plans per mission (default 3)")
    p.add_argument("--step", type=float, default=None,
                   help="override the missions' step in s (default: the file's)")


@contextlib.contextmanager
def _solver_stats() -> Iterator[list[dict]]:
    """Collect IPOPT's stats of every solve stage of ``plan`` (one dict per stage).

    ``schedule._solve`` returns ``prob.solver.stats()`` of the solve it ran; it is wrapped
    for the duration of the block (the kinematic guess has its own solver and is timed as
    ``guess_s``)."""
    from stlc.backends.nlp import schedule

    collected: list[dict] = []
    orig = getattr(schedule, "_solve", None)
    if orig is None:  # the schedule changed shape: the split is simply not reported
        yield collected
        return

    def wrapped(*args, **kwargs):
        out = orig(*args, **kwargs)
        try:
            collected.append(dict(out[1]))
        except (TypeError, IndexError, ValueError):
            pass
        return out

    schedule._solve = wrapped
    try:
        yield collected
    finally:
        schedule._solve = orig


def _plan_once(program, mission, step: float | None, load_s: float) -> dict[str, float]:
    from stlc.pipeline import plan

    with _solver_stats() as stats:
        t0, c0 = time.perf_counter(), time.process_time()
        _, sol = plan(program, mission, quiet=True, step=step, backend="nlp")
        total = time.perf_counter() - t0 + load_s
        cpu = time.process_time() - c0
    stages = sol.solver.get("stages", [])
    ps, tm = sol.problem_size, sol.timing
    row = {
        "samples": ps.get("samples", 0), "variables": ps.get("variables", 0),
        "constraints": ps.get("constraints", 0),
        "build_s": tm.get("build_s", 0.0), "guess_s": tm.get("guess_s", 0.0),
        "solve_s": tm.get("solve_s", 0.0), "total_s": total,
        "iterations": sol.solver.get("iterations", 0), "stages": len(stages),
        "exact": sol.robustness_exact, "smooth": sol.robustness_smooth, "energy": sol.energy,
        "satisfied": float(sol.status == "satisfied"),  # summed, not medianed
        "cpu_s": cpu + tm.get("guess_cpu_s", 0.0),  # the guess's forked child included
        "compare_energy": min((c.energy for c in sol.comparisons if c.energy), default=0.0),
        "guess_wait_s": tm.get("guess_wait_s", tm.get("guess_s", 0.0)),
        "converged": float(bool(stages) and bool(stages[-1]["converged"])),  # summed
        "stage_list": [(st["label"], st["lam"], st["iterations"], st["status"],
                        st["converged"], st["regularizations"], st["solve_s"])
                       for st in stages],
    }
    if sol.routes:  # a team plan: MILP seed + waypoint refinement (no λ stages)
        seed = sol.solver.get("seed", {})
        row["converged"] = float(sol.solver.get("return_status") in ("optimal", "acceptable"))
        row["milp_s"], row["seed_s"] = tm.get("milp_s", 0.0), tm.get("seed_s", 0.0)
        row["milp_rounds"] = float(seed.get("milp_rounds", 0))
        row["lazy_cuts"] = float(seed.get("lazy_cuts", 0))
        row["verify_s"] = tm.get("verify_s", 0.0)
        comp = {c.label: c for c in sol.comparisons}
        row["stage_list"] = [("refine", sol.smoothing.get("lambda", 0.0),
                              sol.solver.get("iterations", 0),
                              sol.solver.get("ipopt_status", ""),
                              row["converged"] > 0, 0, tm.get("solve_s", 0.0))]
        row["team_specs"] = [(name, comp["MILP only"].specs.get(name) if "MILP only" in comp
                              else None, spec.robustness) for name, spec in sol.specs.items()]
    for key in NLP_TIMERS:
        row[key] = sum(float(s.get(f"t_wall_{key}", 0.0)) for s in stats)
    row["callback"] = sum(float(s.get("t_wall_callback_fun", 0.0)) for s in stats)
    row["functions"] = sum(row[k] for k in NLP_TIMERS)
    row["rest"] = max(0.0, row["solve_s"] - row["functions"] - row["callback"])
    return row


def _median_row(runs: list[dict[str, float]]) -> dict[str, float]:
    out = {k: statistics.median(r[k] for r in runs) for k in runs[0]
           if k not in ("stage_list", "team_specs")}
    out["satisfied"] = sum(r["satisfied"] for r in runs)
    out["converged"] = sum(r["converged"] for r in runs)
    # the stages of the run with the median total time
    median_run = sorted(runs, key=lambda r: r["total_s"])[len(runs) // 2]
    out["stage_list"] = median_run["stage_list"]
    if "team_specs" in median_run:
        out["team_specs"] = median_run["team_specs"]
    out["runs"] = len(runs)
    return out


def _pct(part: float, whole: float) -> str:
    return f"{part:.2f} ({100 * part / whole:.0f}%)" if whole > 0 else f"{part:.2f}"


def _compile_run(args: argparse.Namespace) -> int:
    from stlc.diagnostics import StlcError, render_all
    from stlc.pipeline import load

    repeats = max(1, args.repeats)
    try:
        t0 = time.perf_counter()
        loaded = load(args.file)
        load_s = time.perf_counter() - t0
        program = loaded.program
        if args.mission is not None and args.mission not in program.missions:
            print(f"bench: no mission `{args.mission}` in {args.file} (missions: "
                  f"{', '.join(program.missions) or 'none'})", file=sys.stderr)
            return 1
        names = [args.mission] if args.mission else list(program.missions)
        if not names:
            print(f"bench: {args.file} declares no mission", file=sys.stderr)
            return 1
        results: dict[str, dict[str, float]] = {}
        for name in names:
            runs = []
            for i in range(repeats):
                runs.append(_plan_once(program, program.missions[name], args.step, load_s))
                r = runs[-1]
                print(f"  {name} run {i + 1}/{repeats}: {r['total_s']:.2f} s, exact "
                      f"{r['exact']:+.4f}", file=sys.stderr, flush=True)
            results[name] = _median_row(runs)
    except StlcError as e:
        sources = {}
        with contextlib.suppress(OSError):
            with open(args.file, encoding="utf-8", errors="replace") as fh:
                sources[args.file] = fh.read()
        print(render_all(e.diagnostics, sources), file=sys.stderr)
        return 1

    step = f"step {args.step:g} s (override)" if args.step else "the file's step"
    print(f"file:    {args.file} ({step}); parse + check {load_s:.2f} s")
    print(f"repeats: {repeats} plan(s) per mission, medians shown; paper A: ~{PAPER_S:g} s "
          "per handover plan\n")
    rows = []
    for name, r in results.items():
        rows.append([name, f"{r['samples']:.0f}", f"{r['variables']:.0f}",
                     f"{r['constraints']:.0f}", f"{r['build_s']:.2f}", f"{r['guess_s']:.2f}",
                     f"{r['guess_wait_s']:.2f}", f"{r['solve_s']:.2f}", f"{r['total_s']:.2f}",
                     f"{r['iterations']:.0f}",
                     f"{r['exact']:+.4f}", f"{r['smooth']:+.4f}", f"{r['energy']:.1f}",
                     f"{r['compare_energy']:.1f}" if r["compare_energy"] else "-",
                     f"{r['satisfied']:.0f}/{r['runs']:.0f}",
                     f"{r['converged']:.0f}/{r['runs']:.0f}", f"{r['cpu_s']:.2f}",
                     f"{r['total_s'] / PAPER_S:.4f}"])
    print(table(["mission", "samples", "variables", "constraints", "build s", "guess s",
                 "guess waited s", "solve s", "total s", "iterations", "exact ρ", "smooth ρ",
                 "energy J", "compare energy J",
                 "satisfied", "final converged", "CPU s", f"/ paper {PAPER_S:g} s"], rows))
    print("\n`compare energy J`: the mission's `compare` plan (a handover's w = 0 plan). "
          "The kinematic guess runs in a forked child while the NLP is built: `guess waited "
          "s` is what it adds to the total; CPU s includes the child's.")
    print("\nSolve stages (the run with the median total; converged = IPOPT's own test, "
          "regularised = iterations with δ_w > 0):\n")
    rows = []
    for name, r in results.items():
        for label, lam, its, status, conv, reg, secs in r["stage_list"]:
            rows.append([name, label, f"{lam:g}", f"{its}", status, "yes" if conv else "no",
                         f"{reg}", f"{secs:.2f}"])
    print(table(["mission", "stage", "λ", "iterations", "status", "converged", "regularised",
                 "solve s"], rows))
    teams = {n: r for n, r in results.items() if "team_specs" in r}
    if teams:
        print("\nTeam missions (medians): task-assignment MILP (cvxpy/HiGHS), motion-primitive "
              "seed, waypoint refinement, verification; paper B: 14 min + 37 s (2 x 7), "
              "22 min + 57 s (4 x 11)\n")
        print(table(["mission", "MILP s", "MILP solves", "lazy cuts", "seed s", "refine s",
                     "verify s", "total s"],
                    [[n, f"{r['milp_s']:.3f}", f"{r['milp_rounds']:.0f}",
                      f"{r['lazy_cuts']:.0f}", f"{r['seed_s']:.3f}", f"{r['solve_s']:.2f}",
                      f"{r['verify_s']:.2f}", f"{r['total_s']:.2f}"] for n, r in teams.items()]))
        print("\nExact robustness per spec: the seed (\"MILP only\") and the plan:\n")
        print(table(["mission", "spec", "MILP only", "plan"],
                    [[n, spec, "-" if a is None else f"{a:+.4f}", f"{b:+.4f}"]
                     for n, r in teams.items() for spec, a, b in r["team_specs"]]))
    print("\nIPOPT time split, summed over the solve stages (s, share of solve s):\n")
    rows = []
    for name, r in results.items():
        whole = r["solve_s"]
        rows.append([name, *(f"{r[k]:.3f}" for k in NLP_TIMERS), _pct(r["functions"], whole),
                     _pct(r["callback"], whole), _pct(r["rest"], whole), f"{whole:.2f}"])
    print(table(["mission", "f", "g", "grad_f", "jac_g", "hess_l", "evaluations",
                 "callback (monitor)", "rest (lin. alg. + IPOPT)", "solve s"], rows))
    return 0


#: name -> (help, add_arguments, run)
COMMANDS: dict[str, tuple[str, Callable[[argparse.ArgumentParser], None],
                          Callable[[argparse.Namespace], int]]] = {
    "monitor": ("time the exact monitor and the smooth reference", _monitor_args, _monitor_run),
    "compile": ("time planning the missions of a file (medians of repeats)", _compile_args,
                _compile_run),
}


def build_parser(commands: dict | None = None) -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="python -m stlc.bench", description=__doc__.split(
        "\n\n")[0])
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for name, (help_text, add_arguments, run) in (commands or COMMANDS).items():
        p = sub.add_parser(name, help=help_text, description=help_text)
        add_arguments(p)
        p.set_defaults(run=run)
    return parser


def main(argv: list[str] | None = None, commands: dict | None = None) -> int:
    args = build_parser(commands).parse_args(argv)
    return args.run(args)


if __name__ == "__main__":
    sys.exit(main())
