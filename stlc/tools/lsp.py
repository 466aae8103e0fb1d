"""``stlc lsp``: the language server (pygls + lsprotocol, JSON-RPC over stdio).

Features: diagnostics with their codes on open, change and save (the checker's, also while
the file has a syntax error elsewhere: ``stlc.tools.ide.analyze``); hover (a declaration
with its value and unit, a region's box, a spec's formula and its last exact robustness
from a ``solution.json`` beside the file, a vehicle field's unit); go to definition
(constants, regions, humans' regions, specs, vehicles, humans, missions); completion
(declared names, keywords, functions; after ``operator.`` the human's regions and fields,
after ``uav1.`` the vehicle's fields); document symbols; formatting (= ``stlc fmt``).

Only documents the editor opened are read (their text comes with ``didOpen``/``didChange``);
a request about any other URI (``file:///dev/zero``) answers nothing and reads nothing.  A
document larger than ``MAX_DOCUMENT_CHARS`` is not analysed on the request path: it gets
one STL601 diagnostic (use ``stlc check`` on it), so the server keeps answering.

Editors start it as ``stlc lsp`` (see ``editors/vscode``).  Positions are converted with
the document's position codec (UTF-16 by default); the analysis works in code points.
"""

from __future__ import annotations

import logging

from lsprotocol import types as T
from pygls.lsp.server import LanguageServer

from stlc import __version__
from stlc.diagnostics import Span
from stlc.tools import ide

_KINDS = {"const": T.SymbolKind.Constant, "spec": T.SymbolKind.Function,
          "signal": T.SymbolKind.Variable, "vehicle": T.SymbolKind.Object,
          "human": T.SymbolKind.Object, "mission": T.SymbolKind.Module,
          "workspace": T.SymbolKind.Struct, "region": T.SymbolKind.Struct,
          "obstacle": T.SymbolKind.Struct, "target": T.SymbolKind.Struct,
          "station": T.SymbolKind.Struct, "home": T.SymbolKind.Struct}
_COMPLETION = {"keyword": T.CompletionItemKind.Keyword, "function": T.CompletionItemKind.Function,
               "field": T.CompletionItemKind.Field, "region": T.CompletionItemKind.Struct,
               "group": T.CompletionItemKind.Enum, "const": T.CompletionItemKind.Constant,
               "spec": T.CompletionItemKind.Function, "signal": T.CompletionItemKind.Variable,
               "vehicle": T.CompletionItemKind.Class, "human": T.CompletionItemKind.Class}


#: the largest document analysed (characters): 1 Mi, 50× the largest shipped spec
MAX_DOCUMENT_CHARS = 1 << 20


class StlcServer(LanguageServer):
    def __init__(self) -> None:
        super().__init__("stlc", __version__,
                         text_document_sync_kind=T.TextDocumentSyncKind.Full)
        self.analyses: dict[str, ide.Analysis] = {}  # uri → latest analysis
        self.parsed: dict[str, ide.Analysis] = {}  # uri → latest analysis that parsed
        self.checked: dict[str, ide.Analysis] = {}  # uri → latest analysis that checked

    def opened(self, uri: str):
        """The document if the editor opened it, else None (never read from disk)."""
        return self.workspace.text_documents.get(uri)

    def refresh(self, uri: str) -> None:
        doc = self.opened(uri)
        if doc is None:
            return
        if len(doc.source) > MAX_DOCUMENT_CHARS:
            self.forget(uri)
            self.text_document_publish_diagnostics(T.PublishDiagnosticsParams(
                uri=uri, version=doc.version, diagnostics=[T.Diagnostic(
                    range=T.Range(T.Position(0, 0), T.Position(0, 0)), code="STL601",
                    severity=T.DiagnosticSeverity.Error, source="stlc",
                    message=f"the document has {len(doc.source):,} characters, more than the "
                    f"language server analyses ({MAX_DOCUMENT_CHARS:,})\nhelp: run "
                    "`stlc check FILE` on it")]))
            return
        an = ide.analyze(doc.source, doc.path or uri)
        self.analyses[uri] = an
        if an.tree is not None and not any(d.code in ("STL001", "STL002", "STL003")
                                           for d in an.diagnostics):
            self.parsed[uri] = an
        if an.program is not None:
            self.checked[uri] = an
        diags = [_diagnostic(doc, d) for d in an.diagnostics]
        self.text_document_publish_diagnostics(
            T.PublishDiagnosticsParams(uri=uri, diagnostics=diags, version=doc.version))

    def forget(self, uri: str) -> None:
        self.analyses.pop(uri, None)
        self.parsed.pop(uri, None)
        self.checked.pop(uri, None)

    def known(self, uri: str) -> ide.Analysis | None:
        """The latest analysis, or the latest that parsed when this one did not; when it
        did not check, the checked program of the latest that did (for a vehicle's
        fields)."""
        an = self.analyses.get(uri)
        if an is None or an.tree is None:
            an = self.parsed.get(uri, an)
        ok = self.checked.get(uri)
        if an is not None and an.program is None and ok is not None:
            an = ide.Analysis(an.text, an.path, an.diagnostics, an.tree, ok.program, an.symbols)
        return an


def _range(doc, span: Span) -> T.Range:
    if not span.known:
        return T.Range(T.Position(0, 0), T.Position(0, 0))
    start = T.Position(span.line - 1, max(0, span.col - 1))
    end = T.Position(max(0, span.end_line - 1), max(0, span.end_col - 1))
    try:
        return doc.range_to_client_units(T.Range(start, end))
    except (IndexError, ValueError):
        return T.Range(start, end)


def _diagnostic(doc, d) -> T.Diagnostic:
    msg = d.message + (f"\nhelp: {d.help}" if d.help else "")
    msg += "".join(f"\nnote: {n}" for n in d.notes)
    sev = {"error": T.DiagnosticSeverity.Error, "warning": T.DiagnosticSeverity.Warning
           }.get(d.severity, T.DiagnosticSeverity.Information)
    return T.Diagnostic(range=_range(doc, d.span), message=msg, severity=sev, code=d.code,
                        source="stlc")


def _pos(ls: StlcServer, uri: str, p: T.Position) -> tuple[object, int, int]:
    doc = ls.opened(uri)  # callers ask only about analysed (so opened) documents
    try:
        p = doc.position_from_client_units(p)
    except (IndexError, ValueError):
        pass
    return doc, p.line + 1, p.character + 1


def _symbol(doc, s: ide.Symbol) -> T.DocumentSymbol:
    return T.DocumentSymbol(name=s.name, kind=_KINDS.get(s.kind, T.SymbolKind.Variable),
                            range=_range(doc, s.span), selection_range=_range(doc, s.name_span),
                            detail=s.kind if s.kind != "vehicle" else f"vehicle : {s.model}",
                            children=[_symbol(doc, c) for c in s.children] or None)


def make_server() -> StlcServer:
    server = StlcServer()

    @server.feature(T.TEXT_DOCUMENT_DID_OPEN)
    def did_open(ls: StlcServer, params: T.DidOpenTextDocumentParams):
        ls.refresh(params.text_document.uri)

    @server.feature(T.TEXT_DOCUMENT_DID_CHANGE)
    def did_change(ls: StlcServer, params: T.DidChangeTextDocumentParams):
        ls.refresh(params.text_document.uri)

    @server.feature(T.TEXT_DOCUMENT_DID_SAVE)
    def did_save(ls: StlcServer, params: T.DidSaveTextDocumentParams):
        ls.refresh(params.text_document.uri)

    @server.feature(T.TEXT_DOCUMENT_DID_CLOSE)
    def did_close(ls: StlcServer, params: T.DidCloseTextDocumentParams):
        uri = params.text_document.uri
        ls.forget(uri)
        ls.text_document_publish_diagnostics(T.PublishDiagnosticsParams(uri=uri,
                                                                        diagnostics=[]))

    @server.feature(T.TEXT_DOCUMENT_HOVER)
    def hover(ls: StlcServer, params: T.HoverParams):
        an = ls.known(params.text_document.uri)
        if an is None:
            return None
        _, line, col = _pos(ls, params.text_document.uri, params.position)
        text = ide.hover(an, line, col)
        if text is None:
            return None
        return T.Hover(contents=T.MarkupContent(kind=T.MarkupKind.Markdown, value=text))

    @server.feature(T.TEXT_DOCUMENT_DEFINITION)
    def definition(ls: StlcServer, params: T.DefinitionParams):
        an = ls.known(params.text_document.uri)
        if an is None:
            return None
        doc, line, col = _pos(ls, params.text_document.uri, params.position)
        span = ide.definition(an, line, col)
        if span is None:
            return None
        return T.Location(uri=params.text_document.uri, range=_range(doc, span))

    @server.feature(T.TEXT_DOCUMENT_COMPLETION,
                    T.CompletionOptions(trigger_characters=["."]))
    def completion(ls: StlcServer, params: T.CompletionParams):
        an = ls.known(params.text_document.uri)
        if an is None:
            return T.CompletionList(is_incomplete=False, items=[])
        doc, line, col = _pos(ls, params.text_document.uri, params.position)
        lines = doc.source.split("\n")
        before = lines[line - 1][:col - 1] if line <= len(lines) else ""
        items = [T.CompletionItem(label=label, kind=_COMPLETION.get(kind),
                                  detail=(detail.split("\n")[0] if detail else kind))
                 for label, kind, detail in ide.complete(an, before, line)]
        return T.CompletionList(is_incomplete=False, items=items)

    @server.feature(T.TEXT_DOCUMENT_DOCUMENT_SYMBOL)
    def document_symbol(ls: StlcServer, params: T.DocumentSymbolParams):
        an = ls.known(params.text_document.uri)
        doc = ls.opened(params.text_document.uri)
        return [_symbol(doc, s) for s in an.symbols] if an is not None and doc else []

    @server.feature(T.TEXT_DOCUMENT_FORMATTING)
    def formatting(ls: StlcServer, params: T.DocumentFormattingParams):
        from stlc.diagnostics import StlcError
        from stlc.tools.fmt import FormatError, format_text

        doc = ls.opened(params.text_document.uri)
        if doc is None or len(doc.source) > MAX_DOCUMENT_CHARS:
            return None  # only what the editor opened, and not too large
        try:
            out = format_text(doc.source, doc.path or params.text_document.uri)
        except (StlcError, FormatError, RecursionError):
            return None  # a file that does not parse is not touched
        if out == doc.source:
            return []
        n = len(doc.lines)
        end = T.Position(n, 0)
        return [T.TextEdit(range=T.Range(T.Position(0, 0), end), new_text=out)]

    return server


def serve() -> int:
    """Run the server on stdin/stdout until the client says exit."""
    logging.basicConfig(level=logging.WARNING)
    make_server().start_io()
    return 0
