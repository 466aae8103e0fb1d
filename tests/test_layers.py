"""Folders are layers (issue 18): every import in ``stlc`` — module level, inside a
function, under ``TYPE_CHECKING`` — goes from a higher layer to a strictly lower one, or
stays inside one unit (a folder, or a top-level module).

The units, lowest first (``LAYERS``)::

    settings   the one reader of the process environment
    ground     stlc (the package), diagnostics, interrupt, strictjson, exitcodes, schemas
               (JSON data), deadline
    limits     resource limits: size-limited reads, memory budget, instance limits
    frontend   source text → AST
    vehicles   declared data, dynamics, geometry and behaviour of each vehicle model
    semantics  checker → checked Program, IR, NNF, time grid, named specs
    analysis   semantics of given signals: exact monitor, smooth reference, risk, traces
    solvers    one adapter per solver library (HiGHS, IPOPT): options, status map, result
    team       team algorithms (assignment MILP, primitives, refinement)
    planning   the contract: PlanningProblem in, Solution out; verification
    backends   planners behind the Backend interface
    replan     online replanning (flight loop, events, result)
    output     writers: solution.json, CSVs, the HTML report, the output directory
    pipeline   orders the passes
    simulation ``stlc simulate``: the compile, then the flight loops of ``replan``
    api        the Python API (``stlc.load``, ``stlc.compile``, ...; the package's
               ``__getattr__`` loads it lazily, the one import of a higher layer allowed)
    tools      language tools: fmt, lsp, explain
    sweep      ``stlc sweep`` on Dask (a client and its workers' tasks)
    bench      benchmarks
    cli        command line
    fuzz, __main__

The graph is the one of ``tests/test_import_graph.py`` (``ast``, every import anywhere).
"""

from __future__ import annotations

from collections import defaultdict

from test_import_graph import graph

LAYERS: list[set[str]] = [
    {"settings"},
    {"stlc", "diagnostics", "interrupt", "strictjson", "exitcodes", "schemas", "deadline",
     "lazy"},
    {"limits"},
    {"frontend"},
    {"vehicles"},
    {"semantics"},
    {"analysis"},
    {"solvers"},
    {"team"},
    {"planning"},
    {"backends"},
    {"replan"},
    {"output"},
    {"pipeline"},
    {"simulation"},
    {"api"},
    {"tools"},
    {"sweep"},
    {"bench"},
    {"cli"},
    {"fuzz", "__main__"},
]
RANK = {u: i for i, layer in enumerate(LAYERS) for u in layer}


def unit(module: str) -> str:
    """The layer unit of a module: its first folder under ``stlc``, or the top-level
    module's own name (``stlc.pipeline`` → ``pipeline``), ``stlc`` for the package."""
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else "stlc"


def violations(g: dict[str, set[str]]) -> list[str]:
    out = []
    for m, targets in sorted(g.items()):
        for t in sorted(targets):
            a, b = unit(m), unit(t)
            if (m, t) == ("stlc", "stlc.api"):  # the package's lazy facade (`stlc.load`, ...)
                continue
            if a != b and RANK[a] <= RANK[b]:
                out.append(f"{m} ({a}) imports {t} ({b})")
    return out


def test_every_unit_has_a_layer():
    units = {unit(m) for m in graph()}
    assert units <= set(RANK), f"modules outside every layer: {sorted(units - set(RANK))}"


def test_imports_go_downwards():
    bad = violations(graph())
    assert not bad, "imports against the layer order:\n" + "\n".join(bad)


def test_no_folder_cycle():
    """Implied by the order, checked on its own: the folder graph is acyclic."""
    g = graph()
    fg: dict[str, set[str]] = defaultdict(set)
    for m, ts in g.items():
        fg[unit(m)] |= {unit(t) for t in ts if unit(t) != unit(m)}
    seen: dict[str, int] = {}

    def visit(u: str, path: list[str]) -> None:
        if seen.get(u) == 1:
            raise AssertionError("folder cycle: " + " -> ".join(path + [u]))
        if seen.get(u) == 2:
            return
        seen[u] = 1
        for w in sorted(fg[u]):
            visit(w, path + [u])
        seen[u] = 2

    for u in sorted(fg):
        visit(u, [])


def test_the_checker_catches_an_upward_import():
    g = {"stlc.semantics.check.x": {"stlc.planning.problem"},
         "stlc.planning.problem": {"stlc.semantics.ir"},
         "stlc.output.a": {"stlc.output.b"}, "stlc.output.b": set(), "stlc.semantics.ir": set()}
    assert violations(g) == ["stlc.semantics.check.x (semantics) imports "
                             "stlc.planning.problem (planning)"]


def test_replanning_uses_the_backends_only_through_their_interface():
    """``stlc/replan/`` keeps the flight loop, the event logic and its result type; the
    planners (segment NLP, backup planner) are handed to it by the pipeline, so it imports
    nothing from ``stlc/backends/`` but the interface ``stlc.backends.base``."""
    g = graph()
    reach = sorted({t for m, ts in g.items() if m.startswith("stlc.replan")
                    for t in ts if t.startswith("stlc.backends.") and t != "stlc.backends.base"})
    assert not reach, f"replan reaches past the Backend interface: {reach}"


#: the takeover path below the pipeline: replanning, the backup planner, the contract of its
#: plan, and the re-instantiation of a mission for the executed team
AFTER_CHECK = ("stlc.replan", "stlc.backends.replan.takeover", "stlc.backends.replan.segment",
               "stlc.backends.replan.move", "stlc.planning.takeover", "stlc.semantics.teamform",
               "stlc.semantics.instance")
#: what turns source text into a checked program (and re-checks it: ``overrides.checked``)
BEFORE_CHECK = ("stlc.frontend", "stlc.semantics.check", "stlc.semantics.overrides",
                "stlc.semantics.lint")
ENTRY_POINTS = {"parse", "parse_file", "check", "checked", "source_text", "mission_for_team"}


def _under(m: str, prefixes: tuple[str, ...]) -> bool:
    return any(m == p or m.startswith(p + ".") for p in prefixes)


def reaches_the_checker(g: dict[str, set[str]]) -> list[str]:
    """Import chains (transitive, any level) from the takeover path to the parser/checker."""
    starts = [m for m in g if _under(m, AFTER_CHECK)]
    parent: dict[str, str] = {}
    stack = list(starts)
    while stack:
        m = stack.pop()
        for t in sorted(g.get(m, ())):
            if t not in parent and t not in starts:
                parent[t] = m
                stack.append(t)
    out = []
    for t in sorted(parent):
        if _under(t, BEFORE_CHECK):
            chain = [t]
            while chain[-1] in parent:
                chain.append(parent[chain[-1]])
            out.append(" <- ".join(chain))
    return out


def calls_an_entry_point(path) -> list[str]:
    """Calls of a parse/check entry point, and reads of ``.source`` (the file's text)."""
    import ast

    tree = ast.parse(path.read_text(encoding="utf-8"))
    out = []
    for n in ast.walk(tree):
        if isinstance(n, ast.Call):
            f = n.func
            name = f.id if isinstance(f, ast.Name) else f.attr if isinstance(
                f, ast.Attribute) else ""
            if name in ENTRY_POINTS:
                out.append(f"{path.name}:{n.lineno}: calls {name}()")
        elif isinstance(n, ast.Attribute) and n.attr == "source":
            out.append(f"{path.name}:{n.lineno}: reads .source")
    return out


def test_the_executed_team_is_judged_without_the_checker():
    """Data flows one way: after check time nothing on the takeover path imports the
    parser or the checker (at any depth) or calls their entry points; the executed team is
    judged from the checked mission (``stlc.semantics.teamform.for_team``)."""
    from test_import_graph import module_names

    assert not reaches_the_checker(graph()), "\n".join(reaches_the_checker(graph()))
    mods = module_names()
    paths = [p for m, p in mods.items() if _under(m, AFTER_CHECK)]
    assert len(paths) >= 8
    bad = [c for p in paths for c in calls_an_entry_point(p)]
    assert not bad, "\n".join(bad)


def test_the_one_way_detectors(tmp_path):
    g = {"stlc.replan.a": {"stlc.planning.x"}, "stlc.planning.x": {"stlc.semantics.check.y"},
         "stlc.semantics.check.y": set()}
    assert reaches_the_checker(g) == [
        "stlc.semantics.check.y <- stlc.planning.x <- stlc.replan.a"]
    f = tmp_path / "m.py"
    f.write_text("def j(p):\n    return check(parse(p.program.source))\n")
    assert calls_an_entry_point(f) == ["m.py:2: calls check()", "m.py:2: calls parse()",
                                       "m.py:2: reads .source"]
