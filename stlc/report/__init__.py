"""The HTML mission report: a plain view model (``view``) rendered by jinja2 (``render``).

``build_view(program, mission, solution)`` turns a ``Solution`` into JSON-serialisable data;
``render_report(view)`` returns the self-contained page; ``write_report(path, program,
mission, solution)`` does both and writes the file atomically.
"""

from __future__ import annotations

from .render import ReportError, render_report, script_json, write_report
from .view import build_view

__all__ = ["ReportError", "build_view", "render_report", "script_json", "write_report"]
