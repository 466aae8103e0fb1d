"""The report's view model: a plain, JSON-serialisable dict built from a ``Solution``.

``build_view(program, mission, solution)`` is the only place that looks at the program, the
mission and the solution; the templates and the page script see nothing but the dict it
returns (str, bool, int, float, None, lists and dicts).  Every float is rounded to about five
significant digits and non-finite numbers become ``None`` (the text fields say ``+∞``), so the
plot data can be written into the page with ``json.dumps(..., allow_nan=False)``.

Sections: ``summary``, ``banner`` (``None`` when the mission is satisfied), ``specs`` (the
requirements table), ``scene`` (3D boxes with their world-frame corners, humans and
trajectories), ``signals`` (plots over time with bounds and requirement windows), ``energy``,
``risk`` (``None`` without a risk analysis) and ``source`` (numbered lines, diagnostics).
"""

from __future__ import annotations

import math
import re
from collections.abc import Iterable, Sequence

import numpy as np

from stlc import ir
from stlc.model import Box, Human, Mission, Multirotor, Program
from stlc.solution import Solution

#: region colours (the papers' convention)
COLORS = {
    "nofly": "#d62728",
    "visibility": "#1f77b4",
    "approach": "#e6b400",
    "target": "#2ca02c",
    "station": "#9467bd",
    "home": "#7f7f7f",
    "workspace": "#555555",
    "region": "#17becf",
}
#: shading colours of requirement windows, cycled
WINDOW_COLORS = ("#1f77b4", "#ff7f0e", "#2ca02c", "#9467bd", "#8c564b", "#e377c2", "#17becf")
STATUS_LABELS = {"satisfied": "Satisfied", "violated": "Violated",
                 "solver_failed": "Solver failed"}
STAGE_LABELS = {"lam": "λ", "solve_s": "solve (s)", "smooth": "smooth ρ̃", "exact": "exact ρ"}
TIMING_ORDER = ("parse_s", "check_s", "build_s", "solve_s", "total_s")
#: corner k of a box has x = hi iff bit 0 of k is set, y iff bit 1, z iff bit 2
CORNER_BITS = tuple((k & 1, (k >> 1) & 1, (k >> 2) & 1) for k in range(8))


# --------------------------------------------------------------------------- numbers


def num(x: object, digits: int = 5) -> float | None:
    """Round to ``digits`` significant digits; ``None`` for missing or non-finite values."""
    if x is None:
        return None
    try:
        v = float(x)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        return None
    if not math.isfinite(v):
        return None
    return float(f"{v:.{digits}g}")


def nums(xs: Iterable[object], digits: int = 5) -> list[float | None]:
    """``num`` of every element (arrays are flattened)."""
    arr = xs if isinstance(xs, np.ndarray) else np.asarray(
        [np.nan if x is None else x for x in xs], dtype=float)
    return [num(x, digits) for x in arr.ravel().tolist()]


def fmt(x: object, digits: int = 4, signed: bool = False, unit: str = "") -> str:
    """Human-readable number: ``—`` when missing, ``+∞``/``−∞`` for infinities."""
    if x is None:
        return "—"
    try:
        v = float(x)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        return str(x)
    if math.isnan(v):
        return "NaN"
    if math.isinf(v):
        return "+∞" if v > 0 else "−∞"
    s = f"{v:+.{digits}g}" if signed else f"{v:.{digits}g}"
    s = s.replace("-", "−")
    return f"{s} {unit}" if unit else s


# --------------------------------------------------------------------------- geometry


def rotation(att: Sequence[float]) -> np.ndarray:
    """R = Rz(yaw) Ry(pitch) Rx(roll), body → world; ``att = (roll, pitch, yaw)`` in rad."""
    r, p, y = (float(a) for a in att)
    cr, sr, cp, sp, cy, sy = math.cos(r), math.sin(r), math.cos(p), math.sin(p), \
        math.cos(y), math.sin(y)
    rz = np.array([[cy, -sy, 0.0], [sy, cy, 0.0], [0.0, 0.0, 1.0]])
    ry = np.array([[cp, 0.0, sp], [0.0, 1.0, 0.0], [-sp, 0.0, cp]])
    rx = np.array([[1.0, 0.0, 0.0], [0.0, cr, -sr], [0.0, sr, cr]])
    return rz @ ry @ rx


def box_corners(box: Box, humans: dict[str, Human], clip: tuple[np.ndarray, np.ndarray]
                ) -> np.ndarray:
    """The 8 world-frame corners of ``box`` (index bits as in ``CORNER_BITS``).

    Infinite bounds are clipped to ``clip`` (the drawing extent); a box in a human's frame is
    moved by that human's nominal pose: corner_world = pos + R(att) · corner_local.
    """
    lo, hi = np.asarray(box.lo, float), np.asarray(box.hi, float)
    if box.frame is None:
        lo, hi = np.where(np.isfinite(lo), lo, clip[0]), np.where(np.isfinite(hi), hi, clip[1])
    else:  # an unbounded side of a box in a human's frame: as far as the scene reaches
        reach = float(np.max(clip[1] - clip[0]))
        lo, hi = np.where(np.isfinite(lo), lo, -reach), np.where(np.isfinite(hi), hi, reach)
    local = np.array([[(hi if b else lo)[i] for i, b in enumerate(bits)]
                      for bits in CORNER_BITS])
    human = humans.get(box.frame) if box.frame else None
    if human is None:
        return local
    return np.asarray(human.pos, float) + local @ rotation(human.att).T


def hull_xy(points: np.ndarray) -> list[list[float | None]]:
    """Convex hull of the points' x–y projection (monotone chain), closed polygon."""
    pts = sorted({(float(p[0]), float(p[1])) for p in points})
    if len(pts) < 3:
        return [[num(x), num(y)] for x, y in pts]

    def cross(o, a, b):
        return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])

    lower: list[tuple[float, float]] = []
    for p in pts:
        while len(lower) >= 2 and cross(lower[-2], lower[-1], p) <= 0:
            lower.pop()
        lower.append(p)
    upper: list[tuple[float, float]] = []
    for p in reversed(pts):
        while len(upper) >= 2 and cross(upper[-2], upper[-1], p) <= 0:
            upper.pop()
        upper.append(p)
    ring = lower[:-1] + upper[:-1]
    ring.append(ring[0])
    return [[num(x), num(y)] for x, y in ring]


def region_role(name: str, kind: str, frame: str | None = None) -> str:
    """Colour role of a region: by kind first, then by the words in its name (without a
    ``human.`` prefix); any other region attached to a human is part of an approach."""
    if kind == "workspace":
        return "workspace"
    if kind == "obstacle":
        return "nofly"
    if kind in ("home", "station"):
        return kind
    low = name.lower().rsplit(".", 1)[-1]
    flat = re.sub(r"[^a-z]", "", low)
    words = set(re.split(r"[^a-z]+", low))
    if "behind" in flat or "nofly" in flat:
        return "nofly"
    if "vis" in flat:
        return "visibility"
    if ("handover" in flat or "approach" in flat or words & {"ho", "pr"}
            or re.search(r"(^|[^a-z])(ho|pr)\d", low) or flat.startswith("pref")):
        return "approach"
    if kind == "target":
        return "target"
    return "approach" if frame else "region"


ROLE_LABELS = {"nofly": "no-fly", "visibility": "visibility", "approach": "approach",
               "target": "target", "station": "station", "home": "home",
               "workspace": "workspace", "region": "region"}


# --------------------------------------------------------------------------- helpers


def _channel(sol: Solution, name: str) -> np.ndarray | None:
    c = sol.channels.get(name)
    return None if c is None else np.asarray(c, dtype=float).ravel()


def _indexed(sol: Solution, prefix: str) -> list[tuple[str, np.ndarray]]:
    """Channels ``prefix.1``, ``prefix.2``, … in numeric order."""
    found = []
    for name, arr in sol.channels.items():
        if name.startswith(prefix + ".") and name[len(prefix) + 1:].isdigit():
            found.append((int(name[len(prefix) + 1:]), name, np.asarray(arr, float).ravel()))
    return [(n, a) for _, n, a in sorted(found)]


def _vehicles(mission: Mission, sol: Solution) -> list[str]:
    names = list(mission.vehicles)
    for ch in sol.channels:
        if ch.endswith(".pos.x") and ch[:-6] not in names:
            names.append(ch[:-6])
    return names


def _pair(v: object) -> tuple[float | None, float | None]:
    if v is None:
        return None, None
    if isinstance(v, (int, float)):
        return None, float(v)
    if isinstance(v, dict):
        return v.get("min"), v.get("max")
    vals = list(v)  # type: ignore[arg-type]
    if len(vals) == 1:
        return None, vals[0]
    return vals[0], vals[1]


def _cell(v: object) -> str:
    if isinstance(v, bool) or v is None or isinstance(v, str):
        return "—" if v is None else str(v)
    if isinstance(v, int):
        return str(v)
    return fmt(v)


def _spec_line(program: Program, mission: Mission, name: str, given: int) -> int:
    if given:
        return given
    for spans in (mission.spec_spans, program.spec_spans):
        sp = spans.get(name)
        if sp is not None and sp.known:
            return sp.line
    return 0


def _predicate_line(formula: ir.Formula | None, label: str) -> int:
    if formula is None or not label:
        return 0
    for p in ir.predicates(formula):
        if p.label in (label, f"not ({label})") or f"not ({p.label})" == label:
            if p.span.known:
                return p.span.line
    return 0


def _anchor(line: int, n_lines: int) -> str:
    return f"L{line}" if 0 < line <= n_lines else ""


# --------------------------------------------------------------------------- sections


def _summary(program: Program, mission: Mission, sol: Solution) -> dict:
    smoothing = {"method": mission.smoothing.method, **sol.smoothing}
    declared = smoothing.get("lambda", smoothing.get("lam", mission.smoothing.lam))
    lam = smoothing.get("lambda_final", smoothing.get("lam", declared))
    lam_text = fmt(lam)
    if num(declared) is not None and num(lam) != num(declared):
        lam_text += f" (declared {fmt(declared)})"
    timing = [{"name": k.removesuffix("_s"), "text": fmt(sol.timing[k], 3, unit="s")}
              for k in (*TIMING_ORDER, *sorted(set(sol.timing) - set(TIMING_ORDER)))
              if k in sol.timing]
    solver_extra = [{"name": str(k), "text": str(v)} for k, v in sol.solver.items()
                    if k not in ("name", "iterations", "return_status", "stages")]
    stages = [s if isinstance(s, dict) else vars(s) for s in sol.solver.get("stages") or []
              if isinstance(s, dict) or hasattr(s, "__dict__")]
    stage_keys = list(dict.fromkeys(k for s in stages for k in s))
    n = len(sol.times)
    return {
        "mission": sol.mission or mission.name,
        "file": program.file,
        "status": sol.status,
        "status_label": STATUS_LABELS.get(sol.status, sol.status),
        "robustness_exact": num(sol.robustness_exact),
        "robustness_exact_text": fmt(sol.robustness_exact, signed=True),
        "robustness_smooth": num(sol.robustness_smooth),
        "robustness_smooth_text": fmt(sol.robustness_smooth, signed=True),
        "threshold_text": fmt(mission.threshold),
        "energy": num(sol.energy),
        "energy_text": fmt(sol.energy, 5),
        "vehicles": [{"name": v, "kind": getattr(program.vehicles.get(v), "kind", "?")}
                     for v in mission.vehicles],
        "horizon_text": fmt(mission.horizon, unit="s"),
        "step_text": fmt(mission.step, unit="s"),
        "samples": n,
        "timing": timing,
        "solve_text": fmt(sol.timing.get("solve_s"), 3, unit="s"),
        "total_text": fmt(sol.timing.get("total_s"), 3, unit="s"),
        "solver_name": str(sol.solver.get("name", "—")),
        "iterations": str(sol.solver.get("iterations", "—")),
        "return_status": str(sol.solver.get("return_status", "—")),
        "solver_extra": solver_extra,
        "smoothing_method": str(smoothing.get("method", "—")),
        "smoothing_lam_text": lam_text,
        "smoothing_schedule": ", ".join(fmt(x) for x in smoothing.get("schedule") or []),
        "problem_size": [{"name": str(k), "text": str(v)} for k, v in sol.problem_size.items()],
        "stages": {"columns": [STAGE_LABELS.get(k, k) for k in stage_keys],
                   "rows": [[_cell(s.get(k)) for k in stage_keys] for s in stages]},
        "objective": {
            "robustness_weight_text": fmt(mission.objective.robustness_weight),
            "energy_weight_text": fmt(mission.objective.energy_weight),
        },
        "notes": [str(x) for x in sol.notes],
    }


def _spec_rows(program: Program, mission: Mission, sol: Solution,
               windows: list[dict]) -> list[dict]:
    n_lines = len(program.source.splitlines())
    rows = []
    for name, r in sol.specs.items():
        line = _spec_line(program, mission, name, r.line)
        formula = mission.specs.get(name) or program.specs.get(name)
        pline = _predicate_line(formula, r.binding_predicate)
        win = [w for w in windows if w["spec"] == name]
        rows.append({
            "name": name,
            "robustness": num(r.robustness),
            "robustness_text": fmt(r.robustness, signed=True),
            "smooth_text": fmt(r.smooth, signed=True),
            "satisfied": bool(r.satisfied),
            "verdict": "satisfied" if r.satisfied else "violated",
            "tightest_time": num(r.tightest_time),
            "tightest_text": fmt(r.tightest_time, unit="s") if r.tightest_time is not None
            else "—",
            "binding_predicate": r.binding_predicate or "—",
            "line": line,
            "anchor": _anchor(line, n_lines),
            "predicate_line": pline,
            "predicate_anchor": _anchor(pline, n_lines),
            "window_text": ", ".join(w["text"] for w in win) or "—",
        })
    worst = max((abs(row["robustness"]) for row in rows if row["robustness"] is not None),
                default=0.0) or 1.0
    for row in rows:
        rho = row["robustness"]
        row["bar"] = 0.0 if rho is None else round(min(1.0, abs(rho) / worst) * 100, 1)
    return rows


def _banner(sol: Solution, rows: list[dict]) -> dict | None:
    if sol.status == "satisfied":
        return None
    failing = [r for r in rows if not r["satisfied"]]
    worst = min(failing or rows, key=lambda r: (r["robustness"] is None, r["robustness"] or 0),
                default=None)
    if sol.status == "solver_failed":
        title = "Solver failed"
        lead = (f"{sol.solver.get('name', 'The solver')} stopped with return status "
                f"“{sol.solver.get('return_status', 'unknown')}” after "
                f"{sol.solver.get('iterations', '?')} iterations; the plan below is its last "
                f"iterate.")
    else:
        title = "Mission violated"
        lead = (f"No satisfying plan was found: exact robustness "
                f"{fmt(sol.robustness_exact, signed=True)} < 0.")
    out = {"status": sol.status, "title": title, "lead": lead, "spec": None}
    if worst is not None and not worst["satisfied"]:
        out["spec"] = {k: worst[k] for k in ("name", "robustness_text", "tightest_text",
                                              "binding_predicate", "anchor",
                                              "predicate_anchor")}
        out["spec"]["margin_text"] = fmt(-(worst["robustness"] or 0.0)) \
            if worst["robustness"] is not None else fmt(math.inf)
    return out


def _windows(program: Program, mission: Mission, sol: Solution) -> list[dict]:
    given = sol.extra.get("windows") or []
    out = []
    if given:
        for w in given:
            out.append({"spec": str(w.get("spec", "")), "start": num(w.get("start")),
                        "end": num(w.get("end"))})
    else:  # derive from the outermost temporal operator of each spec
        for name in sol.specs:
            f = mission.specs.get(name) or program.specs.get(name)
            if isinstance(f, ir.Always | ir.Eventually | ir.Until | ir.Release):
                out.append({"spec": name, "start": num(f.lo),
                            "end": num(min(f.hi, mission.horizon))})
    colors: dict[str, str] = {}
    for w in out:
        colors.setdefault(w["spec"], WINDOW_COLORS[len(colors) % len(WINDOW_COLORS)])
        w["color"] = colors[w["spec"]]
        w["text"] = f"[{fmt(w['start'])}, {fmt(w['end'])}] s"
    return [w for w in out if w["start"] is not None and w["end"] is not None]


def _scene(program: Program, mission: Mission, sol: Solution) -> dict:
    humans = {h.name: h for h in program.scenario.humans}
    trajs = []
    pts = []
    t = nums(sol.times)
    for v in _vehicles(mission, sol):
        xyz = [_channel(sol, f"{v}.pos.{a}") for a in "xyz"]
        if any(c is None for c in xyz):
            continue
        pts.append(np.stack(xyz, axis=1))
        trajs.append({"vehicle": v, "x": nums(xyz[0]), "y": nums(xyz[1]), "z": nums(xyz[2]),
                      "t": t})
    ws = program.scenario.by_kind("workspace")
    if ws:
        lo = np.asarray(ws[0].box.lo, float)
        hi = np.asarray(ws[0].box.hi, float)
    else:
        lo, hi = np.full(3, np.inf), np.full(3, -np.inf)
    for arr in pts:
        lo, hi = np.minimum(lo, arr.min(axis=0)), np.maximum(hi, arr.max(axis=0))
    for h in humans.values():
        lo, hi = np.minimum(lo, h.pos), np.maximum(hi, h.pos)
    finite = [r.box for r in program.scenario.regions
              if r.box.frame is None and all(map(math.isfinite, (*r.box.lo, *r.box.hi)))]
    for b in finite:
        lo, hi = np.minimum(lo, b.lo), np.maximum(hi, b.hi)
    lo = np.where(np.isfinite(lo), lo, -1.0)
    hi = np.where(np.isfinite(hi), hi, 1.0)
    clip = (lo, hi)
    boxes = []
    for r in program.scenario.regions:
        role = region_role(r.name, r.kind, r.box.frame)
        corners = box_corners(r.box, humans, clip)
        boxes.append({
            "name": r.name, "label": r.name.rsplit(".", 1)[-1] if r.box.frame else r.name,
            "kind": r.kind, "frame": r.box.frame, "role": role,
            "role_label": ROLE_LABELS[role], "color": COLORS[role],
            "wireframe": role == "workspace",
            "corners": [nums(c) for c in corners],
            "hull_xy": hull_xy(corners),
        })
    people = []
    for h in humans.values():
        yaw = h.att[2]
        people.append({
            "name": h.name, "pos": nums(h.pos),
            "att_deg": nums(np.degrees(h.att), 4),
            "facing": nums(np.asarray(h.pos) + 0.6 * np.array([math.cos(yaw), math.sin(yaw),
                                                               0.0])),
            "uncertain": bool(h.uncertain),
        })
    return {"boxes": boxes, "humans": people, "trajectories": trajs,
            "extent": {"lo": nums(lo), "hi": nums(hi)}}


def _signals(program: Program, mission: Mission, sol: Solution, windows: list[dict],
             markers: list[dict]) -> dict:
    bounds = dict(sol.extra.get("bounds") or {})
    vehicles = _vehicles(mission, sol)
    multi = len(vehicles) > 1
    plots: list[dict] = []

    def tag(v: str, s: str) -> str:
        return f"{v} {s}" if multi else s

    def line(value: object, label: str, style: str = "limit") -> list[dict]:
        v = num(value)
        return [] if v is None else [{"value": v, "label": label, "style": style}]

    def plot(pid: str, title: str, unit: str, traces: list[dict], bnds: list[dict] = (),
             band: dict | None = None) -> None:
        if traces:
            plots.append({"id": pid, "title": title, "unit": unit, "traces": traces,
                          "bounds": list(bnds), "band": band})

    # position
    traces = []
    for v in vehicles:
        for a in "xyz":
            c = _channel(sol, f"{v}.pos.{a}")
            if c is not None:
                traces.append({"name": tag(v, a), "y": nums(c)})
    plot("sig-position", "Position", "m", traces)

    # speed
    traces = []
    for v in vehicles:
        c = _channel(sol, f"{v}.speed")
        vel = [_channel(sol, f"{v}.vel.{a}") for a in "xyz"]
        if c is None and all(x is not None for x in vel):
            c = np.linalg.norm(np.stack(vel), axis=0)
        if c is not None:
            traces.append({"name": tag(v, "speed"), "y": nums(c)})
    lo, hi = _pair(bounds.get("speed"))
    plot("sig-speed", "Speed", "m/s", traces,
         line(lo, "Γ_vel min") + line(hi, "Γ_vel max"))

    # rotor speeds (with Γ_pro and the force limits mapped to rotor speed)
    traces, bnds = [], []
    lo, hi = _pair(bounds.get("rotor_speed"))
    bnds += line(lo, "Γ_pro min") + line(hi, "Γ_pro max")
    f_lo, f_hi = _pair(bounds.get("force"))
    for v in vehicles:
        for name, c in _indexed(sol, f"{v}.rotor_speed"):
            traces.append({"name": tag(v, "rotor " + name.rsplit(".", 1)[1]), "y": nums(c)})
        veh = program.vehicles.get(v)
        if isinstance(veh, Multirotor) and veh.c_f > 0 and _indexed(sol, f"{v}.rotor_speed"):
            lo_f = veh.force_min if f_lo is None else f_lo
            hi_f = veh.force_max if f_hi is None else f_hi
            if not any(b["label"].startswith("force") for b in bnds):
                if lo_f is not None and lo_f > 0:
                    bnds += line(math.sqrt(lo_f / veh.c_f), "force min", "soft")
                if hi_f is not None and hi_f > 0:
                    bnds += line(math.sqrt(hi_f / veh.c_f), "force max", "soft")
    plot("sig-rotor", "Rotor speeds", "Hz", traces, bnds)

    # rotor forces
    traces, bnds = [], []
    for v in vehicles:
        for name, c in _indexed(sol, f"{v}.force"):
            traces.append({"name": tag(v, "ξ" + name.rsplit(".", 1)[1]), "y": nums(c)})
        veh = program.vehicles.get(v)
        if f_lo is None and isinstance(veh, Multirotor):
            f_lo, f_hi = veh.force_min, veh.force_max
    plot("sig-force", "Rotor forces", "N", traces,
         line(f_lo, "ξ min") + line(f_hi, "ξ max"))

    # heading vs direction of motion
    gamma = num(bounds.get("heading_margin_deg"))
    for iv, v in enumerate(vehicles):
        heading = _channel(sol, f"{v}.heading")
        if heading is None:
            heading = _channel(sol, f"{v}.att.z")
        course = _channel(sol, f"{v}.course")
        vx, vy = _channel(sol, f"{v}.vel.x"), _channel(sol, f"{v}.vel.y")
        if course is None and vx is not None and vy is not None:
            course = np.arctan2(vy, vx)
        if heading is None or course is None:
            continue
        course_u = np.unwrap(course)
        diff = (heading - course + np.pi) % (2 * np.pi) - np.pi
        heading_u = course_u + diff
        traces = [{"name": tag(v, "heading ψ"), "y": nums(np.degrees(heading_u))},
                  {"name": tag(v, "direction of motion"), "y": nums(np.degrees(course_u)),
                   "dash": "dot"}]
        band = None
        if gamma is not None:
            band = {"name": f"±γ = {fmt(gamma)}°",
                    "lower": nums(np.degrees(course_u) - gamma),
                    "upper": nums(np.degrees(course_u) + gamma)}
        plot(f"sig-heading-{iv + 1}", tag(v, "Heading vs direction of motion"), "deg",
             traces, band=band)

    # distance between drones
    traces = []
    pos = {v: [_channel(sol, f"{v}.pos.{a}") for a in "xyz"] for v in vehicles}
    pos = {v: np.stack(p, axis=1) for v, p in pos.items() if all(c is not None for c in p)}
    names = list(pos)
    for i, a in enumerate(names):
        for b in names[i + 1:]:
            d = np.linalg.norm(pos[a] - pos[b], axis=1)
            traces.append({"name": f"{a}–{b}", "y": nums(d)})
    dmin = bounds.get("distance_min")
    if dmin is None:
        dmin = _pair(bounds.get("distance"))[0]
    plot("sig-distance", "Distance between drones", "m", traces, line(dmin, "Γ_dis"))

    # payload
    traces = []
    for v in vehicles:
        c = _channel(sol, f"{v}.payload")
        if c is not None:
            traces.append({"name": tag(v, "payload") if multi else v, "y": nums(c),
                           "shape": "hv"})
    plot("sig-payload", "Payload (diverters on board)", "", traces)

    return {"t": nums(sol.times), "plots": plots, "windows": windows, "markers": markers}


def _energy(mission: Mission, sol: Solution) -> dict:
    t = np.asarray(sol.times, float)
    profile = sol.extra.get("energy_profile")
    prof = None if profile is None else np.asarray(profile, float).ravel()
    cumulative = None
    if prof is not None and prof.size:
        per_sample = abs(prof.sum() - sol.energy) <= abs(prof[-1] - sol.energy)
        cumulative = nums(np.cumsum(prof)) if per_sample else None

    def axis(n: int) -> list[float | None]:
        return nums(t) if n == t.size else nums(np.arange(n) * mission.step)

    speed = [c for v in _vehicles(mission, sol)
             if (c := _channel(sol, f"{v}.speed")) is not None]
    if not speed:
        for v in _vehicles(mission, sol):
            vel = [_channel(sol, f"{v}.vel.{a}") for a in "xyz"]
            if all(x is not None for x in vel):
                speed.append(np.linalg.norm(np.stack(vel), axis=0))
    rotor = [c for v in _vehicles(mission, sol) for _, c in _indexed(sol, f"{v}.rotor_speed")]
    label = str(sol.extra.get("label") or f"this plan (w = {fmt(mission.objective.energy_weight)})")
    plans = [{"label": label, "energy": sol.energy, "robustness_exact": sol.robustness_exact,
              "peak_speed": max((float(np.max(s)) for s in speed if s.size), default=None),
              "peak_rotor_speed": max((float(np.max(r)) for r in rotor if r.size),
                                      default=None),
              "energy_profile": profile}]
    plans += [dict(c) for c in sol.extra.get("comparisons") or []]
    profiles = []
    for p in plans:
        ep = p.get("energy_profile")
        if ep is not None and len(ep):
            profiles.append({"name": str(p.get("label", "")), "x": axis(len(ep)), "y": nums(ep)})
    columns = [{"label": str(p.get("label", "")),
                "energy_text": fmt(p.get("energy"), 5),
                "robustness_text": fmt(p.get("robustness_exact"), signed=True),
                "peak_speed_text": fmt(p.get("peak_speed"), unit="m/s"),
                "peak_rotor_speed_text": fmt(p.get("peak_rotor_speed"), unit="Hz")}
               for p in plans]
    return {
        "total": num(sol.energy), "total_text": fmt(sol.energy, 5),
        "has_profile": prof is not None and prof.size > 0,
        "has_comparison": len(plans) > 1,
        "profiles": profiles,
        "cumulative": None if cumulative is None else {"x": axis(len(cumulative)),
                                                       "y": cumulative},
        "columns": columns,
    }


def _risk(risk: object) -> dict | None:
    if not isinstance(risk, dict) or not risk.get("cases"):
        return None
    cases = []
    for i, c in enumerate(risk["cases"]):
        var, cvar = c.get("var") or {}, c.get("cvar") or {}
        betas = sorted(set(var) | set(cvar), key=lambda b: float(b))
        rows = []
        for b in betas:
            v, cv = var.get(b) or {}, cvar.get(b) or {}
            rows.append({"beta": str(b),
                         "var_text": fmt(v.get("value"), signed=True),
                         "var_lower_text": fmt(v.get("lower"), signed=True),
                         "var_upper_text": fmt(v.get("upper"), signed=True),
                         "cvar_text": fmt(cv.get("value"), signed=True),
                         "cvar_lower_text": fmt(cv.get("lower"), signed=True),
                         "cvar_upper_text": fmt(cv.get("upper"), signed=True),
                         "var": num(v.get("value"))})
        pv = c.get("p_violation") or {}
        drivers = c.get("drivers") or {}
        specs = []
        for k, sp in (c.get("specs") or {}).items():
            sp = sp if isinstance(sp, dict) else {"p_violation": sp}
            share = sp.get("driver_fraction", (drivers.get(k) or {}).get("fraction"))
            specs.append({"name": str(k), "p": num(sp.get("p_violation")),
                          "p_text": fmt(sp.get("p_violation")),
                          "p_upper_text": fmt(sp.get("p_violation_upper")),
                          "share_text": "—" if share is None else f"{100 * float(share):.0f} %"})
        specs.sort(key=lambda r: -(r["p"] if r["p"] is not None else -1.0))
        driver = c.get("driver")
        if isinstance(driver, dict):
            driver = driver.get("spec") or driver.get("name")
        if not driver and drivers:
            best = max(drivers.items(), key=lambda kv: (kv[1] or {}).get("count", 0))
            driver = best[0] if (best[1] or {}).get("count") else None
        if not driver and specs and specs[0]["p"]:
            driver = specs[0]["name"]
        hist = c.get("histogram") or {}
        edges = np.asarray(hist.get("edges") or [], float)
        counts = list(hist.get("counts") or [])
        histogram = None
        if edges.size >= 2 and len(counts) == edges.size - 1:
            histogram = {"centers": nums((edges[:-1] + edges[1:]) / 2),
                         "widths": nums(np.diff(edges)), "counts": nums(counts)}
        cases.append({
            "id": f"risk-{i}", "name": str(c.get("name", f"case {i + 1}")),
            "K": str(c.get("K", "—")), "delta": fmt(c.get("delta")),
            "seed": str(c.get("seed", "—")),
            "rows": rows,
            "var_lines": [{"beta": r["beta"], "value": r["var"]} for r in rows
                          if r["var"] is not None],
            "p_violation_text": fmt(pv.get("value")),
            "p_violation_upper_text": fmt(pv.get("upper")),
            "specs": specs,
            "driver": str(driver) if driver else "—",
            "epsilon_text": fmt(c.get("epsilon")),
            "nominal_text": fmt(c.get("nominal_robustness"), signed=True),
            "range_text": (f"mean {fmt(c.get('mean'), signed=True)}, min "
                           f"{fmt(c.get('min'), signed=True)}, max "
                           f"{fmt(c.get('max'), signed=True)}") if "mean" in c else "",
            "histogram": histogram,
        })
    return {"cases": cases}


def _source(program: Program, mission: Mission, sol: Solution, rows: list[dict]) -> dict:
    text = program.source.splitlines()
    spec_lines = {r["line"] for r in rows}
    fail_lines = {r["line"] for r in rows if not r["satisfied"]} | \
        {r["predicate_line"] for r in rows if not r["satisfied"]}
    diags = []
    for d in sol.extra.get("diagnostics") or []:
        if isinstance(d, dict):
            line = int(d.get("line") or 0)
            diags.append({"code": str(d.get("code", "")), "severity": str(d.get("severity",
                                                                                "error")),
                          "message": str(d.get("message", "")), "line": line,
                          "anchor": _anchor(line, len(text)),
                          "help": str(d.get("help") or "")})
        else:
            diags.append({"code": "", "severity": "note", "message": str(d), "line": 0,
                          "anchor": "", "help": ""})
    diag_lines = {d["line"] for d in diags}
    m_lo, m_hi = (mission.span.line, mission.span.end_line) if mission.span.known else (0, -1)
    lines = []
    for n, s in enumerate(text, start=1):
        cls = []
        if m_lo <= n <= m_hi:
            cls.append("in-mission")
        if n in spec_lines:
            cls.append("spec")
        if n in fail_lines:
            cls.append("fail")
        if n in diag_lines:
            cls.append("diag")
        lines.append({"n": n, "id": f"L{n}", "text": s, "cls": " ".join(cls)})
    return {"file": program.file, "lines": lines, "diagnostics": diags}


# --------------------------------------------------------------------------- entry point


def build_view(program: Program, mission: Mission, solution: Solution) -> dict:
    """Everything the report shows, as plain JSON-serialisable data."""
    windows = _windows(program, mission, solution)
    rows = _spec_rows(program, mission, solution, windows)
    markers = [{"spec": r["name"], "t": r["tightest_time"], "label": f"{r['name']} fails"}
               for r in rows if not r["satisfied"] and r["tightest_time"] is not None]
    summary = _summary(program, mission, solution)
    return {
        "title": f"{summary['mission']} — stlc mission report",
        "summary": summary,
        "banner": _banner(solution, rows),
        "specs": rows,
        "scene": _scene(program, mission, solution),
        "signals": _signals(program, mission, solution, windows, markers),
        "energy": _energy(mission, solution),
        "risk": _risk(solution.extra.get("risk")),
        "source": _source(program, mission, solution, rows),
    }
