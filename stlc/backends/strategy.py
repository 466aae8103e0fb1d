"""Choosing the backend chain of a problem from the registry, by capabilities.

``CHAINS`` names the chains (each a tuple of registry names, seed first) in the order they
are tried; the first chain whose every backend accepts the problem (``Backend.accepts``:
vehicle models — "linear dynamics only" —, formula nodes, functions, planned signals, and
``needs_signals``: a team chain plans only missions that read a payload) plans it:

* ``team``: task-assignment MILP → waypoint refinement (missions with payloads, paper B);
* ``milp``: a coarse-grid MILP start (``milp_start``) → the exact STL→MILP backend (linear
  vehicles, predicates linear in the state; integer variables decide every disjunction
  globally);
* ``nlp``: MILP seed (the discrete choices of a double-integrator abstraction, chosen
  globally; ``milp_seed``) → the full-dynamics smooth-robustness NLP (anything else);
  ``kinematic`` forces the local kinematic guess as the seed instead.

A forced name (``--backend NAME`` or the mission's ``backend = NAME``) is a chain name or a
registry name (the chain that ends with it); a forced chain that cannot plan the problem
reports its STL401 diagnostics, as every chain does before any work.
"""

from __future__ import annotations

from dataclasses import dataclass

from stlc.backends.registry import registry
from stlc.diagnostics import Diagnostic, Span, StlcError, did_you_mean

CHAINS: dict[str, tuple[str, ...]] = {
    "team": ("team-milp", "team-refine"),
    "milp": ("milp-start", "milp"),
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


def chain_record(chain: Chain, sols: list) -> dict:
    """What ``solution.json`` and the report say about the chain: its name, whether it was
    forced, and each stage's backend and status."""
    stages = []
    for b, s in zip(chain.backends, sols):
        st = s.solver.get("return_status", s.solver.get("status", ""))
        stage = {"backend": b.name, "status": str(st),
                 "converged": bool(s.solver.get("converged", str(st) in
                                                ("optimal", "acceptable")))}
        if "seed" in s.solver:  # the MILP seed's record: grid, phases, time, ρ̂
            stage["seed"] = s.solver["seed"]
        stages.append(stage)
    for b in chain.backends[len(sols):]:  # after a proof of infeasibility
        stages.append({"backend": b.name, "status": "not_run", "converged": False})
    return {"name": chain.name, "forced": chain.forced, "stages": stages}
