"""``stlc lsp``: a scripted editor session over stdio with a small JSON-RPC client (the real
server process, the LSP framing of the spec), and the analysis behind it in process."""

from __future__ import annotations

import json
import os
import queue
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

from stlc.tools import ide
from stlc.tools.fmt import format_text

ROOT = Path(__file__).resolve().parent.parent

SOURCE = """const T = 4 s

vehicle uav1 : point_mass {
  vel_max = (1, 1, 1) m/s
  acc_max = (1, 1, 1) m/s^2
  start { pos = (0, 0, 1) m }
}

scenario {
  workspace = box((-5, -5, 0), (5, 5, 3)) m
  obstacle pole = box((1, 1, 0), (1.5, 1.5, 3)) m
  human operator {
    pos = (2, 0, 0) m
    att = (0, 0, 0) deg
    region handover = box((0.5, -0.25, 0.75), (1, 0.25, 1.25)) m
    region behind   = box((-1, -1, 0), (-0.2, 1, 2)) m
  }
}

spec safe = always[0, T] (uav1.pos in workspace and uav1.pos not in pole)
mission m {
  vehicles = [uav1]
  horizon = T
  step = 0.1 s
  spec reach = eventually[1, 3] (uav1.pos in operator.handovr)
  require safe and reach
}
"""


class Client:
    """JSON-RPC 2.0 over the server's stdin/stdout, with LSP's Content-Length framing."""

    def __init__(self, cwd: Path):
        env = {**os.environ, "PYTHONPATH": str(ROOT)}
        self.proc = subprocess.Popen([sys.executable, "-m", "stlc", "lsp"], cwd=cwd, env=env,
                                     stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                                     stderr=subprocess.PIPE)
        self.inbox: queue.Queue = queue.Queue()
        self.next_id = 0
        threading.Thread(target=self._read, daemon=True).start()

    def _read(self) -> None:
        out = self.proc.stdout
        while True:
            headers = {}
            while True:
                line = out.readline()
                if not line:
                    return
                line = line.decode("ascii").strip()
                if not line:
                    break
                k, _, v = line.partition(":")
                headers[k.strip().lower()] = v.strip()
            body = out.read(int(headers["content-length"]))
            self.inbox.put(json.loads(body))

    def send(self, msg: dict) -> None:
        data = json.dumps({"jsonrpc": "2.0", **msg}).encode("utf-8")
        self.proc.stdin.write(b"Content-Length: %d\r\n\r\n" % len(data) + data)
        self.proc.stdin.flush()

    def notify(self, method: str, params: dict) -> None:
        self.send({"method": method, "params": params})

    def request(self, method: str, params: dict | None, timeout: float = 60) -> object:
        self.next_id += 1
        rid = self.next_id
        self.send({"id": rid, "method": method, "params": params})
        msg = self.wait(lambda m: m.get("id") == rid and "method" not in m, timeout)
        assert "error" not in msg, msg
        return msg["result"]

    def wait(self, pred, timeout: float = 60) -> dict:
        end = time.monotonic() + timeout
        while True:
            msg = self.inbox.get(timeout=max(0.01, end - time.monotonic()))
            if pred(msg):
                return msg

    def diagnostics(self, uri: str, version: int) -> list:
        m = self.wait(lambda m: m.get("method") == "textDocument/publishDiagnostics"
                      and m["params"]["uri"] == uri and m["params"].get("version") == version)
        return m["params"]["diagnostics"]


def _at(text: str, needle: str, offset: int = 0) -> dict:
    """The LSP position (0-based) of ``needle`` in ``text`` plus ``offset`` characters."""
    i = text.index(needle) + offset
    line = text.count("\n", 0, i)
    return {"line": line, "character": i - (text.rfind("\n", 0, i) + 1)}


def test_a_scripted_editor_session(tmp_path):
    path = tmp_path / "mission.stl"
    path.write_text(SOURCE, encoding="utf-8")
    uri = path.as_uri()
    c = Client(tmp_path)
    try:
        init = c.request("initialize", {"processId": os.getpid(), "rootUri": tmp_path.as_uri(),
                                        "capabilities": {}})
        caps = init["capabilities"]
        assert caps["hoverProvider"] and caps["definitionProvider"]
        assert "." in caps["completionProvider"]["triggerCharacters"]
        assert caps["documentFormattingProvider"] and caps["documentSymbolProvider"]
        c.notify("initialized", {})
        doc = {"uri": uri, "languageId": "stlc", "version": 1, "text": SOURCE}
        c.notify("textDocument/didOpen", {"textDocument": doc})

        # an unknown region: a located STL101 diagnostic (0-based LSP range)
        diags = c.diagnostics(uri, 1)
        assert [d["code"] for d in diags] == ["STL103"] or [d["code"] for d in diags] == \
            ["STL101"], diags
        d = diags[0]
        where = _at(SOURCE, "handovr")
        assert d["range"]["start"]["line"] == where["line"] and d["source"] == "stlc"
        assert "handovr" in d["message"] and "did you mean `handover`" in d["message"]

        # a change that fixes it, plus a syntax error elsewhere: both kinds reported
        fixed = SOURCE.replace("handovr", "handover")
        broken = fixed.replace("step = 0.1 s", "step = 0.1 s +").replace(
            "uav1.pos not in pole", "uav1.pos not in pol")
        c.notify("textDocument/didChange", {"textDocument": {"uri": uri, "version": 2},
                                            "contentChanges": [{"text": broken}]})
        codes = sorted(d["code"] for d in c.diagnostics(uri, 2))
        assert "STL002" in codes and "STL101" in codes, codes
        c.notify("textDocument/didChange", {"textDocument": {"uri": uri, "version": 3},
                                            "contentChanges": [{"text": fixed}]})
        # no error left; the lint warning of `stlc check` (STLWxx) with LSP severity 2:
        # the human's region `behind` is declared but no formula uses it
        diags = c.diagnostics(uri, 3)
        assert [(d["code"], d["severity"]) for d in diags] == [("STLW04", 2)], diags
        assert diags[0]["range"]["start"]["line"] == _at(fixed, "region behind")["line"]
        assert "operator.behind" in diags[0]["message"]

        # hover on a region: its box (the human's frame); on a spec: its formula
        h = c.request("textDocument/hover", {"textDocument": {"uri": uri},
                                             "position": _at(fixed, "operator.handover", 10)})
        value = h["contents"]["value"]
        assert "(0.5, -0.25, 0.75) m to (1, 0.25, 1.25) m" in value and "`operator`" in value
        h = c.request("textDocument/hover", {"textDocument": {"uri": uri},
                                             "position": _at(fixed, "require safe", 9)})
        assert "always[0, T] (uav1.pos in workspace" in h["contents"]["value"]

        # definition of a spec → its declaration's line; of a human's region → its line
        loc = c.request("textDocument/definition", {"textDocument": {"uri": uri},
                                                    "position": _at(fixed, "safe and", 1)})
        assert loc["uri"] == uri and loc["range"]["start"] == _at(fixed, "safe =")
        loc = c.request("textDocument/definition", {
            "textDocument": {"uri": uri}, "position": _at(fixed, "operator.handover", 12)})
        assert loc["range"]["start"] == _at(fixed, "handover =")

        # completion after `operator.` (the line does not parse yet): its regions and fields
        typing = fixed.replace("require safe and reach", "require safe and uav1.pos in operator.")
        c.notify("textDocument/didChange", {"textDocument": {"uri": uri, "version": 4},
                                            "contentChanges": [{"text": typing}]})
        c.diagnostics(uri, 4)
        pos = _at(typing, "operator.\n", len("operator."))
        items = c.request("textDocument/completion", {"textDocument": {"uri": uri},
                                                      "position": pos})["items"]
        labels = {i["label"] for i in items}
        assert {"handover", "behind", "pos", "att", "heading"} <= labels
        assert "uav1" not in labels and "workspace" not in labels
        pos = _at(typing, "uav1.pos in operator.\n", len("uav1."))
        items = c.request("textDocument/completion", {"textDocument": {"uri": uri},
                                                      "position": pos})["items"]
        assert {"pos", "vel", "speed", "acc", "payload"} <= {i["label"] for i in items}

        # formatting = `stlc fmt`
        messy = fixed.replace("const T = 4 s", "const   T=4 s").replace("  step = 0.1 s",
                                                                         "      step=0.1 s")
        c.notify("textDocument/didChange", {"textDocument": {"uri": uri, "version": 5},
                                            "contentChanges": [{"text": messy}]})
        assert [d["code"] for d in c.diagnostics(uri, 5)] == ["STLW04"]
        edits = c.request("textDocument/formatting", {"textDocument": {"uri": uri},
                                                      "options": {"tabSize": 2,
                                                                  "insertSpaces": True}})
        assert len(edits) == 1 and edits[0]["newText"] == format_text(messy)
        assert edits[0]["range"]["start"] == {"line": 0, "character": 0}

        symbols = c.request("textDocument/documentSymbol", {"textDocument": {"uri": uri}})
        names = [s["name"] for s in symbols]
        assert names == ["T", "uav1", "workspace", "pole", "operator", "safe", "m"]
        human = symbols[names.index("operator")]
        assert [s["name"] for s in human["children"]] == ["operator.handover",
                                                          "operator.behind"]

        assert c.request("shutdown", None) is None
        c.notify("exit", {})
        assert c.proc.wait(timeout=30) == 0
    finally:
        if c.proc.poll() is None:
            c.proc.kill()
            c.proc.wait()


# ---------------------------------------------------------------- the analysis in process


def test_hover_shows_the_last_robustness_of_a_spec_from_solution_json(tmp_path):
    path = tmp_path / "m.stl"
    text = SOURCE.replace("handovr", "handover")
    path.write_text(text, encoding="utf-8")
    an = ide.analyze(text, str(path))
    line = text[:text.index("require safe")].count("\n") + 1
    assert "robustness" not in ide.hover(an, line, len("  require s"))
    (tmp_path / "solution.json").write_text(json.dumps(
        {"mission": "m", "specs": {"safe": {"robustness": 0.125}}}), encoding="utf-8")
    assert "exact robustness +0.125" in ide.hover(an, line, len("  require s"))


def test_vehicle_field_hover_names_the_unit():
    text = SOURCE.replace("handovr", "handover")
    an = ide.analyze(text, "m.stl")
    line = text[:text.index("spec safe")].count("\n") + 1
    col = text.split("\n")[line - 1].index("uav1.pos") + 6
    assert "m" in ide.hover(an, line, col) and "point_mass" in ide.hover(an, line, col)
    # `radius` (issue 22) is a constant length, not a signal
    text = text.replace("require safe and reach", "require safe and reach and uav1.radius >= 0 m")
    an = ide.analyze(text, "m.stl")
    line = text[:text.index("uav1.radius")].count("\n") + 1
    col = text.split("\n")[line - 1].index("uav1.radius") + 6
    assert ide.hover(an, line, col).startswith("`uav1.radius`: a length (m), a constant")


@pytest.mark.parametrize("path", sorted((ROOT / "specs").glob("*.stl")), ids=lambda p: p.name)
def test_every_shipped_spec_analyses_clean_with_symbols(path):
    an = ide.analyze(path.read_text(encoding="utf-8"), str(path))
    assert an.diagnostics == [] and an.program is not None
    kinds = {s.kind for s in an.all_symbols()}
    assert "spec" in kinds
