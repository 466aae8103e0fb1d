"""Grid scaling of a point-mass mission: the same 60 s patrol
(``tests/missions/patrol_60s.stl``: obstacles, an implication with a nested ``eventually``,
an ``until``) compiled at several steps; prints a table of the chain that ran, each stage's
status, the verdict, the exact robustness and the wall time.

    python scripts/grid_scaling.py [--steps 0.5,0.25,0.2,0.1] [--time-limit 300]
"""

from __future__ import annotations

import argparse
import json
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
MISSION = ROOT / "tests" / "missions" / "patrol_60s.stl"


def run(step: float, limit: float, backend: str | None) -> dict:
    src = re.sub(r"step = [0-9.]+ s", f"step = {step:g} s", MISSION.read_text())
    with tempfile.TemporaryDirectory() as d:
        f = Path(d) / "patrol.stl"
        f.write_text(src)
        cmd = [sys.executable, "-m", "stlc", "compile", str(f), "--no-risk", "-q",
               "-o", str(Path(d) / "out"), "--time-limit", f"{limit:g}"]
        if backend:
            cmd += ["--backend", backend]
        t0 = time.perf_counter()
        r = subprocess.run(cmd, capture_output=True, text=True)
        wall = time.perf_counter() - t0
        try:
            sol = json.loads((Path(d) / "out" / "solution.json").read_text())
        except OSError:
            return {"step": step, "wall": wall, "status": f"no output (exit {r.returncode})"}
    chain = sol["solver"].get("chain", {})
    stages = " → ".join(f"{s['backend']}: {s['status']}" for s in chain.get("stages", []))
    if "fallback_from" in chain:
        first = " → ".join(f"{s['backend']}: {s['status']}"
                           for s in chain["fallback_from"].get("stages", []))
        stages = f"{first} ⇒ {stages}"
    return {"step": step, "samples": round(60 / step) + 1, "wall": wall,
            "status": sol["status"], "rho": sol["robustness"]["exact"], "chain": stages}


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--steps", default="0.5,0.25,0.2,0.1")
    ap.add_argument("--time-limit", type=float, default=300.0)
    ap.add_argument("--backend", default=None)
    a = ap.parse_args()
    print("| step | samples | status | exact ρ | wall | stages |")
    print("|---|---|---|---|---|---|")
    for s in (float(x) for x in a.steps.split(",")):
        r = run(s, a.time_limit, a.backend)
        print(f"| {s:g} s | {r.get('samples', '')} | {r['status']} | "
              f"{r.get('rho', float('nan')):+.4f} | {r['wall']:.1f} s | {r.get('chain', '')} |",
              flush=True)


if __name__ == "__main__":
    main()
