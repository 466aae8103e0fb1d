"""The numbers of issue 18's "What must be shown", from the test suite's own detectors
(``tests/test_import_graph.py``, ``tests/test_layers.py``, ``tests/test_architecture.py``):
folder-level import cycles, imports against the layer order, file cycles, vehicle-kind
string tests and vehicle ``isinstance`` tests outside ``stlc/vehicles/``, what ``replan/``
imports from the backends, import chains from the takeover path to the parser/checker,
and module lengths.

    python scripts/arch_numbers.py
"""

from __future__ import annotations

import ast
import sys
from collections import defaultdict
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
import test_architecture as ta  # noqa: E402
from test_import_graph import graph, strongly_connected  # noqa: E402
from test_layers import reaches_the_checker, unit, violations  # noqa: E402


def _count(detector, paths) -> int:
    return sum(len(detector(ast.parse(p.read_text(encoding="utf-8")))) for p in paths)


def main() -> int:
    g = graph()
    fg: dict[str, set[str]] = defaultdict(set)
    for m, ts in g.items():
        fg[unit(m)] |= {unit(t) for t in ts if unit(t) != unit(m)}
    outside = [p for p in ta.MODULES if "vehicles" not in p.relative_to(ta.ROOT).parts]
    lens = sorted(((len(p.read_text().splitlines()), ta._rel(p)) for p in ta.MODULES),
                  reverse=True)
    replan = sorted({t for m, ts in g.items() if m.startswith("stlc.replan") for t in ts
                     if t.startswith("stlc.backends.")})
    print(f"modules {len(g)}, internal imports {sum(len(v) for v in g.values())}")
    print("folder-level cycles:", [c for c in strongly_connected(dict(fg)) if len(c) > 1])
    print("imports against the layer order:", len(violations(g)))
    print("file cycles:", strongly_connected(g))
    print("vehicle-kind string tests outside stlc/vehicles/:",
          _count(ta.vehicle_kind_comparisons, ta.OUTSIDE_REGISTRY))
    print("vehicle isinstance tests outside stlc/vehicles/:",
          _count(ta.vehicle_isinstance_calls, outside))
    print("replan/ imports from the backends:", replan)
    print("takeover path -> parser/checker chains:", reaches_the_checker(g))
    print(f"longest modules: {lens[:3]}; over {ta.MAX_LINES} lines: "
          f"{[x for x in lens if x[0] > ta.MAX_LINES]}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
