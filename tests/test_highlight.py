"""The Pygments lexer (``stlc.frontend.lexer``): no error token on any shipped file,
``pygmentize`` with it, its entry point when installed, and the report's Source section."""

from __future__ import annotations

import subprocess
import sys
from importlib import metadata
from pathlib import Path

import pytest
from pygments.token import Error, Keyword, Name, Number, Operator

from stlc.frontend.lexer import StlcLexer, highlight_lines

ROOT = Path(__file__).resolve().parent.parent
SHIPPED = sorted([*ROOT.glob("specs/*.stl"), *ROOT.glob("tests/missions/*.stl")])


def errors(text: str) -> list[str]:
    return [v for t, v in StlcLexer(stripnl=False).get_tokens(text) if t in Error]


@pytest.mark.parametrize("path", SHIPPED, ids=lambda p: p.name)
def test_no_error_token_on_a_shipped_file(path):
    text = path.read_text(encoding="utf-8")
    assert errors(text) == []
    assert len(highlight_lines(text)) == len(text.splitlines())


def test_tokens_of_a_line():
    toks = [(t, v) for t, v in StlcLexer().get_tokens(
        "spec s = always[0, T] (uav1.pos in box((0, 0, 0), (1, 1, 1)) m and x <= 2.5 m/s)")
        if v.strip()]
    assert (Keyword.Declaration, "spec") in toks and (Operator.Word, "always") in toks
    assert (Name.Attribute, "pos") in toks and (Name.Builtin, "box") in toks
    assert (Number.Float, "2.5") in toks and (Keyword.Type, "m/s") in toks
    assert (Keyword.Type, "m") in toks and (Operator.Word, "and") in toks
    assert errors("spec a = x > 1 && y") == ["&", "&"]  # what the parser rejects too


def test_pygmentize_with_the_lexer(tmp_path):
    r = subprocess.run([sys.executable, "-m", "pygments", "-x", "-l",
                        f"{ROOT / 'stlc/frontend/lexer.py'}:StlcLexer", "-f", "html",
                        str(ROOT / "specs/handover.stl")], text=True, capture_output=True,
                       timeout=60)
    assert r.returncode == 0, r.stderr
    assert 'class="err"' not in r.stdout and 'class="k' in r.stdout


def test_the_entry_point_when_installed():
    eps = [e for e in metadata.entry_points(group="pygments.lexers") if e.name == "stlc"]
    text = (ROOT / "pyproject.toml").read_text(encoding="utf-8")
    assert '[project.entry-points."pygments.lexers"]' in text
    assert 'stlc = "stlc.frontend.lexer:StlcLexer"' in text
    if eps:  # the installed package registers it: `pygmentize -l stlc`, Sphinx, MkDocs
        from pygments.lexers import get_lexer_by_name, get_lexer_for_filename

        assert type(get_lexer_by_name("stlc")).__name__ == "StlcLexer"
        assert type(get_lexer_for_filename("x.stl")).__name__ == "StlcLexer"


def test_highlighted_html_is_escaped():
    (line,) = highlight_lines('spec a = x > 1  # </script> "<b>"\n')
    assert "</script>" not in line and "&lt;/script&gt;" in line
    assert line.startswith('<span class="hl-kd">spec</span>')


def test_the_editor_files():
    import json
    import re

    grammar = json.loads((ROOT / "editors/stlc.tmLanguage.json").read_text(encoding="utf-8"))
    assert grammar["scopeName"] == "source.stlc" and grammar["fileTypes"] == ["stl"]
    for name, rule in grammar["repository"].items():
        for r in rule.get("patterns", [rule]):
            re.compile(r["match"])  # the patterns use only what Oniguruma and `re` share
    comment = re.compile(grammar["repository"]["comment"]["match"], re.M)
    assert comment.search("x = 1  # note").group() == "# note"
    pkg = json.loads((ROOT / "editors/vscode/package.json").read_text(encoding="utf-8"))
    (lang,) = pkg["contributes"]["languages"]
    assert lang["id"] == "stlc" and lang["extensions"] == [".stl"]
    (gram,) = pkg["contributes"]["grammars"]
    assert (ROOT / "editors/vscode" / gram["path"]).resolve() == \
        (ROOT / "editors/stlc.tmLanguage.json").resolve()
    assert pkg["contributes"]["configuration"]["properties"]["stlc.command"]["default"] == \
        ["stlc", "lsp"]
    assert "LanguageClient" in (ROOT / "editors/vscode/extension.js").read_text()
