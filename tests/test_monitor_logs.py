"""``stlc monitor`` on real flight logs: ``--resample DT`` and ``--fail-on-violation``.

A log with jitter (sample times t_k = 0.1·k ± up to 20 ms, i.i.d.) of a signal that is
linear in time, x(t) = 2 − t: linear interpolation is exact for it, so the resampled
trace equals x on the uniform grid and the robustness of ``always[0, 1] x >= 0.5`` is
min over t ∈ {0, 0.1, …, 1} of (1.5 − t) = 0.5 (by hand), and of ``always[0, 2] x >= 0.5``
is 1.5 − 2 = −0.5 (a violation).  The note names the largest gap, computed here from the
file.  Without ``--resample`` the log is refused (STL604) with a hint naming the option.
"""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np

SPEC = """signal x
spec early = always[0, 1] (x >= 0.5)
spec late = always[0, 2] (x >= 0.5)
"""


def _run(*args):
    return subprocess.run([sys.executable, "-m", "stlc", "monitor", *args],
                          capture_output=True, text=True, timeout=120)


def _files(tmp_path, jitter=True):
    rng = np.random.default_rng(3)
    t = 0.1 * np.arange(31) + (rng.uniform(-0.02, 0.02, 31) if jitter else 0.0)
    t[0] = 0.0
    (tmp_path / "s.stl").write_text(SPEC)
    rows = "\n".join(f"{a:.6f},{2 - a:.6f}" for a in t)
    (tmp_path / "log.csv").write_text("t,x\n" + rows + "\n")
    return t


def test_resample_a_jittered_log(tmp_path):
    t = _files(tmp_path)
    r = _run(str(tmp_path / "s.stl"), "--trace", str(tmp_path / "log.csv"),
             "--resample", "0.1", "--json")
    assert r.returncode == 0, r.stderr
    out = json.loads(r.stdout)
    assert abs(out["specs"]["early"]["robustness"] - 0.5) < 1e-9
    assert abs(out["specs"]["late"]["robustness"] + 0.5) < 1e-9
    gap = float(np.max(np.diff(t)))
    assert abs(out["resampled"]["largest_gap"] - gap) < 1e-6
    assert "largest gap" in r.stderr


def test_non_uniform_without_resample_is_refused_with_a_hint(tmp_path):
    _files(tmp_path)
    r = _run(str(tmp_path / "s.stl"), "--trace", str(tmp_path / "log.csv"))
    assert r.returncode == 1
    assert "STL604" in r.stderr and "--resample" in r.stderr


def test_fail_on_violation_exit_codes(tmp_path):
    _files(tmp_path, jitter=False)
    base = [str(tmp_path / "s.stl"), "--trace", str(tmp_path / "log.csv")]
    assert _run(*base).returncode == 0  # `late` is violated, but only reported
    assert _run(*base, "--fail-on-violation").returncode == 3
    (tmp_path / "s.stl").write_text("signal x\nspec early = always[0, 1] (x >= 0.5)\n")
    assert _run(*base, "--fail-on-violation").returncode == 0
