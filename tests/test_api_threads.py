"""``stlc.compile`` from several threads (after an earlier compile, so the cached NLP is
shared): the plannings are serialised (``stlc.deadline.serial``), the process does not
abort and every thread gets the plan a single thread gets."""

from __future__ import annotations

import os
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
HEXA = os.path.join(ROOT, "tests", "missions", "hexa_climb.stl")

SCRIPT = """
import sys, threading, stlc
prog = stlc.load(sys.argv[1])
first = stlc.compile(prog, risk=False).robustness
out = {}
def go(i):
    out[i] = stlc.compile(prog, risk=False).robustness
ts = [threading.Thread(target=go, args=(i,)) for i in range(2)]
[t.start() for t in ts]
[t.join() for t in ts]
print(repr(first), repr(out[0]), repr(out[1]))
"""


def test_two_threads_after_one_compile_do_not_abort():
    r = subprocess.run([sys.executable, "-c", SCRIPT, HEXA], capture_output=True, text=True,
                       timeout=600, env=dict(os.environ, PYTHONPATH=ROOT))
    assert r.returncode == 0, r.stderr[-2000:]  # was 134 (free(): invalid next size)
    first, a, b = (float(x) for x in r.stdout.split())
    assert first > 0 and abs(a - first) <= 1e-9 and abs(b - first) <= 1e-9
