"""`stlc simulate` end to end: the command writes the compile outputs plus `replan.json`
(the contract keys) and `executed.csv`, the report gets its replanning section, and the exit
code says whether the executed trajectory kept its specs.  Small missions (seconds)."""

from __future__ import annotations

import csv
import json
from pathlib import Path

import pytest

from stlc import cli

MISSIONS = Path(__file__).parent / "missions"


def simulate(argv, capsys):
    rc = cli.main(["simulate", *argv, "-q"])
    out = capsys.readouterr()
    return rc, out.out + out.err


def header(path: Path) -> list[str]:
    with open(path) as fh:
        return next(csv.reader(fh))


def test_disturbance_from_the_command_line(tmp_path, capsys):
    out = tmp_path / "o"
    rc, text = simulate([str(MISSIONS / "team_small.stl"), "--disturb", "uav1@10:1.5,0,0",
                         "-o", str(out)], capsys)
    assert rc == 0, text
    rj = json.loads((out / "replan.json").read_text())
    assert {"mission", "budget_s", "ok", "events", "replans", "executed"} <= set(rj)
    trig = [e for e in rj["events"] if e["triggered"]]
    # 1.5 m > ζ = 1 m: the event instant at the push triggers, the earlier ones do not
    assert trig and trig[0]["time"] == pytest.approx(10.0) and trig[0]["vehicle"] == "uav1"
    assert trig[0]["deviation"] == pytest.approx(1.5, abs=1e-6)
    assert all(not e["triggered"] for e in rj["events"] if e["time"] < 10.0 - 1e-9)
    assert trig[0]["accepted"] and trig[0]["status"] in ("optimal", "acceptable")
    assert {"solve_s", "within_budget", "segment", "kept"} <= set(trig[0])
    assert rj["executed"]["satisfied"]["mission"] in (True, False)
    assert set(rj["executed"]["kept"]) <= set(rj["executed"]["robustness"])
    # executed.csv: the same columns as the plan's trajectory.csv, on the same grid
    assert header(out / "executed.csv") == header(out / "trajectory.csv")
    assert "id=\"replan\"" in (out / "report.html").read_text()


def test_takeover_from_the_file(tmp_path, capsys):
    src = (MISSIONS / "takeover_cross.stl").read_text()
    assert "simulate" not in src
    f = tmp_path / "cross.stl"
    f.write_text(src.replace("mission cross {", "mission cross {\n  simulate { fail uav1 "
                             "{ time = 2 s; backup = uav3 } }", 1))
    out = tmp_path / "o"
    rc, text = simulate([str(f), "-o", str(out)], capsys)
    rj = json.loads((out / "replan.json").read_text())
    (fail,) = [e for e in rj["events"] if e["kind"] == "failure"]
    assert fail["vehicle"] == "uav1" and fail["time"] == 2.0 and fail["triggered"]
    assert fail["segment"][0] == pytest.approx(12.0)  # t_fail + T_rep (default 10 s)
    assert rc == (0 if rj["ok"] else 3), text
    assert "uav3.pos.x" in header(out / "executed.csv")  # the backup was flown
    assert "uav3.pos.x" not in header(out / "trajectory.csv")


def test_shipped_takeover_2x7(tmp_path, capsys):
    """specs/bird_diverter_2x7.stl's own simulate block (uav1 fails at 60 s, uav3 takes over,
    paper B §IV-C): every pending target installed by the backup, separation ≥ Γ_dis = 3 m
    against the fixed drones, the install spec holds on the executed trajectories."""
    out = tmp_path / "o"
    rc, text = simulate([str(Path(__file__).parents[1] / "specs" / "bird_diverter_2x7.stl"),
                         "-o", str(out)], capsys)
    assert rc == 0, text
    rj = json.loads((out / "replan.json").read_text())
    (ev,) = [e for e in rj["events"] if e["kind"] == "failure"]
    assert ev["triggered"] and ev["accepted"] and ev["within_budget"]
    pending = ev["detail"]["pending"]
    assert pending and set(pending) <= set(ev["detail"]["backup_route"])
    rob = rj["executed"]["robustness"]
    assert rob["separation"] >= 0.2 and rob["install"] >= 0.2 and rob["mission"] >= 0.2
    # independently: the backup's executed positions stay >= 3 m from uav2's
    with open(out / "executed.csv") as fh:
        rows = list(csv.DictReader(fh))
    d = min(sum((float(r[f"uav3.pos.{a}"]) - float(r[f"uav2.pos.{a}"])) ** 2
                for a in "xyz") ** 0.5 for r in rows)
    assert d >= 3.0
