"""The command line as users see it: rendering of diagnostics, `--format json`, exit codes.

Most tests call ``stlc.cli.main`` in-process (fast); a few run ``python -m stlc`` in a
subprocess to check the real process exit status and that no traceback ever reaches the
terminal.
"""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

from stlc.cli import main

GOOD = """\
signal x, y
spec phi = always[0, 2] (x >= 0.5) and eventually[1, 3] (y < 0)
vehicle uav1 : point_mass {
  vel_max = (1, 1, 0.5) m/s
  acc_max = (2, 2, 1) m/s^2
  start { pos = (0, 0, 1) m }
}
scenario {
  workspace = box((-3, -3, 0), (3, 3, 3)) m
}
mission m {
  horizon = 4 s
  step = 0.1 s
  require always uav1.pos in workspace
  minimize 0.5 * energy - robustness
}
"""

#: three independent errors; line 4 is indented with a tab on purpose
BAD = """\
signal speed
spec a = sped >= 1
mission m {
\thorizon = 17 m
  step = 0.1 s
  require speed > 0 furlong
}
"""
BAD_EXPECTED = [(2, 10, "STL101"), (4, 12, "STL204"), (6, 19, "STL203")]

HEADER = re.compile(r"^(?P<file>.+?):(?P<line>\d+):(?P<col>\d+): error\[(?P<code>STL\d{3})\]: "
                    r"(?P<message>.+)$")


def run(*args: str, cwd: Path) -> subprocess.CompletedProcess:
    env = {k: v for k, v in os.environ.items() if k != "STLC_DEBUG"}
    return subprocess.run([sys.executable, "-m", "stlc", *args], cwd=cwd, env=env,
                          capture_output=True, text=True, timeout=120)


def write(tmp_path: Path, name: str, text: str) -> Path:
    p = tmp_path / name
    p.write_text(text, encoding="utf-8")
    return p


def parse_rendered(stderr: str) -> list[dict]:
    """Split rustc-style output into diagnostics: header, source line, carets, help."""
    out: list[dict] = []
    for line in stderr.splitlines():
        m = HEADER.match(line)
        if m:
            out.append({**m.groupdict(), "line": int(m["line"]), "col": int(m["col"]),
                        "body": []})
        elif out:
            out[-1]["body"].append(line)
    return out


# ---------------------------------------------------------------- stlc check


def test_check_good_file_exits_0(tmp_path, capsys):
    p = write(tmp_path, "good.stl", GOOD)
    assert main(["check", str(p)]) == 0
    out, err = capsys.readouterr()
    assert out.strip() == f"{p}: ok"
    assert err == ""


def test_check_good_file_as_a_process(tmp_path):
    write(tmp_path, "good.stl", GOOD)
    r = run("check", "good.stl", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    assert "good.stl: ok" in r.stdout
    assert r.stderr == ""


def test_check_bad_file_as_a_process(tmp_path):
    write(tmp_path, "bad.stl", BAD)
    r = run("check", "bad.stl", cwd=tmp_path)
    assert r.returncode == 1
    assert "Traceback" not in r.stderr and "Traceback" not in r.stdout
    diags = parse_rendered(r.stderr)
    assert [(d["line"], d["col"], d["code"]) for d in diags] == BAD_EXPECTED
    assert all(d["file"] == "bad.stl" for d in diags)
    assert r.stderr.rstrip().endswith("stlc: 3 errors")


def test_rendering_shows_source_line_and_caret_under_the_span(tmp_path, capsys):
    p = write(tmp_path, "bad.stl", BAD)
    assert main(["check", str(p)]) == 1
    err = capsys.readouterr().err
    assert "Traceback" not in err
    src_lines = BAD.splitlines()
    diags = parse_rendered(err)
    assert len(diags) == 3
    for d in diags:
        gutter, source, carets = d["body"][0], d["body"][1], d["body"][2]
        n = str(d["line"])
        pad = " " * len(n)
        assert gutter == f"{pad} |"
        assert source == f"{n} | {src_lines[d['line'] - 1].expandtabs(1)}"
        assert carets.startswith(f"{pad} | ")
        caret_col = carets.index("^") - len(f"{pad} | ") + 1
        assert caret_col == d["col"]
        assert set(carets[len(pad) + 3:].strip()) == {"^"}
    # the carets sit under the offending text
    first = diags[0]
    assert first["body"][1][len("2 | ") + first["col"] - 1:].startswith("sped")
    assert first["body"][2].count("^") == len("sped")


def test_help_line_when_there_is_a_hint(tmp_path, capsys):
    p = write(tmp_path, "bad.stl", BAD)
    main(["check", "--format", "json", str(p)])
    helps = [d["help"] for d in json.loads(capsys.readouterr().out)["diagnostics"]]
    main(["check", str(p)])
    diags = parse_rendered(capsys.readouterr().err)
    for d, h in zip(diags, helps, strict=True):
        help_lines = [b for b in d["body"] if b.startswith("  = help: ")]
        if h:
            assert help_lines == [f"  = help: {h}"]
        else:
            assert help_lines == []
    assert diags[0]["body"][3] == "  = help: did you mean `speed`?"


def test_json_format_has_the_same_diagnostics(tmp_path, capsys):
    p = write(tmp_path, "bad.stl", BAD)
    assert main(["check", "--format", "json", str(p)]) == 1
    out = capsys.readouterr().out
    data = json.loads(out)
    diags = data["diagnostics"]
    assert [(d["line"], d["col"], d["code"]) for d in diags] == BAD_EXPECTED
    for d in diags:
        assert d["file"] == str(p)
        assert d["severity"] == "error"
        assert set(d) >= {"code", "message", "line", "col", "end_line", "end_col", "help"}
    assert main(["check", str(p)]) == 1
    text = parse_rendered(capsys.readouterr().err)
    assert [t["message"] for t in text] == [d["message"] for d in diags]


def test_json_format_for_a_good_file(tmp_path, capsys):
    p = write(tmp_path, "good.stl", GOOD)
    assert main(["check", "--format", "json", str(p)]) == 0
    assert json.loads(capsys.readouterr().out) == {"diagnostics": []}


def test_several_files_report_every_error(tmp_path, capsys):
    good = write(tmp_path, "good.stl", GOOD)
    bad = write(tmp_path, "bad.stl", BAD)
    other = write(tmp_path, "other.stl", "signal x\nspec a = x >= 1 $\n")
    assert main(["check", "--format", "json", str(good), str(bad), str(other)]) == 1
    diags = json.loads(capsys.readouterr().out)["diagnostics"]
    assert {d["file"] for d in diags} == {str(bad), str(other)}
    assert len(diags) == 4


def test_missing_file_is_an_input_error(tmp_path, capsys):
    assert main(["check", str(tmp_path / "nope.stl")]) == 1
    err = capsys.readouterr().err
    assert "error[STL601]" in err and "Traceback" not in err


def test_invalid_utf8_file(tmp_path, capsys):
    p = tmp_path / "latin1.stl"
    p.write_bytes(b"signal x\nspec a = x > 1 # caf\xe9\n")
    assert main(["check", str(p)]) == 1
    diags = parse_rendered(capsys.readouterr().err)
    assert [(d["line"], d["col"], d["code"]) for d in diags] == [(2, 21, "STL005")]
    assert diags[0]["body"][1].startswith("2 | spec a = x > 1 # caf")


def test_long_line_rendering_keeps_the_caret_on_the_span(tmp_path, capsys):
    line = "spec a = " + " + ".join(["x"] * 100) + " + sped > 1"
    p = write(tmp_path, "long.stl", f"signal x, speed\n{line}\n")
    assert main(["check", str(p)]) == 1
    [d] = parse_rendered(capsys.readouterr().err)
    assert d["col"] == line.index("sped") + 1
    source, carets = d["body"][1], d["body"][2]
    at = carets.index("^")
    assert source[at:at + 4] == "sped"


def test_deeply_nested_formula_is_an_input_error(tmp_path, capsys):
    p = write(tmp_path, "deep.stl", "signal x\nspec a = " + "not\n" * 400 + "x > 1\n")
    assert main(["check", str(p)]) == 1


# ---------------------------------------------------------------- usage errors


def test_unknown_subcommand_exits_2(tmp_path):
    r = run("frobnicate", cwd=tmp_path)
    assert r.returncode == 2
    assert "usage" in r.stderr.lower()
    assert "Traceback" not in r.stderr


@pytest.mark.parametrize("argv", [
    [],
    ["frobnicate"],
    ["check"],
    ["check", "--format", "xml", "x.stl"],
    ["monitor", "x.stl"],
    ["compile"],
], ids=["no-args", "unknown-command", "check-no-file", "bad-format", "monitor-no-trace",
        "compile-no-file"])
def test_usage_errors_exit_2(argv, capsys):
    with pytest.raises(SystemExit) as e:
        main(argv)
    assert e.value.code == 2
    assert "usage" in capsys.readouterr().err.lower()


def test_monitor_without_trace_as_a_process(tmp_path):
    write(tmp_path, "good.stl", GOOD)
    r = run("monitor", "good.stl", cwd=tmp_path)
    assert r.returncode == 2
    assert "--trace" in r.stderr
    assert "Traceback" not in r.stderr
