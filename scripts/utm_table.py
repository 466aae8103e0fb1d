"""Plan shipped missions as written and moved to UTM coordinates; print a table of the
verdicts and exact robustness (they must agree).

    python scripts/utm_table.py specs/benchmarks/reach_avoid.stl specs/handover.stl:handover_left_tb

The move is done on the source text, independently of the planner's local frame
(``stlc.planning.frame``): every world-frame point — a vehicle's start, a scenario box
(corners or centre), a human's position and the means of its uncertain position — is
shifted by (4.5e5, 5.4e6, 0) m; boxes inside a ``human`` block (the human's own frame),
velocities, sizes and displacements are not.
"""

from __future__ import annotations

import re
import sys
import time

SHIFT = (450000.0, 5400000.0, 0.0)
_VEC = r"\(\s*([-+0-9.eE]+)\s*,\s*([-+0-9.eE]+)\s*,\s*([-+0-9.eE]+)\s*\)"


def _moved(m: re.Match) -> str:
    vals = [float(m.group(i)) + d for i, d in zip((1, 2, 3), SHIFT)]
    return "(" + ", ".join(repr(v) for v in vals) + ")"


def translate(text: str) -> str:
    out, depth, human_depth = [], 0, None
    for line in text.splitlines(keepends=True):
        code = line.split("#", 1)[0]
        if re.match(r"\s*human\s+\w+\s*\{", code):
            human_depth = depth
        in_human = human_depth is not None
        if re.search(r"\bstart\s*\{", code) or (in_human and re.search(r"\bpos\s*=", code)
                                                 and not re.search(r"\bbox\(", code)):
            code = re.sub(r"(\bpos\s*=\s*)" + _VEC, lambda m: m.group(1) + _moved(
                re.match(_VEC, m.group(0)[len(m.group(1)):])), code)
        if not in_human and re.search(r"\bbox\(", code):
            code = re.sub(r"box\(\s*" + _VEC + r"\s*,\s*" + _VEC,
                          lambda m: "box(" + _moved(m) + ", " + _moved(
                              re.match(_VEC, m.group(0)[m.group(0).index(")") + 1:]
                                       .lstrip(" ,"))), code)
            code = re.sub(r"(center\s*=\s*)" + _VEC, lambda m: m.group(1) + _moved(
                re.match(_VEC, m.group(0)[len(m.group(1)):])), code)
        if re.search(r"\.pos\s*~\s*normal\(", code):
            code = re.sub(r"(normal\(\s*)" + _VEC, lambda m: m.group(1) + _moved(
                re.match(_VEC, m.group(0)[len(m.group(1)):])), code)
        depth += code.count("{") - code.count("}")
        if human_depth is not None and depth <= human_depth:
            human_depth = None
        out.append(code + ("\n" if line.endswith("\n") and not code.endswith("\n") else ""))
    return "".join(out)


def row(path: str, mission: str | None) -> tuple:
    import stlc

    text = open(path, encoding="utf-8").read()
    res = []
    for src, name in ((text, path), (translate(text), path + " (UTM)")):
        t0 = time.perf_counter()
        p = stlc.compile(stlc.loads(src, name), mission, risk=False)
        res.append((p.status, p.robustness, time.perf_counter() - t0))
    return res


def main(argv: list[str]) -> int:
    print(f"{'mission':<44} {'verdict':>10} {'ρ':>12} {'UTM verdict':>12} {'UTM ρ':>12} "
          f"{'|Δρ|':>8} {'s':>6} {'UTM s':>6}", flush=True)
    bad = 0
    for arg in argv:
        path, _, mission = arg.partition(":")
        (s0, r0, t0), (s1, r1, t1) = row(path, mission or None)
        d = abs(r0 - r1)
        bad += s0 != s1 or not d <= 1e-6
        label = path.rsplit("/", 1)[-1] + (f":{mission}" if mission else "")
        print(f"{label:<44} {s0:>10} {r0:>+12.6f} {s1:>12} {r1:>+12.6f} {d:>8.1e} "
              f"{t0:>6.1f} {t1:>6.1f}", flush=True)
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
