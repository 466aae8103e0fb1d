"""The local frame: a planning problem far from the origin (a survey drone in UTM, easting
4.5e5 m, northing 5.4e6 m) is planned in well-scaled coordinates and mapped back.

Solver tolerances are absolute (HiGHS's 1e-9, IPOPT's 1e-8) and a float64 at 5.4e6 m
resolves 1e-9 m only barely: the NLP, the MILP seed, the exact MILP, its big-Ms and the
infeasibility proof all lose the mission's centimetres there.  ``to_local`` translates a
``PlanningProblem`` by a reference point ``o`` — the first vehicle's start, rounded to a
multiple of ``GRID`` (1 km), so a mission near the origin is its own local problem and a
mission moved by whole kilometres is planned *as the original* — and every backend of the
chain plans the translated problem: vehicle starts, start-state overrides, world-frame
boxes (workspace, obstacles, targets, stations; a ``placed`` box's centre parameters),
human poses and their parameters, fixed channels and seeds, and every position predicate
of the requirement and the named specs.  A predicate ``x − 450001.5`` becomes
``x' − 1.5``: the offset is folded into the predicate's constant (exact for the usual
decimal coordinates by Sterbenz's lemma), so the solvers see small numbers; an offset
that cannot be folded (inside a product or a function) is kept as ``x' + o`` — correct,
only not rescaled.  ``to_world`` maps a ``Solution``'s position channels back; the
verification pass then judges the plan in the mission's own coordinates.

Local coordinates are rounded to ``DIGITS`` decimals (10 nm): a decimal coordinate given
in UTM (``450000.3``) is not exactly ``450000 + 0.3`` in binary, and the 1e-11 m between
the two is enough to send a nonconvex NLP to another local optimum; rounded, the local
problem of a mission moved by whole kilometres is bit for bit the original's (for
coordinates given to 10 nm or coarser: a double near 1e7 m resolves 2e-9 m), so it gets
the original's plan.  10 nm is far below every tolerance, and the plan is verified in the
mission's own coordinates all the same.

Only translations: lengths keep their unit (a mission whose *extent* is huge is a
different problem, which scaling would not make easier for the dynamics).
"""

from __future__ import annotations

import copy
from dataclasses import dataclass, replace

import numpy as np

from stlc.semantics import ir, model

#: the reference point is the first vehicle's start rounded to a multiple of this (m)
GRID = 1000.0
#: local coordinates are rounded to this many decimals of a metre (10 nm)
DIGITS = 8
AXES = "xyz"


@dataclass(frozen=True)
class Frame:
    """World = local + ``origin`` (m, per axis)."""

    origin: tuple[float, float, float]

    @property
    def identity(self) -> bool:
        return not any(self.origin)

    def offset(self, name: str) -> float:
        """The world offset of a channel or parameter named ``<v>.pos.<axis>`` (0 for any
        other name: velocities, attitudes, forces are translation-free)."""
        head, _, axis = name.rpartition(".")
        if axis in AXES and head.endswith(".pos") and head.count(".") == 1:
            return self.origin[AXES.index(axis)]
        if axis in AXES and head.endswith(".center") and head.count(".") == 1:
            return self.origin[AXES.index(axis)]
        return 0.0


def frame_of(problem) -> Frame:
    """The local frame of ``problem``: its first vehicle's start position rounded to
    ``GRID`` (identity near the origin)."""
    if not problem.team:
        return Frame((0.0, 0.0, 0.0))
    v = problem.program.vehicles[problem.team[0]]
    pos = getattr(v, "start_pos", None)
    if problem.team[0] in problem.start_states:
        pos = np.asarray(problem.start_states[problem.team[0]], dtype=float)[:3]
    if pos is None:
        return Frame((0.0, 0.0, 0.0))
    o = tuple(float(GRID * round(float(p) / GRID)) if np.isfinite(p) else 0.0
              for p in pos)
    return Frame(o)  # type: ignore[arg-type]


# ------------------------------------------------------------------ expressions


def _shift_expr(e: ir.Expr, fr: Frame, memo: dict) -> tuple[ir.Expr, float]:
    """(e', c) with e = e' + c, where e' reads local positions; offsets are folded into a
    constant operand of ``+``/``−`` where there is one."""
    key = id(e)
    if key in memo:
        return memo[key][0]
    out: tuple[ir.Expr, float]
    match e:
        case ir.Sig(name) | ir.Param(name):
            out = (e, fr.offset(name))
        case ir.Const():
            out = (e, 0.0)
        case ir.Neg(a):
            a1, c = _shift_expr(a, fr, memo)
            out = (ir.Neg(a1), -c)
        case ir.Bin(op, left, right) if op in ("+", "-"):
            l1, a = _shift_expr(left, fr, memo)
            r1, b = _shift_expr(right, fr, memo)
            c = a + b if op == "+" else a - b
            if c != 0.0 and isinstance(r1, ir.Const):
                out = (ir.Bin(op, l1, ir.Const(_nm(r1.value + c if op == "+" else
                                                   r1.value - c))), 0.0)
            elif c != 0.0 and isinstance(l1, ir.Const):
                out = (ir.Bin(op, ir.Const(_nm(l1.value + c)), r1), 0.0)
            else:
                out = (ir.Bin(op, l1, r1), c)
        case ir.Bin(op, left, right):
            out = (ir.Bin(op, _whole(left, fr, memo), _whole(right, fr, memo)), 0.0)
        case ir.Call(fn, args):
            out = (ir.Call(fn, tuple(_whole(a, fr, memo) for a in args)), 0.0)
        case _:
            raise TypeError(f"not an expression node: {e!r}")
    memo[key] = (out, e)  # keep ``e`` alive: its id stays unique while memo lives
    return out


def _nm(x: float) -> float:
    """``x`` rounded to ``DIGITS`` decimals (module docstring)."""
    return round(float(x), DIGITS)


def _less(xs, o) -> tuple:
    """A point (or box corner) in local coordinates: ``xs − o``, to 10 nm."""
    return tuple(_nm(x - d) if d else x for x, d in zip(xs, o))


def _whole(e: ir.Expr, fr: Frame, memo: dict) -> ir.Expr:
    e1, c = _shift_expr(e, fr, memo)
    return e1 if c == 0.0 else ir.Bin("+", e1, ir.Const(c))


def shift_formula(f: ir.Formula, fr: Frame, memo: dict | None = None) -> ir.Formula:
    """``f`` reading local positions (every node kept, only predicates change)."""
    memo = {} if memo is None else memo

    def go(g: ir.Formula) -> ir.Formula:
        key = ("f", id(g))
        if key in memo:
            return memo[key][0]
        if isinstance(g, ir.Pred):
            b = g.bound
            if b is not None:
                d = fr.offset(b.signal)
                b = replace(b, value=_nm(b.value - d) if d else b.value,
                            expr=_whole(b.expr, fr, memo))
            out = replace(g, expr=_whole(g.expr, fr, memo), bound=b)
        else:
            out = ir.map_children(g, go)
        memo[key] = (out, g)
        return out

    return go(f)


# ------------------------------------------------------------------ the problem


def _box(b: model.Box, o) -> model.Box:
    if b.frame is not None:  # in a human's frame: moves with the human's (shifted) pose
        return b
    return replace(b, lo=_less(b.lo, o), hi=_less(b.hi, o))


def _program(p: model.Program, fr: Frame) -> model.Program:
    o = fr.origin
    vehicles = {n: (replace(v, start_pos=_less(v.start_pos, o))
                    if hasattr(v, "start_pos") else v) for n, v in p.vehicles.items()}
    sc = p.scenario
    scenario = replace(sc, regions=tuple(replace(r, box=_box(r.box, o)) for r in sc.regions),
                       humans=tuple(replace(h, pos=_less(h.pos, o)) for h in sc.humans))
    params = {k: _nm(v - fr.offset(k)) if fr.offset(k) else v for k, v in p.params.items()}
    memo: dict = {}
    specs = {k: shift_formula(f, fr, memo) for k, f in p.specs.items()}
    return replace(p, vehicles=vehicles, scenario=scenario, params=params, specs=specs)


def _channels(ch, fr: Frame, sign: float) -> dict:
    """Position channels moved by ``sign`` × the origin: into the frame (−1, to 10 nm) or
    back to the world (+1, not rounded)."""
    def move(k, v):
        x = np.asarray(v, dtype=float) + sign * fr.offset(k)
        return np.round(x, DIGITS) if sign < 0 else x

    return {k: (move(k, v) if fr.offset(k) else v) for k, v in ch.items()}


def _states(problem, fr: Frame) -> dict:
    out = {}
    for name, x in problem.start_states.items():
        x = np.array(x, dtype=float)
        x[:3] = _less(x[:3], fr.origin)  # every vehicle model's state starts with it
        out[name] = x
    return out


def to_local(problem) -> tuple[object, Frame]:
    """``(local problem, frame)``; the problem itself when the frame is the identity."""
    fr = frame_of(problem)
    if fr.identity:
        return problem, fr
    from stlc.planning.problem import frozen
    from stlc.semantics.specs import NamedSpec

    memo: dict = {}
    specs = {k: NamedSpec(s.name, shift_formula(s.formula, fr, memo),
                          shift_formula(s.normal, fr, memo), s.span)
             for k, s in problem.specs.items()}
    seed = problem.seed
    if seed is not None:
        seed = _solution(seed, fr, -1.0)
    local = replace(problem, program=_program(problem.program, fr),
                    requirement=shift_formula(problem.requirement, fr, memo),
                    specs=frozen(specs), start_states=frozen(_states(problem, fr)),
                    fixed_channels=frozen(_channels(problem.fixed_channels, fr, -1.0)),
                    seed=seed)
    return local, fr


def _solution(sol, fr: Frame, sign: float):
    out = copy.copy(sol)
    out.channels = _channels(sol.channels, fr, sign)
    out.solver_states = _channels(getattr(sol, "solver_states", {}) or {}, fr, sign)
    out.comparisons = [replace(c, channels=_channels(c.channels, fr, sign))
                       for c in sol.comparisons]
    return out


def to_world(sol, fr: Frame):
    """``sol`` (planned in the local frame ``fr``) in the mission's coordinates."""
    if fr.identity:
        return sol
    out = _solution(sol, fr, +1.0)
    out.notes = [*sol.notes, "planned in a local frame translated by ("
                 + ", ".join(f"{d:.15g}" for d in fr.origin) + ") m (well-scaled numbers for "
                 "the solvers); the plan and its verification are in the mission's "
                 "coordinates"]
    return out


def run_local(run, problem, *args):
    """``run(problem, *args) -> (sol, sols)`` (``stlc.backends.base.run_chain``) on the
    local problem, its solutions mapped back to the world."""
    local, fr = to_local(problem)
    sol, sols = run(local, *args)
    if fr.identity:
        return sol, sols
    world = {id(s): to_world(s, fr) for s in [sol, *sols]}
    return world[id(sol)], [world[id(s)] for s in sols]
