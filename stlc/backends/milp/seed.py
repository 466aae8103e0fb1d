"""MILP seeds for nonlinear vehicles: the discrete structure of a plan chosen globally.

The full NLP (``nlp.model``) is local: started on the wrong side of an obstacle, or at the
wrong sample of an ``eventually``, it converges there, and no smoothing λ moves it across.
``MilpPathSeed`` (``milp.path_seed``) replaces the local kinematic guess of the ``nlp`` chain by a global one:

* every vehicle becomes a **double integrator** in its position and velocity, with the
  speed and acceleration bounds its model offers for a guess
  (``VehicleModel.kinematic_limits``: for a multirotor a per-axis speed and acceleration it
  can fly at any attitude the NLP allows — an inner bound, so the NLP can follow the path);
* the requirement keeps its predicates on positions and velocities; an upper bound on a
  norm of them (a speed limit) becomes the box inside its ball (``seed_inner``); every
  other predicate (a lower bound on a norm, heading, rotor speed, attitude, payload)
  becomes ``true`` (the NLP adds them back); a signed distance to a region (``dist``, a
  round region) becomes its polyhedral bound below the exact robustness
  (``stlc.semantics.polyhedral``: a round shape is seen through its circumscribed polytope
  for a clearance, an inscribed bound for a band's far side);
* the grid is **as coarse as the formula's intervals allow**: the largest multiple h of the
  mission step, at most ``MAX_STEP_S``, that divides the horizon and every finite bound of a
  temporal operator — so every window of the formula falls on seed samples;
* the STL→MILP encoding of ``milp.encode`` (a binary per branch of every disjunction: the
  side of every obstacle, the sample of every ``eventually``, the branch of every ``or``)
  is solved by HiGHS in three phases (``_solve``): a path with ρ̂ ≥ κ, a shorter one from it
  (L1 acceleration penalty: LPs with the choices fixed, each followed by the best choices
  on its path, ``Encoder.complete``), the LP with that path's binaries fixed maximising ρ̂
  minus the penalty, and from it the MILP with its choices free for at most ``FREE_S`` (a
  better class, if HiGHS finds one), under ``TIME_LIMIT_S`` in all — that last MILP in a
  forked child beside the kinematic smoothing of the polished path, which runs again only
  from a better class.  The smoothing's NLP (``kinematic.GuessNlp``, the choice rows as its
  parameters) is built in a thread while HiGHS runs (``kinematic.build_in_thread``).

The seed path is exact between seed samples (piecewise-constant acceleration), so it is
sampled onto the mission grid, smoothed there by the kinematic NLP with the seed's choices
fixed (``schedule.kinematic_guess(problem, path=…)``) and lifted to the vehicle's states and
inputs (``schedule.full_guess``); the NLP's first stage keeps the same choices
(``choices.choose``), and only if that misses κ does the schedule solve the formula as written.

When the MILP cannot be built (a position predicate that is not affine), finds no path in
its time limit, or the mission has no predicate on positions, the seed is the kinematic
guess; ``Solution.solver`` says which ran.  ``next_seed`` gives the next-best discrete
choice (a no-good cut on this seed's binaries for the conjuncts a plan violates), which
``pipeline`` tries when the plan from this seed misses κ.  The seed proves nothing (inner
bounds, coarse samples; the exact monitor judges the plan); the proof is ``milp.conflict``'s.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, replace

import numpy as np

from stlc import deadline, vehicles
from stlc.planning import effort
from stlc.backends.milp.encode import NotLinear
from stlc.backends.milp.rolling import feasible, samples
from stlc.planning.coarse_grid import MAX_SAMPLES, MAX_STEP_S, refine, seed_factor  # noqa: F401
from stlc.backends.milp.seed_inner import inner_norms
from stlc.semantics import ir
from stlc.semantics.polyhedral import DISTANCE_NOTE, has_distance, polyhedral_formula
from stlc.semantics.timegrid import TimeGrid

TIME_LIMIT_S = effort.SEED_BASE_S  #: the seed's least wall budget (``effort.seed_budget``)
ACC_WEIGHT = 1e-3  #: L1 penalty per m/s² · s of acceleration, against ρ̂ in metres
ROUNDS = 20  #: LPs of the shortening's local search, at most (≈ 30 ms each on a handover)
ROUND_GAIN = 0.01  #: … while each one lowers the penalty by more than this fraction
#: then the MILP with its choices free, from the polished path, at most this long: its better
#: classes come from HiGHS's heuristics on the start (a two-drone mission's direct assignment
#: was found within 0.1 s), the rest of the time goes to a proof it does not finish on a
#: handover; 0.5 → 0.2 s: six handovers 0.1–0.2 s faster, the same plans
FREE_S = 0.2
POLISH_S = 0.3  #: kept for the last LP (choices fixed)
RELAX = 2.0  #: a relaxed seed's guess limits, times the vehicle's (``plan(relaxed=True)``)


def seed_formula(problem, clearance: float = 0.0, relaxed: bool = False) -> ir.Formula:
    """The requirement with only its affine predicates on positions and velocities (every
    other predicate is ``true``); with ``clearance`` > 0 every face of a region the formula
    keeps the vehicle *out of* (a negated box face: ``not in``, the left side of
    ``implies``) is pushed out by that much (``e ≥ 0`` becomes ``e − clearance ≥ 0``);
    ``relaxed``: a speed limit's box around its ball instead of the box inside it."""
    from stlc.backends.milp.conflict import drop_nonlinear, kept_channels

    keep = kept_channels(problem)  # positions, velocities and fixed channels
    inner = inner_norms(problem.requirement, problem.params, outer=relaxed)  # speed limits
    inner = polyhedral_formula(inner)  # distances: affine bounds below the exact ρ
    f = ir.restrict(drop_nonlinear(inner, problem.params, {}), lambda s: s in keep)
    if clearance <= 0:
        return f

    def go(g: ir.Formula) -> ir.Formula:
        o = getattr(g, "origin", None)
        if isinstance(g, ir.Pred) and o is not None and o.kind == "face" and o.negated:
            return replace(g, expr=ir.Bin("-", g.expr, ir.Const(clearance)))
        return ir.map_children(g, go)

    return go(f)


def clearance(problem, h: float) -> float:
    """How far a path between two samples h apart can stray from the nearer one, per axis
    (speed ·h/2 + acceleration ·(h/2)²/2, the largest over the vehicles' bounds): a sample
    that far outside a face keeps the path out of it up to the middle of the interval."""
    out = 0.0
    for v in problem.vehicles():
        vmax, amax = vehicles.model_of(v).kinematic_limits(v)
        out = max(out, float(np.max(np.asarray(vmax, float) * h / 2
                                    + np.asarray(amax, float) * h * h / 8)))
    return out


@dataclass(frozen=True)
class _Box:
    x_lo: np.ndarray
    x_hi: np.ndarray
    u_lo: np.ndarray
    u_hi: np.ndarray


def _lins(problem, h: float, widen: float = 1.0):
    """Each vehicle as a double integrator on the seed grid (step h), inner bounds (times
    ``widen``)."""
    hold = problem.hold_end

    def lins(v):
        vm = vehicles.model_of(v)
        vmax, amax = (widen * np.asarray(b, float) for b in vm.kinematic_limits(v))
        sc = vm.state_channels(v)
        x0 = np.asarray(problem.start_state(v.name), float)
        pos, vel = sc[vm.pos_index()], sc[vm.vel_index()]
        x0 = np.concatenate([x0[vm.pos_index()], x0[vm.vel_index()]])
        eye = np.eye(3)
        ad = np.block([[eye, h * eye], [np.zeros((3, 3)), eye]])
        bd = np.vstack([h * h / 2 * eye, h * eye])
        vmax = np.asarray(vmax, float)
        # the start velocity may exceed the seed's bound (a disturbed replan): widen to it
        vmax = np.maximum(vmax, np.abs(x0[3:]))

        b = _Box(np.concatenate([np.full(3, -np.inf), -vmax]),
                 np.concatenate([np.full(3, np.inf), vmax]),
                 -np.asarray(amax, float), np.asarray(amax, float))
        inputs = [f"__seed.{v.name}.acc.{a}" for a in "xyz"]
        return list(pos) + list(vel), inputs, ad, bd, b, x0

    lins.hold = hold
    return lins


def conjuncts(f: ir.Formula) -> list[ir.Formula]:
    return list(f.args) if isinstance(f, ir.And) else [f]


def plan(problem, time_limit: float | None = None, quiet: bool = True,
         exclude: tuple = (), rounds: int = ROUNDS, keep_clear: bool = False,
         defer_free: bool = False, on_solve=None, best_blocks: bool = False,
         relaxed: bool = False):
    """The seed paths on the mission grid (per vehicle P 3×n, V 3×n, A 3×(n−1)) and a record
    of the MILP; the paths are None when the MILP found none (or cannot be built).
    ``exclude``: earlier choices to leave out, each {conjunct index: (binary columns, their
    0/1 values)} — a no-good cut: at least one of those binaries differs.  ``rounds``:
    the shortening's LPs at most (0: none).  ``keep_clear``: regions the formula keeps the
    vehicle out of are inflated by the ``clearance`` of the seed step, so that the path
    between seed samples does not cut their corners (for a start on a finer grid).  The
    record's ``choices`` are this seed's, in the same form, for every conjunct of the seed
    formula.  ``defer_free``: the MILP with its choices free (``_free``) is left out and a
    third value returned — None, or a function that runs it: ((paths, record) of a better
    class, or None when it finds none; its phases) — ``MilpPathSeed`` runs it beside the
    kinematic smoothing.  ``on_solve()`` is called once the MILP is built, just before HiGHS
    runs (not for a mission the MILP cannot encode); ``best_blocks``: ``rolling.feasible``'s.
    ``relaxed``: the vehicles' guess limits times ``RELAX`` and the box around every speed
    ball (``path_seed``: when the inner bounds leave no path)."""
    from stlc.backends.milp.backend import build, invariant_box

    t0 = time.perf_counter()
    f = seed_formula(problem, relaxed=relaxed)
    grid = problem.grid
    rec: dict = {"name": "HiGHS MILP seed (highspy)"}
    if relaxed:
        rec["relaxed"] = RELAX
    if has_distance(problem.requirement):
        rec["distances"] = DISTANCE_NOTE
    if isinstance(f, (ir.TrueF, ir.FalseF)):
        rec["status"] = "no position predicate"
        return (None, rec, None) if defer_free else (None, rec)
    m = seed_factor(grid, problem.requirement)
    h = m * grid.dt
    if keep_clear and m > 1:
        rec["clearance"] = clearance(problem, h)
        f = seed_formula(problem, rec["clearance"], relaxed)
    coarse = TimeGrid(h, grid.n_intervals // m)
    fixed = {k: np.asarray(v)[::m] for k, v in problem.fixed_channels.items()}
    cp = replace(problem, grid=coarse, fixed_channels=fixed, requirement=f, seed=None)
    lins = _lins(problem, h, RELAX if relaxed else 1.0)
    parts = {f"c{i}": c for i, c in enumerate(conjuncts(f))}
    try:
        low = build(cp, {**parts, "requirement": f}, lins, box=invariant_box(cp),
                    top_of="requirement")
    except (NotLinear, ValueError) as e:
        rec["status"] = f"not encodable: {e}"
        return (None, rec, None) if defer_free else (None, rec)
    milp = low.milp
    bins = {i: [j for j in range(*low.spans[f"c{i}"]) if milp.integer[j]]
            for i in range(len(parts))}
    for cut in exclude:  # Σ_{v=0} y − Σ_{v=1} y ≥ 1 − |ones|
        coefs = {int(j): (1.0 if v < 0.5 else -1.0) for cols, vals in cut.values()
                 for j, v in zip(cols, vals)}
        if coefs:
            milp.row(coefs, 1.0 - sum(1 for c in coefs.values() if c < 0), np.inf)
    if lins.hold:  # the holdable end: at rest at the last seed sample
        for lv in low.vehicles:
            for c in lv.x[-1][3:]:
                milp.row({int(c): 1.0}, 0.0, 0.0)
    cost: dict[int, float] = {}
    if low.top >= 0:
        cost[low.top] = -1.0
    for lv in low.vehicles:  # t ≥ |a|: the L1 penalty
        for col in lv.u.ravel():
            t = milp.var(0.0, np.inf)
            milp.row({t: 1.0, int(col): -1.0}, 0.0, np.inf)
            milp.row({t: 1.0, int(col): 1.0}, 0.0, np.inf)
            cost[t] = ACC_WEIGHT * h
    limit = effort.seed_budget(milp.n_binaries) if time_limit is None else \
        float(min(time_limit, max(deadline.solve_remaining(), 0.05)))
    rec["budget_s"] = limit
    t_start = time.perf_counter()
    if on_solve is not None:
        on_solve()
    res, phases = _solve(milp, low.top, cost, problem.threshold, limit, rounds,
                         low.encoder.complete, not defer_free, (samples(low), best_blocks))
    rec.update({"step_s": h, "samples": coarse.n, "binaries": milp.n_binaries,
                "build_s": low.build_s, "excluded": len(exclude)})
    if low.top >= 0:  # the encoding's own bound on ρ̂ (a start inside a no-fly box: < κ)
        rec["bound"] = float(milp.hi[low.top])

    def record(res, phases) -> tuple[dict | None, dict]:
        r = {**rec, "status": res.highs_status, "wall_s": sum(p[2] for p in phases),
             "nodes": res.nodes, "phases": [list(p) for p in phases]}
        if res.x is None:
            return None, r
        r["robustness"] = float(res.x[low.top]) if low.top >= 0 else float("nan")
        r["choices"] = {i: (cols, [int(round(res.x[j])) for j in cols])
                        for i, cols in bins.items() if cols}
        paths = {}
        for lv, v in zip(low.vehicles, problem.vehicles()):
            xs, uu = lv.simulate(res.x)
            paths[v.name] = refine(xs, uu, m, grid.dt)
        r["total_s"] = time.perf_counter() - t0
        return paths, r

    out = record(res, phases)
    if not defer_free:
        return out
    left = limit - (time.perf_counter() - t_start)
    if out[0] is None or low.top < 0 or left <= 2 * POLISH_S:
        return (*out, None)

    def resume():
        better, more = _free(milp, low.top, cost, problem.threshold, res, left)
        return (record(better, list(phases) + more) if better is not res else None), more

    return (*out, resume)


def _solve(milp, top: int, cost: dict[int, float], kappa: float, limit: float,
           rounds: int = ROUNDS, complete=None, free: bool = True, at=None):
    """Three phases: a path with ρ̂ ≥ κ (a feasibility MILP: HiGHS finds one far sooner than
    it closes any optimisation; on a large one block by block along the grid, ``at``: the
    sample of each column and ``best_blocks``, ``rolling``); then a local search for a shorter path (a feasibility
    solution's choices at samples where nothing binds are arbitrary: a path that wanders):
    with the choices fixed, the LP minimising the acceleration penalty under ρ̂ ≥ κ, then
    the best choices on that path (``complete``: ``Encoder.complete``), again while the
    penalty falls by more than ``ROUND_GAIN``, for at most ``rounds`` LPs; then, with the
    choices fixed, the LP maximising ρ̂ − penalty (the most robust, economical path of that
    homotopy class); then the MILP with its choices free from that point for at most
    ``FREE_S`` (the local search never leaves the class of the first feasible path: on
    `eventually (x ≥ 2 or y ≤ −2.5)` it kept the branch worth 0.25 where 0.75 exists).
    When HiGHS proves that no path reaches κ, that result is returned at once (the caller
    asks the sound relaxation for a proof); when none was found in time, the whole MILP
    maximises ρ̂ − penalty in the time left and its incumbent, if any, is the seed."""
    from stlc.solvers.highs import Highs

    t0 = time.perf_counter()
    left = lambda: max(limit - (time.perf_counter() - t0), 0.05)  # noqa: E731
    phases = []
    best, x = None, None
    if top >= 0:
        kappa_lo = min(max(milp.lo[top], kappa), milp.hi[top])
        best = feasible(milp, top, kappa_lo, limit, *(at or (None, False)), phases)
        if best.highs_status == "Infeasible":  # no seed path reaches κ: the caller asks for a proof
            return best, phases
        x = None if best.x is None else best.x.copy()
        penalty = {j: c for j, c in cost.items() if j != top}
        prev = np.inf
        for _ in range(rounds if complete is not None and x is not None else 0):
            h = Highs(milp, penalty, time_limit=left())
            h.set_col_bounds(top, kappa_lo, milp.hi[top])
            h.fix_integers(x)
            res = h.solve()
            phases.append(("shorter path (choices fixed)", res.highs_status, res.wall_s))
            if res.x is None:
                break
            x = res.x.copy()
            complete(x)
            if res.objective > prev * (1 - ROUND_GAIN):
                break
            prev = res.objective
    h = Highs(milp, cost, time_limit=left(), rel_gap=1e-3, abs_gap=1e-4)
    if x is None:  # no path with ρ̂ ≥ κ found in time: the whole MILP for what it finds
        res = h.solve()
        phases.append(("optimisation", res.highs_status, res.wall_s))
        return res, phases
    h.fix_integers(x)  # its choices fixed: an LP
    res = h.solve()
    phases.append(("polish (choices fixed)", res.highs_status, res.wall_s))
    if res.x is None:
        res.x, res.status, res.highs_status = best.x, best.status, best.highs_status
        return res, phases
    if free and top >= 0 and left() > 2 * POLISH_S:
        res, more = _free(milp, top, cost, kappa, res, left())
        phases += more
    return res, phases


def _free(milp, top: int, cost: dict[int, float], kappa: float, res, limit: float):
    """The choices free, from the polished point ``res``: another class with a better
    ρ̂ − penalty (a small MILP closes in far less than ``FREE_S``; a handover's does not,
    and keeps its), polished with its choices fixed: (the better result, or ``res`` itself
    when there is none, and the phases)."""
    from stlc.solvers.highs import Highs

    t0 = time.perf_counter()
    kappa_lo = min(max(milp.lo[top], kappa), milp.hi[top])
    h = Highs(milp, cost, time_limit=min(FREE_S, limit - POLISH_S), rel_gap=1e-3,
              abs_gap=1e-4)
    h.set_col_bounds(top, kappa_lo, milp.hi[top])
    h.start(res.x)
    free = h.solve()
    phases = [("better class (choices free)", free.highs_status, free.wall_s)]
    if free.x is not None and free.objective < res.objective - 1e-6:
        h = Highs(milp, cost, time_limit=max(limit - (time.perf_counter() - t0), 0.05),
                  rel_gap=1e-3, abs_gap=1e-4)
        h.fix_integers(free.x)
        pol = h.solve()
        phases.append(("polish (choices fixed)", pol.highs_status, pol.wall_s))
        res = pol if pol.x is not None and pol.objective <= free.objective + 1e-9 else free
    return res, phases
