"""``stlc fly``: plan the mission (as ``stlc compile``), then fly the plan closed loop —
the tracking controller on the vehicle's full model, through the mission's pushes
(``simulate`` block), wind, Dryden turbulence and sensor noise (``stlc.flight``) — judge
the flown trajectory with the exact monitor, and with ``--runs N`` the distribution of
the flown robustness over N seeded realisations — wind, noise and the scenario's uncertain
human pose (the mission's first risk case) drawn per run — judged against the risk levels
of the mission's ``risk`` block (on Dask with ``--workers`` / ``--scheduler``).

Writes the compile outputs plus ``flight.json`` and ``flown.csv`` (the seeded flight,
``trajectory.csv``'s columns) as one set.  Exit 0 when the plan satisfies its mission,
the seeded flight keeps it (flown robustness > 0) and the runs meet every risk level, 3
otherwise.

Also the command-line glue of the flight features: the ``fly`` subcommand's options and
``stlc monitor --log`` (``monitor_log``, reading ``stlc.flight.logs``).
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import time

import numpy as np

from stlc import deadline
from stlc.analysis import verdict
from stlc.diagnostics import Diagnostic, Span, StlcError
from stlc.exitcodes import EXIT_OK, EXIT_UNSAT
from stlc.pipeline import load, mission_span, one_mission, plan_in_time
from stlc.strictjson import channels_csv, json_number, strict_dumps

DEFAULT_BETAS = (0.7, 0.8, 0.9)
DEFAULT_DELTA = 0.01


def fly_file(path: str, out: str | None = None, mission: str | None = None, *,
             wind=None, turbulence: str | None = None, runs: int | None = None,
             seed: int = 0, noise=None, quiet: bool = False,
             time_limit: float | None = None, sets=(), client=None,
             pushes: bool = True, uncertain: bool = True, replan: bool = True) -> int:
    from stlc.flight import engine
    from stlc.flight.rigid import FlightSetup
    from stlc.output.compile import summary, write_files
    from stlc.output.directory import preflight

    t0 = time.perf_counter()
    loaded = load(path, sets)
    program = loaded.program
    m = one_mission(path, program, mission, "fly")
    outdir = out if out is not None else os.path.join("reports", m.name)
    preflight(outdir, mission_span(path, m))
    with deadline.limited(deadline.mission_limit(m.options, time_limit, time_limit or 0.0),
                          start=time.monotonic() - (time.perf_counter() - t0)):
        problem, sol = plan_in_time(program, m, quiet=quiet, values=loaded.values)
    sol.timing.update(loaded.timing)
    if sol.times.size < 2 or f"{m.vehicles[0]}.pos.x" not in sol.channels:
        sol.notes.append("not flown: there is no plan to fly")
        write_files(outdir, program, m, sol)
        summary(sol, outdir)
        print(f"{m.name}: not flown: there is no plan to fly", file=sys.stderr)
        return EXIT_UNSAT
    pushes = tuple(m.simulate.disturbances) if m.simulate and pushes else ()
    # the command line's wind, turbulence and noise replace the `simulate` block's
    air = m.simulate.wind if m.simulate and m.simulate.wind else None
    sensors = m.simulate.noise if m.simulate and m.simulate.noise else None
    wind = wind if wind is not None else air.velocity if air else (0.0, 0.0, 0.0)
    turbulence = turbulence or (air.turbulence if air else "none")
    noise = noise if noise is not None else (sensors.pos, sensors.vel) if sensors else (0, 0)
    setup = FlightSetup(wind=tuple(float(x) for x in wind), turbulence=turbulence,
                        noise_pos=float(noise[0]), noise_vel=float(noise[1]), pushes=pushes)
    t1 = time.perf_counter()
    sim = None
    reference = sol.channels
    if pushes and replan and m.replan is not None:  # the replans decide the reference
        sim = _replanned(problem, sol, program, m, pushes)
        reference = {k: sim.executed[k] for k in sol.channels if k in sim.executed}
    seeded = engine.fly_batch(program, m, sol.times, reference, setup, 1, seed, chunk=0)
    record = _record(m, sol, seeded, setup, seed, pushes, reference)
    if sim is not None:
        record["replan"] = _replan_record(sim)
        record["notes"] = ["the reference after each push is the event-triggered replan's "
                           "(paper A §4.4, decided on the open-loop prediction as `stlc "
                           "simulate` does); the controller tracks it"]
    record["timing"] = {"fly_s": time.perf_counter() - t1}
    if runs:
        t2 = time.perf_counter()
        many = engine.many(program, m, sol.times, reference, setup, runs, seed,
                           client=client, uncertain=uncertain)
        cfg = m.risk
        record["runs"] = {
            **engine.run_statistics(many["robustness"], cfg.betas if cfg else DEFAULT_BETAS,
                                    cfg.delta if cfg else DEFAULT_DELTA, float(m.threshold)),
            "tracking": {"max_error_m": _stats(many["err_max"]),
                         "rms_error_m": _stats(many["err_rms"])},
            "chunk": engine.CHUNK, "wall_s": time.perf_counter() - t2,
            "on": "dask" if client is not None else "local",
            "uncertain": sorted(p for d in engine.uncertainty(program, m) for p in d.params)
            if uncertain else [],
            "levels": engine.judge_levels(cfg.levels if cfg else (), many["robustness"],
                                          cfg.delta if cfg else DEFAULT_DELTA)}
    flown = {k: np.asarray(seeded.channels[k][0]) for k in sol.channels}
    sol.notes.append(_note(record))
    sol.timing["total_s"] = time.perf_counter() - t0

    def extra(tmp: str) -> None:
        with open(os.path.join(tmp, "flight.json"), "w") as fh:
            fh.write(strict_dumps(record, indent=2))
        with open(os.path.join(tmp, "flown.csv"), "w") as fh:
            fh.write(channels_csv(sol.times, flown))

    write_files(outdir, program, m, sol, extra=extra, simulation=sim,
                flight={"record": record, "flown": flown})
    if sol.status != "satisfied":
        summary(sol, outdir)
    failed = [lv for lv in record.get("runs", {}).get("levels", []) if not lv["holds"]]
    ok = sol.status == "satisfied" and record["flown"]["satisfied"] and not failed
    print(_note(record) + f" → {outdir}/flight.json", file=sys.stdout if ok else sys.stderr)
    for lv in failed:
        print(f"  risk level `{lv['level']}` (line {lv['line']}) does not hold on the flown "
              f"runs: {lv['measure']} {'upper bound ' if lv['measure'] == 'p_violation' else ''}"
              f"= {lv['value']:.4g}", file=sys.stderr)
    if not quiet:
        print(f"done in {time.perf_counter() - t0:.1f} s", file=sys.stderr)
    return EXIT_OK if ok else EXIT_UNSAT


def _replanned(problem, sol, program, m, pushes):
    """Event-triggered replanning through the pushes (``stlc.replan.disturb``, the flight
    loop of ``stlc simulate``): its executed trajectory, nominal plan and accepted
    replanned segments, is the reference the controller then tracks."""
    from dataclasses import replace

    from stlc.backends.strategy import replanner
    from stlc.replan.disturb import simulate_disturbances
    from stlc.replan.explain import default_waypoint_period
    from stlc.semantics import model
    from stlc.vehicles import model_of

    cfg = m.replan or model.ReplanConfig()
    if "waypoint_period" not in cfg.given and m.vehicles:
        acc = np.min([model_of(program.vehicles[v]).kinematic_limits(program.vehicles[v])[1]
                      for v in m.vehicles], axis=0)
        cfg = replace(cfg, waypoint_period=default_waypoint_period(cfg.threshold, acc, m.step))
    with deadline.bounded():
        try:
            sim = simulate_disturbances(problem, sol, list(pushes), cfg,
                                        segment=replanner("segment"))
        except ValueError as e:  # the replanning modules' input errors (subclasses)
            if type(e) is ValueError:
                raise
            raise StlcError([Diagnostic("STL401", f"cannot replan `{m.name}`: {e}", m.span,
                                        "fly it with --no-replan")]) from None
    sim.kept = tuple(cfg.specs) or ("mission",)
    return sim


def _replan_record(sim) -> dict:
    trig = sim.triggered
    return {"replans": len(trig), "accepted": sum(1 for e in trig if e.accepted),
            "kept": list(sim.kept),
            "recoveries": [{"time": e.time, "vehicle": e.vehicle, "accepted": e.accepted,
                            **e.detail["recovery"]}
                           for e in trig if "recovery" in (e.detail or {})],
            "open_loop_robustness": {k: json_number(v)
                                     for k, v in sim.executed_robustness.items()}}


def _stats(x: np.ndarray) -> dict:
    return {"mean": float(np.mean(x)), "p95": float(np.quantile(x, 0.95)),
            "max": float(np.max(x))}


def _record(m, sol, b, setup, seed: int, pushes, reference: dict) -> dict:
    """flight.json; the tracking error is against ``reference`` (the plan, or the plan
    with its replanned segments)."""
    plan_pos = {d: np.stack([reference[f"{d}.pos.{a}"] for a in "xyz"], axis=1)
                for d in m.vehicles if f"{d}.pos.x" in reference}
    err = np.zeros(len(sol.times))
    for d, p in plan_pos.items():
        flown = np.stack([b.channels[f"{d}.pos.{a}"][0] for a in "xyz"], axis=1)
        err = np.maximum(err, np.linalg.norm(flown - p, axis=1))
    rho = float(b.robustness[m.name][0])
    return {
        "mission": m.name,
        "plan": {"robustness": json_number(sol.robustness_exact), "status": str(sol.status),
                 "specs": {k: json_number(s.robustness) for k, s in sol.specs.items()}},
        "flown": {"robustness": json_number(rho),
                  "satisfied": verdict.judge(rho, float(m.threshold)),
                  "specs": {k: json_number(float(v[0])) for k, v in b.robustness.items()
                            if k != m.name}},
        "tracking": {"max_error_m": float(b.err_max[0]), "rms_error_m": float(b.err_rms[0]),
                     "envelope": {"t": [round(float(t), 9) for t in sol.times],
                                  "error_m": [float(e) for e in err]}},
        "setup": {"wind_mps": list(setup.wind), "turbulence": setup.turbulence,
                  "noise": {"pos_m": setup.noise_pos, "vel_mps": setup.noise_vel},
                  "seed": seed, "step_s": setup.dt,
                  "pushes": [{"vehicle": d.vehicle, "time": d.time,
                              "displacement": list(d.displacement),
                              "velocity": list(d.velocity)} for d in pushes],
                  "frames": "ENU world, FLU body, ZYX Euler (stlc.flight.frames)"},
        "notes": (["the pushes are flown by the tracking controller back onto the nominal "
                   "plan (no replanning)"] if pushes else []),
    }


def _note(r: dict) -> str:
    t = r["tracking"]
    s = (f"{r['mission']}: flown closed loop: exact robustness "
         f"{_num(r['flown']['robustness'])} (plan {_num(r['plan']['robustness'])}), "
         f"tracking error max {t['max_error_m']:.4f} m, rms {t['rms_error_m']:.4f} m")
    if "runs" in r:
        u = r["runs"]
        s += (f"; {u['n']} runs: P(violation) {u['p_violation']:.4f} "
              f"(≤ {u['p_violation_upper']:.4f} at {1 - u['delta']:g})")
    return s


def _num(x) -> str:
    return f"{x:+.4f}" if isinstance(x, float) else str(x)


# ---------------------------------------------------------------- command line


def _number(text: str) -> float:
    try:
        x = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
    if not math.isfinite(x):
        raise argparse.ArgumentTypeError(f"{text!r} is not finite")
    return x


def _numbers(text: str, k: int, what: str) -> tuple[float, ...]:
    parts = text.split(",")
    if len(parts) != k:
        raise argparse.ArgumentTypeError(f"{text!r}: expected {k} numbers separated by commas "
                                         f"({what})")
    return tuple(_number(x) for x in parts)


def _triple(text: str) -> tuple[float, ...]:
    return _numbers(text, 3, "m/s east, north, up")


def _pair(text: str) -> tuple[float, ...]:
    x = _numbers(text, 2, "m, m/s")
    if min(x) < 0:
        raise argparse.ArgumentTypeError(f"{text!r}: noise levels are not negative")
    return x


def _count(text: str) -> int:
    try:
        n = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a whole number") from None
    if n < 1:
        raise argparse.ArgumentTypeError(f"{text!r} must be at least 1")
    return n


def mapping(text: str) -> tuple[str, str]:
    """``--map DRONE=TOPIC``."""
    drone, sep, topic = text.partition("=")
    if not sep or not drone or not topic:
        raise argparse.ArgumentTypeError(f"{text!r}: expected DRONE=TOPIC, e.g. "
                                         "uav1=/uav1/odom")
    return drone, topic


def add_log_options(m) -> None:
    """``stlc monitor``'s trace source: ``--trace CSV`` or ``--log PATH [--map ...]``."""
    src = m.add_mutually_exclusive_group(required=True)
    src.add_argument("--trace", metavar="CSV",
                     help="the trace: a header `t,<signal>,...`, one row per sample")
    src.add_argument("--log", metavar="PATH", help="a flight log: PX4 ULog (.ulg), rosbag2 "
                     "folder or .mcap, resampled onto the mission's step (or --resample)")
    m.add_argument("--map", metavar="DRONE=TOPIC", action="append", default=[],
                   type=mapping, dest="maps", help="the log's topic (ULog: instance) of a "
                   "vehicle, e.g. uav1=/uav1/odom (repeatable)")


def add_parser(sub, set_option, seconds) -> None:
    """The ``fly`` subcommand (``set_option``, ``seconds``: the CLI's ``--set`` option and
    its seconds type)."""
    y = sub.add_parser("fly", help="plan a mission and fly it closed loop (tracking "
                       "controller, full vehicle model, wind, turbulence, noise)")
    y.add_argument("file", metavar="FILE", help="the .stl file to plan and fly")
    y.add_argument("--mission", metavar="NAME", default=None,
                   help="the mission to fly (default: the file's only mission)")
    y.add_argument("-o", "--out", metavar="OUTDIR", default=None,
                   help="where flight.json, flown.csv and the report go")
    y.add_argument("-q", "--quiet", action="store_true", help="no progress output")
    y.add_argument("--wind", metavar="VX,VY,VZ", type=_triple, default=None,
                   help="steady wind in m/s (ENU); replaces the simulate block's `wind`")
    y.add_argument("--turbulence", choices=("none", "light", "moderate", "severe"),
                   default=None, help="Dryden turbulence (MIL-F-8785C) level")
    y.add_argument("--noise", metavar="POS,VEL", type=_pair, default=None,
                   help="position (m) and velocity (m/s) sensor noise, standard deviations")
    y.add_argument("--runs", metavar="N", type=_count, default=None,
                   help="fly N seeded realisations: P(violation), VaR, CVaR of the flown "
                   "robustness")
    y.add_argument("--seed", type=int, default=0,
                   help="seed of the wind, noise and scenario draws (the same seed flies the same)")
    y.add_argument("--no-pushes", action="store_true",
                   help="fly without the pushes of the mission's simulate block")
    y.add_argument("--no-replan", action="store_true",
                   help="after a push, track the nominal plan (no event-triggered replans)")
    y.add_argument("--fixed-scenario", action="store_true",
                   help="--runs keep the scenario's nominal human pose (only the air and "
                   "the sensors vary)")
    y.add_argument("--time-limit", metavar="SECONDS", type=seconds, default=None,
                   help="stop planning after SECONDS (best verified plan)")
    set_option(y)
    g = y.add_mutually_exclusive_group()
    g.add_argument("--workers", metavar="K", type=_count, default=None,
                   help="fly the runs on a local Dask cluster of K workers")
    g.add_argument("--scheduler", metavar="ADDRESS", default=None,
                   help="... or on an existing Dask cluster")


def command(args) -> int:
    """``stlc fly`` from parsed arguments; the runs on Dask with --workers/--scheduler
    (the sweep's client setup)."""
    def run(client=None) -> int:
        return fly_file(args.file, out=args.out, mission=args.mission, wind=args.wind,
                        turbulence=args.turbulence, runs=args.runs, seed=args.seed,
                        noise=args.noise, quiet=args.quiet, time_limit=args.time_limit,
                        sets=args.sets, client=client, pushes=not args.no_pushes,
                        uncertain=not args.fixed_scenario, replan=not args.no_replan)

    if not args.runs or (args.workers is None and args.scheduler is None):
        return run()
    from stlc.sweeping.run import dask_session

    with dask_session(args.workers, args.scheduler, args.file) as client:
        return run(client)


def monitor_log(args, program):
    """``stlc monitor --log``: the flight log as a trace on the mission's grid (the
    ``--resample`` step, else the first mission's), and the exact robustness of every
    monitored formula it has the signals of (``stlc.flight.logs``)."""
    from stlc.flight.logs import monitor_available, read_log
    from stlc.pipeline import monitored_formulas

    dt = args.resample or next((m.step for m in program.missions.values()), None)
    if dt is None:
        raise StlcError([Diagnostic("STL602", f"{args.file} declares no mission whose step "
                                    "the log could be resampled to",
                                    Span(args.file, 1, 1, 1, 2),
                                    "give the step: `--resample 0.1`")])
    trace = read_log(args.log, list(program.vehicles), dict(args.maps), dt,
                     {v: x.span for v, x in program.vehicles.items()})
    res = monitor_available(monitored_formulas(program, args.mission), trace, program.params,
                            verdict.margins(program, args.mission))
    for name, v in res.items():
        if v.get("missing"):
            print(f"note: `{name}` is undefined: the log has no " + ", ".join(v["missing"]),
                  file=sys.stderr)
    return trace, res
