"""The HTML mission report: a plain view model (``view``) rendered by jinja2 (``render``).

``build_view(program, mission, solution)`` turns a ``Solution`` into JSON-serialisable data;
``render_report(view)`` returns the self-contained page; ``write_report(path, program,
mission, solution)`` does both and writes the file atomically.  The view model is built by
``view`` (summary, requirements, energy, source) with ``scene``, ``signals`` and
``risk_view``; ``predicates`` renders the monitor's predicate labels readably; ``common``
holds the number formatting.
"""

from __future__ import annotations

from .render import ReportError, load_samples, render_report, script_json, write_report
from .view import build_view

__all__ = ["ReportError", "build_view", "load_samples", "render_report", "script_json",
           "write_report"]
