"""Round regions and distances (``cylinder``, ``sphere``, ``capsule``, ``dist(p, R)``).

* the tower inspection (``specs/tower_inspection.stl``) monitored exactly on a trace whose
  distances are computed here by hand (closed form: radial distance minus the radius, the
  corner above the rim by Pythagoras);
* the same mission planned satisfied by ``stlc compile``; every sample of the written
  ``trajectory.csv`` is in the 2–4 m band and ≥ the vehicle radius from the tower, by a
  distance computed here from the file;
* the report's scene draws the tower as a cylinder mesh: every vertex on its surface;
* the checker's diagnostics for bad arguments; units; a round region in a human's frame;
  the vehicle radius grows a round obstacle as it grows a box.
"""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from stlc.analysis import monitor
from stlc.analysis.trace import read_trace
from stlc.frontend.syntax import parse
from stlc.semantics.check import check
from stlc.semantics.shapes import Round

ROOT = Path(__file__).resolve().parent.parent
TOWER = ROOT / "specs" / "tower_inspection.stl"
#: the tower: centre (0, 0, 5), radius 1.5, height 10 (z from 0 to 10)


def _program(text: str):
    return check(parse(text, "<geom>"))


def _errors(text: str) -> list[str]:
    from stlc.diagnostics import StlcError

    try:
        _program(text)
    except StlcError as e:
        return [d.code for d in e.diagnostics]
    return []


# ------------------------------------------------------------------ monitored by hand

#: (x, y, z) and the distance to the tower's surface, by hand
HAND = [
    ((-4.5, 0.0, 2.0), 3.0),                       # beside: 4.5 − 1.5
    ((0.0, 4.0, 11.0), math.hypot(2.5, 1.0)),      # above the rim: (4 − 1.5, 11 − 10)
    ((3.0, 4.0, 5.0), 3.5),                        # radial 5
    ((2.4, 3.2, 9.0), 2.5),                        # radial 4
    ((-3.0, 0.0, 6.0), 1.5),                       # radial 3: in front of the band
    ((0.0, 0.0, 10.5), 0.5),                       # straight above the top
]


def _trace_csv(path: Path, pts) -> None:
    rows = ["t,uav1.pos.x,uav1.pos.y,uav1.pos.z"]
    rows += [f"{k * 1.0:g},{x!r},{y!r},{z!r}" for k, (x, y, z) in enumerate(pts)]
    path.write_text("\n".join(rows) + "\n")


def test_band_monitored_against_hand_computed_distances(tmp_path):
    prog = check(parse(TOWER.read_text(), str(TOWER)))
    band = prog.missions["inspect"].specs["band"]
    pts = [p for p, _ in HAND]
    ch = {f"uav1.pos.{a}": np.array([p[i] for p in pts]) for i, a in enumerate("xyz")}
    d = np.array([d for _, d in HAND])
    hand = np.minimum(d - 2.0, 4.0 - d)  # the band at each sample, by hand
    sig = monitor.robustness_signal(band, 1.0, ch, prog.params)
    assert sig[0] == pytest.approx(hand.min(), abs=1e-12)  # always[0, 16]: the worst
    # the first four samples alone are in the band: min over d = 3, 2.69, 3.5, 2.5 of
    # min(d − 2, 4 − d) = 0.5 (at 3.5 and at 2.5)
    first = {k: v[:4] for k, v in ch.items()}
    assert monitor.robustness(band, 1.0, first, prog.params) == pytest.approx(0.5, abs=1e-12)
    assert hand.min() == pytest.approx(-1.5)  # 0.5 m above the top: 1.5 m short of the band


def test_monitor_cli_json_on_hand_trace(tmp_path):
    src = tmp_path / "band.stl"
    src.write_text(TOWER.read_text())
    trace = tmp_path / "t.csv"
    _trace_csv(trace, [p for p, _ in HAND[:4]])
    r = subprocess.run([sys.executable, "-m", "stlc", "monitor", str(src), "--trace",
                        str(trace), "--json"], capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    specs = json.loads(r.stdout)["specs"]
    band = next(v for k, v in specs.items() if k.endswith("band"))
    assert band["robustness"] == pytest.approx(0.5, abs=1e-9)
    clear = next(v for k, v in specs.items() if k.endswith("clear"))
    # `not in tower` grows the tower by the 0.3 m radius: worst sample 2.5 − 0.3 (radial 4)
    assert clear["robustness"] == pytest.approx(2.5 - 0.3, abs=1e-9)


# ------------------------------------------------------------------ planned


@pytest.fixture(scope="module")
def planned(tmp_path_factory):
    out = tmp_path_factory.mktemp("tower")
    r = subprocess.run([sys.executable, "-m", "stlc", "compile", str(TOWER), "-o", str(out),
                        "-q", "--no-risk"], capture_output=True, text=True, timeout=600)
    return r, out


def test_tower_inspection_planned_satisfied(planned):
    r, out = planned
    assert r.returncode == 0, r.stderr
    sol = json.loads((out / "solution.json").read_text())
    assert sol["status"] == "satisfied"
    assert sol["robustness"]["exact"] >= 0.05  # κ
    tr = read_trace(str(out / "trajectory.csv"))
    P = np.stack([tr.channels[f"uav1.pos.{a}"] for a in "xyz"], axis=1)
    radial = np.hypot(P[:, 0], P[:, 1])
    assert np.all(P[:, 2] <= 10.0)  # never above the top: the distance is radial − 1.5
    d = radial - 1.5
    assert d.min() >= 2.0 + 0.05 - 1e-6 and d.max() <= 4.0 - 0.05 + 1e-6
    # it reached the sphere around (0, 3.5, 9) of radius 0.8
    assert np.min(np.linalg.norm(P - [0.0, 3.5, 9.0], axis=1)) <= 0.8 - 0.05 + 1e-6
    assert any("polyhedral" in n for n in sol["notes"])  # the MILP's direction, stated


def test_scene_draws_the_cylinder(planned):
    from stlc.output.report.scene import scene
    from stlc.planning.solution import Solution

    r, out = planned
    assert r.returncode == 0, r.stderr
    prog = check(parse(TOWER.read_text(), str(TOWER)))
    mission = prog.missions["inspect"]
    tr = read_trace(str(out / "trajectory.csv"))
    sol = Solution(mission="inspect", status="satisfied", robustness_exact=0.0,
                   robustness_smooth=0.0, specs={}, energy=0.0, times=tr.times,
                   channels=tr.channels)
    sc = scene(prog, mission, sol)
    tower = next(b for b in sc["boxes"] if b["name"] == "tower")
    assert tower["shape"] == "cylinder" and tower["role"] == "nofly"
    m = tower["mesh"]
    V = np.stack([m["x"], m["y"], m["z"]], axis=1)
    ok_side = np.isclose(np.hypot(V[:, 0], V[:, 1]), 1.5, atol=1e-5)
    ok_cap = np.isclose(V[:, 2], 0.0, atol=1e-5) | np.isclose(V[:, 2], 10.0, atol=1e-5)
    assert np.all(ok_side | ok_cap)  # every vertex on the surface
    assert V[:, 2].min() == pytest.approx(0.0) and V[:, 2].max() == pytest.approx(10.0)
    tri = np.stack([m["i"], m["j"], m["k"]], axis=1)
    assert tri.max() < len(V) and len(tri) >= 2 * 32 * 3
    assert len(m["outline"][0]) == len(m["outline"][2])
    top = next(b for b in sc["boxes"] if b["name"] == "top")
    assert top["shape"] == "sphere"
    W = np.stack([top["mesh"][a] for a in "xyz"], axis=1)
    assert np.allclose(np.linalg.norm(W - [0.0, 3.5, 9.0], axis=1), 0.8, atol=1e-5)
    ws = next(b for b in sc["boxes"] if b["name"] == "workspace")
    assert ws["shape"] == "box" and ws["mesh"] is None


# ------------------------------------------------------------------ the checker

BASE = """\
vehicle d : point_mass {{
  vel_max = (1, 1, 1) m/s
  acc_max = (1, 1, 1) m/s^2
  radius = 0.25 m
  start {{ pos = (0, 0, 1) m }}
}}
scenario {{
  obstacle r = {shape}
}}
spec s = always[0, 1] ({formula})
"""


def test_shapes_are_regions_with_their_bounding_box():
    prog = _program(BASE.format(shape="cylinder(center = (1, 2, 3) m, radius = 0.5 m, "
                                "height = 2 m)", formula="d.pos not in r"))
    r = prog.scenario.region("r")
    assert r.box.shape == Round("cylinder", (1.0, 2.0, 3.0), 0.5, 1.0)
    assert r.box.lo == pytest.approx((0.5, 1.5, 2.0)) and r.box.hi == pytest.approx((1.5, 2.5, 4.0))
    cap = _program(BASE.format(shape="capsule((0, 0, 0) m, (4, 0, 0) m, 1 m)",
                               formula="d.pos not in r")).scenario.region("r").box
    assert cap.shape.half == 2.0 and cap.shape.axis == pytest.approx((1.0, 0.0, 0.0))
    assert cap.lo == pytest.approx((-1.0, -1.0, -1.0)) and cap.hi == pytest.approx((5.0, 1.0, 1.0))
    tilted = _program(BASE.format(shape="cylinder(center = (0, 0, 0) m, radius = 1 m, "
                                  "height = 4 m, axis = (1, 0, 0))",
                                  formula="d.pos not in r")).scenario.region("r").box
    assert tilted.lo == pytest.approx((-2.0, -1.0, -1.0))


@pytest.mark.parametrize("shape,code", [
    ("cylinder(center = (0, 0, 1) m, radius = -1 m, height = 2 m)", "STL207"),
    ("cylinder(center = (0, 0, 1) m, radius = 1 m)", "STL104"),
    ("cylinder(center = (0, 0, 1) m, radius = 1 m, height = 2 m, colour = 3)", "STL103"),
    ("cylinder(center = (0, 0, 1) m, radius = 1 s, height = 2 m)", "STL204"),
    ("cylinder(center = (0, 0) m, radius = 1 m, height = 2 m)", "STL205"),
    ("cylinder(center = (0, 0, 1) m, radius = 1 m, height = 2 m, axis = (0, 0, 0))", "STL207"),
    ("sphere((0, 0, 1) m, 1 m, 2 m)", "STL206"),
    ("sphere(center = (0, 0, 1) m, radius = 0 m)", "STL207"),
    ("capsule((0, 0, 1) m, (1, 0, 1) m)", "STL104"),
])
def test_bad_shape_arguments(shape, code):
    assert code in _errors(BASE.format(shape=shape, formula="d.pos not in r"))


@pytest.mark.parametrize("formula,code", [
    ("dist(d.pos, r) >= 2 s", "STL204"),  # a distance is a length
    ("dist(d.vel, r) >= 2 m", "STL204"),  # a velocity is no point
    ("dist(d.pos.x, r) >= 2 m", "STL205"),
    ("dist(d.pos, d) >= 2 m", "STL202"),
])
def test_bad_distances(formula, code):
    shape = "sphere(center = (3, 0, 1) m, radius = 1 m)"
    assert code in _errors(BASE.format(shape=shape, formula=formula))


def _one(prog, name="s", **pos):
    f = prog.specs[name]
    ch = {f"d.pos.{a}": np.array([float(pos.get(a, 0.0))] * 2) for a in "xyz"}
    return float(monitor.robustness(f, 1.0, ch, prog.params))


def test_membership_and_radius_on_round_regions():
    sph = "sphere(center = (3, 0, 1) m, radius = 1 m)"
    inside = _program(BASE.format(shape=sph, formula="d.pos in r"))
    assert _one(inside, x=3.5, z=1) == pytest.approx(0.5)  # 1 − 0.5: −(signed distance)
    assert _one(inside, x=6, y=4, z=1) == pytest.approx(1 - 5.0)
    out = _program(BASE.format(shape=sph, formula="d.pos not in r"))
    assert _one(out, x=6, y=4, z=1) == pytest.approx(5.0 - 1 - 0.25)  # grown by the radius
    cyl = "cylinder(center = (0, 0, 5) m, radius = 1 m, height = 10 m)"
    out = _program(BASE.format(shape=cyl, formula="d.pos not in r"))
    # above the rim: (radial 4 − 1.25, height 13 − 10.25) → hypot(2.75, 2.75)
    assert _one(out, x=4, z=13) == pytest.approx(math.hypot(2.75, 2.75))
    band = _program(BASE.format(shape=cyl, formula="dist(d.pos, r) >= 1 m and "
                                "dist(d.pos, r) <= 3 m"))
    assert _one(band, x=3.5, z=5) == pytest.approx(0.5)  # min(2.5 − 1, 3 − 2.5)


def test_box_distance_is_signed_euclidean():
    prog = _program(BASE.format(shape="box((0, 0, 0), (2, 2, 2)) m",
                                formula="dist(d.pos, r) >= 0 m"))
    assert _one(prog, x=5, y=6, z=1) == pytest.approx(5.0)  # (3, 4, 0) from the corner edge
    assert _one(prog, x=1.5, y=1, z=1) == pytest.approx(-0.5)  # inside: nearest face


def test_round_region_in_a_human_frame_moves_with_the_human():
    text = """\
vehicle d : point_mass {
  vel_max = (1, 1, 1) m/s
  acc_max = (1, 1, 1) m/s^2
  start { pos = (0, 0, 1) m }
}
scenario {
  human op {
    pos = (2, 0, 0) m
    att = (0, 0, 90) deg
    region near = sphere(center = (1, 0, 1) m, radius = 0.5 m)   # 1 m ahead of op
  }
}
spec s = always[0, 1] (dist(d.pos, op.near) <= 1 m and d.pos in op.near)
"""
    prog = _program(text)
    f = prog.specs["s"]
    # op faces +y: the sphere's centre is (2, 1, 1) in the world
    ch = {"d.pos.x": np.array([2.0, 2.0]), "d.pos.y": np.array([1.2, 1.2]),
          "d.pos.z": np.array([1.0, 1.0])}
    assert monitor.robustness(f, 1.0, ch, prog.params) == pytest.approx(0.3)
    moved = dict(prog.params, **{"op.pos.x": 5.0})  # the human moved 3 m: so did the sphere
    assert monitor.robustness(f, 1.0, ch, moved) == pytest.approx(0.5 - math.hypot(3, 0.2))


def test_fmt_round_trips_shapes():
    from stlc.tools.fmt import format_text as format_source

    text = BASE.format(shape="cylinder(center = (0, 0, 5) m, radius = 1 m, height = 10 m, "
                       "axis = (0, 1, 0))", formula="dist(d.pos, r) >= 1 m")
    once = format_source(text)
    assert format_source(once) == once
    assert _program(once).scenario.region("r").box == _program(text).scenario.region("r").box


def test_language_server_knows_the_shapes():
    from stlc.tools import ide

    text = TOWER.read_text()
    an = ide.analyze(text, str(TOWER))
    line = next(i for i, ln in enumerate(text.splitlines()) if "obstacle tower" in ln)
    col = text.splitlines()[line].index("tower")
    h = ide.hover(an, line + 1, col + 2) or ide.hover(an, line, col + 1)
    assert h is not None and "cylinder(center = (0, 0, 5) m, radius = 1.5 m, height = 10 m)" in h
    labels = {lab: detail for lab, kind, detail in ide.complete(an, "  spec x = ", line)}
    assert "mid-height" in labels["cylinder"] and "signed distance" in labels["dist"]
    assert {"sphere", "capsule"} <= set(labels)


def test_report_reads_a_round_membership():
    from stlc.output.report.predicates import readable

    prog = _program(BASE.format(shape="sphere(center = (3, 0, 1) m, radius = 1 m)",
                                formula="d.pos not in r"))
    from stlc.semantics import ir, nnf

    (p,) = ir.predicates(nnf.normalize(prog.specs["s"]))  # one predicate: the distance
    assert readable(p.origin, p.label) == "d.pos outside r"


def test_region_distance_is_not_a_drone_separation():
    from stlc.planning.bounds import stated_bounds

    prog = _program(BASE.format(shape="sphere(center = (3, 0, 1) m, radius = 1 m)",
                                formula="dist(d.pos, r) >= 1 m and dist(d.pos, d.pos) >= 0 m"))
    assert "distance_min" in stated_bounds(prog.specs["s"])  # the point–point one only
    only = _program(BASE.format(shape="sphere(center = (3, 0, 1) m, radius = 1 m)",
                                formula="dist(d.pos, r) >= 1 m"))
    assert "distance_min" not in stated_bounds(only.specs["s"])


def test_scene_places_a_human_frame_round_region():
    from stlc.output.report.scene import scene
    from stlc.planning.solution import Solution

    text = """\
vehicle d : point_mass {
  vel_max = (1, 1, 1) m/s
  acc_max = (1, 1, 1) m/s^2
  start { pos = (0, 0, 1) m }
}
scenario {
  human op {
    pos = (2, 0, 0) m
    att = (0, 0, 90) deg
    region reach = capsule((1, 0, 1) m, (1, 0, 2) m, 0.3 m)   # ahead of op, upright
  }
}
mission m {
  vehicles = [d]
  horizon = 1 s
  step = 1 s
  require always[0, 1] (d.pos not in op.reach)
}
"""
    prog = _program(text)
    t = np.array([0.0, 1.0])
    sol = Solution(mission="m", status="satisfied", robustness_exact=0.0,
                   robustness_smooth=0.0, specs={}, energy=0.0, times=t,
                   channels={f"d.pos.{a}": np.zeros(2) for a in "xyz"})
    sc = scene(prog, prog.missions["m"], sol)
    (reach,) = [b for b in sc["boxes"] if b["name"] == "op.reach"]
    assert reach["shape"] == "capsule" and reach["frame"] == "op"
    V = np.stack([reach["mesh"][a] for a in "xyz"], axis=1)
    # op faces +y: the segment is (2, 1, 1)–(2, 1, 2) in the world; every vertex 0.3 m from it
    s = np.clip(V[:, 2] - 1.0, 0.0, 1.0)
    nearest = np.stack([np.full(len(V), 2.0), np.full(len(V), 1.0), 1.0 + s], axis=1)
    assert np.allclose(np.linalg.norm(V - nearest, axis=1), 0.3, atol=1e-6)
