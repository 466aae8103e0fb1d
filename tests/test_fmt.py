"""``stlc fmt``: idempotent, comments kept, the meaning unchanged (same AST, same checked
program, same robustness) on every shipped spec, every test mission and the fuzzer's
corpus; syntax errors leave a file untouched; ``--check``; stdin; atomic replacement."""

from __future__ import annotations

import dataclasses
import os
import random
import stat
import subprocess
import sys
from pathlib import Path

import pytest

from stlc import fuzz
from stlc.diagnostics import StlcError
from stlc.frontend.syntax import parse
from stlc.semantics.check import check
from stlc.tools.fmt import comments_of, format_text, parse_with_comments

ROOT = Path(__file__).resolve().parent.parent
FILES = sorted([*ROOT.glob("specs/*.stl"), *ROOT.glob("tests/missions/*.stl"),
                *ROOT.glob("tests/diagnostics/*.stl")])


def _parses(text: str) -> bool:
    try:
        parse(text)
        return True
    except StlcError:
        return False


def _plain(o):
    """A checked program without what is only display (spans, the predicates' labels and
    bounds' names, which quote the source)."""
    if dataclasses.is_dataclass(o) and not isinstance(o, type):
        return (type(o).__name__, tuple(
            (f.name, _plain(getattr(o, f.name))) for f in dataclasses.fields(o)
            if f.name not in ("span", "name_span", "label", "spec_spans", "source")
            and not (type(o).__name__ == "Bound" and f.name == "signal")  # source text
            and not (type(o).__name__ == "Origin" and f.name in ORIGIN_TEXT)))
    if isinstance(o, dict):
        return tuple((k, _plain(v)) for k, v in o.items())
    if isinstance(o, (list, tuple)):
        return tuple(_plain(x) for x in o)
    return o


#: the fields of a predicate's origin that are source text as written (layout may change
#: them; what they say about the predicate — kind, face, side, regions, negation — may not)
ORIGIN_TEXT = {"text", "subject", "left", "right", "region_text", "bound_text"}


def _words(comments) -> list[str]:
    return " ".join(c.text for c in comments).split()


def assert_same_meaning(src: str) -> tuple[str, bool]:
    """The formatted text, and whether the source checks (then both programs are equal)."""
    out = format_text(src)
    assert format_text(out) == out, "not idempotent"
    (a, ca), (b, cb) = parse_with_comments(src), parse_with_comments(out)
    assert a.members == b.members
    assert _words(cb) == _words(ca), "a comment was lost or reordered"
    try:
        before = _plain(dataclasses.replace(check(a), source=""))
    except StlcError:
        return out, False
    assert _plain(dataclasses.replace(check(b), source="")) == before
    return out, True


@pytest.mark.parametrize("path", [p for p in FILES if _parses(p.read_text("utf-8"))],
                         ids=lambda p: f"{p.parent.name}/{p.name}")
def test_shipped_files_keep_their_meaning_and_comments(path):
    src = path.read_text(encoding="utf-8")
    out, _ = assert_same_meaning(src)
    # every comment line's text survives verbatim (trailing comments may be re-aligned)
    assert sorted(c.text for c in comments_of(out)) == sorted(c.text for c in comments_of(src))
    assert max(len(x) for x in out.splitlines()) <= 100 or any(
        len(x) > 100 and ("#" in x or "=" in x) for x in out.splitlines())


def test_every_shipped_spec_and_mission_is_covered():
    names = {p.name for p in FILES if _parses(p.read_text("utf-8"))}
    assert {"handover.stl", "bird_diverter_2x7.stl", "monitor_example.stl",
            "hexa_climb.stl", "team_small.stl"} <= names
    assert len(names) >= 45


def test_the_fuzzers_accepted_corpus_keeps_its_meaning():
    """Generated files and mutations of every shipped spec, as ``python -m stlc.fuzz`` makes
    them (seeds 0..): whatever parses is formatted to the same AST (and, when it checks, to
    the same program)."""
    seeds = fuzz.seed_files()
    parsed = checked = 0
    for seed in range(120):
        rng = random.Random(seed)
        for text in (fuzz.gen_source(rng), fuzz.mutate(Path(seeds[seed % len(seeds)])
                                                       .read_text("utf-8"), rng)):
            if isinstance(text, bytes) or not _parses(text):
                continue
            parsed += 1
            checked += assert_same_meaning(text)[1]
    assert parsed >= 80 and checked >= 15, (parsed, checked)


def test_layout_rules():
    src = ("const  a=1 s   # one\nconst bb = 2 s\n\n\n# alone\nvehicle v : point_mass {"
           "  # head\n  vel_max=(1,1,1) m/s\n acc_max = (1, 1, 1) m/s^2\n"
           "  start { pos = (0, 0, 1) m }\n}\nsignal x\n"
           "spec s = (x > 1) and ((x < 3) or not (x > 2))  # why\n")
    out = format_text(src)
    assert out == (
        "const a  = 1 s  # one\nconst bb = 2 s\n\n# alone\nvehicle v : point_mass {  # head\n"
        "  vel_max = (1, 1, 1) m/s\n  acc_max = (1, 1, 1) m/s^2\n"
        "  start { pos = (0, 0, 1) m }\n}\nsignal x\n"
        "spec s = (x > 1) and ((x < 3) or not (x > 2))  # why\n")  # the user's parentheses


def test_long_formulas_break_at_the_loosest_operator_and_comments_stay_on_their_line():
    names = [f"signal_number_{i}" for i in range(8)]
    src = "signal " + ", ".join(names) + "\nspec s = always[0, 1] (" + " and ".join(
        f"{n} > {i}" for i, n in enumerate(names)) + " or signal_number_0 < 0)\n"
    out, _ = assert_same_meaning(src)
    lines = out.splitlines()
    assert all(len(x) <= 100 for x in lines)
    assert lines[-1].lstrip().startswith("or signal_number_0 < 0")
    inner = "spec t = signal_number_1 > 0  # first\n  and signal_number_2 > 0  # second\n"
    out, _ = assert_same_meaning("signal " + ", ".join(names) + "\n" + inner)
    lines = out.splitlines()
    assert lines[-2].startswith("spec t = signal_number_1 > 0") and lines[-2].endswith("# first")
    assert lines[-1].lstrip().startswith("and signal_number_2 > 0")
    assert lines[-1].endswith("# second")


# ---------------------------------------------------------------- the command


def stlc(*args, stdin: str | None = None, cwd=None):
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    return subprocess.run([sys.executable, "-m", "stlc", *args], input=stdin, text=True,
                          capture_output=True, env=env, cwd=cwd, timeout=120)


def test_check_write_stdin_and_untouched_broken_files(tmp_path):
    messy = "const   T=4 s\nsignal x\nspec s = always[0,T] ((x>1))\n"
    good = format_text(messy)
    a, b, bad = tmp_path / "a.stl", tmp_path / "b.stl", tmp_path / "bad.stl"
    a.write_text(messy)
    b.write_text(good)
    bad.write_text("signal x\nspec s = x >= >= 1\n")
    os.chmod(a, 0o640)
    r = stlc("fmt", "--check", str(a), str(b))
    assert r.returncode == 1 and r.stdout.strip() == f"would reformat {a}"
    assert a.read_text() == messy
    assert stlc("fmt", "--check", str(b)).returncode == 0
    r = stlc("fmt", str(a), str(b))
    assert r.returncode == 0 and a.read_text() == good and b.read_text() == good
    assert stat.S_IMODE(a.stat().st_mode) == 0o640
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.stl", "b.stl", "bad.stl"]  # no temp
    before = bad.read_bytes(), bad.stat().st_mtime_ns
    r = stlc("fmt", str(bad), str(a))
    assert r.returncode == 1 and "error[STL002]" in r.stderr and str(bad) in r.stderr
    assert (bad.read_bytes(), bad.stat().st_mtime_ns) == before
    r = stlc("fmt", "-", stdin=messy)
    assert r.returncode == 0 and r.stdout == good
    r = stlc("fmt", "-", stdin="spec s = = 1\n")
    assert r.returncode == 1 and r.stdout == "" and "STL002" in r.stderr
    assert stlc("fmt", "--check", "-", stdin=messy).returncode == 1
    assert stlc("fmt", "--check", "-", stdin=good).returncode == 0
    crlf = tmp_path / "w.stl"
    crlf.write_bytes(messy.replace("\n", "\r\n").encode())
    link = tmp_path / "link.stl"
    link.symlink_to(crlf)
    assert stlc("fmt", str(link)).returncode == 0
    assert link.is_symlink() and crlf.read_bytes() == good.replace("\n", "\r\n").encode()
    assert stlc("fmt", "--check", str(crlf)).returncode == 0
    r = stlc("fmt", str(tmp_path / "missing.stl"))
    assert r.returncode == 1 and "STL601" in r.stderr


@pytest.fixture(scope="module")
def climb_trace(tmp_path_factory):
    """The trajectory of a compiled multirotor mission (hexa_climb, the suite's fast one)."""
    import stlc as api

    out = tmp_path_factory.mktemp("climb")
    api.compile(api.load(ROOT / "tests/missions/hexa_climb.stl"), risk=False).write(out)
    return out / "trajectory.csv"


@pytest.mark.parametrize("name", ["specs/handover.stl", "tests/missions/hexa_climb.stl"])
def test_monitor_gives_the_same_robustness_with_the_formatted_file(climb_trace, tmp_path, name):
    import stlc as api

    src = (ROOT / name).read_text(encoding="utf-8")
    formatted = tmp_path / Path(name).name
    formatted.write_text(format_text(src), encoding="utf-8")
    assert formatted.read_text() != src
    before = api.monitor(api.load(ROOT / name), climb_trace)
    after = api.monitor(api.load(formatted), climb_trace)
    assert before == after and len(before) >= 2
