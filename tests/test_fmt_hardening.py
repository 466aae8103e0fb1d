"""``stlc fmt``: idempotent (a property over mutated layouts of the shipped specs, and the
`;`-joined long line), own-line comments inside a formula kept on their own lines, each
input read once (a pipe, a FIFO), and a folder that refuses new files is a diagnostic."""

from __future__ import annotations

import glob
import os
import subprocess
import sys
import tempfile
import threading

from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from stlc.diagnostics import StlcError
from stlc.tools import fmt_command
from stlc.tools.fmt import format_text

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SPECS = sorted(glob.glob(os.path.join(ROOT, "specs", "**", "*.stl"), recursive=True))
UNFORMATTED = "signal x\nspec  s =   always[0,1]   (x<=1)\n"


def _stlc(*args, **kw):
    return subprocess.run([sys.executable, "-m", "stlc", *args], capture_output=True,
                          text=True, timeout=120, env=dict(os.environ, PYTHONPATH=ROOT), **kw)


def test_joined_declarations_on_a_long_line_are_idempotent():
    src = ("signal x\nconst " + "a" * 47 + " = 1; const " + "b" * 74 + " = 2\n")
    once = format_text(src)
    assert format_text(once) == once
    assert once.count("\nconst ") == 2  # split: the two do not fit on one line


def test_own_line_comments_inside_a_formula_stay_on_their_own_lines():
    src = ("signal x, y\nspec s = always[0, 1] (x <= 1\n  # first\n  and y <= 2\n"
           "  # second\n  and x >= -1)\n")
    out = format_text(src)
    lines = out.splitlines()
    assert [ln.strip() for ln in lines if "#" in ln] == ["# first", "# second"]
    first = next(i for i, ln in enumerate(lines) if "# first" in ln)
    assert "x <= 1" in lines[first - 1] and "y <= 2" in lines[first + 1]
    assert format_text(out) == out


def _mutations(text: str, data) -> str:
    """The text with random layout changes only: spaces, indentation, line joins."""
    out = []
    for line in text.split("\n"):
        code, hash_, comment = line.partition("#")
        k = data.draw(st.integers(0, 3), label="mutation")
        if k == 1:
            code = code.replace(" ", "  ")
        elif k == 2:
            code = code.lstrip()
        elif k == 3 and not hash_ and code.strip():
            code = " " * data.draw(st.integers(0, 8), label="indent") + code.strip()
        out.append(code + hash_ + comment)
    return "\n".join(out)


@settings(max_examples=12, deadline=None, derandomize=True,
          suppress_health_check=list(HealthCheck))
@given(path=st.sampled_from(SPECS), data=st.data())
def test_fmt_is_idempotent_on_mutated_layouts(path, data):
    src = open(path, encoding="utf-8").read()
    mutated = _mutations(src, data)
    try:
        once = format_text(mutated, path)
    except StlcError:
        assume(False)
    assert format_text(once, path) == once


def test_check_reads_a_pipe_once(tmp_path):
    r = _stlc("fmt", "--check", "/dev/stdin", input=UNFORMATTED)
    assert r.returncode == 1 and "would reformat" in r.stdout, r.stdout + r.stderr
    r = _stlc("fmt", "--check", "/dev/stdin", input=format_text(UNFORMATTED))
    assert r.returncode == 0, r.stdout + r.stderr


def test_check_reads_a_fifo_once_and_does_not_block(tmp_path):
    fifo = str(tmp_path / "f.stl")
    os.mkfifo(fifo)

    def writer():
        with open(fifo, "w") as fh:
            fh.write(UNFORMATTED)

    t = threading.Thread(target=writer, daemon=True)
    t.start()
    r = _stlc("fmt", "--check", fifo)  # timeout=120: a second open would block forever
    t.join(5)
    assert r.returncode == 1 and "would reformat" in r.stdout, r.stdout + r.stderr


def test_a_pipe_is_not_rewritten(tmp_path):
    r = _stlc("fmt", "/dev/stdin", input=UNFORMATTED)
    assert r.returncode == 1 and "error[STL605]" in r.stderr and "Traceback" not in r.stderr


def test_a_folder_that_refuses_new_files_is_a_diagnostic(tmp_path, monkeypatch, capsys):
    f = tmp_path / "s.stl"
    f.write_text(UNFORMATTED)

    def refuse(*a, **k):
        raise PermissionError(13, "Permission denied")

    monkeypatch.setattr(tempfile, "mkstemp", refuse)  # a read-only folder (we may be root)
    assert fmt_command.run([str(f)]) == 1
    err = capsys.readouterr().err
    assert "error[STL605]" in err and "Permission denied" in err
    assert f.read_text() == UNFORMATTED

