"""The Python API (``import stlc``): the example of docs/api.md runs, ``import stlc`` stays cheap,
errors carry located diagnostics, ``set=`` overrides constants, ``monitor`` takes a CSV or
arrays; and the JSON Schemas of ``stlc/schemas/`` accept real outputs (jsonschema)."""

from __future__ import annotations

import json
import re
import subprocess
import sys
from pathlib import Path

import jsonschema
import numpy as np
import pytest

import stlc
from stlc.schemas import SCHEMAS, schema

ROOT = Path(__file__).resolve().parent.parent
CLIMB = ROOT / "tests/missions/hexa_climb.stl"


def run(args, cwd=ROOT, **kw):
    env_path = {"PYTHONPATH": str(ROOT)}
    import os

    return subprocess.run(args, cwd=cwd, capture_output=True, text=True, timeout=300,
                          env={**os.environ, **env_path}, **kw)


def test_the_docs_example_runs(tmp_path):
    text = (ROOT / "docs/api.md").read_text(encoding="utf-8")
    code = re.findall(r"```python\n(.*?)```", text, re.S)[0]
    code = code.replace('"tests/missions/hexa_climb.stl"', repr(str(CLIMB)))
    r = run([sys.executable, "-c", code], cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    # every `# value` comment after a print is what it prints
    expected = [m.group(1).split(" (")[0].strip() for m in
                re.finditer(r"print\(.*\)\s+# (.*)", code)]
    out = r.stdout.splitlines()
    assert len(out) == len(expected)
    for got, want in zip(out, expected):
        assert got == want
    # the files of `stlc compile -o out`, with the directory's ownership record
    # (`.stlc-outputs.json`: a later write replaces only what stlc wrote there)
    assert sorted(p.name for p in (tmp_path / "out").iterdir()) == [
        ".stlc-outputs.json", "flight", "report.html", "rosbag2", "solution.json",
        "trajectory.csv"]


def test_import_is_cheap():
    r = run([sys.executable, "-X", "importtime", "-c",
             "import stlc, sys; print(sorted(m for m in ('numpy', 'casadi', 'lark', 'cvxpy') "
             "if m in sys.modules))"])
    assert r.returncode == 0 and r.stdout.strip() == "[]", r.stdout
    own = [ln for ln in r.stderr.splitlines() if ln.rstrip().endswith("| stlc")]
    print("\n" + own[0])  # `python -X importtime -c "import stlc"` (self µs | cumulative µs)


def test_errors_are_located():
    with pytest.raises(stlc.StlError) as e:
        stlc.loads("signal x\nspec a = always[0, 1] (x > 1)\nspec b = a and sped > 1\n")
    (d,) = e.value.diagnostics
    assert (d.code, d.line, d.column) == ("STL101", 3, 16) and "sped" in d.message
    with pytest.raises(stlc.StlError) as e:
        stlc.load(ROOT / "tests/diagnostics/syntax_extra_paren.stl")
    assert e.value.diagnostics[0].code == "STL002"
    with pytest.raises(stlc.StlError) as e:
        stlc.load("no/such/file.stl")
    assert e.value.diagnostics[0].code == "STL601"


def test_monitor_takes_arrays_and_set_overrides_constants():
    src = "signal x\nconst c = 2\nspec a = always[0, 1] (x <= c)\nspec b = eventually x > 3\n"
    p = stlc.loads(src)
    t = np.arange(0, 2.01, 0.5)
    x = np.array([0.0, 1.0, 1.5, 2.5, 4.0])
    # by hand: a = min(c - x) over t in [0, 1] = 2 - 1.5; b = max(x - 3) over all = 1
    assert stlc.monitor(p, {"t": t, "x": x}) == pytest.approx({"a": 0.5, "b": 1.0})
    p2 = stlc.api.with_constants(p, {"c": "3"})
    assert stlc.monitor(p2, {"t": t, "x": x})["a"] == pytest.approx(1.5)
    with pytest.raises(stlc.StlError) as e:
        stlc.api.with_constants(p, {"cc": 1})
    assert e.value.diagnostics[0].code == "STL101" and "`c`" in e.value.diagnostics[0].help
    with pytest.raises(stlc.StlError) as e:
        stlc.monitor(p, {"t": [0, 0.5, 2], "x": [1, 2, 3]})
    assert e.value.diagnostics[0].code == "STL604"
    with pytest.raises(stlc.StlError) as e:
        stlc.monitor(p, {"x": [1, 2, 3]})
    assert e.value.diagnostics[0].code == "STL602"


# ---------------------------------------------------------------- output schemas

RISKY = CLIMB.read_text(encoding="utf-8").replace(
    "  region shelf = box((0.8, -0.3, 1.3), (1.4, 0.3, 1.7)) m\n",
    "  human op {\n    pos = (1, 0, 0) m\n    att = (0, 0, 0) deg\n"
    "    region shelf = box((-0.2, -0.3, 1.3), (0.4, 0.3, 1.7)) m\n  }\n").replace(
    "(uav1.pos in shelf)", "(uav1.pos in op.shelf)").replace(
    "  minimize 0.5 * energy - robustness\n",
    "  minimize 0.5 * energy - robustness\n"
    "  risk {\n    K = 200; delta = 0.05; beta = [0.8, 0.9]; seed = 3\n"
    "    case small { op.pos ~ normal((1, 0, 0) m, diag(0.01, 0.01, 0) m^2) }\n  }\n"
    "  replan { threshold = 0.3 m; budget = 0.4 s; keep = [stay] }\n"
    # a push clearly past ζ = 0.3 m: a 0.3 m push is a deviation of 0.3 ± 1 ulp, which
    # triggers (> ζ) or not depending on the plan's last bits
    "  simulate { disturb uav1 { time = 1 s; displacement = (0, 0.4, 0) m } }\n")


def validate(name: str, data) -> None:
    s = schema(name)
    jsonschema.Draft202012Validator.check_schema(s)
    jsonschema.Draft202012Validator(s).validate(data)


@pytest.fixture(scope="module")
def outputs(tmp_path_factory):
    d = tmp_path_factory.mktemp("schemas")
    mission = d / "risky.stl"
    mission.write_text(RISKY, encoding="utf-8")
    plan = stlc.compile(stlc.load(mission))
    plan.write(d / "compiled")
    r = run([sys.executable, "-m", "stlc", "simulate", str(mission), "-o", str(d / "sim"),
             "-q"])
    assert r.returncode in (0, 3), r.stderr
    return d


def test_every_schema_is_shipped_and_valid():
    for name in SCHEMAS:
        jsonschema.Draft202012Validator.check_schema(schema(name))
    with pytest.raises(KeyError):
        schema("nope")


def test_solution_and_risk_json_match_their_schemas(outputs):
    sol = json.loads((outputs / "compiled/solution.json").read_text())
    risk = json.loads((outputs / "compiled/risk.json").read_text())
    validate("solution", sol)
    validate("risk", risk)
    assert risk["cases"][0]["K"] == 200
    with pytest.raises(jsonschema.ValidationError):  # the schema does say something
        validate("solution", {**sol, "status": "fine"})


def test_replan_json_matches_its_schema(outputs):
    rep = json.loads((outputs / "sim/replan.json").read_text())
    validate("replan", rep)
    validate("solution", json.loads((outputs / "sim/solution.json").read_text()))
    assert any(e["triggered"] for e in rep["events"])
    with pytest.raises(jsonschema.ValidationError):  # the event kinds are named
        validate("replan", {**rep, "events": [{**rep["events"][0], "kind": "nope"}]})


def test_check_and_monitor_json_match_their_schemas(outputs):
    r = run([sys.executable, "-m", "stlc", "check", "--format", "json",
             str(ROOT / "tests/diagnostics/collect_three_errors.stl"), str(CLIMB)])
    data = json.loads(r.stdout)
    assert r.returncode == 1 and len(data["diagnostics"]) == 3
    validate("check", data)
    r = run([sys.executable, "-m", "stlc", "check", "--format", "json", str(CLIMB)])
    validate("check", json.loads(r.stdout))
    r = run([sys.executable, "-m", "stlc", "monitor", str(ROOT / "specs/monitor_example.stl"),
             "--trace", str(ROOT / "specs/monitor_example.csv"), "--json"])
    assert r.returncode == 0, r.stderr
    validate("monitor", json.loads(r.stdout))
    r = run([sys.executable, "-m", "stlc", "monitor", str(outputs / "risky.stl"), "--trace",
             str(outputs / "compiled/trajectory.csv"), "--json"])
    data = json.loads(r.stdout)
    validate("monitor", data)
    plan_specs = json.loads((outputs / "compiled/solution.json").read_text())["specs"]
    for k, v in plan_specs.items():  # the CLI's monitor agrees with the plan's verification
        assert data["specs"][k]["robustness"] == pytest.approx(v["robustness"], abs=1e-6)


def test_the_report_source_is_highlighted(outputs):
    html = (outputs / "compiled/report.html").read_text(encoding="utf-8")
    assert '<span class="hl-kd">mission</span>' in html
    assert 'class="hl-un">kg*m^2</span>' in html and 'class="hl-err"' not in html
