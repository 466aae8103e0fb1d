"""Built NLPs reused across instances of one structure (``stlc sweep``, ``--set``).

The quantities ``--set`` changes without changing the structure — a human's pose (the
``Param`` leaves of formulas) and a vehicle's start state — are not constants of the NLP:
the pose is a vector of NLP parameters (``nlp.model.build`` appends them to ``p``) and the
start state is the bounds of the first sample's variables.  So one build serves every value,
and a plain ``stlc compile`` goes through the same path (``lowered``: a cache miss builds,
then ``bind`` sets the instance's values — also on the instance that was built).

The cache is per process (a Dask worker keeps it between tasks) and keyed by the
*structure*: the vehicles with their start states blanked, the planner form of the
problem's requirement (whose predicate scales could depend on parameter values: then the key
differs and the instance gets its own build), the problem's threshold, smoothing, objective,
end-state rule and iteration limit, the grid and the integrator.  ``STATS["builds"]``
counts the builds of this process.
"""

from __future__ import annotations

import hashlib
from collections import OrderedDict
from dataclasses import replace

from stlc.backends.nlp import choices
from stlc.planning.problem import PlanningProblem
from stlc.semantics import model

MAX_ENTRIES = 2  # distinct structures kept per process (each holds a built NLP)
_CACHE: OrderedDict[str, tuple] = OrderedDict()
STATS = {"builds": 0, "reused": 0}


def _blank_start(v: model.Vehicle) -> model.Vehicle:
    if hasattr(v, "start_att"):
        return replace(v, start_pos=(0.0, 0.0, 0.0), start_att=(0.0, 0.0, 0.0))
    return replace(v, start_pos=(0.0, 0.0, 0.0))


def structure_key(problem: PlanningProblem) -> str:
    """What the built NLP depends on, except the values ``bind`` sets."""
    from stlc.backends.nlp.expr import planner_form

    program, grid = problem.program, problem.grid
    planned = planner_form(problem.requirement, problem.threshold, program.params)
    parts = (tuple(repr(_blank_start(program.vehicles[n])) for n in problem.team),
             repr(planned), problem.threshold, problem.smoothing, problem.objective,
             problem.hold_end, problem.max_iter, grid.n, grid.dt,
             problem.integrator)
    return hashlib.sha256(repr(parts).encode()).hexdigest()


def bind(prob, inv, problem: PlanningProblem) -> None:
    """Set an instance's values into a built NLP: the scenario parameters (``inv.params``,
    the tail of ``p``), each vehicle's start state (bounds of its first sample: the
    problem's ``start_state``) and the vehicle objects the inverse maps read; the choice rows
    back to the formula as written."""
    program = problem.program
    inv.params = {k: float(program.params[k]) for k in inv.params}
    for L in inv.layouts:
        v = program.vehicles[L.vehicle.name]
        L.vehicle = v
        x0 = problem.start_state(v.name)
        start = L.x_slice.start
        prob.lbx[start:start + L.nx] = x0
        prob.ubx[start:start + L.nx] = x0
    if inv.choice_nodes:
        inv.choice_values = choices.written(inv.choice_nodes, inv.grid.n)


def lowered(problem: PlanningProblem, quiet: bool = True) -> tuple[object, object, bool]:
    """(NlpProblem, InverseData, built now?) for this instance, its values bound."""
    from stlc.backends.nlp import model as casadi_nlp

    key = structure_key(problem)
    hit = _CACHE.get(key)
    built = hit is None
    if built:
        hit = casadi_nlp.build(problem, quiet=quiet)
        STATS["builds"] += 1
        _CACHE[key] = hit
        while len(_CACHE) > MAX_ENTRIES:
            _CACHE.popitem(last=False)
    else:
        STATS["reused"] += 1
        _CACHE.move_to_end(key)
    prob, inv = hit
    prob.progress.quiet = quiet
    bind(prob, inv, problem)
    return prob, inv, built


def clear() -> None:
    _CACHE.clear()
