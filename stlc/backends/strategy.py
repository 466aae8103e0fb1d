"""The planning strategy: which backend chain plans a problem, and what follows when its
plan misses κ — further seeds, the fallback chain, the proof and explanation of
infeasibility (``plan``; ``stlc.pipeline`` only orders the passes around it).

Choosing the backend chain of a problem from the registry, by capabilities.

``CHAINS`` names the chains (each a tuple of registry names, seed first) in the order they
are tried; the first chain whose every backend accepts the problem (``Backend.accepts``:
vehicle models — "linear dynamics only" —, formula nodes, functions, planned signals, and
``needs_signals``: a team chain plans only missions that read a payload) plans it:

* ``team``: task-assignment MILP → waypoint refinement (missions with payloads, paper B);
* ``milp``: a coarse-grid MILP start (``milp.start``) → the exact STL→MILP backend (linear
  vehicles, predicates linear in the state; integer variables decide every disjunction
  globally);
* ``knots``: a long mission (more than ``knots.LONG_SAMPLES`` samples) planned by the
  ``nlp`` chain on a coarse grid of knots, simulated on the mission grid (``knots``);
* ``timed``: a multirotor's mission on its own grid, planned by the ``nlp`` chain with the
  MILP seed's timing kept (``knots.timed``); a plan that misses κ is planned again by the
  ``nlp`` chain with the times free;
* ``nlp``: MILP seed (the discrete choices of a double-integrator abstraction, chosen
  globally; ``milp.seed``) → the full-dynamics smooth-robustness NLP (anything else);
  ``kinematic`` forces the local kinematic guess as the seed instead.

A forced name (``--backend NAME`` or the mission's ``backend = NAME``) is a chain name or a
registry name (the chain that ends with it); a forced chain that cannot plan the problem
reports its STL401 diagnostics, as every chain does before any work.
"""

from __future__ import annotations

import sys
import time
from dataclasses import dataclass

from stlc.backends.registry import registry
from stlc.diagnostics import Diagnostic, Span, StlcError, did_you_mean
from stlc.planning.record import ChainRecord, ChainStage

CHAINS: dict[str, tuple[str, ...]] = {
    "team": ("team-milp", "team-refine"),
    "milp": ("milp-start", "milp"),
    "knots": ("knots",),
    "timed": ("timed",),
    "nlp": ("seed-milp", "casadi"),
    "kinematic": ("kinematic", "casadi"),
}
DEFAULT = "nlp"  #: planned when no chain accepts: its diagnostics say why


@dataclass
class Chain:
    name: str
    backends: list  # Backend instances, seed first
    forced: bool = False


def names() -> list[str]:
    """Every name ``--backend`` accepts: the chains, then the registry's backends that are
    members of a chain (the replanning backends are not chosen by ``--backend``)."""
    members = {n for c in CHAINS.values() for n in c}
    return list(CHAINS) + [n for n in registry() if n not in CHAINS and n in members]


def _instances(chain: str, quiet: bool) -> list:
    out = []
    for n in CHAINS[chain]:
        cls = registry()[n]
        try:
            out.append(cls(quiet=quiet))
        except TypeError:
            out.append(cls())
    return out


def _needs(b, problem) -> bool:
    """The problem reads a signal field the backend needs (``needs_signals``)."""
    from stlc.semantics import ir

    need = getattr(b.capabilities, "needs_signals", frozenset())
    if not need:
        return True
    return any(s.rsplit(".", 1)[-1] in need for s in ir.signals(problem.requirement))


def chain_of(name: str, span: Span | None = None) -> str:
    """The chain a forced name selects (STL207 for an unknown name)."""
    if name in CHAINS:
        return name
    for c, members in CHAINS.items():
        if members[-1] == name or name in members:
            return c
    raise StlcError([Diagnostic("STL207", f"unknown backend `{name}`", span or Span.none(),
                                did_you_mean(name, names()) or "backends: " + ", ".join(names()))])


def select(problem, forced: str | None = None, quiet: bool = True,
           span: Span | None = None) -> Chain:
    """The chain that plans ``problem``: the forced one, else the first that accepts it."""
    if forced is None:
        forced = problem.mission.options.get("backend")
        span = span or problem.mission.options.get("backend_span")
    if forced is not None:
        return Chain(chain_of(str(forced), span or problem.mission.span),
                     _instances(chain_of(str(forced)), quiet), True)
    for name in CHAINS:
        bs = _instances(name, quiet)
        if all(_needs(b, problem) and not b.accepts(problem) for b in bs):
            return Chain(name, bs)
    return Chain(DEFAULT, _instances(DEFAULT, quiet))


def chain_record(chain: Chain, sols: list) -> ChainRecord:
    """What ``solution.json`` and the report say about the chain: its name, whether it was
    forced, and each stage's backend and status."""
    stages = []
    for b, s in zip(chain.backends, sols):
        rec = s.solver
        st = rec.return_status if rec.return_status is not None else (rec.status or "")
        conv = rec.converged if rec.converged is not None else str(st) in ("optimal",
                                                                             "acceptable")
        stages.append(ChainStage(b.name, str(st), bool(conv), rec.get("seed")))
    for b in chain.backends[len(sols):]:  # after a proof of infeasibility
        stages.append(ChainStage(b.name, "not_run", False))
    return ChainRecord(chain.name, chain.forced, stages)


# ---------------------------------------------------------------- the plan of a problem


def plan(problem, chain: Chain, quiet: bool = True):
    """Plan ``problem`` with ``chain`` and verify the plan (the exact monitor): the memory
    budget checked first, then the chain; a plan that misses κ is planned again from other
    seeds (``next_choices``), an unconverged exact chain falls back to the ``nlp`` chain,
    and a mission no plan satisfied is proved infeasible and explained where it can be."""
    from stlc import deadline

    _check_budget(problem, chain.backends)
    if not quiet:
        print(f"{problem.mission.name}: chain `{chain.name}`"
              f"{' (forced)' if chain.forced else ''}: "
              + " → ".join(b.name for b in chain.backends), file=sys.stderr)
    sol = _run_verified(problem, chain)
    sol = _next_choices(problem, chain, sol, quiet)
    if _falls_back(chain, sol):
        sol = _fallback(problem, sol, quiet)
    elif _untimed(chain, sol):
        sol = _timing_free(problem, chain, sol, quiet)
    if sol.status not in ("satisfied", "infeasible") and not deadline.solve_expired():
        from stlc.backends.milp.conflict import explain_infeasible
        from stlc.planning.frame import to_local

        explain_infeasible(to_local(problem)[0], sol, quiet=quiet)  # proved in local numbers
    return sol


def _team_comparisons(sols: list) -> None:
    """A team plan is shown beside its seed ("MILP only", paper B Fig. 8), first; the
    refinement already added the standard plan of a ``compare`` variant (Fig. 11)."""
    from stlc.planning.solution import Comparison

    seed, final = sols[0], sols[-1]
    final.comparisons.insert(0, Comparison("MILP only", dict(seed.channels)))
    final.timing.update({k: v for k, v in seed.timing.items() if k in ("milp_s", "seed_s")})
    final.solver["seed"] = seed.solver.to_json()
    final.notes.extend(seed.solver.notes())


def _check_budget(problem, backends) -> None:
    """Before building: refuse (STL606) a trajectory NLP that cannot fit the memory
    budget (a chain with the CasADi NLP; the team chain plans on waypoints)."""
    from stlc.planning.budget import check_nlp

    if any(isinstance(b, registry()["casadi"]) for b in backends):
        check_nlp(problem, problem.mission.span)


def _run_verified(problem, chain):
    """Run ``chain`` on ``problem`` and judge its plan with the exact monitor; a watchdog cut
    (the run's time limit) gives the hover plan, judged the same way."""
    from stlc import deadline
    from stlc.backends.base import run_chain
    from stlc.planning.fallback import NoPlanFound, fallback, not_found
    from stlc.planning.frame import run_local
    from stlc.planning.verify import verify

    try:  # planned in a well-scaled local frame, mapped back (``stlc.planning.frame``)
        sol, sols = run_local(run_chain, problem, chain.backends)
    except deadline.TimeLimitReached:  # the watchdog cut a build or the guess
        deadline.caught()
        sol, sols = fallback(problem), []
    except NoPlanFound as e:  # a planner's own model: "no plan found", never "none exists"
        sol, sols = not_found(problem, e), []
    if len(sols) > 1 and sols[0].routes:
        _team_comparisons(sols)
    sol.solver.chain = chain_record(chain, sols)
    seed = next((s.solver.get("seed") for s in sols
                 if isinstance(s.solver.get("seed"), dict)), {})
    if seed.get("distances"):  # the MILP's polyhedral distances: their direction, stated
        sol.notes.append(seed["distances"])
    t0 = time.perf_counter()
    verify(problem, sol)
    sol.timing["verify_s"] = time.perf_counter() - t0
    return sol


NEXT_CHOICES = 2  #: further seeds tried when the NLP's plan from a MILP seed misses κ


def _next_choices(problem, chain, sol, quiet: bool):
    """The NLP planned from a MILP seed missed κ: plan again from other seeds — the local
    kinematic guess (the seed of the `kinematic` chain: a class the MILP's coarse, relaxed
    path did not choose), then the next-best discrete choice (the MILP seed with a no-good
    cut on its choices for the conjuncts the plan violates) — at most ``NEXT_CHOICES`` and
    within the time limit; the verified plan with the larger exact robustness is kept, and
    the record lists every try.  Any seed backend with ``next_seed`` (and its
    ``NEXT_LABEL``) takes part: a sweep's plan library gives this instance's own seed."""
    from stlc import deadline

    seed = chain.backends[0] if chain.backends else None
    if sol.status in ("satisfied", "infeasible") or not hasattr(seed, "next_seed"):
        return sol
    others = []
    if getattr(seed, "choices", None):  # the MILP chose the first path: the local guess
        others.append(("the kinematic guess", registry()["kinematic"]()))  # another class
    nxt = seed.next_seed(problem, sol.channels)
    if nxt is not None:
        others.append((seed.NEXT_LABEL, nxt))
    first = solve_cost(sol)
    tries = []
    for label, other_seed in others[:NEXT_CHOICES]:
        if sol.status == "satisfied" or deadline.solve_expired():
            break
        if not quiet:
            print(f"{problem.mission.name}: exact robustness {sol.robustness_exact:+.4f} < κ; "
                  f"planning again from {label}", file=sys.stderr)
        other = _run_verified(problem, Chain(chain.name, [other_seed, *chain.backends[1:]],
                                             chain.forced))
        tries.append({"seed": label, "exact": other.robustness_exact,
                      "status": str(other.status), **solve_cost(other)})
        a, b = sol.robustness_exact, other.robustness_exact
        if _better(b, a):
            other.notes.append(f"planned from {label}: the plan from the {seed.name} had "
                               f"exact robustness {a:.6g}")
            sol = other
    if tries:
        sol.solver.chain.next_choices = tries
        sol.solver.chain.first_try = first  # what the first seed's plan cost
    return sol


def solve_cost(sol) -> dict:
    """What planning ``sol`` cost: its IPOPT iterations and solve seconds."""
    return {"iterations": int(sol.solver.iterations or 0),
            "solve_s": float(sol.timing.get("solve_s", 0.0))}


def _better(b: float, a: float) -> bool:
    """Exact robustness ``b`` strictly beats ``a`` (NaN-safe: a NaN never wins, anything
    beats a NaN)."""
    return b == b and not (a == a and a >= b)


def _falls_back(chain, sol) -> bool:
    """An exact chain chosen by capability that stopped without a satisfying plan and
    without a proof of its optimum (a time limit, no incumbent) hands the problem to the
    general chain: a point-mass mission too large for the MILP's budget is still planned
    (locally) as before the exact backend existed.  Not once the run's time limit is out."""
    from stlc import deadline

    return (chain.name == "milp" and not chain.forced and sol.status != "satisfied"
            and not sol.solver.converged and not deadline.solve_expired())


def _untimed(chain, sol) -> bool:
    """The ``timed`` chain's plan missed κ: the ``nlp`` chain, which decides the times
    itself and tries further seeds, plans the mission again (not once the time limit is
    out)."""
    from stlc import deadline

    return (chain.name == "timed" and sol.status not in ("satisfied", "infeasible")
            and bool(sol.solver.get("seed_timing")) and not deadline.solve_expired())


def _timing_free(problem, timed, first, quiet: bool):
    """Plan ``problem`` with the ``nlp`` chain (and its further seeds) after the ``timed``
    chain's plan missed κ; the verified plan with the larger exact robustness is kept
    (ties: the first).  A plan that kept no timing already is the ``nlp`` chain's first
    plan: only the further seeds of its MILP seed follow."""
    if not first.solver.get("seed_timing", {}).get("kept", True):
        seed = timed.backends[0].seed
        if seed is None:
            return first
        nlp = Chain("nlp", [seed, registry()["casadi"](quiet=quiet)], timed.forced)
        return _next_choices(problem, nlp, first, quiet)
    chain = select(problem, "nlp", quiet)
    if not quiet:
        print(f"{problem.mission.name}: exact robustness {first.robustness_exact:+.4f} < κ "
              "from the `timed` chain; planning again with the times free: "
              + " → ".join(b.name for b in chain.backends), file=sys.stderr)
    sol = _next_choices(problem, chain, _run_verified(problem, chain), quiet)
    return _keep_better(first, sol, "planned with the times free: the `timed` chain's plan "
                        f"(the seed's timing kept) had exact robustness "
                        f"{first.robustness_exact:.6g}",
                        "the `nlp` chain, tried with the times free, found no better plan")


def _keep_better(first, sol, took: str, kept: str):
    """Of two verified plans, the one with the larger exact robustness (ties: ``first``),
    noted: ``took`` when ``sol`` wins, ``kept`` and its robustness when ``first`` stays;
    ``sol``'s record says which chain ran first."""
    sol.solver.chain.fallback_from = first.solver.chain
    if _better(sol.robustness_exact, first.robustness_exact):
        sol.notes.append(took)
        return sol
    first.notes.append(f"{kept} (exact robustness {sol.robustness_exact:.6g})")
    return first


def _fallback(problem, first, quiet: bool):
    """Plan ``problem`` with the ``nlp`` chain (on knots if long) after an unconverged exact
    chain; keep the verified plan with the larger exact robustness (ties: the exact chain's).
    Both plans are judged by the exact monitor; the record says what ran."""
    long = not registry()["knots"]().accepts(problem)  # no diagnostics: a long mission
    chain = select(problem, "knots" if long else "nlp", quiet)
    stopped = first.solver.return_status
    if not quiet:
        print(f"{problem.mission.name}: the exact MILP stopped without a satisfying plan "
              f"({stopped}); falling back to chain `{chain.name}`: "
              + " → ".join(b.name for b in chain.backends), file=sys.stderr)
    sol = _run_verified(problem, chain)
    return _keep_better(first, sol, f"the exact MILP stopped without a satisfying plan "
                        f"({stopped}); this plan is the `nlp` chain's (local, not a global "
                        f"optimum)", "the `nlp` chain, tried after the MILP stopped, found no "
                        "better plan")


# ------------------------------------------------- what the orderers ask of the planners


def replanner(kind: str):
    """The planner the simulation hands each replanning event: ``"segment"`` (the
    segment NLP's class, built once per vehicle), ``"takeover"`` (the backup drone's
    planner) or ``"move"`` (the operator move's replan of the rest of the mission)."""
    if kind == "move":
        from stlc.backends.replan.move import replan_rest

        return replan_rest
    if kind == "takeover":
        return registry()["takeover"]()
    return registry()[kind]


def warm_startable(chain: list) -> bool:
    """Does the chain end with the trajectory NLP, which a plan library can warm start?"""
    return bool(chain) and isinstance(_as_nlp(chain)[-1], registry()["casadi"])


def _as_nlp(chain: list) -> list:
    """The ``timed`` chain as the ``nlp`` chain it runs on (its seed and NLP): a
    neighbour's plan brings its own times, so a warm start plans with the formula as
    written."""
    if chain and isinstance(chain[-1], registry()["timed"]):
        return _instances("nlp", getattr(chain[-1], "quiet", True))
    return chain


def library_chain(chain: list, near) -> list:
    """The chain seeded from a library's plan ``near`` (values, label, channels ...)
    instead of its own seed, which stays the fallback."""
    from stlc.backends.nlp.library import LibrarySeed

    chain = _as_nlp(chain)
    return [LibrarySeed(*near, own=chain[0]), chain[-1]]


def plan_library():
    """A new, empty plan library (warm starts from the nearest solved instance)."""
    from stlc.backends.nlp.library import PlanLibrary

    return PlanLibrary()


def structure_key(problem) -> str:
    """What a built NLP depends on, except the values an instance sets."""
    from stlc.backends.nlp.cache import structure_key as key

    return key(problem)


def nlp_builds() -> int:
    """NLPs this process has built (a reused one is not counted)."""
    from stlc.backends.nlp import cache

    return int(cache.STATS["builds"])


def team_plan(sol):
    """A team solution's plan (routes, dwells, waypoints) for its per-drone writers."""
    from stlc.backends.team.backend import solution_plan

    return solution_plan(sol)
