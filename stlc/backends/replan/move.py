"""The operator move's replan (paper A §6, ``stlc simulate --move``): the rest of the
mission on the same parametric NLP as the compile (``nlp.cache``: the human's new pose is a
parameter value, nothing is rebuilt), every sample up to the move fixed to what was flown
(bounds), warm-started from the flown plan or from the nearest plan of a sweep's directory
(``--library DIR``), through the whole λ/energy schedule.  ``stlc.replan.move`` decides
and judges; this module only plans (the pipeline hands ``replan_rest`` to it)."""

from __future__ import annotations

import csv
import os
import time

import numpy as np


def _library_plans(directory: str) -> list[tuple[dict[str, float], dict[str, np.ndarray]]]:
    """(values, channels) of every plan of a sweep directory (sweep.csv + plans/<i>.csv)."""
    out = []
    try:
        with open(os.path.join(directory, "sweep.csv"), newline="") as fh:
            rows = list(csv.DictReader(fh))
    except OSError:
        return out
    fixed = {"instance", "status", "robustness", "iterations", "solve_s", "total_s", "worker",
             "error"}
    for r in rows:
        p = os.path.join(directory, "plans", f"{r['instance']}.csv")
        if r["status"] != "satisfied" or not os.path.isfile(p):
            continue
        with open(p) as fh:
            header = fh.readline().strip().split(",")
        data = np.atleast_2d(np.loadtxt(p, delimiter=",", skiprows=1))
        ch = {h: data[:, i] for i, h in enumerate(header)}
        vals = {k: float(v) for k, v in r.items() if k not in fixed and not k.startswith("spec.")}
        out.append((vals, ch))
    return out


def replan_rest(problem, flown: dict[str, np.ndarray], k_e: int, library: str | None,
                pose: dict[str, float]) -> tuple[dict, dict]:
    """(channels of the new plan, info: solve_s, status, iterations, built, warm_start) of
    ``problem`` (the mission at the moved pose) with samples 0..k_e fixed to ``flown``."""
    from stlc.backends.nlp import cache as nlp_cache
    from stlc.backends.nlp import schedule
    from stlc.backends.nlp.backend import channels_with_derived
    from stlc.backends.nlp.library import PlanLibrary, warm_start

    program, lam = problem.program, problem.smoothing.lam
    prob, inv, built = nlp_cache.lowered(problem)
    lbx, ubx = prob.lbx.copy(), prob.ubx.copy()
    try:
        seed_ch, source = flown, "current plan"
        if library:
            lib = PlanLibrary()
            for vals, ch in _library_plans(library):
                lib.add(vals, ch, "library")
            near = lib.nearest(pose)
            if near is not None:
                seed_ch, source = near[0], f"library {library} (distance {near[2]:.3g})"
        w_now = warm_start(prob, inv, flown, program.params, lam)
        w0 = warm_start(prob, inv, seed_ch, program.params, lam)
        for L in inv.layouts:  # what was flown up to the event is fixed
            xs = slice(L.x_slice.start, L.x_slice.start + L.nx * (k_e + 1))
            us = slice(L.u_slice.start, L.u_slice.start + L.nu * k_e)
            prob.lbx[xs] = prob.ubx[xs] = w0[xs] = w_now[xs]
            prob.lbx[us] = prob.ubx[us] = w0[us] = w_now[us]
        t0 = time.perf_counter()
        raw = schedule.solve_mission(problem, prob, inv, w0)
        solve_s = time.perf_counter() - t0
    finally:
        prob.lbx[:], prob.ubx[:] = lbx, ubx
    info = {"solve_s": solve_s, "status": str(raw.stages[-1].status), "built": built,
            "iterations": sum(s.iterations for s in raw.stages), "warm_start": source}
    return channels_with_derived(inv, raw.w), info
