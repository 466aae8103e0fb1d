"""Checking a ``mission`` block: time grid (STL305 for a bad horizon or step), team, named
specs, requirement, objective, smoothing, dwell times of paper B's payload rule
(``install_time``, ``refill_time``), risk cases and replanning options.

Part of the checker (``stlc.semantics.check``): ``check_mission`` takes the checker ``Context``;
mission fields are evaluated in the mission's scope, so they may use its constants."""

from __future__ import annotations

import math

from stlc.diagnostics import Span, did_you_mean
from stlc.frontend import ast
from stlc.semantics import ir, model
from stlc.semantics.check import units
from stlc.semantics.check.context import Context, misaligned_intervals, nearest_hint
from stlc.semantics.check.values import GroupV, StrV, VehicleV
from stlc.semantics.timegrid import is_aligned

MISSION_FIELDS = {
    "vehicles": False, "team": False, "vehicle": False, "horizon": True, "step": True,
    "threshold": False, "smoothing": False, "lambda": False, "forward_speed": False,
    "integrator": False, "max_iter": False, "install_time": False, "refill_time": False,
    "backend": False,
    "time_limit": False, "end": False, "margin": False,
}
MISSION_BLOCKS = ("risk", "replan", "compare", "simulate")
MAX_SAMPLES = 20_000
MAX_COUNT = 10**9  # sample counts, iteration limits
MAX_SEED = 2**63 - 1
MAX_K = 10**6  # risk realisations (1,000,000 run, also across Dask workers); the
#: risk pass works in chunks bounded by the trace length, so memory stays bounded
OBJECTIVE_TERMS = ("robustness", "energy", "forward_cost")


def check_mission(ck: Context, b: ast.Block, top_specs: dict[str, ir.Formula]
                  ) -> model.Mission | None:
    name = b.name or "mission"
    if not ck.define(name, b.name_span, "mission"):
        return None
    f = ck.fields(b, MISSION_FIELDS, sub_blocks=MISSION_BLOCKS, named_kinds=("spec", "const"))
    for m in b.members:
        if isinstance(m, ast.Named) and m.kind not in ("spec", "const"):
            ck.bad_kind(m.kind, m.span, ("spec", "const"), "in a mission")
        elif isinstance(m, ast.Block) and m.kind not in MISSION_BLOCKS:
            ck.bad_kind(m.kind, m.span, MISSION_BLOCKS, "in a mission")
        elif isinstance(m, (ast.Signals, ast.Uncertain)):
            ck.d.error("STL108", "not allowed in a mission", m.span,
                       "declare signals at the top level and uncertainty in the scenario")
    scope = ck.globals.child({})
    ck.consts([m for m in b.members if isinstance(m, ast.Named) and m.kind == "const"], scope)

    # time grid
    horizon = _grid_time(ck, f, "horizon", scope)
    step = _grid_time(ck, f, "step", scope)
    if horizon is not None and step is not None:
        if horizon / step > MAX_SAMPLES:  # first: a tiny step overflows the alignment test
            ck.d.error("STL305", f"{horizon / step:.3g} samples is more than the limit "
                       f"{MAX_SAMPLES}", f["step"].value.span,
                       f"use a larger step, at least {horizon / MAX_SAMPLES:.3g} s")
            horizon = step = None
        elif not is_aligned(horizon, step):
            # the root cause: one error naming both; the time bounds are not checked
            # against a step that is wrong anyway (they were, one error each, before)
            good = [s for s in (1, 0.5, 0.25, 0.2, 0.1, 0.05, 0.02, 0.01)
                    if is_aligned(horizon, s)]
            near = sorted(good, key=lambda s: abs(s - step))[:2]
            ck.d.error("STL305", f"the step {step:g} s does not divide the horizon "
                       f"{horizon:g} s ({horizon / step:.4g} steps), so no time bound of "
                       f"mission `{name}` was checked against it", f["step"].value.span,
                       (f"use a step that divides {horizon:g} s and your time bounds, e.g. "
                        + " or ".join(f"{s:g} s" for s in near)) if near else
                       "make the horizon a multiple of the step")
            horizon = step = None

    vehicles = _team(ck, b, f)
    scope.names["team"] = GroupV("vehicle", tuple(VehicleV(ck.vehicles[v]) for v in vehicles))

    # named specs, requirement
    specs_members = [m for m in b.members if isinstance(m, ast.Named) and m.kind == "spec"]
    specs, spans = ck.named_specs(specs_members, scope, step)
    all_specs = {**top_specs, **specs}
    reqs = [m for m in b.members if isinstance(m, ast.Require)]
    requirement = None
    if not reqs:
        ck.d.error("STL104", f"mission `{name}` has no `require`", b.name_span,
                   "add `require <formula>` naming what the plan must satisfy")
    for extra in reqs[1:]:
        ck.d.error("STL102", "a mission has one `require`", extra.span,
                   "combine the requirements with `and`")
    if reqs:
        ck.step = step
        requirement = ck.formula(reqs[0].value, scope)
        ck.step = None
    if step is not None:
        _check_inlined_steps(ck, b, name, step, [requirement, *specs.values()])
    if requirement is not None and horizon is not None and step is not None:
        reach = ir.horizon(requirement, step)
        if reach > horizon + 1e-9:
            ck.d.error("STL304", f"the requirement looks {reach:g} s ahead but the mission "
                       f"horizon is {horizon:g} s", reqs[0].value.span,
                       "shorten the time bounds or lengthen the horizon")
        _check_team_refs(ck, requirement, vehicles, reqs[0].value.span, name)
    for sname, sf in specs.items():
        if horizon is not None and step is not None and ir.horizon(sf, step) > horizon + 1e-9:
            ck.d.error("STL304", f"spec `{sname}` looks {ir.horizon(sf, step):g} s ahead but "
                       f"the mission horizon is {horizon:g} s", spans[sname])

    objective = _objective(ck, b, scope)
    smoothing = _smoothing(ck, f, scope)
    threshold = ck.num(f, "threshold", None, 0.0, scope=scope)
    if threshold is not None and not (math.isfinite(threshold) and threshold >= 0):
        # κ < 0 would certify violated plans (ρ = -1 reported `satisfied`)
        ck.d.error("STL207", f"`threshold` must be a finite number >= 0, found {threshold:g}",
                   f["threshold"].value.span, "the threshold κ is the margin a plan must "
                   "keep: 0 means \"satisfied\", more means robustly satisfied")
        threshold = None
    fwd = ck.num(f, "forward_speed", units.SPEED, positive=True, scope=scope)
    dwell = {k: _dwell(ck, f, k, horizon, scope) for k in ("install_time", "refill_time")}
    if objective is not None and fwd is not None:
        objective = model.Objective(objective.robustness_weight, objective.energy_weight,
                                    objective.forward_weight, fwd)
    options: dict = {}
    if "integrator" in f:
        v = f["integrator"].value
        txt = v.parts[0] if isinstance(v, ast.Path) else getattr(v, "value", "")
        if txt not in ("rk4", "euler"):
            ck.d.error("STL207", "`integrator` is `rk4` or `euler`", v.span)
        options["integrator"] = txt
    if "backend" in f:  # a chain or backend name; checked against the registry when planned
        v = f["backend"].value
        txt = v.parts[0] if isinstance(v, ast.Path) else getattr(v, "value", "")
        if not isinstance(txt, str) or not txt:
            ck.d.error("STL207", "`backend` is a backend name, e.g. `milp` or `nlp`", v.span)
        else:
            options["backend"], options["backend_span"] = txt, v.span
    if "end" in f:  # the plan's end state: `hover` (holdable, the default) or `free`
        v = f["end"].value
        txt = v.parts[0] if isinstance(v, ast.Path) else getattr(v, "value", "")
        if txt not in ("hover", "free"):
            ck.d.error("STL207", "`end` is `hover` (the last sample can be held, the "
                       "default) or `free`", v.span)
        options["end"] = txt
    if "max_iter" in f:
        mi = _whole(ck, f["max_iter"].value, "max_iter", 1, MAX_COUNT, scope)
        if mi is not None:
            options["max_iter"] = mi
    time_limit = ck.num(f, "time_limit", units.TIME, positive=True, scope=scope)
    if time_limit is not None:  # `--time-limit` overrides it (stlc.deadline)
        options["time_limit"] = time_limit
    compares = [m for m in b.members if isinstance(m, ast.Block) and m.kind == "compare"]
    options["compare"] = [(c.name or f"variant{i + 1}", _objective(ck, c, scope))
                          for i, c in enumerate(compares)]
    risk = _risk(ck, b)
    replan = _replan(ck, b, all_specs, step)
    if None in (horizon, step, requirement, objective, smoothing, threshold):
        return None
    return model.Mission(
        name=name, vehicles=tuple(vehicles), horizon=horizon, step=step,  # type: ignore
        specs=specs, requirement=requirement, objective=objective,  # type: ignore
        threshold=threshold, smoothing=smoothing, risk=risk, replan=replan,  # type: ignore
        options=options, span=b.span, spec_spans=spans,
        install_time=dwell["install_time"], refill_time=dwell["refill_time"],
        team_form=ck.team_form(vehicles, requirement, specs))


def _grid_time(ck: Context, f: dict, key: str, scope) -> float | None:
    """``horizon`` or ``step``: a positive, finite time (STL305 otherwise)."""
    m = f.get(key)
    if m is None:
        return None
    x = ck.number(m.value, scope, units.TIME, f"`{key}`")
    if x is not None and not (math.isfinite(x) and x > 0):
        ck.d.error("STL305", f"`{key}` must be a positive, finite time, found {x:g} s",
                   m.value.span, "e.g. `horizon = 20 s` and `step = 0.1 s`")
        return None
    return x


def _dwell(ck: Context, f: dict, key: str, horizon: float | None, scope) -> float | None:
    """``install_time`` / ``refill_time`` (paper B's payload rule): a time in (0, horizon],
    or None if it is absent or wrong (reported; the pass then fails)."""
    x = ck.num(f, key, units.TIME, positive=True, scope=scope)
    if x is not None and horizon is not None and x > horizon * (1 + 1e-12):
        ck.d.error("STL207", f"`{key}` {x:g} s is longer than the mission horizon "
                   f"{horizon:g} s", f[key].value.span, "shorten it or lengthen the horizon")
        return None
    return x


def _whole(ck: Context, node: ast.Node, what: str, lo: int, hi: int, scope=None
           ) -> int | None:
    """A whole number in [lo, hi] (finite: ``int()`` of inf or nan would crash)."""
    x = ck.number(node, scope or ck.globals, units.DIMLESS, f"`{what}`")
    if x is None:
        return None
    if not (math.isfinite(x) and x == round(x) and lo <= x <= hi):
        ck.d.error("STL207", f"`{what}` must be a whole number from {lo} to {hi:.3g}, "
                   f"found {x:g}", node.span)
        return None
    return int(x)


def _check_inlined_steps(ck: Context, b: ast.Block, name: str, step: float,
                         formulas: list[ir.Formula | None]) -> None:
    """Time bounds written in the mission are checked against its step as they are
    elaborated; a top-level spec used here was elaborated without a step, so its intervals
    are checked on the IR, once each, where the spec wrote them."""
    inside = b.span
    done: set[Span] = set()
    for f in formulas:
        if f is None:
            continue
        for node, t in misaligned_intervals(f, step):
            sp = node.span
            if not sp.known or sp in done or _contains(inside, sp):
                continue
            done.add(sp)
            ck.d.error("STL303", f"time bound {t:g} s is not a multiple of the step {step:g} s "
                       f"of mission `{name}`, which uses this formula", sp,
                       nearest_hint(t, step) or f"use multiples of {step:g} s")


def _contains(outer: Span, inner: Span) -> bool:
    return (outer.file == inner.file and (outer.line, outer.col) <= (inner.line, inner.col)
            and (inner.end_line, inner.end_col) <= (outer.end_line, outer.end_col))


def _team(ck: Context, b: ast.Block, f: dict) -> list[str]:
    keys = [k for k in ("vehicles", "team", "vehicle") if k in f]
    if len(keys) > 1:
        ck.d.error("STL102", "give the mission's vehicles once", f[keys[1]].span)
    if not keys:  # the only declared vehicle by default; with several, say which (STL104)
        if len(ck.vehicles) > 1:
            names = ", ".join(ck.vehicles)
            ck.d.error("STL104", f"mission `{b.name or 'mission'}` does not say which vehicles "
                       f"it plans, and the file declares {len(ck.vehicles)}: {names}",
                       b.name_span if b.name_span.line else b.span,
                       f"add `vehicles = [{names}]` to the mission, without the ones it does "
                       "not mean (a backup drone stays out of the list)")
        return list(ck.vehicles)
    node = f[keys[0]].value
    items = node.items if isinstance(node, ast.List) else (node,)
    out = []
    for it in items:
        if isinstance(it, ast.Path) and len(it.parts) == 1 and it.parts[0] in ck.failed:
            continue  # its declaration is already reported
        if isinstance(it, ast.Path) and len(it.parts) == 1 and it.parts[0] in ck.vehicles:
            if it.parts[0] in out:
                ck.d.error("STL102", f"`{it.parts[0]}` is listed twice", it.span)
            out.append(it.parts[0])
        else:
            txt = it.parts[0] if isinstance(it, ast.Path) else "?"
            ck.d.error("STL101", f"unknown vehicle `{txt}`", it.span,
                       did_you_mean(txt, ck.vehicles) or
                       ("vehicles: " + ", ".join(ck.vehicles) if ck.vehicles else
                        "declare it with `vehicle NAME : multirotor { ... }`"))
    return out


def _check_team_refs(ck: Context, f: ir.Formula, team: list[str], span: Span, name: str):
    used = {s.split(".")[0] for s in ir.signals(f)}
    for v in sorted(used & set(ck.vehicles) - set(team)):
        ck.d.error("STL101", f"vehicle `{v}` is not part of mission `{name}`", span,
                   f"add it: `vehicles = [{', '.join(team + [v])}]`")


def _objective(ck: Context, b: ast.Block, scope) -> model.Objective | None:
    objs = [m for m in b.members if isinstance(m, ast.Objective)]
    if not objs:
        return model.Objective()
    for extra in objs[1:]:
        ck.d.error("STL102", "a mission has one objective", extra.span,
                   "add the terms into one `minimize` expression")
    o = objs[0]
    terms = _linear(ck, o.value, scope)
    if terms is None:
        return None
    sign = 1.0 if o.sense == "minimize" else -1.0
    w = {k: sign * v for k, v in terms.items()}
    if -w.get("robustness", 0.0) < 0:
        ck.d.error("STL207", "the objective must reward robustness, not penalise it", o.span,
                   "write `minimize w * energy - robustness`")
        return None
    return model.Objective(robustness_weight=-w.get("robustness", 0.0),
                           energy_weight=w.get("energy", 0.0),
                           forward_weight=w.get("forward_cost", 0.0))


def _linear(ck: Context, n: ast.Node, scope) -> dict[str, float] | None:
    """A linear combination of objective terms with constant weights."""
    match n:
        case ast.Path(parts) if len(parts) == 1 and parts[0] in OBJECTIVE_TERMS:
            return {parts[0]: 1.0}
        case ast.Binary(op, left, right) if op in "+-":
            a, b = _linear(ck, left, scope), _linear(ck, right, scope)
            if a is None or b is None:
                return None
            s = 1.0 if op == "+" else -1.0
            out = dict(a)
            for k, v in b.items():
                out[k] = out.get(k, 0.0) + s * v
            return out
        case ast.Binary("*", left, right):
            for c, t in ((left, right), (right, left)):
                if not _mentions_term(c):
                    k = ck.number(c, scope, None, "an objective weight")
                    if k is not None and not ck.finite(k, "an objective weight", c.span):
                        return None
                    terms = _linear(ck, t, scope)
                    if k is None or terms is None:
                        return None
                    return {name: k * v for name, v in terms.items()}
        case ast.Unary(op, arg):
            t = _linear(ck, arg, scope)
            return None if t is None else {k: (-v if op == "-" else v) for k, v in t.items()}
        case ast.Path(parts):
            ck.d.error("STL101", f"unknown objective term `{'.'.join(parts)}`", n.span,
                       did_you_mean(parts[0], OBJECTIVE_TERMS) or
                       "terms: " + ", ".join(OBJECTIVE_TERMS))
            return None
    ck.d.error("STL207", "the objective is a weighted sum of robustness, energy and "
               "forward_cost", n.span, "e.g. `minimize 0.5 * energy - robustness`")
    return None


def _mentions_term(n: ast.Node) -> bool:
    if isinstance(n, ast.Path):
        return n.parts[0] in OBJECTIVE_TERMS
    return any(_mentions_term(c) for c in ast.node_children(n))


def _smoothing(ck: Context, f: dict, scope) -> model.Smoothing | None:
    method = "gkl"
    if "smoothing" in f:
        node = f["smoothing"].value
        v = ck.value(node, scope) if not isinstance(node, ast.Path) else None
        txt = node.parts[0] if isinstance(node, ast.Path) else (v.s if isinstance(v, StrV)
                                                                else "")
        if txt not in ("gkl", "lse"):
            ck.d.error("STL207", f"unknown smoothing `{txt}`", node.span,
                       "`gkl` (Gilpin–Kurtz–Lin, sound) or `lse` (log-sum-exp)")
            method = None
        else:
            method = txt
    lam = ck.num(f, "lambda", units.DIMLESS, 10.0, positive=True, scope=scope)  # checked either way
    return None if lam is None or method is None else model.Smoothing(method, lam)


def _in_unit(ck: Context, node: ast.Node, lo: float, hi: float, what: str) -> float | None:
    x = ck.number(node, ck.globals, units.DIMLESS, f"`{what}`")
    if x is not None and not lo < x < hi:
        ck.d.error("STL207", f"{what} must be in ({lo:g}, {hi:g}), found {x:g}", node.span)
        return None
    return x


def _risk(ck: Context, b: ast.Block) -> model.RiskConfig | None:
    blocks = [m for m in b.members if isinstance(m, ast.Block) and m.kind == "risk"]
    if not blocks:
        return None
    rb = blocks[0]  # a second one is reported by check_mission (`_fields`)
    f = ck.fields(rb, {"K": False, "delta": False, "beta": False, "seed": False})
    K, delta, seed, betas = 15000, 0.01, 0, (0.7, 0.8, 0.9)
    if "K" in f:
        K = _whole(ck, f["K"].value, "K", 1, MAX_K) or K
    if "delta" in f:
        delta = _in_unit(ck, f["delta"].value, 0, 1, "delta") or delta
    if "seed" in f:
        x = _whole(ck, f["seed"].value, "seed", 0, MAX_SEED)
        seed = seed if x is None else x
    if "beta" in f:
        node = f["beta"].value
        items = node.items if isinstance(node, ast.List) else (node,)
        vals = [_in_unit(ck, it, 0, 1, "beta") for it in items]
        if all(v is not None for v in vals) and vals:
            betas = tuple(vals)  # type: ignore[assignment]
    cases = []
    names: set[str] = set()
    for m in rb.members:
        if isinstance(m, ast.Block) and m.kind == "case":
            cname = m.name or f"case{len(cases) + 1}"
            if cname in names:
                ck.d.error("STL102", f"risk case `{cname}` is defined twice", m.name_span)
                continue
            names.add(cname)
            dists = []
            for cm in m.members:
                if isinstance(cm, ast.Uncertain):
                    d = ck.uncertain(cm, None, attach=False)
                    if d is not None:
                        dists.append(d)
                else:
                    ck.d.error("STL108", "a risk case holds `human.pos ~ normal(...)` lines",
                               cm.span)
            cases.append(model.RiskCase(cname, tuple(dists), m.span))
        elif isinstance(m, ast.Block):
            ck.bad_kind(m.kind, m.span, ("case",), "in a risk block")
    if not cases:
        base = tuple(d for h in ck.humans.values() for d in h.uncertain)
        if not base:
            ck.d.error("STL104", "a `risk` block needs a `case` or an uncertain human pose",
                       rb.span, "add `case NAME { operator.pos ~ normal(mean, cov) }`")
        cases.append(model.RiskCase("nominal", (), rb.span))
    return model.RiskConfig(tuple(cases), K, tuple(betas), delta, seed)


def _replan(ck: Context, b: ast.Block, specs: dict, step: float | None = None
            ) -> model.ReplanConfig | None:
    blocks = [m for m in b.members if isinstance(m, ast.Block) and m.kind == "replan"]
    if not blocks:
        return None
    f = ck.fields(blocks[0], {"threshold": False, "event_period": False,
                              "waypoint_period": False, "budget": False, "keep": False,
                              "takeover_delay": False})
    thr = ck.num(f, "threshold", units.LENGTH, 1.0, positive=True)
    te = ck.num(f, "event_period", units.TIME, 0.5, positive=True)
    tg = ck.num(f, "waypoint_period", units.TIME, 1.0, positive=True)
    tc = ck.num(f, "budget", units.TIME, 0.4, positive=True)
    trep = ck.num(f, "takeover_delay", units.TIME, 10.0)
    for key, x in (("event_period", te), ("waypoint_period", tg)):
        if x is not None and step is not None and x < step * (1 - 1e-9):
            ck.d.error("STL207", f"`{key}` {x:g} s is shorter than the mission step "
                       f"{step:g} s", f[key].value.span,
                       f"use at least one step, e.g. `{key} = {step:g} s`")
    if trep is not None and trep < 0:
        ck.d.error("STL207", "`takeover_delay` must not be negative",
                   f["takeover_delay"].value.span)
        trep = None
    keep: list[str] = []
    if "keep" in f:
        node = f["keep"].value
        for it in (node.items if isinstance(node, ast.List) else (node,)):
            txt = it.parts[0] if isinstance(it, ast.Path) else "?"
            if txt not in specs:
                ck.d.error("STL101", f"unknown spec `{txt}`", it.span,
                           did_you_mean(txt, specs))
            else:
                keep.append(txt)
    if None in (thr, te, tg, tc, trep):
        return None
    return model.ReplanConfig(thr, te, tg, tc, tuple(keep), trep,  # type: ignore[arg-type]
                              frozenset(f))


