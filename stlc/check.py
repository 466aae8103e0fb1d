"""The checker: AST → ``model.Program`` (vehicles, scenario, missions; formulas as typed IR).

It resolves names (with "did you mean" hints), converts units to SI, tells formulas from
numbers, checks intervals against the mission step and horizon, rejects duplicates and
unknown fields, and collects *every* error of the pass before raising ``StlcError``.
Declaration order matters only for named specs (a spec may use the specs defined before
it); vehicles, the scenario and constants can appear anywhere in the file.
"""

from __future__ import annotations

import math

import numpy as np

from stlc import ast, ir, model, units
from stlc.diagnostics import Collector, Span, StlcError, did_you_mean
from stlc.elaborate import Elaborator, Scope
from stlc.formulas import named_specs
from stlc.values import (
    DistV,
    ErrorV,
    Form,
    GroupV,
    HumanV,
    Num,
    RegionV,
    RotorsV,
    Sym,
    VehicleV,
    kind_name,
)

REGION_KINDS = ("obstacle", "region", "target", "station", "home")
GROUP_NAMES = {"obstacles": "obstacle", "regions": "region", "targets": "target",
               "stations": "station", "homes": "home"}
TOP_KINDS = ("vehicle", "scenario", "mission", "spec", "const", "signal")
SINGLE_BLOCKS = ("start", "risk", "replan")  # sub-blocks that a block holds at most once


def check(tree: ast.File) -> model.Program:
    """Check a parsed file; raise ``StlcError`` with all diagnostics if anything is wrong."""
    ck = Checker(tree)
    try:
        return ck.run()
    except RecursionError:  # the elaborator guards each value; this is the last resort
        ck.d.error("STL004", "formula nested too deeply", ck.where,
                   "name sub-formulas with `spec` instead")
        raise StlcError(ck.d.diagnostics) from None


class Checker:
    def __init__(self, tree: ast.File):
        self.tree = tree
        self.d = Collector()
        self.el = Elaborator(self.d, tree.source, tree.path)
        self.globals = Scope()
        self.vehicles: dict[str, model.Vehicle] = {}
        self.regions: list[model.Region] = []
        self.humans: dict[str, model.Human] = {}
        self.human_regions: dict[str, dict[str, RegionV]] = {}
        self.params: dict[str, float] = {}
        self.defined: dict[str, Span] = {}
        #: names whose declaration had errors: bound to ``ErrorV`` so that uses stay silent
        self.failed: set[str] = set()
        self.where = tree.members[0].span if tree.members else Span.none()  # for STL004

    # ------------------------------------------------------------ driver
    def run(self) -> model.Program:
        members = self.tree.members
        signals = self._signals(members)
        for s in signals:  # bound first: a constant that reads a signal is STL210, not STL101
            self.globals.names[s] = Sym((ir.Sig(s),), None, False, (s,))
        self._consts([m for m in members if isinstance(m, ast.Named) and m.kind == "const"],
                     self.globals)
        for m in members:
            if isinstance(m, ast.Block) and m.kind == "vehicle":
                self.where = m.span
                self._vehicle(m)
        scen = [m for m in members if isinstance(m, ast.Block) and m.kind == "scenario"]
        for extra in scen[1:]:
            self.d.error("STL102", "a file has one scenario block", extra.span,
                         "merge the scenario blocks")
        if scen:
            self._scenario(scen[0])
        self.el.human_regions = self.human_regions
        self._bind_world(self.globals)
        specs, spans = self._specs([m for m in members if isinstance(m, ast.Named)
                                    and m.kind == "spec"], self.globals, None)
        missions: dict[str, model.Mission] = {}
        for m in members:
            self.where = m.span
            if isinstance(m, ast.Block) and m.kind == "mission":
                mis = self._mission(m, specs)
                if mis is not None:
                    missions[mis.name] = mis
            elif isinstance(m, ast.Block) and m.kind not in ("vehicle", "scenario"):
                self._bad_kind(m.kind, m.span, TOP_KINDS, "at the top level")
            elif isinstance(m, ast.Named) and m.kind not in ("spec", "const"):
                self._bad_kind(m.kind, m.span, TOP_KINDS, "at the top level")
            elif isinstance(m, (ast.Field, ast.Require, ast.Objective, ast.Uncertain)):
                self.d.error("STL108", "this belongs inside a block", m.span,
                             "put fields in a `vehicle`, `scenario` or `mission` block")
        self.d.raise_if_failed()
        return model.Program(
            file=self.tree.path, source=self.tree.source, signals=tuple(signals), specs=specs,
            spec_spans=spans, vehicles=self.vehicles,
            scenario=model.Scenario(tuple(self.regions), tuple(self.humans.values())),
            missions=missions, params=self.params)

    # ------------------------------------------------------------ small helpers
    def _define(self, name: str, span: Span, what: str) -> bool:
        if name in self.defined:
            prev = self.defined[name]
            self.d.error("STL102", f"`{name}` is already defined (line {prev.line})", span,
                         f"rename this {what}")
            return False
        self.defined[name] = span
        return True

    def _bad_kind(self, kind: str, span: Span, allowed, where: str) -> None:
        self.d.error("STL108", f"`{kind}` is not allowed {where}", span,
                     did_you_mean(kind, allowed) or "allowed here: " + ", ".join(allowed))

    def _consts(self, members: list[ast.Named], scope: Scope) -> None:
        for m in members:
            if not self._define(m.name, m.name_span, "constant"):
                continue
            v = self.el.value(m.value, scope)
            if isinstance(v, (Num, ErrorV)):
                scope.names[m.name] = v
                continue
            scope.names[m.name] = ErrorV()  # reported here, silent where it is used
            if isinstance(v, Sym):
                self.d.error("STL210", "a constant must not read signals", m.value.span,
                             "use the expression in a spec directly, or declare the "
                             "constant from numbers only")
            else:
                self.d.error("STL210", f"a constant must be a number, found {kind_name(v)}",
                             m.value.span, "use `spec` to name a formula"
                             if isinstance(v, Form) else None)

    def _signals(self, members) -> list[str]:
        out: list[str] = []
        for m in members:
            if isinstance(m, ast.Signals):
                for name in m.names:
                    if self._define(name, m.span, "signal"):
                        out.append(name)
        return out

    def _fields(self, block: ast.Block, allowed: dict[str, bool], sub_blocks=(),
                named_kinds=()) -> dict[str, ast.Member]:
        """Index a block's members by name; report unknown, duplicate and missing ones.
        ``allowed`` maps field name → required.  Of the ``sub_blocks``, a ``SINGLE_BLOCKS``
        kind may appear once; others may repeat (`rotor { }` blocks), but not under one
        name."""
        out: dict[str, ast.Member] = {}
        for m in block.members:
            if isinstance(m, ast.Field):
                key, span = m.name, m.name_span
                if key not in allowed:
                    self.d.error("STL103", f"unknown field `{key}` in `{block.kind}`", span,
                                 did_you_mean(key, allowed) or
                                 "fields: " + ", ".join(allowed))
                    continue
            elif isinstance(m, ast.Block) and m.kind in sub_blocks:
                if m.kind in SINGLE_BLOCKS:
                    key, span = m.kind, m.span
                    if key in out:
                        self.d.error("STL102", f"`{key}` is given twice: a `{block.kind}` has "
                                     f"one `{key}` block", span, f"merge the `{key}` blocks")
                        continue
                elif m.name:
                    key, span = m.kind + ":" + m.name, m.name_span
                else:
                    continue
            elif isinstance(m, ast.Named) and m.kind in named_kinds:
                continue
            else:
                continue
            if key in out:
                self.d.error("STL102", f"`{key.split(':')[-1]}` is given twice", span)
                continue
            out[key] = m
        for name, required in allowed.items():
            if required and name not in out:
                self.d.error("STL104", f"`{block.kind}` `{block.name or ''}` is missing "
                             f"`{name}`".replace("`` ", ""), block.name_span,
                             f"add `{name} = ...`")
        return out

    # ------------------------------------------------------------ vehicles
    def _vehicle(self, b: ast.Block) -> None:
        name = b.name or "?"
        if not self._define(name, b.name_span, "vehicle"):
            return
        self.failed.add(name)  # until it checks
        if b.model == "multirotor":
            v = self._multirotor(b)
        elif b.model in ("point_mass", "motion_primitive"):
            v = self._point_mass(b)
        else:
            self.d.error("STL105", f"unknown vehicle model `{b.model}`", b.span,
                         did_you_mean(b.model or "", ["multirotor", "point_mass"]) or
                         "models: multirotor, point_mass")
            return
        if v is not None:
            self.vehicles[name] = v
            self.failed.discard(name)

    def _num(self, f: dict, key: str, dim, default=None, positive=False):
        m = f.get(key)
        if m is None:
            return default
        x = self.el.number(m.value, self.globals, dim, f"`{key}`")
        if x is not None and not math.isfinite(x):
            self.d.error("STL207", f"`{key}` must be a finite number, found {x:g}", m.value.span)
            return None
        if x is not None and positive and not x > 0:
            self.d.error("STL207", f"`{key}` must be positive", m.value.span)
            return None
        return x

    def _vec(self, f: dict, key: str, n: int | None, dim, default=None):
        m = f.get(key)
        if m is None:
            return default
        arr = self.el.vector(m.value, self.globals, n, dim, f"`{key}`")
        if arr is not None and not np.all(np.isfinite(arr)):
            self.d.error("STL207", f"`{key}` must be finite numbers", m.value.span)
            return None
        return None if arr is None else tuple(float(x) for x in arr)

    def _start(self, b: ast.Block, keys: dict[str, units.Dim]) -> dict[str, tuple]:
        starts = [m for m in b.members if isinstance(m, ast.Block) and m.kind == "start"]
        if not starts:
            self.d.error("STL104", f"vehicle `{b.name}` has no `start {{ pos = ... }}` block",
                         b.name_span, "add `start { pos = (x, y, z) m }`")
            return {}
        f = self._fields(starts[0], {k: k == "pos" for k in keys})
        return {k: self._vec(f, k, 3, dim) for k, dim in keys.items() if k in f}

    def _multirotor(self, b: ast.Block) -> model.Multirotor | None:
        f = self._fields(b, {"mass": True, "inertia": True, "c_f": True, "c_tau": True,
                             "force": True, "rotors": False, "dforce_max": False,
                             "gravity": False}, sub_blocks=("start", "rotor"))
        mass = self._num(f, "mass", units.MASS, positive=True)
        c_f = self._num(f, "c_f", None, positive=True)
        c_tau = self._num(f, "c_tau", None, positive=True)
        dfmax = self._num(f, "dforce_max", (1, 1, -3, 0), positive=True)
        gravity = self._num(f, "gravity", units.ACCEL, 9.81, positive=True)
        inertia = None
        if "inertia" in f:
            node = f["inertia"].value
            v = self.el.value(node, self.globals)
            if isinstance(v, Num) and units.compatible(v.dim, units.INERTIA):
                arr = np.asarray(v.v, dtype=float)
                if arr.shape == (3,):
                    arr = np.diag(arr)
                if arr.shape != (3, 3):
                    self.d.error("STL205", "inertia must be 3 numbers or a 3x3 matrix",
                                 node.span, "e.g. diag(0.0207, 0.0210, 0.0310) kg*m^2")
                elif not np.allclose(arr, arr.T) or np.linalg.eigvalsh(arr).min() <= 0:
                    self.d.error("STL207", "inertia must be symmetric positive definite",
                                 node.span)
                else:
                    inertia = tuple(tuple(float(x) for x in row) for row in arr)
            elif isinstance(v, Num):
                self.d.error("STL204", "unit mismatch: inertia must be "
                             f"{units.describe(units.INERTIA)}, found {units.describe(v.dim)}",
                             node.span, "write it in kg*m^2")
            elif not isinstance(v, ErrorV):
                self.d.error("STL210", "inertia must be constant numbers", node.span)
        fmin = fmax = None
        if "force" in f:
            node = f["force"].value
            arr = self.el.vector(node, self.globals, 2, units.FORCE, "the rotor force range")
            if arr is not None:
                fmin, fmax = float(arr[0]), float(arr[1])
                if not 0 <= fmin < fmax < math.inf:
                    self.d.error("STL207", "rotor force range must be 0 <= min < max (finite)",
                                 node.span)
                    fmin = fmax = None
        rotors = self._rotors(b, f)
        start = self._start(b, {"pos": units.LENGTH, "att": units.ANGLE, "vel": units.SPEED,
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
            dforce_max=dfmax, gravity=gravity, span=b.span)
        self._check_hover(v, b)
        return v

    def _check_hover(self, v: model.Multirotor, b: ast.Block) -> None:
        from stlc import dynamics

        try:
            dynamics.hover_forces(v, check_bounds=True)
        except Exception as e:  # noqa: BLE001 - any failure here is a modelling error
            why = str(e).removeprefix(f"{v.name} ")
            if not why.startswith("cannot hover"):
                why = f"cannot hover: {why}"
            self.d.error("STL402", f"vehicle `{v.name}` {why}", b.name_span,
                         "check mass, rotor geometry and the force range")

    def _rotors(self, b: ast.Block, f: dict) -> tuple[model.Rotor, ...] | None:
        blocks = [m for m in b.members if isinstance(m, ast.Block) and m.kind == "rotor"]
        if "rotors" in f and blocks:
            self.d.error("STL102", "give either `rotors = ...` or `rotor` blocks, not both",
                         f["rotors"].span)
            return None
        if "rotors" in f:
            node = f["rotors"].value
            v = self.el.value(node, self.globals)
            if isinstance(v, RotorsV):
                return v.rotors
            if not isinstance(v, ErrorV):
                self.d.error("STL210", "`rotors` must be hexarotor(...), quadrotor(...) or "
                             "a list of `rotor { }` blocks", node.span)
            return None
        if not blocks:
            self.d.error("STL104", f"vehicle `{b.name}` has no rotors", b.name_span,
                         "add `rotors = hexarotor(arm = 0.39 m, tilt = 20 deg)`")
            return None
        out = []
        for rb in blocks:
            rf = self._fields(rb, {"position": True, "axis": False, "spin": True})
            pos = self._vec(rf, "position", 3, units.LENGTH)
            axis = self._vec(rf, "axis", 3, None, (0.0, 0.0, 1.0))
            spin = None
            if "spin" in rf:
                node = rf["spin"].value
                txt = node.parts[0] if isinstance(node, ast.Path) else None
                spin = {"ccw": 1, "cw": -1}.get(txt or "")
                if spin is None:
                    self.d.error("STL207", "`spin` is `ccw` or `cw`", node.span)
            if pos is None or axis is None or spin is None:
                return None
            a = np.array(axis)
            if np.linalg.norm(a) == 0:
                self.d.error("STL207", "rotor axis must be non-zero", rb.span)
                return None
            a = a / np.linalg.norm(a)
            out.append(model.Rotor(pos, tuple(float(x) for x in a), spin))  # type: ignore
        return tuple(out)

    def _point_mass(self, b: ast.Block) -> model.PointMass | None:
        f = self._fields(b, {"vel_max": True, "acc_max": True, "capacity": False, "mass": False},
                         sub_blocks=("start",))
        vmax = self._vec(f, "vel_max", 3, units.SPEED)
        amax = self._vec(f, "acc_max", 3, units.ACCEL)
        cap = self._num(f, "capacity", None)
        mass = self._num(f, "mass", units.MASS, positive=True)
        for key, vec in (("vel_max", vmax), ("acc_max", amax)):
            if vec is not None and min(vec) <= 0:
                self.d.error("STL207", f"`{key}` must be positive", f[key].value.span)
                return None
        if cap is not None and (cap < 0 or cap != round(cap)):
            self.d.error("STL207", "`capacity` must be a whole number >= 0",
                         f["capacity"].value.span)
            cap = None
        start = self._start(b, {"pos": units.LENGTH, "vel": units.SPEED})
        if vmax is None or amax is None or start.get("pos") is None:
            return None
        return model.PointMass(b.name, vmax, amax, start["pos"],  # type: ignore[arg-type]
                               start.get("vel") or (0.0, 0.0, 0.0),
                               None if cap is None else int(cap), mass, b.span)

    # ------------------------------------------------------------ scenario
    def _region(self, kind: str, name: str, node: ast.Node, span: Span, frame: str | None,
                scope: Scope) -> RegionV | None:
        v = self.el.value(node, scope)
        if isinstance(v, ErrorV):
            self.failed.add(name)
            return None
        if not isinstance(v, RegionV):
            self.d.error("STL208", f"`{name}` must be a region, e.g. box(lo, hi) m", node.span)
            self.failed.add(name)
            return None
        reg = RegionV(name, model.Box(v.box.lo, v.box.hi, frame))
        self.regions.append(model.Region(name, kind, reg.box, span))
        return reg

    def _scenario(self, b: ast.Block) -> None:
        for m in b.members:
            if isinstance(m, ast.Field):
                if m.name == "workspace":
                    if self._define("workspace", m.name_span, "region"):
                        self._region("workspace", "workspace", m.value, m.span, None, self.globals)
                else:
                    self.d.error("STL103", f"unknown field `{m.name}` in `scenario`", m.name_span,
                                 did_you_mean(m.name, ["workspace"]) or
                                 "declare regions as `obstacle NAME = box(...)`, "
                                 "`target NAME = ...`, `station`, `home`, `region`")
            elif isinstance(m, ast.Named) and m.kind in REGION_KINDS:
                if self._define(m.name, m.name_span, m.kind):
                    self._region(m.kind, m.name, m.value, m.span, None, self.globals)
            elif isinstance(m, ast.Named) and m.kind == "const":
                self._consts([m], self.globals)
            elif isinstance(m, ast.Block) and m.kind == "human":
                self._human(m)
            elif isinstance(m, ast.Uncertain):
                pass  # handled after every human is known
            else:
                kind = getattr(m, "kind", type(m).__name__.lower())
                self._bad_kind(kind, m.span, REGION_KINDS + ("human", "workspace", "const"),
                               "in a scenario")
        for m in b.members:
            if isinstance(m, ast.Uncertain):
                self._uncertain(m, None)

    def _human(self, b: ast.Block) -> None:
        name = b.name or "human"
        if not self._define(name, b.name_span, "human"):
            return
        f = self._fields(b, {"pos": True, "att": False}, named_kinds=("region",))
        pos = self._vec(f, "pos", 3, units.LENGTH)
        att = self._vec(f, "att", 3, units.ANGLE, (0.0, 0.0, 0.0))
        if pos is None or att is None:
            self.failed.add(name)
            return
        self.humans[name] = model.Human(name, pos, att, (), b.span)  # type: ignore[arg-type]
        for k, a in enumerate("xyz"):
            self.params[f"{name}.pos.{a}"] = pos[k]
            self.params[f"{name}.att.{a}"] = att[k]
        regs: dict[str, RegionV] = {}
        for m in b.members:
            if isinstance(m, ast.Named) and m.kind == "region":
                if m.name in regs or m.name in ("pos", "att", "heading"):
                    self.d.error("STL102", f"`{m.name}` is already defined in `{name}`",
                                 m.name_span)
                    continue
                r = self._region("region", f"{name}.{m.name}", m.value, m.span, name,
                                 self.globals)
                regs[m.name] = ErrorV() if r is None else r  # type: ignore[assignment]
            elif isinstance(m, ast.Uncertain):
                self._uncertain(m, name)
            elif isinstance(m, ast.Named):
                self._bad_kind(m.kind, m.span, ("region",), "in a human")
        self.human_regions[name] = regs

    def _uncertain(self, m: ast.Uncertain, human: str | None, attach: bool = True
                   ) -> model.Normal | None:
        parts = m.target.parts if human is None else (human, *m.target.parts)
        if len(parts) != 2 or parts[0] not in self.humans or parts[1] not in ("pos", "att"):
            cand = [f"{h}.{f}" for h in self.humans for f in ("pos", "att")]
            self.d.error("STL101", f"`{'.'.join(parts)}` is not an uncertain human pose",
                         m.target.span, did_you_mean(".".join(parts), cand) or
                         "uncertain quantities are a human's `pos` or `att`")
            return None
        v = self.el.value(m.value, self.globals)
        if isinstance(v, ErrorV):
            return None
        if not isinstance(v, DistV):
            self.d.error("STL210", "expected a distribution, e.g. normal(mean, cov)",
                         m.value.span)
            return None
        want = units.LENGTH if parts[1] == "pos" else units.ANGLE
        if v.mean.size != 3:
            self.d.error("STL205", f"`{parts[1]}` has 3 components, the distribution has "
                         f"{v.mean.size}", m.value.span)
            return None
        if not units.compatible(v.dim, want):
            self.d.error("STL204", f"unit mismatch: `{parts[1]}` is {units.describe(want)}, "
                         f"the distribution is in {units.describe(v.dim)}", m.value.span)
            return None
        dist = model.Normal(tuple(f"{parts[0]}.{parts[1]}.{a}" for a in "xyz"),
                            tuple(float(x) for x in v.mean),
                            tuple(tuple(float(x) for x in row) for row in v.cov), m.span)
        h = self.humans[parts[0]]
        if attach:
            if any(set(d.params) & set(dist.params) for d in h.uncertain):
                self.d.error("STL102", f"`{'.'.join(parts)}` already has a distribution",
                             m.span)
                return None
            self.humans[parts[0]] = model.Human(h.name, h.pos, h.att, h.uncertain + (dist,),
                                                h.span)
        return dist

    def _bind_world(self, scope: Scope) -> None:
        for name, v in self.vehicles.items():
            scope.names[name] = VehicleV(v)
        for name, h in self.humans.items():
            scope.names[name] = HumanV(h)
        for r in self.regions:
            if r.box.frame is None:
                scope.names[r.name] = RegionV(r.name, r.box)
        for group, kind in GROUP_NAMES.items():
            scope.names[group] = GroupV(kind, tuple(RegionV(r.name, r.box) for r in self.regions
                                                    if r.kind == kind))
        scope.names["vehicles"] = GroupV("vehicle", tuple(VehicleV(v) for v in
                                                          self.vehicles.values()))
        for name in self.failed:
            scope.names.setdefault(name, ErrorV())

    # ------------------------------------------------------------ specs
    def _specs(self, members: list[ast.Named], scope: Scope, step: float | None
               ) -> tuple[dict[str, ir.Formula], dict[str, Span]]:
        return named_specs(self, members, scope, step)

    # ------------------------------------------------------------ missions
    def _mission(self, b: ast.Block, top_specs: dict[str, ir.Formula]) -> model.Mission | None:
        from stlc.mission import check_mission

        return check_mission(self, b, top_specs)


