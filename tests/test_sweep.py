"""``stlc sweep``: on a real Dask cluster started here (``dask scheduler`` + two ``dask
worker`` processes on free localhost ports), the sweep's numbers against the exact monitor
(``stlc monitor --set ... --trace plans/<i>.csv``), a failing instance as a row, Ctrl-C."""

from __future__ import annotations

import csv
import json
import os
import signal
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest
from test_set import SOURCE  # one mission for --set and the sweep over it

ENV = {**os.environ, "OMP_NUM_THREADS": "1"}


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def stlc(*args: str, **kw) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "stlc", *args], capture_output=True,
                          text=True, env=ENV, timeout=600, **kw)


def rows(out: Path) -> list[dict]:
    with open(out / "sweep.csv", newline="") as fh:
        return list(csv.DictReader(fh))


@pytest.fixture
def cluster():
    port = free_port()
    addr = f"tcp://127.0.0.1:{port}"
    dask = [sys.executable, "-m", "dask"]
    procs = [subprocess.Popen([*dask, "scheduler", "--host", "127.0.0.1", "--port", str(port),
                               "--no-dashboard"], env=ENV, stdout=subprocess.DEVNULL,
                              stderr=subprocess.DEVNULL)]
    try:
        for name in ("w1", "w2"):
            procs.append(subprocess.Popen([*dask, "worker", addr, "--nthreads", "1",
                                           "--nworkers", "1", "--name", name,
                                           "--no-dashboard"], env=ENV,
                                          stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL))
        from distributed import Client

        with Client(addr, timeout="60s") as c:
            c.wait_for_workers(2, timeout=120)
        yield addr
    finally:
        for p in reversed(procs):
            p.terminate()
        for p in procs:
            try:
                p.wait(timeout=20)
            except subprocess.TimeoutExpired:
                p.kill()


def test_sweep_on_a_real_cluster(tmp_path, cluster):
    f = tmp_path / "m.stl"
    f.write_text(SOURCE)
    out = tmp_path / "out"
    r = stlc("sweep", str(f), "--mission", "m", "--vary", "op.att.z=-30 deg:30 deg:3",
             "--vary", "op.pos.x=100 cm:1.5 m:2", "--scheduler", cluster, "-o", str(out), "-q")
    assert r.returncode == 0, r.stderr
    rs = rows(out)
    assert [int(x["instance"]) for x in rs] == list(range(6))
    assert {x["status"] for x in rs} == {"satisfied"}
    assert {x["worker"] for x in rs} == {"w1", "w2"}  # both workers were used
    # the grid, in SI, ends included, x fastest-varying last
    assert [float(x["op.pos.x"]) for x in rs] == [1.0, 1.5] * 3
    assert float(rs[0]["op.att.z"]) == pytest.approx(-0.5235987755982988, abs=1e-15)
    summary = json.loads((out / "sweep.json").read_text())
    assert summary["counts"] == {"satisfied": 6} and 1 <= summary["nlp_builds"] <= 2
    assert summary["t_c_estimate_s"] == summary["solve_s"]["p95"] > 0
    html = (out / "sweep.html").read_text()
    assert "plans/5.csv" in html and "Plotly" in html and "https://" not in html.split(
        "<script>", 1)[0]
    # the stored plan, re-monitored at the instance's values, gives the sweep's robustness
    for x in (rs[0], rs[5]):
        plan = out / "plans" / f"{x['instance']}.csv"
        m = stlc("monitor", str(f), "--set", f"op.att.z={x['op.att.z']} rad", "--set",
                 f"op.pos.x={x['op.pos.x']} m", "--trace", str(plan), "--json")
        assert m.returncode == 0, m.stderr
        specs = json.loads(m.stdout)["specs"]
        assert specs["m"]["robustness"] == pytest.approx(float(x["robustness"]), abs=1e-6)
        assert specs["reach"]["robustness"] == pytest.approx(float(x["spec.reach"]), abs=1e-6)


def test_failing_instance_is_a_row(tmp_path):
    """T = 2.5 s is not on the 0.2 s grid: that instance fails (STL303) on its worker, the
    others are planned; exit 3 (not every instance satisfied)."""
    f = tmp_path / "m.stl"
    f.write_text(SOURCE)
    out = tmp_path / "out"
    r = stlc("sweep", str(f), "--mission", "m", "--vary", "T=2 s:3 s:3", "--workers", "1",
             "-o", str(out), "-q")
    assert r.returncode == 3, r.stderr
    rs = rows(out)
    assert [x["status"] for x in rs] == ["satisfied", "failed", "satisfied"]
    assert "STL303" in rs[1]["error"]
    assert sorted(os.listdir(out / "plans")) == ["0.csv", "2.csv"]


def test_bad_sweep_input(tmp_path):
    f = tmp_path / "m.stl"
    f.write_text(SOURCE)
    for vary, code in [("op.pos.q=0 m:1 m:2", "STL101"), ("op.pos.x=0 m:1 deg:2", "STL204"),
                       ("op.pos.x=0 m:1 m", "STL201")]:
        r = stlc("sweep", str(f), "--mission", "m", "--vary", vary, "-o", str(tmp_path / "o"))
        assert r.returncode == 1 and f"error[{code}]" in r.stderr, (vary, r.stderr)
        assert "Traceback" not in r.stderr
    assert not (tmp_path / "o").exists()


def test_ctrl_c_leaves_finished_rows(tmp_path):
    f = tmp_path / "m.stl"
    f.write_text(SOURCE)
    out = tmp_path / "out"
    out.mkdir()
    (out / "mine.txt").write_text("keep")
    p = subprocess.Popen([sys.executable, "-m", "stlc", "sweep", str(f), "--mission", "m",
                          "--vary", "op.pos.y=-0.5 m:0.5 m:40", "--workers", "1", "-o",
                          str(out)], env=ENV, stderr=subprocess.PIPE, text=True,
                         preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    seen = threading.Event()

    def watch():
        buf = ""
        while (c := p.stderr.read(1)):
            buf += c
            if "] 2/40" in buf:
                seen.set()

    threading.Thread(target=watch, daemon=True).start()
    assert seen.wait(300)
    p.send_signal(signal.SIGINT)
    t0 = time.time()
    assert p.wait(60) == 130
    assert time.time() - t0 < 30
    rs = rows(out)
    assert 2 <= len(rs) < 40 and {x["status"] for x in rs} == {"satisfied"}
    assert sorted(os.listdir(out / "plans")) == sorted(f"{x['instance']}.csv" for x in rs)
    assert json.loads((out / "sweep.json").read_text())["interrupted"] is True
    assert sorted(os.listdir(out)) == [".stlc-outputs.json", "mine.txt", "plans", "sweep.csv",
                                       "sweep.html", "sweep.json"]
    assert json.loads((out / ".stlc-outputs.json").read_text())["sweep"] == sorted(
        ["sweep.csv", "sweep.html", "sweep.json", *(f"plans/{x['instance']}.csv" for x in rs)])


USER = {"trajectory.final.csv": "t,x\n0,1\n", "trajectory.backup.csv": "mine\n",
        "notes.txt": "user notes\n", "plans/7.csv": "my own plan\n",
        "plans/notes.md": "mine\n"}


def test_sweep_output_directory_is_under_the_manifest(tmp_path):
    """`-o .` in a directory of user files (issue 23): every user file survives a sweep —
    also one named like a sweep's plan that no sweep recorded (`plans/7.csv`); a second
    sweep replaces and removes only what the first recorded; a compile into the same
    directory and a sweep keep each other's files."""
    f = tmp_path / "m.stl"
    f.write_text(SOURCE)
    out = tmp_path / "out"
    (out / "plans").mkdir(parents=True)
    for name, text in USER.items():
        (out / name).write_text(text)

    def user_files_intact():
        for name, text in USER.items():
            assert (out / name).read_text() == text, name

    def sweep(n: int) -> subprocess.CompletedProcess:
        r = stlc("sweep", str(f), "--mission", "m", "--vary", f"T=2.6 s:3 s:{n}",
                 "--workers", "1", "-o", ".", "-q", cwd=out)
        assert r.returncode == 0, r.stderr
        return r

    def recorded(key: str) -> list[str]:
        return json.loads((out / ".stlc-outputs.json").read_text()).get(key, [])

    sweep(2)
    user_files_intact()
    assert sorted(os.listdir(out / "plans")) == ["0.csv", "1.csv", "7.csv", "notes.md"]
    assert recorded("sweep") == ["plans/0.csv", "plans/1.csv", "sweep.csv", "sweep.html",
                                 "sweep.json"]
    r = stlc("compile", str(f), "-o", ".", "-q", "--no-risk", cwd=out)
    assert r.returncode == 0, r.stderr
    user_files_intact()
    assert len(rows(out)) == 2 and (out / "plans" / "1.csv").is_file()  # kept by compile
    assert [f for f in recorded("files") if "/" not in f] == [
        "report.html", "solution.json", "trajectory.csv"]
    assert len(recorded("sweep")) == 5
    solution = (out / "solution.json").read_text()
    sweep(1)  # replaces the first sweep's set: its plans/1.csv goes, nothing else
    user_files_intact()
    assert sorted(os.listdir(out / "plans")) == ["0.csv", "7.csv", "notes.md"]
    assert len(rows(out)) == 1
    assert (out / "solution.json").read_text() == solution  # the compile's set is kept
    assert [f for f in recorded("files") if "/" not in f] == [
        "report.html", "solution.json", "trajectory.csv"]
    assert not [n for n in os.listdir(out) if n.startswith(".stlc-stage-")]


def test_time_limit_is_each_instances_limit(tmp_path):
    """`sweep --time-limit S` (issue 22): S bounds each instance from its start on its
    worker, as `compile --time-limit` bounds a compile.  With 1 ms an instance is `stopped`,
    or `satisfied` by the MILP's minimal slice (the verdict is the exact monitor's, as for
    compile); nothing else.  A stopped row's plan is judged like any: its robustness
    is the one `stlc monitor` finds on plans/<i>.csv.  Exit 3; the limit is in sweep.json."""
    f = tmp_path / "m.stl"
    f.write_text(SOURCE)
    out = tmp_path / "out"
    r = stlc("sweep", str(f), "--mission", "m", "--vary", "T=2.6 s:3 s:2", "--workers", "1",
             "--time-limit", "0.001", "-o", str(out), "-q")
    rs = rows(out)
    statuses = {row["status"] for row in rs}
    # every instance ends within its 1 ms (plus the solvers' minimal slices): `stopped`,
    # or `satisfied` when the exact MILP closes this small mission inside its minimal slice
    # (with the backends imported before the limit starts, the first instance may do so too)
    assert statuses <= {"stopped", "satisfied"}, rs
    assert r.returncode == (3 if "stopped" in statuses else 0), r.stderr
    assert json.loads((out / "sweep.json").read_text())["time_limit_s"] == 0.001
    m = stlc("monitor", str(f), "--set", "T=2.6 s", "--trace", str(out / "plans" / "0.csv"),
             "--json")
    assert m.returncode == 0, m.stderr
    rho = json.loads(m.stdout)["specs"]["m"]["robustness"]
    assert rho == pytest.approx(float(rs[0]["robustness"]), abs=1e-6)
    r = stlc("sweep", str(f), "--mission", "m", "--vary", "T=2.6 s:3 s:2", "--time-limit",
             "0", "-o", str(out))
    assert r.returncode == 2 and "positive" in r.stderr
