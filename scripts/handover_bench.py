"""Handover compile times over shipped, random and unseen variants (the goal: a
median total time of 6 s or less).  Each variant is ``specs/handover.stl`` with ``--set``
values (the operator's pose, the vehicle's start) and one of its three missions, compiled
by ``stlc compile --no-risk`` in its own process, one at a time; the table gives the wall
time of the whole process, the guess, the solve, the IPOPT iterations and the exact
robustness, then the median.

    python scripts/handover_bench.py [--random 12] [--seed 0] [--repeats 1] [--json OUT]

The random variants are drawn with ``--seed`` (operator at x, y ∈ [−0.4, 0.4] m turned
z ∈ [−60°, 60°], start x ∈ [−2.1, −1.5] m, y ∈ [−0.6, 0.6] m, z ∈ [0.8, 1.4] m, a random
mission); the unseen ones are fixed: the operator turned 90° and 180°, a start beside the
operator, the operator moved and turned with the start near the pole.
"""

from __future__ import annotations

import argparse
import json
import random
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
SPEC = ROOT / "specs" / "handover.stl"
MISSIONS = ("handover_left_tb", "handover_front", "handover_left")

UNSEEN = {
    "turned90": ("handover_left_tb", {"operator.att.z": "90 deg"}),
    "turned180": ("handover_front", {"operator.att.z": "180 deg"}),
    "beside": ("handover_left", {"uav1.start.pos.x": "-0.6 m", "uav1.start.pos.y": "-1.4 m"}),
    "moved_pole": ("handover_left_tb", {"operator.pos.x": "0.3 m", "operator.pos.y": "-0.3 m",
                                         "operator.att.z": "-40 deg",
                                         "uav1.start.pos.x": "-1.7 m",
                                         "uav1.start.pos.y": "0.9 m"}),
}


def variants(n: int, seed: int) -> dict[str, tuple[str, dict[str, str]]]:
    out = {m: (m, {}) for m in MISSIONS}
    rng = random.Random(seed)
    for i in range(n):
        out[f"r{seed}_{i}"] = (rng.choice(MISSIONS), {
            "operator.pos.x": f"{rng.uniform(-0.4, 0.4):.3f} m",
            "operator.pos.y": f"{rng.uniform(-0.4, 0.4):.3f} m",
            "operator.att.z": f"{rng.uniform(-60, 60):.1f} deg",
            "uav1.start.pos.x": f"{rng.uniform(-2.1, -1.5):.3f} m",
            "uav1.start.pos.y": f"{rng.uniform(-0.6, 0.6):.3f} m",
            "uav1.start.pos.z": f"{rng.uniform(0.8, 1.4):.3f} m",
        })
    out.update(UNSEEN)
    return out


def run(name: str, mission: str, sets: dict[str, str], extra: list[str]) -> dict:
    with tempfile.TemporaryDirectory() as d:
        cmd = [sys.executable, "-m", "stlc", "compile", str(SPEC), "--mission", mission,
               "--no-risk", "-q", "-o", str(Path(d) / "out"), *extra]
        for k, v in sets.items():
            cmd += ["--set", f"{k}={v}"]
        t0 = time.perf_counter()
        r = subprocess.run(cmd, capture_output=True, text=True)
        wall = time.perf_counter() - t0
        try:
            sol = json.loads((Path(d) / "out" / "solution.json").read_text())
        except OSError:
            return {"name": name, "wall": wall, "status": f"no output (exit {r.returncode})",
                    "stderr": r.stderr[-400:]}
    t = sol.get("timing", {})
    solver = sol.get("solver", {})
    return {"name": name, "mission": mission, "wall": wall, "status": sol["status"],
            "rho": sol["robustness"]["exact"], "iterations": solver.get("iterations"),
            "stages": [s["label"] for s in solver.get("stages", [])],
            "guess_wait": t.get("guess_wait_s"), "solve": t.get("solve_s"),
            "build": t.get("build_s"), "energy": sol.get("energy")}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--random", type=int, default=12)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--repeats", type=int, default=1)
    ap.add_argument("--only", default="", help="comma-separated variant names")
    ap.add_argument("--json", type=Path)
    ap.add_argument("extra", nargs="*", help="more arguments for stlc compile (after --)")
    a = ap.parse_args()
    todo = variants(a.random, a.seed)
    if a.only:
        todo = {k: v for k, v in todo.items() if k in a.only.split(",")}
    rows = []
    print(f"{'variant':<18}{'mission':<18}{'status':<11}{'rho':>8}{'iters':>6}"
          f"{'wait':>6}{'solve':>7}{'wall':>7}  stages", flush=True)
    for name, (mission, sets) in todo.items():
        runs = [run(name, mission, sets, a.extra) for _ in range(a.repeats)]
        r = sorted(runs, key=lambda x: x["wall"])[len(runs) // 2]
        rows.append(r)
        if "rho" not in r:
            print(f"{name:<18}{mission:<18}{r['status']}  {r.get('stderr', '')}", flush=True)
            continue
        print(f"{name:<18}{mission:<18}{r['status']:<11}{r['rho']:>+8.4f}"
              f"{r['iterations'] or 0:>6}{r['guess_wait'] or 0:>6.2f}{r['solve'] or 0:>7.2f}"
              f"{r['wall']:>7.2f}  {' + '.join(r['stages'])}", flush=True)
    walls = [r["wall"] for r in rows]
    sat = sum(r["status"] == "satisfied" for r in rows)
    print(f"\n{sat}/{len(rows)} satisfied; wall median {statistics.median(walls):.2f} s "
          f"(min {min(walls):.2f}, max {max(walls):.2f}); iterations in all "
          f"{sum(r.get('iterations') or 0 for r in rows)}")
    if a.json:
        a.json.write_text(json.dumps(rows, indent=1))


if __name__ == "__main__":
    main()
