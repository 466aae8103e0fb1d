"""``stlc sweep``: the client side.  Validate, start (or connect to) a Dask cluster, submit
one task per instance, show progress, collect rows, write the outputs.

One task per worker thread is in flight (``stlc.sweeping.order``: each task carries the plans
solved so far); a finished task wakes the client at once (a done-callback queue, not a
poll) and the next task is submitted before the finished one's bookkeeping, so a worker
waits only for one round trip.  The first wave is cold and pre-emptible: the first plan
starts a grace as long as its own IPOPT solve took; then a Dask ``Event`` stops the cold
instances still running (``stlc.sweeping.task``), which are solved again, warm started; their
builds count in ``nlp_builds``.  (A cold try that began with the first and still runs then
is slower than the first by its whole solve time: usually a long one — 216 iterations
against ~30 warm on ``handover_left_tb``; without the grace a try only seconds from its end
was cut: measured on ``handover_front``.)

Outputs (DIR, default ``reports/<mission>-sweep``): ``sweep.csv``, ``plans/<i>.csv``,
``sweep.json``, ``sweep.html``.  They are written into a private staging directory and
published under the directory lock at the end (``stlc.output.directory.publish``, the
manifest's ``sweep`` record) — also after Ctrl-C or SIGTERM (rows for the instances that
finished; the rest cancelled) — so DIR never holds a half-written file, and a sweep removes
only the files the manifest records for the last sweep into DIR: never a user's file nor a
compile's outputs, whatever their names.
"""

from __future__ import annotations

import contextlib
import csv
import io
import json
import logging
import math
import os
import queue
import sys
import tempfile
import time
import uuid

import numpy as np

from stlc import interrupt
from stlc.diagnostics import Diagnostic, Span, StlcError
from stlc.sweeping import axes as axes_mod
from stlc.sweeping.order import PREDICTED, Order

POLL_S = 0.05  #: the client's wait for a finished task (Ctrl-C is seen within it)


def _progress(done: int, total: int, sat: int, t0: float, quiet: bool) -> None:
    if quiet:
        return
    el = time.perf_counter() - t0
    eta = el / done * (total - done) if done else float("nan")
    w = 30
    bar = "#" * (w * done // max(total, 1))
    eta_s = f"{eta:5.0f} s" if math.isfinite(eta) else "    ? s"
    print(f"\r[{bar:<{w}}] {done}/{total}  ETA {eta_s}  satisfied {sat}", end="",
          file=sys.stderr, flush=True)


def _slots(client, workers: int | None, scheduler: str | None) -> int:
    """Tasks kept in flight: one per worker thread of the cluster (≥ 1)."""
    if not scheduler:
        return workers or os.cpu_count() or 1
    try:
        info = client.scheduler_info().get("workers", {})
        return max(1, sum(int(w.get("nthreads", 1)) for w in info.values()))
    except Exception:  # noqa: BLE001 - a scheduler that does not answer: one at a time
        return 1


def dask_client(workers: int | None, scheduler: str | None, path: str):
    from distributed import Client, LocalCluster

    if scheduler:
        try:
            return Client(scheduler, timeout="10s"), None
        except (OSError, TimeoutError) as e:
            raise StlcError([Diagnostic("STL607", f"cannot connect to the Dask scheduler "
                                        f"`{scheduler}`: {e}", Span(path, 1, 1, 1, 2),
                                        "start one with `dask scheduler` and `dask worker "
                                        "ADDRESS`, or drop --scheduler for a local cluster")]
                            ) from None
    import dask

    k = workers or os.cpu_count() or 1
    # each worker's share of the cores for the derivatives' map (``derivatives.map_threads``):
    # one each on the 2-core machine — 24-instance sweep 33.1 / 31.7 s → 30.0 / 29.8 s of wall
    # with the same iterations (two threads per worker only oversubscribed the cores)
    share = str(max(1, (os.cpu_count() or 1) // k))
    with dask.config.set(WORKER_CONFIG):
        cluster = LocalCluster(n_workers=k, threads_per_worker=1, processes=True,
                               dashboard_address=":0", silence_logs=logging.ERROR,
                               env={"OMP_NUM_THREADS": "1",
                                    "STLC_MAP_THREADS": share})
    return Client(cluster), cluster


#: the local cluster's workers: (1) without the nanny's ``MALLOC_TRIM_THRESHOLD_`` — any
#: value of it switches off glibc's dynamic mmap threshold, so every temporary ≥ 128 KiB
#: (numpy's in the risk pass, MUMPS's workspace) is mapped and unmapped again: a risk batch
#: of 1,024 realisations took 0.13 s in a worker vs 0.05 s in the client, 0.07 s without
#: it (measured, loaded); (2) without the statistical profiler, which samples the task's
#: stack every 10 ms; (3) the event loops' blocked-loop check every 1 s, not 20 ms: the
#: local scheduler runs in the client's process, which then used 0.054 s of CPU per second
#: idle, against 0.026 s — CPU the two workers of a two-core machine share with it.  A
#: cluster started by ``dask worker`` keeps its own settings.
WORKER_CONFIG = {"distributed.nanny.pre-spawn-environ.MALLOC_TRIM_THRESHOLD_": None,
                 "distributed.worker.profile.enabled": False,
                 "distributed.admin.tick.interval": "1s"}


def sweep(path: str, mission: str, vary: list[str], sets: list[str], out: str | None,
          workers: int | None = None, scheduler: str | None = None,
          random: int | None = None, seed: int = 0, quiet: bool = False,
          time_limit: float | None = None, collect: list | None = None) -> int:
    """``stlc sweep``; ``time_limit``: each instance's limit (``stlc.sweeping.task``);
    ``collect``: a list that receives the finished rows (the Python API's table)."""
    from stlc.frontend.syntax import parse_file
    from stlc.output.directory import (MANIFEST, STAGE_PREFIX, SWEEP_OWNED, _cleanup, preflight,
                                       refuse_foreign)
    from stlc.pipeline import select_missions
    from stlc.semantics import overrides

    t0 = time.perf_counter()
    tree = parse_file(path)
    source = tree.source
    axes = [axes_mod.parse_axis(path, v) for v in vary]
    if not axes:
        raise StlcError([Diagnostic("STL104", "nothing to sweep: give --vary NAME=LO:HI:N",
                                    Span(path, 1, 1, 1, 2),
                                    "e.g. --vary 'operator.att.z=-30 deg:30 deg:6'")])
    fixed = overrides.split(sets)
    names = [a.name for a in axes]
    clash = [n for n, _ in fixed if n in names] + [n for i, n in enumerate(names)
                                                   if n in names[:i]]
    if clash:
        raise StlcError([Diagnostic("STL102", f"`{clash[0]}` is both varied and set (or "
                                    "varied twice)", Span(path, 1, 1, 1, 2),
                                    "give each name once")])
    from stlc.sweeping.handshake import check_count

    check_count(path, [a.n for a in axes], random, axes_mod.MAX_INSTANCES)  # before allocating
    insts = axes_mod.instances(axes, random, seed)
    # validate both corners before any worker starts: unknown names, units, consts
    for corner in (insts[0], insts[-1]):
        program, _ = overrides.checked(tree, fixed + [(n, t) for n, _, t in corner])
        ms = select_missions(path, program, mission)
        if len(ms) > 1:
            raise StlcError([Diagnostic("STL104", f"{path} has {len(ms)} missions: say which "
                                        "to sweep", Span(path, 1, 1, 1, 2), "pass --mission "
                                        + " | ".join(x.name for x in ms))])
        m = ms[0]
    outdir = out if out is not None else os.path.join("reports", f"{m.name}-sweep")
    span = m.span if m.span.known else Span(path, 1, 1, 1, 2)
    preflight(outdir, span, names=(*SWEEP_OWNED, MANIFEST), dirs=("plans",))
    refuse_foreign(outdir, [f"plans/{i}.csv" for i in range(len(insts))], span)
    if scheduler:
        from stlc.sweeping.handshake import check_scheduler

        check_scheduler(scheduler, path)  # a Dask handshake within 5 s, or STL607
    try:
        os.makedirs(outdir, exist_ok=True)
        stage = tempfile.mkdtemp(prefix=STAGE_PREFIX, dir=outdir)
    except OSError as e:
        raise StlcError([Diagnostic("STL605", f"cannot create output directory `{outdir}`: "
                                    f"{e.strerror or e}", span, "choose another `-o DIR`")]
                        ) from None
    os.makedirs(os.path.join(stage, "plans"))
    rows: dict[int, dict] = {}
    client = cluster = None
    interrupted = False
    futs: dict = {}
    lost = {"builds": 0, "preempted": 0}  # pre-empted cold tries (solved again, warm)
    try:
        from distributed import Event

        from stlc.sweeping.task import run_instance

        client, cluster = dask_client(workers, scheduler, path)
        order = Order([{n: v for n, v, _ in inst} for inst in insts], names)
        pending: set = set()
        finished: queue.SimpleQueue = queue.SimpleQueue()  # futures, as they finish
        first_plan = Event(f"stlc-sweep-{uuid.uuid4().hex}", client=client)
        cold: set = set()

        def submit(i: int) -> None:
            items = fixed + [(n, t) for n, _, t in insts[i]]
            seeds = order.neighbours(i)
            f = client.submit(run_instance, source, path, m.name, items,
                              {n: v for n, v, _ in insts[i]}, i, time_limit=time_limit,
                              seeds=seeds, preempt=None if seeds else first_plan.name,
                              pure=False, retries=1)
            futs[f] = i
            pending.add(f)
            if not seeds:
                cold.add(f)
            f.add_done_callback(finished.put)

        def refill() -> None:
            slots = _slots(client, workers, scheduler)
            while len(pending) < slots:
                i = order.next()
                if i is None:
                    break
                submit(i)

        for i in order.seeds(_slots(client, workers, scheduler)):
            submit(i)
        sat = 0
        _progress(0, len(insts), 0, t0, quiet)
        preempt_at, preempting = math.inf, False  # when the cold tries still running stop
        while pending:
            if cold and not preempting and time.perf_counter() >= preempt_at:
                first_plan.set()
                preempting = True
            try:
                f = finished.get(timeout=POLL_S)
            except queue.Empty:
                interrupt.check()
                continue
            if f not in pending:
                continue
            pending.discard(f)
            cold.discard(f)
            i = futs[f]
            try:
                row = f.result()
            except Exception as e:  # noqa: BLE001 - a worker that kept dying, etc.
                row = {"instance": i, "values": {n: v for n, v, _ in insts[i]},
                       "status": "failed", "error": f"{type(e).__name__}: {e}",
                       "robustness": float("nan"), "specs": {}, "iterations": 0,
                       "solve_s": 0.0, "total_s": 0.0, "worker": "", "built": False}
            plan = row.pop("plan_csv", None)
            channels = row.pop("channels", None)
            if channels is not None:  # a satisfied plan: a seed for its neighbours
                order.add(i, row["values"], channels, str(row["values"]))
                if cold and preempt_at == math.inf:  # the first plan: the cold ones still
                    preempt_at = time.perf_counter() + row["solve_s"]  # running get a grace
            if row.pop("preempted", False):  # its solve was cut: solved again, warm, and
                lost["builds"] += bool(row.get("built"))  # only that row is kept (a
                lost["preempted"] += 1  # satisfied plan of the cut solve is a seed)
                order.requeue(i)
                refill()
                continue
            refill()  # before the bookkeeping: no worker waits for it
            if plan is not None:
                with open(os.path.join(stage, "plans", f"{i}.csv"), "w") as fh:
                    fh.write(plan)
            rows[i] = row
            sat += row["status"] == "satisfied"
            _progress(len(rows), len(insts), sat, t0, quiet)
            interrupt.check()
    except KeyboardInterrupt:
        interrupted = True
    finally:
        if not quiet:
            print(file=sys.stderr)
    wall = time.perf_counter() - t0
    with interrupt.deferred():
        try:
            if client is not None and interrupted:
                client.cancel(list(futs))
            summary = _write(stage, outdir, path, m.name, axes, insts, rows, wall, fixed,
                             workers, scheduler, interrupted, random, seed, time_limit, lost)
        finally:
            _cleanup(stage)
    close_client(client, cluster)
    if collect is not None:
        collect.extend(rows[i] for i in sorted(rows))
    if interrupted:
        raise KeyboardInterrupt
    if not quiet:
        print(_summary_text(summary, outdir), file=sys.stderr)
    return 0 if summary["counts"].get("satisfied", 0) == len(insts) else 3


@contextlib.contextmanager
def dask_session(workers: int | None, scheduler: str | None, path: str):
    """A Dask client (``dask_client``) for the ``with`` block, closed after it."""
    client, cluster = dask_client(workers, scheduler, path)
    try:
        yield client
    finally:
        close_client(client, cluster)


def close_client(client, cluster) -> None:
    with contextlib.suppress(Exception):
        if client is not None:
            client.close(timeout=5)
    with contextlib.suppress(Exception):
        if cluster is not None:
            cluster.close(timeout=5)


def quantiles(x: list[float]) -> dict:
    if not x:
        return {}
    a = np.asarray(x, float)
    return {"min": float(a.min()), "p50": float(np.quantile(a, 0.5)),
            "p90": float(np.quantile(a, 0.9)), "p95": float(np.quantile(a, 0.95)),
            "max": float(a.max()), "mean": float(a.mean())}


def _csv(axes, rows: list[dict], spec_names: list[str]) -> str:
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(["instance", *[a.name for a in axes], "status", "robustness",
                *[f"spec.{s}" for s in spec_names], "iterations", "solve_s", "total_s",
                "worker", "error"])
    for r in rows:
        w.writerow([r["instance"], *[repr(r["values"][a.name]) for a in axes], r["status"],
                    repr(r["robustness"]), *[repr(r["specs"].get(s, float("nan")))
                                             for s in spec_names],
                    r["iterations"], f"{r['solve_s']:.4f}", f"{r['total_s']:.4f}", r["worker"],
                    r.get("error", "")])
    return buf.getvalue()


def _write(stage, outdir, path, mission, axes, insts, rows_by_i, wall, fixed, workers,
           scheduler, interrupted, random=None, seed=0, time_limit=None,
           lost: dict | None = None) -> dict:
    from stlc.output.directory import publish
    from stlc.strictjson import strict
    from stlc.sweeping.report import render

    rows = [rows_by_i[i] for i in sorted(rows_by_i)]
    spec_names = sorted({s for r in rows for s in r["specs"]})
    counts: dict[str, int] = {}
    for r in rows:
        counts[r["status"]] = counts.get(r["status"], 0) + 1
    if interrupted:
        counts["cancelled"] = len(insts) - len(rows)
    ok = [r for r in rows if r["status"] != "failed"]
    per_worker: dict[str, int] = {}
    for r in rows:
        per_worker[r["worker"]] = per_worker.get(r["worker"], 0) + 1
    summary = {
        "file": path, "mission": mission, "instances": len(insts), "finished": len(rows),
        "interrupted": interrupted, "counts": counts,
        "varied": [{"name": a.name, "lo": a.lo * a.scale, "hi": a.hi * a.scale, "n": a.n,
                    "unit": a.unit or "", "given": {"lo": a.lo, "hi": a.hi}}
                   for a in axes], "set": {n: t for n, t in fixed},
        "wall_s": wall, "per_instance_s": wall / max(len(rows), 1),
        "nlp_builds": sum(1 for r in rows if r.get("built")) + (lost or {}).get("builds", 0),
        "preempted": (lost or {}).get("preempted", 0),
        "warm_started": sum(1 for r in rows if r.get("warm") == "plan library"),
        # warm starts that missed κ and were planned again from the instance's own seed
        "replanned_own_seed": sum(1 for r in rows if r.get("warm") == "plan library"
                                  and r.get("replanned")),
        "warm_from_prediction": sum(1 for r in rows
                                    if str(r.get("seed", "")).startswith(PREDICTED)),
        "solve_s": quantiles([r["solve_s"] for r in ok]),
        "total_s": quantiles([r["total_s"] for r in ok]),
        "t_c_estimate_s": quantiles([r["solve_s"] for r in ok]).get("p95"),
        "t_c_note": "p95 of solve_s over the instances: paper A §4.4's estimate of the "
                    "replanning budget t_c",
        "random": random, "seed": seed if random is not None else None,
        "time_limit_s": time_limit,  # per instance; None: the default limit
        "scheduler": scheduler or f"LocalCluster({workers or os.cpu_count()} processes, "
                                  "1 thread each)",
        "workers": per_worker,
        "failed": [{"instance": r["instance"], "error": r.get("error", "")}
                   for r in rows if r["status"] == "failed"],
    }
    with open(os.path.join(stage, "sweep.csv"), "w") as fh:
        fh.write(_csv(axes, rows, spec_names))
    with open(os.path.join(stage, "sweep.json"), "w") as fh:
        json.dump(strict(summary), fh, indent=2, allow_nan=False)
    with open(os.path.join(stage, "sweep.html"), "w") as fh:
        fh.write(render(summary, axes, rows, spec_names))
    try:
        publish(stage, outdir, complete=True, key="sweep")
    except OSError as e:
        raise StlcError([Diagnostic("STL605", f"cannot write the sweep's outputs to `{outdir}`: "
                                    f"{e.strerror or e}", Span(path, 1, 1, 1, 2),
                                    "check free space and permissions, or choose another "
                                    "`-o DIR`")]) from None
    return summary


def _summary_text(s: dict, outdir: str) -> str:
    q = s["solve_s"]
    return (f"{s['finished']} instances: " + ", ".join(f"{v} {k}" for k, v in s["counts"].items())
            + f"; wall {s['wall_s']:.1f} s ({s['per_instance_s']:.2f} s per instance), "
            f"{s['nlp_builds']} NLP builds, solve_s p50 {q.get('p50', float('nan')):.2f} s, "
            f"p95 {q.get('p95', float('nan')):.2f} s (t_c estimate)\n→ {outdir}/sweep.html")
