"""Architecture rules of the ``stlc`` package, checked on the source with ``ast``.

* every module is at most ``MAX_LINES`` lines long;
* only the vehicle registry (``stlc/vehicles/``) tests whether a vehicle is a
  ``Multirotor`` or a ``PointMass``: no ``isinstance(…, Multirotor | PointMass)`` elsewhere;
* every module opens with a docstring;
* no module outside ``stlc/vehicles/`` compares a string with a vehicle kind
  (``kind == "multirotor"``, ``b.model != "point_mass"``, ``kind in ("point_mass", …)``):
  passes ask the model (``stlc.vehicles.model_of(v)``) what it can do.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent / "stlc"
MAX_LINES = 450
VEHICLE_CLASSES = {"Multirotor", "PointMass"}
MODULES = sorted(ROOT.rglob("*.py"))


def _rel(p: Path) -> str:
    return p.relative_to(ROOT.parent).as_posix()


def vehicle_isinstance_calls(tree: ast.AST) -> list[int]:
    """Lines of ``isinstance(x, C)`` calls whose class argument names a vehicle class
    (``Multirotor``, ``model.PointMass``, a tuple containing one, …)."""
    out = []
    for node in ast.walk(tree):
        if not (isinstance(node, ast.Call) and isinstance(node.func, ast.Name)
                and node.func.id == "isinstance" and len(node.args) >= 2):
            continue
        names = {n.id for n in ast.walk(node.args[1]) if isinstance(n, ast.Name)}
        names |= {n.attr for n in ast.walk(node.args[1]) if isinstance(n, ast.Attribute)}
        if names & VEHICLE_CLASSES:
            out.append(node.lineno)
    return out


def test_the_package_is_found():
    assert len(MODULES) > 20 and (ROOT / "vehicles" / "__init__.py") in MODULES


@pytest.mark.parametrize("path", MODULES, ids=_rel)
def test_module_length(path: Path):
    n = len(path.read_text(encoding="utf-8").splitlines())
    assert n <= MAX_LINES, f"{_rel(path)} has {n} lines (at most {MAX_LINES})"


@pytest.mark.parametrize("path", MODULES, ids=_rel)
def test_module_docstring(path: Path):
    tree = ast.parse(path.read_text(encoding="utf-8"), str(path))
    doc = ast.get_docstring(tree)
    assert doc and doc.strip(), f"{_rel(path)} does not open with a docstring"


OUTSIDE_REGISTRY = [p for p in MODULES if "vehicles" not in p.relative_to(ROOT).parts]


@pytest.mark.parametrize("path", OUTSIDE_REGISTRY, ids=_rel)
def test_no_vehicle_isinstance_outside_the_registry(path: Path):
    tree = ast.parse(path.read_text(encoding="utf-8"), str(path))
    lines = vehicle_isinstance_calls(tree)
    assert not lines, (f"{_rel(path)}: isinstance on a vehicle class at lines {lines}; "
                       "ask stlc.vehicles.model_of(v) instead")


def test_the_isinstance_detector():
    """The detector itself, on snippets whose answer is known."""
    cases = {
        "isinstance(v, Multirotor)": [1],
        "isinstance(v, model.PointMass)": [1],
        "isinstance(v, (int, model.Multirotor))": [1],
        "if x:\n    y = isinstance(v, model.Vehicle)": [],
        "isinstance(v, ir.And)": [],
        "Multirotor(1)\nisinstance(PointMass, int)": [],
        "f(isinstance(a, int), isinstance(b, PointMass))": [1],
    }
    for src, want in cases.items():
        assert vehicle_isinstance_calls(ast.parse(src)) == want, src


VEHICLE_KINDS = {"multirotor", "point_mass"}


def vehicle_kind_comparisons(tree: ast.AST) -> list[int]:
    """Lines of comparisons (``==``, ``!=``, ``in``, ``not in``) of anything with a string
    constant that names a vehicle kind, or a tuple/list/set of such constants."""
    out = []
    for node in ast.walk(tree):
        if not isinstance(node, ast.Compare):
            continue
        for side in (node.left, *node.comparators):
            consts = [side] if isinstance(side, ast.Constant) else (
                list(side.elts) if isinstance(side, (ast.Tuple, ast.List, ast.Set)) else [])
            if any(isinstance(c, ast.Constant) and c.value in VEHICLE_KINDS for c in consts):
                out.append(node.lineno)
                break
    return out


def test_the_vehicle_kinds_are_the_registry_s():
    from stlc import vehicles
    from stlc.semantics.check.declarations import READERS

    assert set(vehicles.kinds()) == VEHICLE_KINDS == set(READERS)


@pytest.mark.parametrize("path", OUTSIDE_REGISTRY, ids=_rel)
def test_no_vehicle_kind_test_outside_the_registry(path: Path):
    tree = ast.parse(path.read_text(encoding="utf-8"), str(path))
    lines = vehicle_kind_comparisons(tree)
    assert not lines, (f"{_rel(path)}: compares a vehicle kind by name at lines {lines}; "
                       "ask the model (stlc.vehicles.model_of(v)) instead")


def test_the_kind_detector():
    cases = {
        'model_of(v).kind == "multirotor"': [1],
        'if b.model != "point_mass":\n    pass': [1],
        'k in ("point_mass", "x")': [1],
        'r.kind == "obstacle"': [],
        'READERS = {"multirotor": 1}': [],
        'x = "point_mass"': [],
    }
    for src, want in cases.items():
        assert vehicle_kind_comparisons(ast.parse(src)) == want, src
