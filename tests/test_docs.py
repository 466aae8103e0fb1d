"""The README and docs/ are run, not just read.

Every fenced block in ``README.md`` and ``docs/*.md`` is marked with its kind:

* ```` ```sh ```` — a shell script, run with bash; it must exit 0;
* ```` ```console ```` — ``$ command`` lines, each run with bash; the lines after a command
  are output that must appear, in order, in what it printed (stdout and stderr), and
  ``[exit N]`` says the exit status it must have (0 when absent);
* ```` ```python ```` — run with this interpreter; every ``print(...)  # value`` prints
  exactly ``value`` (a parenthesised remark after the value is a comment);
* ```` ```stl ```` — a complete mission file: ``stlc check --deny-warnings`` accepts it;
* ```` ```text ```` — output samples, synopses and formulas: not run.

The blocks of one page run in order in one scratch folder that links the repository's
``specs/``, ``tests/`` and ``scripts/`` and holds a copy of ``docs/`` (a block may write
there); ``stlc`` and ``python`` are this interpreter with this checkout on ``PYTHONPATH``.
Two commands are not run as written: the README's test command (it would run this suite
inside itself — it must be the command ``.ci/run`` runs instead), and the performance
table's full benchmark (minutes): it runs with ``--cases monitor``, into the copy.

Also here: the README's length, the error-code table against the registered codes, the
links between pages, and that no development history (rounds, issue numbers) is left in
the README, the docs or the code.
"""

from __future__ import annotations

import os
import re
import shlex
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from stlc.diagnostics import CODES

ROOT = Path(__file__).resolve().parent.parent
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
FENCE = re.compile(r"^```(\w*)\n(.*?)^```\s*$", re.S | re.M)
RUN = {"sh", "console", "python", "stl"}
NOT_RUN = {"text"}
#: commands too long for the suite, and what runs instead
CHEAPER = {"stlc bench suite --update docs/performance.md":
           "stlc bench suite --cases monitor --update docs/performance.md"}
HISTORY = re.compile(r"session [0-9]|issue [0-9]|tried and not kept", re.I)


def blocks(page: Path) -> list[tuple[str, str]]:
    return [(m.group(1), m.group(2)) for m in FENCE.finditer(page.read_text("utf-8"))]


def ci_commands() -> tuple[str, str]:
    """(the pip target of ``.ci/run``'s install, its test command)."""
    lines = [ln.strip() for ln in (ROOT / ".ci/run").read_text("utf-8").splitlines()
             if ln.strip() and not ln.lstrip().startswith("#")]
    (install,) = [ln for ln in lines if "pip install" in ln and " -e " in ln]
    return shlex.split(install)[-1], lines[-1]


@pytest.fixture
def scratch(tmp_path: Path) -> tuple[Path, dict[str, str]]:
    work = tmp_path / "work"
    work.mkdir()
    for name in ("specs", "tests", "scripts", "grammar"):
        (work / name).symlink_to(ROOT / name)
    shutil.copytree(ROOT / "docs", work / "docs")
    bin_dir = tmp_path / "bin"
    bin_dir.mkdir()
    for name, line in (("stlc", f'exec "{sys.executable}" -m stlc "$@"'),
                       ("python", f'exec "{sys.executable}" "$@"')):
        (bin_dir / name).write_text(f"#!/bin/sh\n{line}\n")
        (bin_dir / name).chmod(0o755)
    env = {**os.environ, "PYTHONPATH": str(ROOT),
           "PATH": f"{bin_dir}{os.pathsep}{os.environ.get('PATH', '')}"}
    return work, env


def bash(command: str, work: Path, env: dict[str, str]) -> subprocess.CompletedProcess:
    return subprocess.run(["bash", "-c", command], cwd=work, env=env, capture_output=True,
                          text=True, timeout=600)


def run_sh(code: str, work: Path, env: dict[str, str]) -> None:
    if "pip install" in code:  # an install line: check what it installs, run the rest
        (line,) = [ln for ln in code.splitlines() if ln.strip()]
        parts = [p.strip() for p in line.split("&&")]
        (pip,) = [p for p in parts if p.startswith("pip install")]
        rest = parts[parts.index(pip) + 1:]
        target, ci_test = ci_commands()
        if rest == [ci_test]:  # the test command: exactly what CI runs
            assert shlex.split(pip)[-1] == target
            return
        assert shlex.split(pip)[2:] == ["-e", "."]
        code = " && ".join(rest)
    r = bash(code, work, env)
    assert r.returncode == 0, f"{code}\n{r.stdout}\n{r.stderr}"


def run_console(code: str, work: Path, env: dict[str, str]) -> None:
    steps: list[tuple[str, list[str]]] = []
    for line in code.splitlines():
        if line.startswith("$ "):
            steps.append((line[2:].strip(), []))
        elif line.strip():
            assert steps, f"output before any command: {line}"
            steps[-1][1].append(line.strip())
    for command, expected in steps:
        want_rc = 0
        if expected and re.fullmatch(r"\[exit \d+\]", expected[-1]):
            want_rc = int(expected.pop()[6:-1])
        r = bash(CHEAPER.get(command, command), work, env)
        assert r.returncode == want_rc, f"$ {command}\n{r.stdout}\n{r.stderr}"
        got = [ln.strip() for ln in (r.stdout + r.stderr).splitlines()]
        at = 0
        for want in expected:
            assert want in got[at:], f"$ {command}: `{want}` not in\n{r.stdout}{r.stderr}"
            at = got.index(want, at) + 1


def run_python(code: str, work: Path, env: dict[str, str]) -> None:
    r = subprocess.run([sys.executable, "-c", code], cwd=work, env=env, capture_output=True,
                       text=True, timeout=600)
    assert r.returncode == 0, f"{code}\n{r.stderr}"
    expected = [m.group(1).split(" (")[0].strip()
                for m in re.finditer(r"print\(.*\)\s+# (.*)", code)]
    assert r.stdout.splitlines() == expected, r.stdout


def run_stl(code: str, work: Path, env: dict[str, str]) -> None:
    path = work / "block.stl"
    path.write_text(code, encoding="utf-8")
    r = bash("stlc check --deny-warnings block.stl", work, env)
    assert r.returncode == 0, f"{code}\n{r.stdout}{r.stderr}"


RUNNERS = {"sh": run_sh, "console": run_console, "python": run_python, "stl": run_stl}


@pytest.mark.parametrize("page", PAGES, ids=lambda p: p.relative_to(ROOT).as_posix())
def test_every_block_of_the_page_runs(page: Path, scratch) -> None:
    work, env = scratch
    for kind, code in blocks(page):
        assert kind in RUN | NOT_RUN, f"{page.name}: a block marked `{kind or '(none)'}`"
        if kind in RUN:
            RUNNERS[kind](code, work, env)
    if page.name == "performance.md":  # the table was rewritten in the copy
        table = (work / "docs/performance.md").read_text("utf-8")
        assert "| exact monitor, 10,000 samples |" in table and "cores" in table


def test_the_readme_test_command_is_what_ci_runs() -> None:
    target, ci_test = ci_commands()
    assert (target, ci_test) == ('.[test]', "python -m pytest -q")
    commands = [c for k, c in blocks(ROOT / "README.md") if k == "sh" and "pip install" in c]
    assert any(c.strip().endswith(f'pip install -e "{target}" && {ci_test}')
               for c in commands), commands


def test_the_readme_is_short() -> None:
    assert len((ROOT / "README.md").read_text("utf-8").splitlines()) <= 300


def test_the_error_table_is_the_registered_codes() -> None:
    text = (ROOT / "docs/errors.md").read_text("utf-8")
    rows = re.findall(r"^\| `(STL\w+)` \| (.*) \|$", text, re.M)
    assert [(c, m.replace("\\|", "|")) for c, m in rows] == list(CODES.items())


def _anchor(heading: str) -> str:
    """GitHub's anchor of a heading: lower case, punctuation dropped, spaces to dashes."""
    return re.sub(r"[^\w\- ]", "", heading.strip().lower()).replace(" ", "-")


def test_links_between_pages_resolve() -> None:
    for page in [*PAGES, ROOT / "specs/README.md"]:
        text = page.read_text("utf-8")
        for target in re.findall(r"\]\(([^)\s]+)\)", text):
            if re.match(r"[a-z]+://", target):
                continue
            file, _, anchor = target.partition("#")
            dest = (page.parent / file).resolve() if file else page
            assert dest.exists(), f"{page.name}: link to missing {target}"
            if anchor and dest.suffix == ".md":
                heads = re.findall(r"^#+ (.*)$", dest.read_text("utf-8"), re.M)
                assert anchor in {_anchor(h) for h in heads}, f"{page.name}: {target}"


def test_no_development_history_in_readme_docs_or_code() -> None:
    """The product speaks of itself: `grep -rniE "session [0-9]|issue [0-9]|tried and not
    kept"` over README.md, docs/, scripts/ and stlc/ finds nothing (history lives in the git
    log)."""
    files = [ROOT / "README.md", *(ROOT / "docs").rglob("*"), *(ROOT / "stlc").rglob("*"),
             *(ROOT / "scripts").rglob("*")]
    hits = []
    for f in files:
        if not f.is_file() or "__pycache__" in f.parts:
            continue
        try:
            text = f.read_text("utf-8")
        except UnicodeDecodeError:
            continue
        hits += [f"{f.relative_to(ROOT)}:{i}: {ln.strip()}"
                 for i, ln in enumerate(text.splitlines(), 1) if HISTORY.search(ln)]
    assert not hits, "\n".join(hits)


def test_the_bench_table_replaces_only_its_block(tmp_path: Path) -> None:
    from stlc.bench import suite

    page = tmp_path / "perf.md"
    page.write_text(f"intro\n{suite.START}\nold table\n{suite.END}\nafter\n", "utf-8")
    table = suite.render([["a", "`stlc x`", "satisfied", "+0.100", "3", "1.0", "0.5", "—"]],
                         "2026-01-01 00:00 UTC", "0.1 / 0.1 / 0.1", "0.2 / 0.2 / 0.2")
    suite.update(str(page), table)
    text = page.read_text("utf-8")
    assert text.startswith(f"intro\n{suite.START}\n") and text.endswith(f"{suite.END}\nafter\n")
    assert "old table" not in text and "| a | `stlc x` | satisfied | +0.100 |" in text
    assert "cores" in text and "0.1 / 0.1 / 0.1 before" in text
    page.write_text("no markers\n", "utf-8")
    with pytest.raises(SystemExit):
        suite.update(str(page), table)
    assert page.read_text("utf-8") == "no markers\n"
