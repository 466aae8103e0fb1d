"""One instance of a checked program: the ``--set`` values that need no new check.

A human's pose, a vehicle's start and a placed region's centre (``stlc.semantics.overrides``
resolves the ``--set`` items; a const or a region's placement is applied to the AST and
checked there) are applied here to the *checked* program, so a later pass (the operator
move of ``stlc simulate``) can apply them without the parser or the checker.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

from stlc.semantics import model

__all__ = ["Setting", "apply_values"]


@dataclass(frozen=True, slots=True)
class Setting:
    """One ``--set``: the name as written, the value text, its SI value, and what it sets
    (``const`` | ``human`` | ``start`` | ``region``)."""

    name: str
    text: str
    value: float
    kind: str = ""


def _moved(d: model.Normal, delta: dict[str, float]) -> model.Normal:
    if not any(p in delta for p in d.params):
        return d
    return replace(d, mean=tuple(mu + delta.get(p, 0.0) for p, mu in zip(d.params, d.mean)))


def apply_values(program: model.Program, settings: list[Setting]) -> model.Program:
    """The checked program with the human poses, vehicle starts and region centres of
    ``settings`` (a region's centre is a parameter only once checked ``placed``)."""
    poses = {s.name: s.value for s in settings if s.kind == "human"}
    starts = {s.name: s.value for s in settings if s.kind == "start"}
    centres = {s.name: s.value for s in settings if s.kind == "region"}
    if not poses and not starts and not centres:
        return program
    delta = {k: v - program.params[k] for k, v in poses.items()}
    params = {**program.params, **poses, **centres}
    regions = []
    for r in program.scenario.regions:
        if r.box.placed is not None:  # the box moves by its centre's change, size kept
            d = [params[f"{r.name}.center.{a}"] - (r.box.lo[k] + r.box.hi[k]) / 2
                 for k, a in enumerate("xyz")]
            r = replace(r, box=replace(r.box, lo=tuple(x + e for x, e in zip(r.box.lo, d)),
                                       hi=tuple(x + e for x, e in zip(r.box.hi, d)),
                                       shape=r.box.shape and r.box.shape.moved(d)))
        regions.append(r)
    humans = []
    for h in program.scenario.humans:
        pos = tuple(params[f"{h.name}.pos.{a}"] for a in "xyz")
        att = tuple(params[f"{h.name}.att.{a}"] for a in "xyz")
        humans.append(replace(h, pos=pos, att=att,
                              uncertain=tuple(_moved(d, delta) for d in h.uncertain)))
    vehicles = dict(program.vehicles)
    for name, v in program.vehicles.items():
        new = {}
        for f in ("pos", "att"):
            key = f"{name}.start.{f}."
            if any(k.startswith(key) for k in starts):
                old = getattr(v, f"start_{f}")
                new[f"start_{f}"] = tuple(starts.get(key + a, old[i])
                                          for i, a in enumerate("xyz"))
        if new:
            vehicles[name] = replace(v, **new)
    missions = {}
    for name, m in program.missions.items():
        if m.risk is not None and delta:
            cases = tuple(replace(c, distributions=tuple(_moved(d, delta)
                                                         for d in c.distributions))
                          for c in m.risk.cases)
            m = replace(m, risk=replace(m.risk, cases=cases))
        missions[name] = m
    return replace(program, params=params, vehicles=vehicles, missions=missions,
                   scenario=replace(program.scenario, humans=tuple(humans),
                                    regions=tuple(regions)))
