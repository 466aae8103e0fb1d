"""A team mission that the planner's stop-and-go route model cannot fit in the horizon is
"no plan found" with the reason (exit 3, STL503 at the mission, the plan judged by the
monitor) — never a rejection as if no plan existed (exit 1)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
TEAM_SMALL = (ROOT / "tests" / "missions" / "team_small.stl").read_text()


def test_the_route_models_bound_is_no_plan_found(tmp_path):
    spec = tmp_path / "short.stl"
    spec.write_text(TEAM_SMALL.replace("const T_N = 40 s", "const T_N = 8 s"))
    out = tmp_path / "o"
    r = subprocess.run([sys.executable, "-m", "stlc", "compile", str(spec), "-o", str(out),
                        "--no-risk", "-q"], capture_output=True, text=True, timeout=600,
                       env=dict(os.environ, PYTHONPATH=str(ROOT)))
    assert r.returncode == 3, r.stderr
    assert "error[STL503]" in r.stderr and "no plan found" in r.stderr
    assert "stop-and-go route model" in r.stderr and "Traceback" not in r.stderr
    sol = json.loads((out / "solution.json").read_text())
    assert sol["status"] == "violated" and sol["status"] != "infeasible"
    assert sol["solver"]["return_status"] == "no_plan_found"
    assert any(n.startswith("no plan found") for n in sol["notes"])
