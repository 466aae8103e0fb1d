"""The import graph of the ``stlc`` package has no cycles.

The graph is built from the source with ``ast``: every ``import stlc.x`` / ``from stlc.x
import y`` / ``from stlc import x`` anywhere in a module (top level, inside functions, under
``if TYPE_CHECKING``) is an edge to the module it names (``from stlc.a import b`` is an edge
to ``stlc.a.b`` when that is a module, else to ``stlc.a``).  Importing a submodule also runs
its package's ``__init__``, but that is not counted as an edge: a package that re-exports
from its own submodules is no cycle.  Every strongly connected component with more than one
module (or a module importing itself) is a cycle; the test prints one cycle path for each.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent / "stlc"

#: cycles outside the checker that are known and being removed; each entry is the
#: set of modules of one strongly connected component.  Empty it as they are fixed: an
#: entry that no longer matches a cycle fails the test too.
KNOWN_CYCLES: list[frozenset[str]] = []


def module_names() -> dict[str, Path]:
    out = {}
    for p in ROOT.rglob("*.py"):
        rel = p.relative_to(ROOT.parent).with_suffix("")
        parts = list(rel.parts)
        if parts[-1] == "__init__":
            parts.pop()
        out[".".join(parts)] = p
    return out


def imports_of(name: str, path: Path, modules: set[str]) -> set[str]:
    """The ``stlc`` modules that module ``name`` imports, anywhere in its body."""
    tree = ast.parse(path.read_text(encoding="utf-8"), str(path))
    is_pkg = path.name == "__init__.py"
    out: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            targets = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:  # relative: resolve against this module's package
                pkg = name.split(".") if is_pkg else name.split(".")[:-1]
                pkg = pkg[: len(pkg) - (node.level - 1)]
                base = ".".join(pkg + ([base] if base else []))
            targets = [f"{base}.{a.name}" if f"{base}.{a.name}" in modules else base
                       for a in node.names]
        else:
            continue
        for t in targets:
            while t and t not in modules:  # `import stlc.a.b` of a name inside a module
                t = t.rpartition(".")[0]
            if t.startswith("stlc.") and t != name:
                out.add(t)
            elif t == name:
                out.add(t)  # a module importing itself is a cycle of one
    return out


def graph() -> dict[str, set[str]]:
    mods = module_names()
    return {m: imports_of(m, p, set(mods)) for m, p in mods.items()}


def strongly_connected(g: dict[str, set[str]]) -> list[list[str]]:
    """Tarjan's algorithm (iterative); components in no particular order."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    on_stack: set[str] = set()
    stack: list[str] = []
    out: list[list[str]] = []
    counter = 0
    for root in sorted(g):
        if root in index:
            continue
        work = [(root, iter(sorted(g[root])))]
        index[root] = low[root] = counter
        counter += 1
        stack.append(root)
        on_stack.add(root)
        while work:
            v, it = work[-1]
            for w in it:
                if w not in index:
                    index[w] = low[w] = counter
                    counter += 1
                    stack.append(w)
                    on_stack.add(w)
                    work.append((w, iter(sorted(g[w]))))
                    break
                if w in on_stack:
                    low[v] = min(low[v], index[w])
            else:
                work.pop()
                if work:
                    low[work[-1][0]] = min(low[work[-1][0]], low[v])
                if low[v] == index[v]:
                    comp = []
                    while True:
                        w = stack.pop()
                        on_stack.discard(w)
                        comp.append(w)
                        if w == v:
                            break
                    if len(comp) > 1 or v in g[v]:
                        out.append(sorted(comp))
    return out


def cycle_path(g: dict[str, set[str]], comp: list[str]) -> list[str]:
    """One cycle through the component's first module (breadth-first, shortest)."""
    members = set(comp)
    start = comp[0]
    prev: dict[str, str] = {}
    frontier = [start]
    while frontier:
        nxt = []
        for v in frontier:
            for w in sorted(g[v] & members):
                if w == start:
                    path = [v]
                    while path[-1] != start:
                        path.append(prev[path[-1]])
                    return [start, *reversed(path[:-1]), start] if v != start else [start, start]
                if w not in prev:
                    prev[w] = v
                    nxt.append(w)
        frontier = nxt
    return comp  # pragma: no cover - a component always has a cycle


def test_graph_sees_the_package():
    g = graph()
    chk = "stlc.semantics.check"
    assert chk in g and f"{chk}.context" in g and "stlc.pipeline" in g
    assert chk in g["stlc.pipeline"]  # module-level `from stlc.semantics.check import check`
    assert f"{chk}.units" in g[f"{chk}.context"]  # `from stlc.semantics.check import units`
    assert "stlc.vehicles.dynamics" in g[f"{chk}.declarations"]  # a function-level import


def test_tarjan_finds_cycles_and_paths():
    g = {"a": {"b"}, "b": {"c"}, "c": {"a", "d"}, "d": set(), "e": {"e"}}
    comps = sorted(strongly_connected(g))
    assert comps == [["a", "b", "c"], ["e"]]
    assert cycle_path(g, ["a", "b", "c"]) == ["a", "b", "c", "a"]
    assert cycle_path(g, ["e"]) == ["e", "e"]


def test_no_import_cycles():
    g = graph()
    comps = strongly_connected(g)
    known = set(KNOWN_CYCLES)
    new = [c for c in comps if frozenset(c) not in known]
    stale = [sorted(k) for k in known if list(sorted(k)) not in comps]
    msg = "\n".join("import cycle: " + " -> ".join(cycle_path(g, c)) for c in new)
    if stale:
        msg += "\n" + "\n".join(f"KNOWN_CYCLES entry is no longer a cycle: {s}" for s in stale)
    if new or stale:
        pytest.fail(msg)


def test_checker_modules_import_only_the_context():
    """Inside ``stlc.semantics.check`` the helpers import only ``context``, ``values``,
    ``units`` and ``hints`` (a leaf: the hints for unknown names); ``program`` (and the
    package) put them together."""
    g = graph()
    chk = "stlc.semantics.check"
    low = {f"{chk}.context", f"{chk}.values", f"{chk}.units", f"{chk}.hints"}
    for helper in ("declarations", "elaborate", "formulas", "mission", "builtins", "events",
                   "risklevel"):
        inside = {m for m in g[f"{chk}.{helper}"] if m.startswith(chk)}
        assert inside <= low, (helper, inside - low)
