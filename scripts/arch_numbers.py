"""Architecture figures from the test suite's own detectors (``tests/test_import_graph.py``,
``tests/test_layers.py``, ``tests/test_architecture.py``): folder-level import cycles,
imports against the layer order, file cycles, vehicle-kind tests outside ``stlc/vehicles/``,
module lengths — and the planners' wing, ``stlc/backends``: its modules, the import arrows
between them, the imports that climb the family order (``base`` < ``nlp`` < ``milp``,
``team`` < ``replan`` < ``registry`` < ``strategy``), its cycles, private names imported
across modules, and solver-library calls outside ``stlc/solvers``.

    python scripts/arch_numbers.py                  # this checkout
    python scripts/arch_numbers.py --root DIR       # another checkout's ``stlc`` (DIR/stlc)
    python scripts/arch_numbers.py --root DIR --families MAP.json   # a flat backends folder:
                                                    # {"module": "family"} for its files
"""

from __future__ import annotations

import argparse
import ast
import json
import re
import sys
from collections import defaultdict
from pathlib import Path

HERE = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(HERE / "tests"))
import test_architecture as ta  # noqa: E402
import test_import_graph as tg  # noqa: E402
from test_import_graph import strongly_connected  # noqa: E402
from test_layers import (ORDERERS, ORDERERS_MAY_IMPORT, _under,  # noqa: E402
                         environment_reads, record_subscripts, unit, violations)

#: the family order of ``stlc/backends``: an import may only go to an equal or lower rank
FAMILY_RANK = {"base": 0, "nlp": 1, "milp": 2, "team": 2, "replan": 3, "registry": 4,
               "strategy": 5}
SOLVER_CALLS = re.compile(r"^\s*(import highspy|import cvxpy|.*\bnlpsol\()", re.M)


def family(module: str, families: dict[str, str]) -> str:
    """``stlc.backends.nlp.model`` → ``nlp``; ``stlc.backends.base`` → ``base``."""
    if module in families:
        return families[module]
    parts = module.split(".")
    return parts[2] if len(parts) > 2 else "package"


def private_imports(g_paths: dict[str, Path]) -> list[str]:
    """``from stlc.x import _name`` across modules (a private name is the module's own)."""
    out = []
    for m, p in sorted(g_paths.items()):
        for node in ast.walk(ast.parse(p.read_text(encoding="utf-8"))):
            if isinstance(node, ast.ImportFrom) and (node.module or "").startswith("stlc"):
                out += [f"{m}: {node.module}.{a.name}" for a in node.names
                        if a.name.startswith("_") and not a.name.startswith("__")]
    return out


def wing(g: dict[str, set[str]], paths: dict[str, Path], families: dict[str, str]) -> None:
    bk = {m: {t for t in ts if t.startswith("stlc.backends.") or t == "stlc.backends"}
          for m, ts in g.items() if m.startswith("stlc.backends")}
    arrows = sum(len(ts - {m}) for m, ts in bk.items())
    up = [f"{m} -> {t}" for m, ts in sorted(bk.items()) for t in sorted(ts)
          if FAMILY_RANK.get(family(t, families), 0) > FAMILY_RANK.get(family(m, families), 0)
          and family(t, families) != family(m, families)]
    fam: dict[str, set[str]] = defaultdict(set)
    for m, ts in bk.items():
        fam[family(m, families)] |= {family(t, families) for t in ts} - {family(m, families)}
    lines = {m: len(p.read_text(encoding="utf-8").splitlines()) for m, p in paths.items()
             if m.startswith("stlc.backends")}
    flat = sorted(m for m in bk if m.count(".") == 2 and paths[m].name != "__init__.py"
                  and m.split(".")[2] not in ("base", "registry", "strategy"))
    solver_calls = sorted(ta._rel(p) for m, p in paths.items()
                          if not m.startswith("stlc.solvers")
                          and SOLVER_CALLS.search(p.read_text(encoding="utf-8")))
    print(f"stlc/backends: {len(bk)} modules, {sum(lines.values())} lines, "
          f"{len([n for n in lines.values() if n >= 400])} at 400+ lines")
    print(f"  modules outside base/registry/strategy and the family folders: {len(flat)}")
    print(f"  import arrows between its modules: {arrows}")
    print(f"  upward imports (against the family order): {len(up)}")
    for u in up:
        print("    ", u)
    print("  family graph:", {k: sorted(v) for k, v in sorted(fam.items())})
    print("  family cycles:", [c for c in strongly_connected(dict(fam)) if len(c) > 1])
    print("  file cycles:", [c for c in strongly_connected(bk) if len(c) > 1])
    priv = private_imports(paths)
    print(f"private names imported across modules (all of stlc): {len(priv)}")
    for p in priv:
        print("    ", p)
    print(f"highspy/cvxpy/nlpsol outside stlc/solvers: {len(solver_calls)} modules "
          f"{solver_calls}")
    orderer_imports = sorted({f"{m} -> {t}" for m, ts in g.items() if _under(m, ORDERERS)
                              for t in ts if t.startswith("stlc.backends")
                              and t not in ORDERERS_MAY_IMPORT})
    print(f"orderers importing backends past strategy/registry/base: {len(orderer_imports)}")
    for o in orderer_imports:
        print("    ", o)
    subs = {m: len(record_subscripts(ast.parse(p.read_text(encoding="utf-8"))))
            for m, p in paths.items() if _under(m, ORDERERS)}
    print(f"solve-record reads as a dict in the orderers: {sum(subs.values())} "
          f"{ {m: n for m, n in subs.items() if n} }")
    env = {m: len(environment_reads(ast.parse(p.read_text(encoding="utf-8"))))
           for m, p in paths.items()}
    print(f"os.environ reads: {sum(env.values())} in {len([n for n in env.values() if n])} "
          f"modules {sorted(m for m, n in env.items() if n)}")


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--root", type=Path, default=HERE)
    ap.add_argument("--families", type=Path)
    args = ap.parse_args()
    tg.ROOT = ta.ROOT = args.root / "stlc"
    paths = tg.module_names()
    g = tg.graph()
    families = json.loads(args.families.read_text()) if args.families else {}
    fg: dict[str, set[str]] = defaultdict(set)
    for m, ts in g.items():
        fg[unit(m)] |= {unit(t) for t in ts if unit(t) != unit(m)}
    lens = sorted(((len(p.read_text().splitlines()), ta._rel(p)) for p in paths.values()),
                  reverse=True)
    print(f"modules {len(g)}, internal imports {sum(len(v) for v in g.values())}")
    print("folder-level cycles:", [c for c in strongly_connected(dict(fg)) if len(c) > 1])
    try:
        print("imports against the layer order:", len(violations(g)))
    except KeyError as e:
        print("imports against the layer order: a folder outside every layer:", e)
    print("file cycles:", [c for c in strongly_connected(g) if len(c) > 1])
    print(f"longest modules: {lens[:3]}; over {ta.MAX_LINES} lines: "
          f"{[x for x in lens if x[0] > ta.MAX_LINES]}")
    wing(g, paths, families)
    return 0


if __name__ == "__main__":
    sys.exit(main())
