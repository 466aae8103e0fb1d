"""``stlc lsp`` never reads an unopened document (``file:///dev/zero``) and refuses to
analyse a huge one on the request path (one STL601 diagnostic): every later request is
answered at once."""

from __future__ import annotations

import os
import time

from test_lsp import SOURCE, Client

from stlc.tools.lsp import MAX_DOCUMENT_CHARS


def test_unopened_and_huge_documents(tmp_path):
    c = Client(tmp_path)
    try:
        c.request("initialize", {"processId": os.getpid(), "rootUri": tmp_path.as_uri(),
                                 "capabilities": {}})
        c.notify("initialized", {})
        zero = {"textDocument": {"uri": "file:///dev/zero"}}
        t0 = time.monotonic()
        assert c.request("textDocument/formatting",
                         {**zero, "options": {"tabSize": 2, "insertSpaces": True}},
                         timeout=30) is None
        assert c.request("textDocument/documentSymbol", zero, timeout=30) == []
        assert c.request("textDocument/hover", {**zero, "position": {"line": 0,
                                                                     "character": 0}},
                         timeout=30) is None
        assert time.monotonic() - t0 < 30

        big_uri = (tmp_path / "big.stl").as_uri()
        big = "signal x\n" + "spec s = x <= 1\n" * (MAX_DOCUMENT_CHARS // 16 * 9)  # ~9 MB
        c.notify("textDocument/didOpen", {"textDocument": {
            "uri": big_uri, "languageId": "stlc", "version": 1, "text": big}})
        diags = c.diagnostics(big_uri, 1)
        assert [d["code"] for d in diags] == ["STL601"] and "stlc check" in diags[0]["message"]
        assert c.request("textDocument/documentSymbol", {"textDocument": {"uri": big_uri}},
                         timeout=30) == []

        uri = (tmp_path / "m.stl").as_uri()  # a normal document is still served at once
        c.notify("textDocument/didOpen", {"textDocument": {
            "uri": uri, "languageId": "stlc", "version": 1, "text": SOURCE}})
        assert c.diagnostics(uri, 1)
        syms = c.request("textDocument/documentSymbol", {"textDocument": {"uri": uri}},
                         timeout=30)
        assert "m" in [s["name"] for s in syms]
        assert c.request("shutdown", None) is None
        c.notify("exit", {})
        assert c.proc.wait(timeout=30) == 0
    finally:
        if c.proc.poll() is None:
            c.proc.kill()
            c.proc.wait()
