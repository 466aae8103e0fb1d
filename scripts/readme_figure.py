"""Draw a compiled plan from above as a small SVG (the README's picture).

    python scripts/readme_figure.py FILE.stl MISSION TRAJECTORY.csv OUT.svg

The world's boxes (workspace, obstacles, the regions the mission's formulas mention; a
human's regions at the human's nominal pose) are drawn as their x–y outlines, the plan as
a polyline with its start and end marked.  Plain SVG, no plotting library.
"""

from __future__ import annotations

import csv
import sys
from html import escape

import numpy as np

import stlc
from stlc.output.report.predicates import mentioned
from stlc.output.report.scene import box_corners, hull_xy

COLORS = {"workspace": "#999999", "obstacle": "#d62728", "region": "#1f77b4",
          "target": "#2ca02c", "station": "#9467bd", "home": "#8c564b"}
SCALE, PAD = 80.0, 20.0  # pixels per metre, margin


def main(argv: list[str]) -> int:
    path, mission_name, trajectory, out = argv
    program = stlc.load(path)
    mission = program.missions[mission_name]
    with open(trajectory, newline="", encoding="utf-8") as fh:
        rows = list(csv.DictReader(fh))
    vehicle = mission.vehicles[0]
    xyz = np.array([[float(r[f"{vehicle}.pos.{a}"]) for a in "xyz"] for r in rows])
    xy = xyz[:, :2]
    humans = {h.name: h for h in program.scenario.humans}
    used = mentioned([mission.requirement, *mission.specs.values()])
    boxes = [(r, hull_xy(box_corners(r.box, humans, (xyz.min(0), xyz.max(0)))))
             for r in program.scenario.regions
             if r.kind in ("workspace", "obstacle") or r.name in used]
    ws = [np.array(h, float) for r, h in boxes if r.kind == "workspace"]
    pts = np.vstack([xy, *(p[:, :2] for p in ws)]) if ws else xy
    lo, hi = pts.min(0), pts.max(0)
    w, h = (hi - lo) * SCALE + 2 * PAD

    def px(p) -> str:  # y up in the world, down in SVG
        return f"{(p[0] - lo[0]) * SCALE + PAD:.1f},{(hi[1] - p[1]) * SCALE + PAD:.1f}"

    parts = [f'<svg xmlns="http://www.w3.org/2000/svg" width="{w:.0f}" height="{h:.0f}" '
             f'viewBox="0 0 {w:.0f} {h:.0f}" font-family="sans-serif" font-size="11">',
             f'<rect width="100%" height="100%" fill="white"/>']
    placed: list[np.ndarray] = []  # label positions: a label near another is left out
    for r, hull in boxes:
        color = COLORS.get(r.kind, "#1f77b4")
        fill = "none" if r.kind == "workspace" else color
        label = r.name.rsplit(".", 1)[-1]
        parts.append(f'<polygon points="{" ".join(px(p) for p in hull)}" fill="{fill}" '
                     f'fill-opacity="0.15" stroke="{color}" stroke-width="1"/>')
        c = np.array(hull[:-1], float).mean(0)
        if r.kind != "workspace" and all(np.abs(c - q).max() * SCALE > 24 for q in placed):
            placed.append(c)
            parts.append(f'<text x="{px(c).split(",")[0]}" y="{px(c).split(",")[1]}" '
                         f'fill="{color}" text-anchor="middle">{escape(label)}</text>')
    for hm in humans.values():
        x, y = px(hm.pos).split(",")
        parts.append(f'<circle cx="{x}" cy="{y}" r="6" fill="#ff7f0e"/>'
                     f'<text x="{x}" y="{float(y) + 18:.1f}" text-anchor="middle">'
                     f'{escape(hm.name)}</text>')
    parts.append(f'<polyline points="{" ".join(px(p) for p in xy)}" fill="none" '
                 f'stroke="black" stroke-width="2"/>')
    for p, name in ((xy[0], "start"), (xy[-1], "end")):
        x, y = px(p).split(",")
        parts.append(f'<circle cx="{x}" cy="{y}" r="4" fill="black"/>'
                     f'<text x="{float(x) + 6:.1f}" y="{float(y) - 6:.1f}">{name}</text>')
    parts.append(f'<text x="{PAD}" y="{h - 5:.0f}">{escape(mission_name)}: top view '
                 f'(x right, y up), {len(xy)} samples</text></svg>')
    with open(out, "w", encoding="utf-8") as fh:
        fh.write("\n".join(parts) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
