"""The engine of ``stlc fly``: fly a plan closed loop (``stlc.flight.rigid``) and judge the
flown trajectory with the exact monitor on the mission's grid.

One flight is a batch of N runs stepping together; each drone of the mission is flown
along its own plan, all with the same setup.  The flown state is recorded at the plan's
sample times; the channels the flight does not produce (a team drone's payload, decided
by the plan's events) are the plan's.  The exact robustness of the requirement and of
every named spec is evaluated for all N runs in one monitor pass (channels of shape
(N, n), ``stlc.analysis.monitor_demand``).

``--runs N`` is cut into chunks of ``CHUNK`` runs; chunk c (1, 2, …; 0 is the seeded
flight of ``flight.json``/``flown.csv``) draws its randomness from
``numpy.random.default_rng([seed, c])``, so the results do not depend on where the chunks
run (locally one after the other, or on Dask workers).  The arrays are numpy's; the
batched code uses only array operations that ``array_api``-style modules also have, but
no other array module is wired in.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from stlc.analysis.risk_levels import judge_levels
from stlc.flight import export, frames, rigid

__all__ = ["Batch", "fly_batch", "judge_levels", "many", "run_statistics", "uncertainty"]

CHUNK = 500


@dataclass
class Batch:
    """N flights: ``channels`` name → (N, n) on the plan's grid, the exact robustness of
    each judged formula (N,), the tracking error's maximum and RMS (N,) (over the drones:
    the largest maximum, the RMS of all)."""

    channels: dict[str, np.ndarray]
    robustness: dict[str, np.ndarray]
    err_max: np.ndarray
    err_rms: np.ndarray


def formulas(program, mission) -> dict:
    """What a flight is judged on: the mission's requirement (under the mission's name)
    and its named specs."""
    from stlc.semantics.specs import mission_specs

    out = {mission.name: mission.requirement}
    out.update({k: s.formula for k, s in mission_specs(program, mission).items()})
    return out


def _flown_channels(v, fl: rigid.Flown, plan: dict) -> dict[str, np.ndarray]:
    from stlc.vehicles import model_of

    vm = model_of(v)
    N, n, nx = fl.states.shape
    out = {}
    for i, c in enumerate(vm.state_channels(v)):
        out[c] = fl.states[:, :, i]
    for i, c in enumerate(vm.input_channels(v)):
        out[c] = fl.inputs[:, :, i]
    yaw = f"{v.name}.att.z"
    if yaw in out and yaw in plan:  # the branch of the plan's heading
        out[yaw] = plan[yaw][None] + frames.wrap(out[yaw] - plan[yaw][None])
    X = np.stack([out[c] for c in vm.state_channels(v)], axis=-1).reshape(N * n, nx)
    for c, x in vm.derived_channels(v, X).items():
        out[c] = np.asarray(x).reshape(N, n)
    return out


def uncertainty(program, mission) -> list:
    """The uncertain scenario parameters a run draws (the human's pose): the scenario's
    distributions overridden by the mission's first risk case, as the risk pass merges
    them (``stlc.analysis.sampling``)."""
    from stlc.analysis.sampling import merge_distributions, scenario_distributions

    base = scenario_distributions(program.scenario)
    case = mission.risk.cases[0].distributions if mission.risk and mission.risk.cases else ()
    return merge_distributions(base, case)


def fly_batch(program, mission, times: np.ndarray, plan: dict, setup: rigid.FlightSetup,
              runs: int, seed: int, chunk: int = 0, uncertain: bool = False) -> Batch:
    """``runs`` flights of the plan (``times``, ``plan`` channels), judged; with
    ``uncertain`` each run also draws the scenario's uncertain parameters (``uncertainty``)
    and is judged with its own draw."""
    from stlc.analysis import monitor_demand

    rng = np.random.default_rng([seed, chunk])
    params = program.params
    dists = uncertainty(program, mission) if uncertain else []
    if dists:
        from stlc.analysis.sampling import sample_params

        params = sample_params(program.params, dists, runs, int(rng.integers(2**31)))
    channels: dict[str, np.ndarray] = {}
    emax, esq = np.zeros(runs), np.zeros(runs)
    drones = [d for d in mission.vehicles if f"{d}.pos.x" in plan]
    for d in drones:
        v = program.vehicles[d]
        tr = export.track(v, times, plan)
        mine = tuple(p for p in setup.pushes if p.vehicle == d)
        fl = rigid.fly(v, tr, times, _with_pushes(setup, mine), runs, rng)
        channels.update(_flown_channels(v, fl, plan))
        emax = np.maximum(emax, fl.err_max)
        esq += fl.err_rms**2
    for c, x in plan.items():  # what the flight does not produce: the plan's
        channels.setdefault(c, np.broadcast_to(np.asarray(x, float), (runs, len(times))))
    fs = formulas(program, mission)
    dt = float(times[1] - times[0]) if len(times) > 1 else mission.step
    vals = monitor_demand.robustness_many(list(fs.values()), dt, channels, params,
                                          n=len(times))
    rob = {k: np.broadcast_to(np.asarray(x, float), (runs,)).copy() for k, x in zip(fs, vals)}
    return Batch(channels, rob, emax, np.sqrt(esq / max(len(drones), 1)))


def _with_pushes(setup: rigid.FlightSetup, pushes: tuple) -> rigid.FlightSetup:
    from dataclasses import replace

    return replace(setup, pushes=pushes)


def chunk_summary(program, mission, times, plan, setup, runs: int, seed: int, chunk: int,
                  uncertain: bool = True) -> dict[str, np.ndarray]:
    """A chunk of ``--runs``, reduced to what the statistics need (for Dask workers: no
    channels travel back)."""
    b = fly_batch(program, mission, times, plan, setup, runs, seed, chunk, uncertain)
    return {"robustness": b.robustness[mission.name], "err_max": b.err_max,
            "err_rms": b.err_rms}


def many(program, mission, times, plan, setup, runs: int, seed: int, client=None,
         uncertain: bool = True) -> dict[str, np.ndarray]:
    """``runs`` flights in chunks of ``CHUNK`` (on ``client``'s Dask workers when given),
    concatenated in chunk order."""
    sizes = [min(CHUNK, runs - s) for s in range(0, runs, CHUNK)]
    if client is None:
        parts = [chunk_summary(program, mission, times, plan, setup, n, seed, c, uncertain)
                 for c, n in enumerate(sizes, start=1)]
    else:
        futures = [client.submit(chunk_summary, program, mission, times, plan, setup, n,
                                 seed, c, uncertain, pure=False)
                   for c, n in enumerate(sizes, start=1)]
        parts = client.gather(futures)
    return {k: np.concatenate([p[k] for p in parts]) for k in parts[0]}


def run_statistics(rho: np.ndarray, betas, delta: float, kappa: float = 0.0) -> dict:
    """P(violation) (ρ < κ, ``stlc.analysis.verdict``) with its one-sided Clopper–Pearson upper bound at confidence
    1 − δ, and VaR/CVaR of the flown robustness at each β with their DKW bounds
    (``stlc.analysis.risk_measures.summarize``: VaR is the robustness level kept with
    probability β, CVaR the mean of the worst 1 − β)."""
    from stlc.analysis.risk_measures import summarize

    s = summarize(rho, betas, delta, kappa=kappa)
    pv = s["p_violation"]
    return {"n": int(rho.size), "violations": pv["count"], "p_violation": pv["value"],
            "p_violation_upper": pv["upper"], "delta": delta,
            "var": {b: d["value"] for b, d in s["var"].items()},
            "cvar": {b: d["value"] for b, d in s["cvar"].items()},
            "var_bounds": s["var"], "cvar_bounds": s["cvar"],
            "robustness": {"mean": s["mean"], "min": s["min"], "max": s["max"]}}
