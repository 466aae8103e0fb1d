"""One verdict vocabulary, scanned on what a user reads: the terminal output of `stlc
compile`, the notes of every `solution.json` and the visible text of every report, for
every shipped mission (``specs/*.stl`` and ``specs/benchmarks/*.stl``) and three small
missions that reach the other verdicts (``tests/vocabulary/``: proved impossible, violated
with an impossibility the check cannot prove, a warning; and a satisfied plan with the
NLP's iterate lines).

Planning every shipped mission to its end takes about ten minutes, so they run under
``--time-limit 3`` (the handover file's three missions share it): each still goes through
planning, verification, the summary, ``solution.json`` and the report, and its verdict is
"stopped" (or satisfied when the monitor says so) — the path with the impossibility note.
The fixtures reach "satisfied", "violated" and "no plan exists".

What fails the scan: "smooth" in a sentence that names a verdict; ``nan``; "(infeasible)"
for an iterate; a count of warnings or errors that differs from the diagnostics shown; a
message line printed twice; a note repeated in ``solution.json``; a mission without a
satisfying plan whose output does not say whether impossibility was proved.
"""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
from html.parser import HTMLParser
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
FIXTURES = Path(__file__).resolve().parent / "vocabulary"
SHIPPED = sorted((ROOT / "specs").glob("*.stl")) + sorted((ROOT / "specs" / "benchmarks").glob("*.stl"))

VERDICT = re.compile(r"\b(satisfied|violated|no plan exists|stopped by the time limit|"
                     r"infeasible)\b", re.IGNORECASE)
RENDERED = re.compile(r"^\S+:\d+:\d+: (error|warning)\[", re.MULTILINE)
COUNT = re.compile(r"^stlc: (.*)$", re.MULTILINE)
MESSAGE = re.compile(r"error\[|warning\[|note:|no plan|: (satisfied|violated|stopped)")


class _Text(HTMLParser):
    """The visible text of a page: scripts and styles left out, one chunk per text node."""

    def __init__(self) -> None:
        super().__init__()
        self.skip = 0
        self.chunks: list[str] = []

    def handle_starttag(self, tag, attrs):
        self.skip += tag in ("script", "style")

    def handle_endtag(self, tag):
        self.skip -= tag in ("script", "style")

    def handle_data(self, data):
        if not self.skip and data.strip():
            self.chunks.append(" ".join(data.split()))


def visible_text(path: Path) -> list[str]:
    p = _Text()
    p.feed(path.read_text(encoding="utf-8"))
    return p.chunks


def sentences(chunks: list[str]) -> list[str]:
    return [s for c in chunks for s in re.split(r"(?<=[.;])\s+", c) if s]


def run(args: list[str], out: Path) -> dict:
    """`stlc ARGS -o OUT` with progress on; the terminal text and what it wrote."""
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    r = subprocess.run([sys.executable, "-m", "stlc", *args, "-o", str(out)], cwd=ROOT,
                       env=env, capture_output=True, text=True, timeout=300)
    sols = {p.parent.name if p.parent != out else "": json.loads(p.read_text())
            for p in out.rglob("solution.json")}
    return {"args": args, "rc": r.returncode, "terminal": r.stdout + r.stderr,
            "solutions": sols, "reports": sorted(out.rglob("report.html"))}


def shipped_args(path: Path) -> list[str] | None:
    text = path.read_text(encoding="utf-8")
    if not re.search(r"^mission\s", text, re.MULTILINE):
        return None  # a monitoring example (specs/monitor_example.stl): nothing to compile
    return ["compile", str(path), "--time-limit", "3"]


@pytest.fixture(scope="module")
def runs(tmp_path_factory) -> list[dict]:
    root = tmp_path_factory.mktemp("vocabulary")
    plan = [(p.stem, shipped_args(p)) for p in SHIPPED]
    plan += [("reach_avoid_nlp", ["compile", str(ROOT / "specs" / "benchmarks" /
                                              "reach_avoid.stl"), "--backend", "nlp"])]
    plan += [(p.stem, ["compile", str(p)]) for p in sorted(FIXTURES.glob("*.stl"))]
    return [run(args, root / name) for name, args in plan if args]


def test_every_shipped_mission_was_scanned(runs):
    scanned = {Path(r["args"][1]).stem for r in runs}
    assert {p.stem for p in SHIPPED if shipped_args(p)} <= scanned
    statuses = {s["status"] for r in runs for s in r["solutions"].values()}
    assert {"satisfied", "violated", "infeasible"} <= statuses  # every verdict's words
    assert all(r["reports"] for r in runs)


def test_smooth_is_never_the_verdict(runs):
    bad = []
    for r in runs:
        bad += [ln for ln in r["terminal"].splitlines()
                if "smooth" in ln.lower() and VERDICT.search(ln)]
        for rep in r["reports"]:
            bad += [s for s in sentences(visible_text(rep))
                    if "smooth" in s.lower() and VERDICT.search(s)]
        for s in r["solutions"].values():
            bad += [n for n in s["notes"] if "smooth" in n.lower() and VERDICT.search(n)]
    assert bad == []


def test_no_nan_and_no_infeasible_iterates(runs):
    bad = []
    for r in runs:
        bad += re.findall(r".*\bnan\b.*", r["terminal"], re.IGNORECASE)
        bad += [ln for ln in r["terminal"].splitlines() if "(infeasible)" in ln]
        for rep in r["reports"]:
            bad += [c for c in visible_text(rep) if re.search(r"\bnan\b", c, re.IGNORECASE)]
        for s in r["solutions"].values():
            bad += [n for n in s["notes"] if re.search(r"\bnan\b", n, re.IGNORECASE)]
    assert bad == []
    iterates = [ln for r in runs for ln in r["terminal"].splitlines() if " iter " in ln]
    assert iterates and all("planner ρ̃" in ln and "exact ρ" in ln for ln in iterates)


def test_counts_match_what_is_shown(runs):
    for r in runs:
        t = r["terminal"]
        shown = {"error": 0, "warning": 0}
        for m in RENDERED.finditer(t):
            shown[m.group(1)] += 1
        said = {"error": 0, "warning": 0}
        for m in COUNT.finditer(t):
            for n, word in re.findall(r"(\d+) (error|warning)s?", m.group(1)):
                said[word] += int(n)
        assert said == shown, (r["args"], t)


def test_each_message_once(runs):
    for r in runs:
        lines = [ln.strip() for ln in r["terminal"].splitlines() if MESSAGE.search(ln)]
        dup = {ln for ln in lines if lines.count(ln) > 1}
        assert dup == set(), (r["args"], dup)
        assert sum("no plan exists" in ln for ln in lines) <= len(r["solutions"])
        for s in r["solutions"].values():
            assert len(s["notes"]) == len(set(s["notes"])), s["notes"]


def test_no_plan_found_says_whether_impossibility_was_proved(runs):
    for r in runs:
        for name, s in r["solutions"].items():
            mission = s["mission"]
            if s["status"] in ("violated", "stopped", "solver_failed"):
                note = [ln for ln in r["terminal"].splitlines()
                        if f"note: {mission}: impossibility" in ln]
                assert len(note) == 1, (mission, r["terminal"])
                rep = next(p for p in r["reports"] if p.parent.name == (name or p.parent.name))
                assert any("impossibility" in c for c in visible_text(rep))
            if s["status"] == "infeasible":
                assert f"{mission}: no plan exists (proved" in r["terminal"]


def test_the_clearance_impossibility_names_what_the_check_ignores(runs):
    r = next(r for r in runs if Path(r["args"][1]).stem == "wary_courier")
    s = r["solutions"][""]
    assert s["status"] == "violated" and s["solver"]["infeasibility"]["proved"] is False
    why = s["solver"]["infeasibility"]["why"]
    assert "dist(uav1.pos, lamp) >= 1 m" in why and "not linear" in why
    assert "impossibility could not be proved" in r["terminal"]
