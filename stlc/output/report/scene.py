"""The 3-D scene of the report: boxes with their world-frame corners, humans, trajectories.

A round region (cylinder, sphere, capsule) has ``shape`` its kind and ``mesh`` its triangle
mesh and outline (``meshes.round_mesh``); its ``corners`` are then the mesh's vertices (for
the top view's hull).  A box has ``shape: "box"`` and ``mesh: None``.

Regions in a human's frame are drawn at the human's nominal pose.  Regions that the mission
never mentions (e.g. the approach corridors of the file's other missions) are kept but
hidden (``visible: False``; the page shows them as toggles in the 3-D legend only).

A region's colour role comes from its declaration (workspace, obstacle, target, station,
home, a free region, a human's region) and, for a human's region, from how the mission
uses it — read from the origins of the predicates (``region_uses``), never from words in
its name: a human's region the mission only keeps out of is no-fly (the papers' "behind"),
one it must stay in for a while (a membership under an ``always`` of positive length, or
the left side of an ``until``) and never keeps out of is a visibility region, any other
is part of an approach.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from stlc.planning.solution import Solution
from stlc.semantics import ir, nnf
from stlc.semantics.model import Box, Human, Mission, Program
from stlc.semantics.origin import FACE

from .common import channel, drone_color, fmt, fmt_vec, nums, vehicles
from .meshes import round_mesh
from .predicates import mentioned

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
ROLE_LABELS = {"nofly": "no-fly", "visibility": "visibility", "approach": "approach",
               "target": "target", "station": "station", "home": "home",
               "workspace": "workspace", "region": "region"}
#: corner k of a box has x = hi iff bit 0 of k is set, y iff bit 1, z iff bit 2
CORNER_BITS = tuple((k & 1, (k >> 1) & 1, (k >> 2) & 1) for k in range(8))
#: drawing height of a human (m) and the height of the facing arrow
HUMAN_HEIGHT, ARROW_HEIGHT, ARROW_LENGTH = 1.75, 1.3, 0.6


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
        return [[x, y] for x, y in (nums(p) for p in pts)]

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
    return [nums(p) for p in ring]


def region_uses(formulas: list[ir.Formula]) -> dict[str, set[str]]:
    """Per declared region, how the formulas (taken to negation normal form) use its
    membership: ``out`` (kept out of), ``stay`` (inside over an interval: under an
    ``always`` of positive length or on the left of an ``until``/``release``), ``in``
    (inside at some instant).  Read from the predicates' origins (``ir.Pred.origin``)."""
    uses: dict[str, set[str]] = {}
    seen: set[tuple[int, bool]] = set()

    def walk(f: ir.Formula, stay: bool) -> None:
        if (id(f), stay) in seen:
            return
        seen.add((id(f), stay))
        match f:
            case ir.Pred(origin=o) if o is not None and o.kind == FACE and o.region:
                use = "out" if o.negated else "stay" if stay else "in"
                uses.setdefault(o.region, set()).add(use)
            case ir.Always(lo, hi, arg):
                walk(arg, stay or hi > lo)
            case ir.Eventually(_, _, arg):
                walk(arg, False)
            case ir.Until(_, _, a, b) | ir.Release(_, _, a, b):
                walk(a, True)
                walk(b, False)
            case _:
                for g in ir.children(f):
                    walk(g, stay)

    normal = [nnf.normalize(f) for f in formulas]  # kept alive: ``seen`` holds their ids
    for f in normal:
        walk(f, False)
    return uses


def region_role(kind: str, frame: str | None = None, uses: set[str] | frozenset = frozenset()
                ) -> str:
    """Colour role of a region: by its declared kind, then (a human's region, ``frame``)
    by the mission's ``uses`` of it (``region_uses``); see the module docstring."""
    if kind == "workspace":
        return "workspace"
    if kind == "obstacle":
        return "nofly"
    if kind in ("home", "station", "target"):
        return kind
    if frame is None:
        return "region"
    if uses and uses <= {"out"}:
        return "nofly"
    if "stay" in uses and "out" not in uses:
        return "visibility"
    return "approach"


def _extent(program: Program, pts: list[np.ndarray], humans: dict[str, Human]
            ) -> tuple[np.ndarray, np.ndarray]:
    ws = program.scenario.by_kind("workspace")
    if ws:
        lo, hi = np.asarray(ws[0].box.lo, float), np.asarray(ws[0].box.hi, float)
    else:
        lo, hi = np.full(3, np.inf), np.full(3, -np.inf)
    for arr in pts:
        lo, hi = np.minimum(lo, np.nanmin(arr, axis=0)), np.maximum(hi, np.nanmax(arr, axis=0))
    for h in humans.values():
        lo, hi = np.minimum(lo, h.pos), np.maximum(hi, h.pos)
    for r in program.scenario.regions:
        b = r.box
        if b.frame is None and all(map(math.isfinite, (*b.lo, *b.hi))):
            lo, hi = np.minimum(lo, b.lo), np.maximum(hi, b.hi)
    lo = np.where(np.isfinite(lo), lo, -1.0)
    hi = np.where(np.isfinite(hi), hi, 1.0)
    return lo, hi


def _human(h: Human) -> dict:
    pos = np.asarray(h.pos, float)
    yaw = float(h.att[2])
    ahead = np.array([math.cos(yaw), math.sin(yaw), 0.0])
    chest = pos + np.array([0.0, 0.0, ARROW_HEIGHT])
    return {
        "name": h.name, "pos": nums(pos),
        "head": nums(pos + np.array([0.0, 0.0, HUMAN_HEIGHT])),
        "chest": nums(chest), "facing_3d": nums(chest + ARROW_LENGTH * ahead),
        "facing": nums(pos + ARROW_LENGTH * ahead),
        "att_deg": nums(np.degrees(h.att), 4),
        "text": f"at {fmt_vec(h.pos)} m, attitude {fmt_vec(np.degrees(h.att))}°",
        "uncertain": bool(h.uncertain),
    }


def scene(program: Program, mission: Mission, sol: Solution) -> dict:
    """The ``scene`` section of the view model."""
    humans = {h.name: h for h in program.scenario.humans}
    trajs, pts = [], []
    t = nums(sol.times)
    for v in vehicles(mission, sol):
        xyz = [channel(sol, f"{v}.pos.{a}") for a in "xyz"]
        if any(c is None for c in xyz) or xyz[0].size == 0:  # type: ignore[union-attr]
            continue
        pts.append(np.stack(xyz, axis=1))  # type: ignore[arg-type]
        trajs.append({"vehicle": v, "x": nums(xyz[0]), "y": nums(xyz[1]),  # type: ignore
                      "z": nums(xyz[2]), "t": t,  # type: ignore[arg-type]
                      "color": drone_color(len(trajs))})
    lo, hi = _extent(program, pts, humans)
    formulas: list[ir.Formula] = [mission.requirement, *mission.specs.values()]
    used = mentioned(formulas)
    uses = region_uses(formulas)
    boxes = []
    for r in program.scenario.regions:
        role = region_role(r.kind, r.box.frame, uses.get(r.name, set()))
        corners = box_corners(r.box, humans, (lo, hi))
        mesh = None
        if r.box.shape is not None:  # a round region: its mesh and outline
            h = humans.get(r.box.frame) if r.box.frame else None
            mesh = round_mesh(r.box.shape, None if h is None else
                              (lambda v, h=h: np.asarray(h.pos, float) + v @ rotation(h.att).T))
            corners = mesh.pop("vertices")
        # workspace, obstacles, targets, stations, homes are always shown (a quantifier over
        # `targets` names none of them); free regions only when the mission mentions them
        visible = r.kind != "region" or r.name in used
        boxes.append({
            "name": r.name, "label": r.name.rsplit(".", 1)[-1] if r.box.frame else r.name,
            "kind": r.kind, "frame": r.box.frame, "role": role,
            "role_label": ROLE_LABELS[role], "color": COLORS[role],
            "wireframe": role == "workspace", "visible": visible,
            "corners": [nums(c) for c in corners],
            "hull_xy": hull_xy(corners),
            "shape": r.box.shape.kind if r.box.shape is not None else "box",
            "mesh": mesh,
        })
    hidden = [b["name"] for b in boxes if not b["visible"]]
    roles = list(dict.fromkeys((b["role_label"], b["color"]) for b in boxes
                               if b["visible"] and not b["wireframe"]))
    return {"boxes": boxes, "humans": [_human(h) for h in humans.values()],
            "trajectories": trajs, "per_drone": len(trajs) > 1,
            "extent": {"lo": nums(lo), "hi": nums(hi)},
            "roles": [{"label": lab, "color": c} for lab, c in roles],
            "hidden": hidden, "hidden_text": ", ".join(hidden),
            "duration_text": fmt(sol.times[-1] if len(sol.times) else None, unit="s")}
