"""Signals over time: one plot per quantity, with the bounds the mission states on it.

A bound drawn on a plot spans the window of the spec that states it (``Γ_vel`` only holds
during ``comfort``'s window), and each plot shades only the windows of the specs that
constrain its signals, leaving out windows that cover the whole horizon; the ``timeline``
plot shows every spec's window and where it is tightest.
"""

from __future__ import annotations

import math

import numpy as np

from stlc.planning.solution import Solution
from stlc.planning.bounds import bound_specs, stated_bounds
from stlc.semantics import ir, nnf
from stlc.semantics.model import Mission, Program
from stlc.vehicles import model_of

from .common import channel, fmt, indexed, num, nums, pair, speed, vehicles
from .predicates import hover_speed

#: shading colours of requirement windows, cycled
WINDOW_COLORS = ("#1f77b4", "#ff7f0e", "#2ca02c", "#9467bd", "#8c564b", "#e377c2", "#17becf")
#: below this horizontal speed (m/s) the direction of motion is not drawn, when the mission
#: states no threshold of its own
HOVER_DEFAULT = 0.05


def spec_formulas(program: Program, mission: Mission, sol: Solution) -> dict[str, ir.Formula]:
    out = {}
    for name in sol.specs:
        f = mission.specs.get(name) or program.specs.get(name)
        if f is not None:
            out[name] = f
    return out


def windows(mission: Mission, sol: Solution, formulas: dict[str, ir.Formula]) -> list[dict]:
    """Outermost window of each named spec (from ``Solution.windows`` or the formulas)."""
    out = []
    if sol.windows:
        for w in sol.windows:
            out.append({"spec": w.spec, "start": num(w.start), "end": num(w.end)})
    else:
        for name, f in formulas.items():
            while isinstance(f, ir.And) and len(f.args) == 1:
                f = f.args[0]
            if isinstance(f, ir.WINDOWED):
                out.append({"spec": name, "start": num(f.lo),
                            "end": num(min(f.hi, mission.horizon))})
    colors: dict[str, str] = {}
    for w in out:
        colors.setdefault(w["spec"], WINDOW_COLORS[len(colors) % len(WINDOW_COLORS)])
        w["color"] = colors[w["spec"]]
        w["text"] = f"[{fmt(w['start'])}, {fmt(w['end'])}] s"
    return [w for w in out if w["start"] is not None and w["end"] is not None]


def _timeline(rows: list[dict], wins: list[dict], horizon: float) -> dict | None:
    by_spec = {w["spec"]: w for w in wins}
    specs = []
    for i, r in enumerate(rows):
        w = by_spec.get(r["name"])
        specs.append({"name": r["name"], "satisfied": r["satisfied"],
                      "start": w["start"] if w else None, "end": w["end"] if w else None,
                      "color": w["color"] if w else WINDOW_COLORS[i % len(WINDOW_COLORS)],
                      "tightest": r["tightest_time"],
                      "robustness_text": r["robustness_text"],
                      "predicate": r["binding_predicate"]})
    return {"specs": specs, "horizon": num(horizon)} if specs else None


def _segments(mask: np.ndarray, t: np.ndarray) -> list[tuple[int, int]]:
    """Index ranges [i, j] (inclusive) where ``mask`` holds."""
    out, start = [], None
    for k, m in enumerate(mask.tolist() + [False]):
        if m and start is None:
            start = k
        elif not m and start is not None:
            out.append((start, k - 1))
            start = None
    return out


def _masked(y: np.ndarray, keep: np.ndarray) -> list[float | None]:
    return [v if k else None for v, k in zip(nums(y), keep.tolist(), strict=True)]


class _Builder:
    """Collects the plots of one solution."""

    def __init__(self, program: Program, mission: Mission, sol: Solution,
                 formulas: dict[str, ir.Formula], wins: list[dict]):
        self.program, self.mission, self.sol = program, mission, sol
        self.t = np.asarray(sol.times, float)
        self.vehicles = vehicles(mission, sol)
        self.multi = len(self.vehicles) > 1
        # the plan's bounds, completed by those the requirement states
        self.bounds = {**stated_bounds(nnf.normalize(mission.requirement)),
                       **sol.bounds}
        self.stated = bound_specs(formulas)
        self.signals = {k: ir.signals(f) for k, f in formulas.items()}
        horizon = float(self.t[-1]) if self.t.size else mission.horizon
        # a window over the whole plan shades everything: it says nothing on a plot
        self.wins = [w for w in wins if not (w["start"] <= 0 and w["end"] >= horizon - 1e-9)]
        self.all_wins = wins
        self.plots: list[dict] = []

    def tag(self, v: str, s: str) -> str:
        return f"{v} {s}" if self.multi else s

    def window_of(self, kind: str) -> tuple[float | None, float | None]:
        """Time span of the specs stating a bound of this kind (None: the whole plan)."""
        specs = set(self.stated.get(kind, []))
        ws = [w for w in self.all_wins if w["spec"] in specs]
        if not ws or len(ws) < len(specs):
            return None, None
        return min(w["start"] for w in ws), max(w["end"] for w in ws)

    def line(self, value: object, label: str, style: str = "limit",
             kind: str | None = None, unit: str = "", bare: bool = False) -> list[dict]:
        """A horizontal bound at ``value``, labelled ``label = value unit`` (just ``label``
        when ``bare``), over the window of the specs stating ``kind``."""
        v = num(value)
        if v is None:
            return []
        x0, x1 = self.window_of(kind) if kind else (None, None)
        sep = " " if label.endswith("≙") else " = "
        text = label if bare else f"{label}{sep}{fmt(v, unit=unit)}".replace(" °", "°")
        return [{"value": v, "label": label, "text": text, "style": style, "x0": x0, "x1": x1}]

    def add(self, pid: str, title: str, unit: str, traces: list[dict], bounds=(),
            band: dict | None = None, prefixes: tuple[str, ...] = (), spans=(),
            note: str = "", specs: set[str] | None = None) -> None:
        """A plot; it shades the windows of ``specs``, by default of the specs whose signals
        start with one of ``prefixes``."""
        if not traces or not self.t.size:
            return
        if specs is None:
            specs = {k for k, sig in self.signals.items()
                     if any(s.startswith(p) for s in sig for p in prefixes)}
        seen: set[tuple] = set()
        bnds = []
        for b in bounds:
            key = (b["value"], b["label"])
            if key not in seen:
                seen.add(key)
                bnds.append(b)
        self.plots.append({"id": pid, "title": title, "unit": unit, "traces": traces,
                           "bounds": bnds, "band": band, "spans": list(spans), "note": note,
                           "windows": [w["spec"] for w in self.wins if w["spec"] in specs]})

    # ------------------------------------------------------------------ the plots

    def position(self) -> None:
        traces = []
        for v in self.vehicles:
            for a in "xyz":
                c = channel(self.sol, f"{v}.pos.{a}")
                if c is not None:
                    traces.append({"name": self.tag(v, a), "y": nums(c)})
        self.add("sig-position", "Position", "m", traces,
                 prefixes=tuple(f"{v}.pos" for v in self.vehicles))

    def speed(self) -> None:
        traces = [{"name": self.tag(v, "speed"), "y": nums(c)} for v in self.vehicles
                  if (c := speed(self.sol, v)) is not None]
        lo, hi = pair(self.bounds.get("speed"))
        bnds = self.line(lo, "Γ_vel min", kind="speed", unit="m/s") if lo else []
        bnds += self.line(hi, "Γ_vel", kind="speed", unit="m/s")
        self.add("sig-speed", "Speed", "m/s", traces, bnds,
                 prefixes=tuple(f"{v}.{s}" for v in self.vehicles
                                for s in ("speed", "vel", "horizontal_speed")))

    def point_mass_limits(self) -> None:
        for field, title, unit in (("vel", "Velocity", "m/s"),
                                   ("acc", "Acceleration", "m/s²")):
            traces, bnds = [], []
            for v in self.vehicles:
                veh = self.program.vehicles.get(v)
                axis = {} if veh is None else model_of(veh).axis_limits(veh)
                if field not in axis:
                    continue
                for a in "xyz":
                    c = channel(self.sol, f"{v}.{field}.{a}")
                    if c is not None:
                        traces.append({"name": self.tag(v, f"{field}.{a}"), "y": nums(c)})
                limits = sorted({float(x) for x in axis[field] if math.isfinite(x)})
                for x in limits:
                    sym = "v̄" if field == "vel" else "ā"
                    bnds += self.line(x, sym, unit=unit) + self.line(-x, f"−{sym}", bare=True)
            self.add(f"sig-{field}", f"{title} components (per-axis limits)", unit, traces,
                     bnds, prefixes=tuple(f"{v}.{field}" for v in self.vehicles))

    def rotors(self) -> None:
        traces, bnds = [], []
        lo, hi = pair(self.bounds.get("rotor_speed"))
        bnds += self.line(lo, "Γ_pro min", kind="rotor_speed", unit="Hz")
        bnds += self.line(hi, "Γ_pro max", kind="rotor_speed", unit="Hz")
        f_lo, f_hi = pair(self.bounds.get("force"))
        for v in self.vehicles:
            rs = indexed(self.sol, f"{v}.rotor_speed")
            for name, c in rs:
                traces.append({"name": self.tag(v, "rotor " + name.rsplit(".", 1)[1]),
                               "y": nums(c)})
            veh = self.program.vehicles.get(v)
            rf = None if veh is None else model_of(veh).rotor_forces(veh)
            if rf is not None and rf[2] > 0 and rs:
                lo_f = rf[0] if f_lo is None else f_lo
                hi_f = rf[1] if f_hi is None else f_hi
                if lo_f is not None and lo_f > 0:
                    bnds += self.line(math.sqrt(lo_f / rf[2]), f"ξ min {fmt(lo_f)} N ≙",
                                      "soft", unit="Hz")
                if hi_f is not None and hi_f > 0:
                    bnds += self.line(math.sqrt(hi_f / rf[2]), f"ξ max {fmt(hi_f)} N ≙",
                                      "soft", unit="Hz")
        self.add("sig-rotor", "Rotor speeds", "Hz", traces, bnds,
                 prefixes=tuple(f"{v}.rotor_speed" for v in self.vehicles))

    def forces(self) -> None:
        traces = []
        f_lo, f_hi = pair(self.bounds.get("force"))
        for v in self.vehicles:
            for name, c in indexed(self.sol, f"{v}.force"):
                traces.append({"name": self.tag(v, "ξ" + name.rsplit(".", 1)[1]), "y": nums(c)})
            veh = self.program.vehicles.get(v)
            rf = None if veh is None else model_of(veh).rotor_forces(veh)
            if f_lo is None and rf is not None:
                f_lo, f_hi = rf[0], rf[1]
        self.add("sig-force", "Rotor forces", "N", traces,
                 self.line(f_lo, "ξ min", unit="N") + self.line(f_hi, "ξ max", unit="N"),
                 prefixes=tuple(f"{v}.force" for v in self.vehicles))

    def heading(self) -> None:
        gamma = num(self.bounds.get("heading_margin_deg"))
        formula = self.mission.requirement
        hover = hover_speed(formula)
        threshold = HOVER_DEFAULT if hover is None else hover
        x0, x1 = self.window_of("heading_margin_deg")
        t = self.t
        for iv, v in enumerate(self.vehicles):
            heading = channel(self.sol, f"{v}.heading")
            if heading is None:
                heading = channel(self.sol, f"{v}.att.z")
            vx, vy = channel(self.sol, f"{v}.vel.x"), channel(self.sol, f"{v}.vel.y")
            course = channel(self.sol, f"{v}.course")
            if course is None and vx is not None and vy is not None:
                course = np.arctan2(vy, vx)
            if heading is None or course is None:
                continue
            moving = np.ones(t.size, bool)
            if vx is not None and vy is not None:
                moving = np.hypot(vx, vy) > threshold
            err = np.degrees((heading - course + np.pi) % (2 * np.pi) - np.pi)
            psi = np.degrees(np.unwrap(heading))
            course_d = psi - err  # the course, drawn next to the heading (same turn)
            band = None
            if gamma is not None:
                inside = moving.copy()
                if x0 is not None:
                    inside &= (t >= x0 - 1e-9) & (t <= x1 + 1e-9)
                xs: list[float | None] = []
                ys: list[float | None] = []
                for i, j in _segments(inside, t):
                    seg = slice(i, j + 1)
                    xs += nums(t[seg]) + nums(t[seg][::-1]) + [None]
                    ys += nums(course_d[seg] + gamma) + nums(course_d[seg][::-1] - gamma) + [None]
                band = {"name": f"course ± γ ({fmt(gamma)}°)", "x": xs, "y": ys} if xs else None
            spans = [{"start": num(t[i]), "end": num(t[j]), "label": "hovering"}
                     for i, j in _segments(~moving, t) if j > i]
            prefixes = (f"{v}.heading", f"{v}.course", f"{v}.att")
            hover_note = (f"Grey: hovering (horizontal speed ≤ {fmt(threshold)} m/s), where the "
                          "direction of motion is undefined" + (" and the heading is free"
                                                                 if hover is not None else ""))
            hover_note = hover_note if spans else ""
            self.add(f"sig-heading-{iv + 1}", self.tag(v, "Heading vs direction of motion"),
                     "deg", [{"name": self.tag(v, "heading ψ"), "y": nums(psi)},
                             {"name": self.tag(v, "direction of motion"),
                              "y": _masked(course_d, moving), "dash": "dot"}],
                     band=band, prefixes=prefixes, spans=spans, note=hover_note)
            bnds = []
            if gamma is not None:
                bnds = (self.line(gamma, "γ", kind="heading_margin_deg", unit="°")
                        + self.line(-gamma, "−γ", kind="heading_margin_deg", bare=True))
            self.add(f"sig-heading-error-{iv + 1}",
                     self.tag(v, "Heading error angdiff(ψ, course)"), "deg",
                     [{"name": self.tag(v, "ψ − course"), "y": _masked(err, moving)}],
                     bnds, prefixes=prefixes, spans=spans, note=hover_note)

    def distances(self) -> None:
        pos = {v: [channel(self.sol, f"{v}.pos.{a}") for a in "xyz"] for v in self.vehicles}
        arrs = {v: np.stack(p, axis=1) for v, p in pos.items()  # type: ignore[arg-type]
                if all(c is not None for c in p)}
        names = list(arrs)
        traces = [{"name": f"{a}–{b}", "y": nums(np.linalg.norm(arrs[a] - arrs[b], axis=1))}
                  for i, a in enumerate(names) for b in names[i + 1:]]
        dmin = self.bounds.get("distance_min")
        if dmin is None:
            dmin = pair(self.bounds.get("distance"))[0]
        self.add("sig-distance", "Distance between drones", "m", traces,
                 self.line(dmin, "Γ_dis", kind="distance_min", unit="m"),
                 specs=set(self.stated.get("distance_min", [])))

    def clearance(self) -> None:
        """Distance to the nearest obstacle, the radius as its limit, and its minimum (at
        the samples, and of the straight segments between them)."""
        from stlc.analysis.clearance import obstacle_clearance, segment_clearance

        traces, notes, radii = [], [], set()
        for v in self.vehicles:
            p = [channel(self.sol, f"{v}.pos.{a}") for a in "xyz"]
            veh = self.program.vehicles.get(v)
            if any(c is None for c in p) or veh is None:
                continue
            d = obstacle_clearance(self.program.scenario, np.stack(p, axis=1))
            if d is None:
                return
            r = float(getattr(veh, "radius", 0.0))
            radii.add(r)
            k = int(np.argmin(d))
            traces.append({"name": self.tag(v, "clearance"), "y": nums(d)})
            seg = segment_clearance(self.program.scenario, np.stack(p, axis=1))
            j = int(np.argmin(seg)) if seg is not None and seg.size else None
            between = "" if j is None else (
                f"; between samples {seg[j]:.3f} m at t = {self.t[j]:g}–{self.t[j + 1]:g} s"
                f"{'' if seg[j] >= r - 1e-9 and seg[j] > 1e-12 else ' (a corner cut)'}")
            notes.append(f"{v}: minimum clearance {d[k]:.3f} m at t = {self.t[k]:g} s "
                         f"(radius {r:g} m{'' if d[k] >= r - 1e-9 else ', BELOW it'}){between}")
        bnds = [b for r in sorted(radii) if r > 0 for b in self.line(r, "radius", unit="m")]
        self.add("sig-clearance", "Clearance to the nearest obstacle", "m", traces, bnds,
                 note="; ".join(notes), specs=set())

    def payload(self) -> None:
        traces = [{"name": v, "y": nums(c), "shape": "hv"} for v in self.vehicles
                  if (c := channel(self.sol, f"{v}.payload")) is not None]
        self.add("sig-payload", "Payload (items on board)", "", traces,
                 prefixes=tuple(f"{v}.payload" for v in self.vehicles))


def signals(program: Program, mission: Mission, sol: Solution, wins: list[dict],
            rows: list[dict], markers: list[dict]) -> dict:
    """The ``signals`` section of the view model (``wins`` from ``windows``, ``rows``: the
    requirements table, ``markers``: times at which a spec fails)."""
    formulas = spec_formulas(program, mission, sol)
    b = _Builder(program, mission, sol, formulas, wins)
    for step in (b.position, b.speed, b.point_mass_limits, b.rotors, b.forces, b.heading,
                 b.distances, b.clearance, b.payload):
        step()
    timeline = _timeline(rows, wins, float(b.t[-1]) if b.t.size else mission.horizon)
    return {"t": nums(b.t), "plots": b.plots, "windows": wins, "markers": markers,
            "timeline": timeline if b.t.size else None}
