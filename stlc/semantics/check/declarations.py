"""Declarations: vehicles (multirotor and point-mass models with their start state), the
scenario (workspace, named regions, humans with their frame-attached regions and uncertain
poses) and the binding of all of them as names for formulas.

Part of the checker (``stlc.semantics.check``): every function takes the checker ``Context`` and
records what it declares there (``ctx.vehicles``, ``ctx.regions``, ``ctx.humans``, ...).
"""

from __future__ import annotations

import math

import numpy as np

from stlc import vehicles
from stlc.diagnostics import Span, did_you_mean
from stlc.frontend import ast
from stlc.semantics import model
from stlc.semantics.check import units
from stlc.semantics.check.context import Context, Scope
from stlc.semantics.check.values import (
    DistV,
    ErrorV,
    GroupV,
    HumanV,
    Num,
    RegionV,
    RotorsV,
    VehicleV,
)

#: payloads a drone carries at once (the payload rule stores counts as int64; a team
#: with more than a thousand per drone is a typo)
MAX_CAPACITY = 1000
REGION_KINDS = ("obstacle", "region", "target", "station", "home")
GROUP_NAMES = {"obstacles": "obstacle", "regions": "region", "targets": "target",
               "stations": "station", "homes": "home"}


# ---------------------------------------------------------------- vehicles


def vehicle(ck: Context, b: ast.Block) -> None:
    name = b.name or "?"
    if not ck.define(name, b.name_span, "vehicle"):
        return
    ck.failed.add(name)  # until it checks
    reader = READERS.get(b.model or "")
    if reader is not None:
        v = reader(ck, b)
    else:
        hint = did_you_mean(b.model or "", vehicles.kinds()) or \
            "models: " + ", ".join(vehicles.kinds())
        if b.model == "motion_primitive":  # paper B's term: its drones are point masses
            hint = ("paper B's drones are `point_mass` vehicles; the team planner builds "
                    "their rest-to-rest motion primitives")
        ck.d.error("STL105", f"unknown vehicle model `{b.model}`", b.span, hint)
        return
    if v is not None:
        ck.vehicles[name] = v
        ck.failed.discard(name)


def _start(ck: Context, b: ast.Block, keys: dict[str, units.Dim]) -> dict[str, tuple]:
    starts = [m for m in b.members if isinstance(m, ast.Block) and m.kind == "start"]
    if not starts:
        ck.d.error("STL104", f"vehicle `{b.name}` has no `start {{ pos = ... }}` block",
                   b.name_span, "add `start { pos = (x, y, z) m }`")
        return {}
    f = ck.fields(starts[0], {k: k == "pos" for k in keys})
    return {k: ck.vec(f, k, 3, dim) for k, dim in keys.items() if k in f}


def _multirotor(ck: Context, b: ast.Block) -> model.Multirotor | None:
    f = ck.fields(b, {"mass": True, "inertia": True, "c_f": True, "c_tau": True,
                      "force": True, "rotors": False, "dforce_max": False,
                      "gravity": False, "radius": False, "vel_max": False},
                  sub_blocks=("start", "rotor"))
    mass = ck.num(f, "mass", units.MASS, positive=True)
    c_f = ck.num(f, "c_f", None, positive=True)
    c_tau = ck.num(f, "c_tau", None, positive=True)
    dfmax = ck.num(f, "dforce_max", (1, 1, -3, 0), positive=True)
    gravity = ck.num(f, "gravity", units.ACCEL, 9.81, positive=True)
    vmax = ck.vec(f, "vel_max", 3, units.SPEED) if "vel_max" in f else None
    if vmax is not None and min(vmax) <= 0:
        ck.d.error("STL207", "`vel_max` must be positive", f["vel_max"].value.span)
        vmax = None
    inertia = None
    if "inertia" in f:
        node = f["inertia"].value
        v = ck.value(node, ck.globals)
        if isinstance(v, Num) and units.compatible(v.dim, units.INERTIA):
            arr = np.asarray(v.v, dtype=float)
            if arr.shape == (3,):
                arr = np.diag(arr)
            if not ck.finite(arr, "inertia", node.span):
                pass
            elif arr.shape != (3, 3):
                ck.d.error("STL205", "inertia must be 3 numbers or a 3x3 matrix",
                           node.span, "e.g. diag(0.0207, 0.0210, 0.0310) kg*m^2")
            elif not np.allclose(arr, arr.T) or np.linalg.eigvalsh(arr).min() <= 0:
                ck.d.error("STL207", "inertia must be symmetric positive definite",
                           node.span)
            else:
                inertia = tuple(tuple(float(x) for x in row) for row in arr)
        elif isinstance(v, Num):
            ck.d.error("STL204", "unit mismatch: inertia must be "
                       f"{units.describe(units.INERTIA)}, found {units.describe(v.dim)}",
                       node.span, "write it in kg*m^2")
        elif not isinstance(v, ErrorV):
            ck.d.error("STL210", "inertia must be constant numbers", node.span)
    fmin = fmax = None
    if "force" in f:
        node = f["force"].value
        arr = ck.vector(node, ck.globals, 2, units.FORCE, "the rotor force range")
        if arr is not None:
            fmin, fmax = float(arr[0]), float(arr[1])
            if not 0 <= fmin < fmax < math.inf:
                ck.d.error("STL207", "rotor force range must be 0 <= min < max (finite)",
                           node.span)
                fmin = fmax = None
    rotors = _rotors(ck, b, f)
    start = _start(ck, b, {"pos": units.LENGTH, "att": units.ANGLE, "vel": units.SPEED,
                           "rate": (0, 0, -1, 1)})
    vals = (mass, c_f, c_tau, fmin, fmax, inertia, rotors, start.get("pos"))
    if any(x is None for x in vals):
        return None
    v = model.Multirotor(
        name=b.name, mass=mass, inertia=inertia, c_f=c_f, c_tau=c_tau,  # type: ignore
        force_min=fmin, force_max=fmax, rotors=rotors, start_pos=start["pos"],  # type: ignore
        start_att=start.get("att") or (0.0, 0.0, 0.0),
        start_vel=start.get("vel") or (0.0, 0.0, 0.0),
        start_rate=start.get("rate") or (0.0, 0.0, 0.0),
        dforce_max=dfmax, gravity=gravity, span=b.span, radius=_radius(ck, f),
        vel_max=None if vmax is None else tuple(float(x) for x in vmax))  # type: ignore
    _check_hover(ck, v, b)
    return v


def _check_hover(ck: Context, v: model.Multirotor, b: ast.Block) -> None:
    from stlc.vehicles import dynamics

    try:
        dynamics.hover_forces(v, check_bounds=True)
    except Exception as e:  # noqa: BLE001 - any failure here is a modelling error
        why = str(e).removeprefix(f"{v.name} ")
        if not why.startswith("cannot hover"):
            why = f"cannot hover: {why}"
        ck.d.error("STL402", f"vehicle `{v.name}` {why}", b.name_span,
                   "check mass, rotor geometry and the force range")


def _rotors(ck: Context, b: ast.Block, f: dict) -> tuple[model.Rotor, ...] | None:
    blocks = [m for m in b.members if isinstance(m, ast.Block) and m.kind == "rotor"]
    if "rotors" in f and blocks:
        ck.d.error("STL102", "give either `rotors = ...` or `rotor` blocks, not both",
                   f["rotors"].span)
        return None
    if "rotors" in f:
        node = f["rotors"].value
        v = ck.value(node, ck.globals)
        if isinstance(v, RotorsV):
            return v.rotors
        if not isinstance(v, ErrorV):
            ck.d.error("STL210", "`rotors` must be hexarotor(...), quadrotor(...) or "
                       "a list of `rotor { }` blocks", node.span)
        return None
    if not blocks:
        ck.d.error("STL104", f"vehicle `{b.name}` has no rotors", b.name_span,
                   "add `rotors = hexarotor(arm = 0.39 m, tilt = 20 deg)`")
        return None
    out = []
    for rb in blocks:
        rf = ck.fields(rb, {"position": True, "axis": False, "spin": True})
        pos = ck.vec(rf, "position", 3, units.LENGTH)
        axis = ck.vec(rf, "axis", 3, units.DIMLESS, (0.0, 0.0, 1.0))
        spin = None
        if "spin" in rf:
            node = rf["spin"].value
            txt = node.parts[0] if isinstance(node, ast.Path) else None
            spin = {"ccw": 1, "cw": -1}.get(txt or "")
            if spin is None:
                ck.d.error("STL207", "`spin` is `ccw` or `cw`", node.span)
        if pos is None or axis is None or spin is None:
            return None
        a = np.array(axis)
        if np.linalg.norm(a) == 0:
            ck.d.error("STL207", "rotor axis must be non-zero", rb.span)
            return None
        a = a / np.linalg.norm(a)
        out.append(model.Rotor(pos, tuple(float(x) for x in a), spin))  # type: ignore
    return tuple(out)


def _point_mass(ck: Context, b: ast.Block) -> model.PointMass | None:
    f = ck.fields(b, {"vel_max": True, "acc_max": True, "capacity": False, "mass": False,
                      "radius": False, **{k: False for k in AERO_FIELDS}},
                  sub_blocks=("start",))
    vmax = ck.vec(f, "vel_max", 3, units.SPEED)
    amax = ck.vec(f, "acc_max", 3, units.ACCEL)
    cap = ck.num(f, "capacity", units.DIMLESS)
    mass = ck.num(f, "mass", units.MASS, positive=True)
    for key, vec in (("vel_max", vmax), ("acc_max", amax)):
        if vec is not None and min(vec) <= 0:
            ck.d.error("STL207", f"`{key}` must be positive", f[key].value.span)
            return None
    if cap is not None and not (0 <= cap <= MAX_CAPACITY and cap == round(cap)):
        ck.d.error("STL207", f"`capacity` must be a whole number from 0 to {MAX_CAPACITY:,}, "
                   f"found {cap:g}", f["capacity"].value.span,
                   "the number of payloads the drone carries at once")
        cap = None
    start = _start(ck, b, {"pos": units.LENGTH, "vel": units.SPEED})
    aero = _aero(ck, b, f, mass)
    if vmax is None or amax is None or start.get("pos") is None:
        return None
    return model.PointMass(b.name, vmax, amax, start["pos"],  # type: ignore[arg-type]
                           start.get("vel") or (0.0, 0.0, 0.0),
                           None if cap is None else int(cap), mass, aero, b.span,
                           _radius(ck, f))


def _radius(ck: Context, f: dict) -> float:
    """``radius = 0.4 m``: the body's clearance (0 when not given; ≥ 0, finite)."""
    r = ck.num(f, "radius", units.LENGTH, 0.0)
    if r is None:
        return 0.0
    if r < 0:
        ck.d.error("STL207", "`radius` must be >= 0", f["radius"].value.span)
        return 0.0
    return float(r)


#: paper B eq. 8: the data of the energy-aware forward speed v* (air density optional)
AERO_FIELDS = {"rotors": units.DIMLESS, "disk_area": units.AREA,
               "flat_plate_area": units.AREA, "induced_factor": units.DIMLESS,
               "air_density": (-3, 1, 0, 0)}


def _aero(ck: Context, b: ast.Block, f: dict, mass: float | None):
    given = [k for k in AERO_FIELDS if k in f]
    if not given:
        return None
    vals = {k: ck.num(f, k, AERO_FIELDS[k], positive=True) for k in given}
    missing = [k for k in ("rotors", "disk_area", "flat_plate_area", "induced_factor")
               if k not in f] + ([] if mass is not None or "mass" in f else ["mass"])
    if missing:
        ck.d.error("STL104", "the energy-aware forward speed (paper B eq. 8) needs "
                   + ", ".join(f"`{k}`" for k in missing), f[given[0]].span,
                   "declare mass, rotors, disk_area, flat_plate_area and induced_factor "
                   "(air_density defaults to 1.225 kg/m^3)")
        return None
    if any(v is None for v in vals.values()):
        return None
    if vals["rotors"] != round(vals["rotors"]):
        ck.d.error("STL207", "`rotors` must be a whole number", f["rotors"].value.span)
        return None
    return (int(vals["rotors"]), vals["disk_area"], vals["flat_plate_area"],
            vals["induced_factor"], vals.get("air_density", 1.225))


#: the reader of each vehicle model's block, by the kind the registry knows it by
#: (``stlc.vehicles.kinds()``; ``tests/test_architecture.py`` checks the two agree)
READERS = {"multirotor": _multirotor, "point_mass": _point_mass}


# ---------------------------------------------------------------- scenario


def _region(ck: Context, kind: str, name: str, node: ast.Node, span: Span, frame: str | None,
            scope: Scope) -> RegionV | None:
    v = ck.value(node, scope)
    if isinstance(v, ErrorV):
        ck.failed.add(name)
        return None
    if not isinstance(v, RegionV):
        ck.d.error("STL208", f"`{name}` must be a region, e.g. box(lo, hi) m", node.span)
        ck.failed.add(name)
        return None
    placed = name if frame is None and name in ck.placed else None
    reg = RegionV(name, model.Box(v.box.lo, v.box.hi, frame, placed, v.box.shape))
    if placed:  # the centre is a parameter of the formulas (--set NAME.center.x=...)
        for k, a in enumerate("xyz"):
            ck.params[f"{name}.center.{a}"] = (v.box.lo[k] + v.box.hi[k]) / 2
    ck.regions.append(model.Region(name, kind, reg.box, span))
    return reg


def scenario(ck: Context, b: ast.Block) -> None:
    for m in b.members:
        if isinstance(m, ast.Field):
            if m.name == "workspace":
                if ck.define("workspace", m.name_span, "region"):
                    _region(ck, "workspace", "workspace", m.value, m.span, None, ck.globals)
            else:
                ck.d.error("STL103", f"unknown field `{m.name}` in `scenario`", m.name_span,
                           did_you_mean(m.name, ["workspace"]) or
                           "declare regions as `obstacle NAME = box(...)`, "
                           "`target NAME = ...`, `station`, `home`, `region`")
        elif isinstance(m, ast.Named) and m.kind in REGION_KINDS:
            if ck.define(m.name, m.name_span, m.kind):
                _region(ck, m.kind, m.name, m.value, m.span, None, ck.globals)
        elif isinstance(m, ast.Named) and m.kind == "const":
            ck.consts([m], ck.globals)
        elif isinstance(m, ast.Block) and m.kind == "human":
            _human(ck, m)
        elif isinstance(m, ast.Uncertain):
            pass  # handled after every human is known
        else:
            kind = getattr(m, "kind", type(m).__name__.lower())
            ck.bad_kind(kind, m.span, REGION_KINDS + ("human", "workspace", "const"),
                        "in a scenario")
    for m in b.members:
        if isinstance(m, ast.Uncertain):
            uncertain(ck, m, None)


def _human(ck: Context, b: ast.Block) -> None:
    name = b.name or "human"
    if not ck.define(name, b.name_span, "human"):
        return
    f = ck.fields(b, {"pos": True, "att": False}, named_kinds=("region",))
    pos = ck.vec(f, "pos", 3, units.LENGTH)
    att = ck.vec(f, "att", 3, units.ANGLE, (0.0, 0.0, 0.0))
    if pos is None or att is None:
        ck.failed.add(name)
        return
    ck.humans[name] = model.Human(name, pos, att, (), b.span)  # type: ignore[arg-type]
    for k, a in enumerate("xyz"):
        ck.params[f"{name}.pos.{a}"] = pos[k]
        ck.params[f"{name}.att.{a}"] = att[k]
    regs: dict[str, RegionV] = {}
    for m in b.members:
        if isinstance(m, ast.Named) and m.kind == "region":
            if m.name in regs or m.name in ("pos", "att", "heading"):
                ck.d.error("STL102", f"`{m.name}` is already defined in `{name}`",
                           m.name_span)
                continue
            r = _region(ck, "region", f"{name}.{m.name}", m.value, m.span, name,
                             ck.globals)
            regs[m.name] = ErrorV() if r is None else r  # type: ignore[assignment]
        elif isinstance(m, ast.Uncertain):
            uncertain(ck, m, name)
        elif isinstance(m, ast.Named):
            ck.bad_kind(m.kind, m.span, ("region",), "in a human")
    ck.human_regions[name] = regs


def uncertain(ck: Context, m: ast.Uncertain, human: str | None, attach: bool = True
               ) -> model.Normal | None:
    parts = m.target.parts if human is None else (human, *m.target.parts)
    if len(parts) != 2 or parts[0] not in ck.humans or parts[1] not in ("pos", "att"):
        cand = [f"{h}.{f}" for h in ck.humans for f in ("pos", "att")]
        ck.d.error("STL101", f"`{'.'.join(parts)}` is not an uncertain human pose",
                   m.target.span, did_you_mean(".".join(parts), cand) or
                   "uncertain quantities are a human's `pos` or `att`")
        return None
    v = ck.value(m.value, ck.globals)
    if isinstance(v, ErrorV):
        return None
    if not isinstance(v, DistV):
        ck.d.error("STL210", "expected a distribution, e.g. normal(mean, cov)",
                   m.value.span)
        return None
    want = units.LENGTH if parts[1] == "pos" else units.ANGLE
    if v.mean.size != 3:
        ck.d.error("STL205", f"`{parts[1]}` has 3 components, the distribution has "
                   f"{v.mean.size}", m.value.span)
        return None
    if not units.compatible(v.dim, want):
        ck.d.error("STL204", f"unit mismatch: `{parts[1]}` is {units.describe(want)}, "
                   f"the distribution is in {units.describe(v.dim)}", m.value.span)
        return None
    dist = model.Normal(tuple(f"{parts[0]}.{parts[1]}.{a}" for a in "xyz"),
                        tuple(float(x) for x in v.mean),
                        tuple(tuple(float(x) for x in row) for row in v.cov), m.span)
    h = ck.humans[parts[0]]
    if attach:
        if any(set(d.params) & set(dist.params) for d in h.uncertain):
            ck.d.error("STL102", f"`{'.'.join(parts)}` already has a distribution",
                       m.span)
            return None
        ck.humans[parts[0]] = model.Human(h.name, h.pos, h.att, h.uncertain + (dist,),
                                          h.span)
    return dist


def bind_world(ck: Context, scope: Scope) -> None:
    for name, v in ck.vehicles.items():
        scope.names[name] = VehicleV(v)
    for name, h in ck.humans.items():
        scope.names[name] = HumanV(h)
    for r in ck.regions:
        if r.box.frame is None:
            scope.names[r.name] = RegionV(r.name, r.box)
    for group, kind in GROUP_NAMES.items():
        scope.names[group] = GroupV(kind, tuple(RegionV(r.name, r.box) for r in ck.regions
                                                if r.kind == kind))
    scope.names["vehicles"] = GroupV("vehicle", tuple(VehicleV(v) for v in
                                                      ck.vehicles.values()))
    for name in ck.failed:
        scope.names.setdefault(name, ErrorV())
