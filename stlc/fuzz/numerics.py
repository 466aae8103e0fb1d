"""Fuzz inputs whose outcome has a known right answer: wrong verdicts, not only crashes.

Five kinds, each made from a seed (``make``) and judged by ``run_check`` — ``wrong`` when
the answer is not the one known to be right:

* ``coords``    — a small point-mass survey (start, a 1 m goal box, maybe a wall; step
  1 s or 0.5 s; κ 0 or 0.1) planned as written and moved to UTM coordinates
  (+4.5e5, +5.4e6, 0 m): the two verdicts must agree and the exact robustness to 1e-6;
* ``boundary``  — the same survey starting on the workspace floor at κ = 0, a goal the
  vehicle reaches with margin: the optimum is exactly ρ = 0 (the floor binds at t = 0),
  so the plan must be *satisfied* with ρ = 0 to 1e-9;
* ``roundtrip`` — a survey planned and written (``Plan.write``), then its own
  ``trajectory.csv`` monitored (``stlc.monitor``): the same robustness, to the last bit,
  and the same verdict by the one rule (``stlc.analysis.verdict``);
* ``fmt``       — a shipped spec with its layout mutated (spaces, indentation, joins with
  ``;``): ``stlc fmt`` must keep the program and be idempotent (a second pass changes
  nothing);
* ``lsp``       — a mutated shipped spec through the language server's analysis
  (``stlc.tools.ide.analyze``) and its formatting path: never an exception.
"""

from __future__ import annotations

import os
import random
import tempfile
from pathlib import Path

KINDS = ("coords", "boundary", "roundtrip", "fmt", "lsp")
UTM = (4.5e5, 5.4e6, 0.0)


def survey(rng: random.Random, shift=(0.0, 0.0, 0.0), floor: bool = False) -> str:
    """A point-mass survey in a 20 m box (coordinates moved by ``shift``)."""
    def p(v):
        return "(" + ", ".join(repr(float(a) + d) for a, d in zip(v, shift)) + ")"

    start = (rng.randint(3, 17), rng.randint(3, 17), 0 if floor else rng.randint(1, 15))
    goal = tuple(min(max(s + rng.randint(-3, 2), 1), 18) for s in start[:2]) + \
        ((0,) if floor else (min(max(start[2] + rng.randint(-2, 1), 1), 18),))
    wall = None
    if not floor and rng.random() < 0.4:
        mid = [(a + b) / 2 for a, b in zip(start[:2], goal[:2])]
        if not all(m <= s <= m + 1 for m, s in zip(mid, start[:2])) and \
                not all(m - 0.5 <= g <= m + 1.5 for m, g in zip(mid, goal[:2])):
            wall = (*mid, 0)
    step = 1 if floor else rng.choice([1, 0.5])
    kappa = 0 if floor else rng.choice([0, 0.1])
    size = (1, 1, 2) if floor else (1, 1, 1)
    obs = (f"  obstacle wall = box({p(wall)}, {p((wall[0] + 1, wall[1] + 1, 20))}) m\n"
           if wall else "")
    return (
        "vehicle d : point_mass {\n  vel_max = (2, 2, 2) m/s\n  acc_max = (1, 1, 1) m/s^2\n"
        f"  start {{ pos = {p(start)} m }}\n}}\n"
        f"scenario {{\n  workspace = box({p((0, 0, 0))}, {p((20, 20, 20))}) m\n"
        f"  target goal = box({p(goal)}, {p(tuple(g + s for g, s in zip(goal, size)))}) m\n"
        f"{obs}}}\n"
        f"mission survey {{\n  vehicles = [d]\n  horizon = 6 s\n  step = {step} s\n"
        f"  threshold = {kappa}\n  spec inside = always[0, 6] (d.pos in workspace)\n"
        "  spec reach = eventually[0, 6] (d.pos in goal)\n"
        + ("  spec clear = always[0, 6] (d.pos not in wall)\n"
           "  require inside and reach and clear\n" if wall else
           "  require inside and reach\n") + "  maximize robustness\n}\n")


def relayout(text: str, rng: random.Random) -> str:
    """``text`` with its layout changed only: spaces doubled, indentation changed,
    adjacent one-line members joined with ``;``."""
    out: list[str] = []
    for line in text.split("\n"):
        code, hash_, comment = line.partition("#")
        k = rng.randrange(5)
        if k == 1:
            code = code.replace(" ", "  ")
        elif k == 2 and not hash_:
            code = " " * rng.randrange(9) + code.strip()
        elif k == 3 and not hash_ and out and not out[-1].strip().startswith("#") \
                and "#" not in out[-1] and code.strip().startswith(("const ", "signal ")) \
                and out[-1].strip().startswith(("const ", "signal ")):
            out[-1] = out[-1].rstrip() + "; " + code.strip()
            continue
        out.append(code + hash_ + comment)
    return "\n".join(out)


def make(kind: str, seed: int, seeds: list[str]) -> dict:
    rng = random.Random(f"{kind}:{seed}")
    case = {"kind": kind, "seed": seed, "trace": None, "check": kind}
    if kind in ("coords", "roundtrip"):
        state = rng.getstate()
        case["stl"] = survey(rng)
        rng.setstate(state)
        case["moved"] = survey(rng, UTM)
    elif kind == "boundary":
        case["stl"] = survey(rng, floor=True)
    else:
        text = Path(seeds[seed % len(seeds)]).read_text(encoding="utf-8") if seeds else ""
        case["stl"] = relayout(text, rng)
    return case


def _plan(text: str):
    import stlc

    return stlc.compile(stlc.loads(text, "<fuzz>"), risk=False)


def run_check(case: dict) -> tuple[str, str]:
    """``(class, detail)``: ``accepted``, ``diagnosed`` (the input does not parse: a
    layout mutation that broke it), ``wrong`` or ``internal`` (raised by the caller)."""
    from stlc.analysis import verdict
    from stlc.diagnostics import StlcError

    kind = case["check"]
    if kind == "coords":
        a, b = _plan(case["stl"]), _plan(case["moved"])
        if a.status != b.status or not abs(a.robustness - b.robustness) <= 1e-6:
            return "wrong", (f"as written {a.status} ρ = {a.robustness!r}, moved to UTM "
                             f"{b.status} ρ = {b.robustness!r}")
        return "accepted", ""
    if kind == "boundary":
        a = _plan(case["stl"])
        if a.status != "satisfied" or not abs(a.robustness) <= 1e-9:
            return "wrong", f"optimum ρ = 0 planned {a.status} with ρ = {a.robustness!r}"
        return "accepted", ""
    if kind == "roundtrip":
        import stlc

        for text in (case["stl"], case["moved"]):
            a = _plan(text)
            with tempfile.TemporaryDirectory(prefix="stlc-fuzz-") as d:
                a.write(d)
                r = stlc.monitor(a.program, os.path.join(d, "trajectory.csv"))["survey"]
            kappa = float(a.mission.threshold)
            if r != a.robustness or verdict.satisfied(r, kappa) != \
                    verdict.satisfied(a.robustness, kappa):
                return "wrong", (f"verified ρ = {a.robustness!r} ({a.status}), its written "
                                 f"trajectory.csv monitors to {r!r}")
        return "accepted", ""
    if kind == "fmt":
        from stlc.tools.fmt import format_text

        try:
            once = format_text(case["stl"], "<fuzz>")
        except StlcError as e:
            return "diagnosed", e.diagnostics[0].code
        twice = format_text(once, "<fuzz>")
        if twice != once:
            return "wrong", "stlc fmt is not idempotent on this layout"
        return "accepted", ""
    if kind == "lsp":
        from stlc.tools import ide
        from stlc.tools.fmt import FormatError, format_text

        an = ide.analyze(case["stl"], "<fuzz>")
        try:
            format_text(case["stl"], "<fuzz>")
        except (StlcError, FormatError, RecursionError):
            pass
        return ("accepted" if an.program is not None else "diagnosed"), ""
    raise ValueError(f"unknown check {kind}")
