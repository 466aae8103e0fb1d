"""Folders are layers: every import in ``stlc`` — module level, inside a
function, under ``TYPE_CHECKING`` — goes from a higher layer to a strictly lower one, or
stays inside one unit (a folder, or a top-level module).

The units, lowest first (``LAYERS``)::

    settings   the one reader of the process environment
    ground     stlc (the package), diagnostics, interrupt, strictjson, exitcodes, schemas
               (JSON data), deadline
    apart      work in a forked child, beside the parent's
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
    flight     frames, flight-stack exports, flight logs in, the closed-loop simulator
    output     writers: solution.json, CSVs, the HTML report, the output directory
    pipeline   orders the passes
    simulation ``stlc simulate``: the compile, then the flight loops of ``replan``
    tools      language tools: fmt, lsp, explain
    sweeping   ``stlc sweep`` on Dask (a client and its workers' tasks)
    flying     ``stlc fly``: the compile, then the closed loop of ``flight`` (on the sweep's
               Dask client); the flight options of the command line
    results    what the Python API hands out (``Plan``, ``Simulation``, sweep tables) and
               the commands it runs beyond ``compile`` (simulate, sweep, risk)
    api        the Python API (``stlc.load``, ``stlc.compile``, ...; the package's
               ``__getattr__`` loads it lazily, the one import of a higher layer allowed)
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
    {"apart"},
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
    {"flight"},
    {"output"},
    {"pipeline"},
    {"simulation"},
    {"tools"},
    {"sweeping"},
    {"flying"},
    {"results"},
    {"api"},
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


# ------------------------------------------------------------------ the planners' wing
#
# ``stlc/backends``: the interface (``base``), the name table (``registry``) and the
# strategy (``strategy``) beside one folder per family; ``stlc/solvers``: one adapter per
# solver library.  The family order, lowest first: an import goes to the same or a lower
# rank, never back (``strategy`` may name any backend; no backend names the strategy).

WING_TOP = {"base", "registry", "strategy"}
FAMILIES = {"nlp", "milp", "team", "knots", "replan"}
FAMILY_RANK = {"base": 0, "nlp": 1, "milp": 2, "team": 2, "knots": 3, "replan": 3,
               "registry": 4, "strategy": 5}
ORDERERS = ("stlc.pipeline", "stlc.simulation", "stlc.api", "stlc.sweeping", "stlc.output")
ORDERERS_MAY_IMPORT = {"stlc.backends.strategy", "stlc.backends.registry",
                       "stlc.backends.base"}
#: private names imported across modules outside the planners' wing, owned by the modules
#: that define them; an entry that no longer matches fails too (the list only shrinks)
KNOWN_PRIVATE = {
    "stlc.analysis.monitor_demand: stlc.analysis.monitor._BINARY",
    "stlc.analysis.monitor_demand: stlc.analysis.monitor._call",
    "stlc.analysis.monitor_demand: stlc.analysis.monitor._channel",
    "stlc.analysis.monitor_demand: stlc.analysis.monitor._param",
    "stlc.analysis.monitor_demand: stlc.analysis.monitor._until",
    "stlc.analysis.smooth_demand: stlc.analysis.monitor_demand._pad",
    "stlc.sweeping.report: stlc.output.report.render._plotly_js",
    "stlc.sweeping.run: stlc.output.directory._cleanup",
}


def family(module: str) -> str:
    """``stlc.backends.nlp.model`` → ``nlp``; ``stlc.backends.base`` → ``base``."""
    parts = module.split(".")
    return parts[2] if len(parts) > 2 else "package"


def wing_violations(g: dict[str, set[str]]) -> list[str]:
    out = []
    for m, ts in sorted(g.items()):
        if not m.startswith("stlc.backends."):
            continue
        for t in sorted(ts):
            if not t.startswith("stlc.backends."):
                continue
            a, b = family(m), family(t)
            if a != b and FAMILY_RANK[b] >= FAMILY_RANK[a] and a != "strategy":
                out.append(f"{m} ({a}) imports {t} ({b})")
            if a == "strategy" and b == "strategy" and m != t:
                out.append(f"{m} imports {t}")
    return out


def _tree(path):
    import ast

    return ast.parse(path.read_text(encoding="utf-8"))


def private_imports(mods) -> list[str]:
    """``from stlc.x import _name`` in another module than ``stlc.x``."""
    import ast

    out = []
    for m, p in sorted(mods.items()):
        for node in ast.walk(_tree(p)):
            if isinstance(node, ast.ImportFrom) and (node.module or "").startswith("stlc"):
                out += [f"{m}: {node.module}.{a.name}" for a in node.names
                        if a.name.startswith("_") and not a.name.startswith("__")]
    return out


def solver_library_uses(tree) -> list[str]:
    """Imports of highspy or cvxpy, and calls of ``nlpsol``."""
    import ast

    out = []
    for n in ast.walk(tree):
        if isinstance(n, ast.Import):
            out += [a.name for a in n.names if a.name.split(".")[0] in ("highspy", "cvxpy")]
        elif isinstance(n, ast.ImportFrom) and (n.module or "").split(".")[0] in (
                "highspy", "cvxpy"):
            out.append(n.module)
        elif isinstance(n, ast.Call):
            f = n.func
            name = f.attr if isinstance(f, ast.Attribute) else getattr(f, "id", "")
            if name == "nlpsol":
                out.append(f"nlpsol() at line {n.lineno}")
    return out


def record_subscripts(tree) -> list[str]:
    """``x.solver[...]``, ``x.solver.get(...)`` and ``x.solver.details`` reads: the solve
    record read as a dictionary, not through its typed fields."""
    import ast

    def is_record(e) -> bool:
        return isinstance(e, ast.Attribute) and e.attr == "solver"

    out = []
    for n in ast.walk(tree):
        if isinstance(n, ast.Subscript) and is_record(n.value):
            out.append(f"line {n.lineno}: solver[...]")
        elif isinstance(n, ast.Attribute) and is_record(n.value) and n.attr in (
                "get", "details", "setdefault", "pop"):
            out.append(f"line {n.lineno}: solver.{n.attr}")
    return out


def environment_reads(tree) -> list[str]:
    import ast

    out = []
    for n in ast.walk(tree):
        if isinstance(n, ast.Attribute) and n.attr in ("environ", "getenv", "putenv"):
            out.append(f"line {n.lineno}: {n.attr}")
        elif isinstance(n, ast.ImportFrom) and n.module == "os" and any(
                a.name in ("environ", "getenv") for a in n.names):
            out.append(f"line {n.lineno}: from os import")
    return out


def test_every_backend_module_is_in_its_place():
    from test_import_graph import module_names

    misplaced = []
    for m in module_names():
        parts = m.split(".")
        if parts[:2] != ["stlc", "backends"] or len(parts) == 2:
            continue
        if len(parts) == 3 and parts[2] not in WING_TOP | FAMILIES:
            misplaced.append(m)
        if len(parts) > 3 and parts[2] not in FAMILIES:
            misplaced.append(m)
    assert not misplaced, f"backend modules outside base/registry/strategy and the " \
                          f"family folders {sorted(FAMILIES)}: {misplaced}"


def test_families_import_each_other_one_way():
    bad = wing_violations(graph())
    assert not bad, "imports against the family order:\n" + "\n".join(bad)


def test_the_family_checker_catches_a_climb():
    g = {"stlc.backends.nlp.model": {"stlc.backends.milp.seed", "stlc.backends.base"},
         "stlc.backends.milp.seed": {"stlc.backends.nlp.model"},
         "stlc.backends.team.backend": {"stlc.backends.milp.seed"},
         "stlc.backends.replan.move": {"stlc.backends.strategy"}}
    assert wing_violations(g) == [
        "stlc.backends.nlp.model (nlp) imports stlc.backends.milp.seed (milp)",
        "stlc.backends.replan.move (replan) imports stlc.backends.strategy (strategy)",
        "stlc.backends.team.backend (team) imports stlc.backends.milp.seed (milp)"]


def test_no_private_name_is_imported_across_modules():
    from test_import_graph import module_names

    found = set(private_imports(module_names()))
    assert found <= KNOWN_PRIVATE, "private names imported across modules:\n" + "\n".join(
        sorted(found - KNOWN_PRIVATE))
    assert KNOWN_PRIVATE <= found, f"no longer imported, drop from KNOWN_PRIVATE: " \
                                   f"{sorted(KNOWN_PRIVATE - found)}"


def test_solver_libraries_only_in_their_adapters():
    from test_import_graph import module_names

    bad = {m: uses for m, p in module_names().items() if not m.startswith("stlc.solvers")
           for uses in [solver_library_uses(_tree(p))] if uses}
    assert not bad, f"highspy/cvxpy/nlpsol outside stlc/solvers: {bad}"


def test_the_adapter_detector():
    import ast

    src = "import highspy\nfrom cvxpy import Variable\nca.nlpsol('x', 'ipopt', {}, {})\n"
    assert len(solver_library_uses(ast.parse(src))) == 3


def test_orderers_reach_the_planners_through_strategy_registry_and_base():
    g = graph()
    bad = sorted(f"{m} imports {t}" for m, ts in g.items() if _under(m, ORDERERS)
                 for t in ts if t.startswith("stlc.backends") and t not in ORDERERS_MAY_IMPORT)
    assert not bad, "\n".join(bad)


def test_orderers_read_the_solve_record_through_its_fields():
    from test_import_graph import module_names

    bad = {m: r for m, p in module_names().items() if _under(m, ORDERERS)
           for r in [record_subscripts(_tree(p))] if r}
    assert not bad, f"the solve record read as a dictionary: {bad}"


def test_the_record_detector():
    import ast

    src = "a = sol.solver['chain']\nb = sol.solver.get('x')\nc = sol.solver.chain\n"
    assert record_subscripts(ast.parse(src)) == ["line 1: solver[...]", "line 2: solver.get"]


def test_the_environment_is_read_in_one_module():
    from test_import_graph import module_names

    bad = {m: r for m, p in module_names().items() if m != "stlc.settings"
           for r in [environment_reads(_tree(p))] if r}
    assert not bad, f"os.environ outside stlc.settings: {bad}"


def test_importing_stlc_leaves_the_thread_counts_alone():
    import os
    import subprocess
    import sys

    code = ("import os, sys; before = dict(os.environ); import stlc, stlc.api, stlc.pipeline; "
            "sys.exit(0 if dict(os.environ) == before else 1)")
    env = {k: v for k, v in os.environ.items()
           if k not in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")}
    assert subprocess.run([sys.executable, "-c", code], env=env).returncode == 0
