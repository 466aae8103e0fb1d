"""``stlc explain``: every code the tool can emit has a long explanation with a wrong and a
fixed example; the `.stl` examples are checked (the wrong one reports the code, the fixed
one checks clean)."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest

import stlc
from stlc.diagnostics import CODES
from stlc.tools.explain import explain
from stlc.tools.explanations import EXPLANATIONS, SOURCE_EXAMPLES

ROOT = Path(__file__).resolve().parent.parent


def emitted_codes() -> set[str]:
    """Every code named in the package's source (what a pass can emit), and the registry."""
    found = set(CODES)
    for p in (ROOT / "stlc").rglob("*.py"):
        found |= set(re.findall(r"[\"'](STL\d{3})[\"']", p.read_text(encoding="utf-8")))
    return found


def test_every_code_has_an_explanation():
    codes = emitted_codes()
    assert len(codes) >= 40
    missing = sorted(codes - set(EXPLANATIONS))
    assert not missing, f"no `stlc explain` text for {missing}"
    assert set(EXPLANATIONS) <= set(CODES), "an explanation for a code nobody registered"
    for code in codes:
        text = explain(code)
        assert text.startswith(f"{code}: {CODES[code]}") and "Wrong:" in text and \
            "Fixed:" in text


@pytest.mark.parametrize("code", SOURCE_EXAMPLES)
def test_the_examples_show_the_error_and_its_fix(code):
    _, wrong, fixed = EXPLANATIONS[code]
    with pytest.raises(stlc.StlError) as e:
        stlc.loads(wrong)
    assert code in {d.code for d in e.value.diagnostics}
    stlc.loads(fixed)  # checks clean


def test_the_command(tmp_path):
    r = subprocess.run([sys.executable, "-m", "stlc", "explain", "stl304"], text=True,
                       capture_output=True, cwd=ROOT, timeout=60)
    assert r.returncode == 0 and r.stdout.startswith("STL304: formula reaches beyond")
    r = subprocess.run([sys.executable, "-m", "stlc", "explain", "STL999"], text=True,
                       capture_output=True, cwd=ROOT, timeout=60)
    assert r.returncode == 2 and "no error code `STL999`" in r.stderr
