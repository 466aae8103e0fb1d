"""Render the report view model into one self-contained HTML file, and write it.

The page is a jinja2 template (autoescape on, ``StrictUndefined``) over the plain dict from
``stlc.output.report.view.build_view``.  The plot data goes into the page as a JSON block
(``<script type="application/json">`` with ``</`` written as ``<\\/``, so no mission text can
close the script element); plotly's bundled ``plotly.min.js``, the stylesheet and the small
script that builds the figures are inlined, so the file opens offline.

``write_report`` also reads the risk pass's per-realisation samples when they lie next to
the report (``risk_samples.npz``, or the Solution's in-memory samples), for the
risk histograms; ``risk.json`` alone holds only their summary.
"""

from __future__ import annotations

import contextlib
import functools
import json
import os
import re
import tempfile
import zipfile
from collections.abc import Mapping
from importlib import resources
from pathlib import Path

import jinja2
import numpy as np
from markupsafe import Markup

from stlc import settings
from stlc.planning.solution import Solution
from stlc.semantics.model import Mission, Program

from .view import build_view

#: the view sections the page script needs, written into the JSON data block
DATA_KEYS = ("scene", "signals", "energy", "team", "risk", "replan", "flight")
#: the risk pass's samples, looked for next to the report
SAMPLES_FILE = "risk_samples.npz"


class ReportError(Exception):
    """The report could not be rendered (e.g. plotly's JavaScript bundle is missing)."""


class _BytecodeCache(jinja2.FileSystemBytecodeCache):
    """jinja2's cache of compiled templates, for which a folder that went away or cannot be
    written only means compiling them again."""

    def load_bytecode(self, bucket) -> None:
        with contextlib.suppress(OSError):
            super().load_bytecode(bucket)

    def dump_bytecode(self, bucket) -> None:
        with contextlib.suppress(OSError):
            super().dump_bytecode(bucket)


@functools.lru_cache(maxsize=1)
def _environment() -> jinja2.Environment:
    """The templates' environment; their compiled form is kept in the cache directory
    (jinja2's ``FileSystemBytecodeCache``: compiling them takes 0.09 s, loading a few ms)."""
    d = settings.writable_cache_dir()
    return jinja2.Environment(
        loader=jinja2.PackageLoader("stlc.output.report", "templates"),
        bytecode_cache=_BytecodeCache(d) if d else None,
        autoescape=True,
        undefined=jinja2.StrictUndefined,
        trim_blocks=True,
        lstrip_blocks=True,
        keep_trailing_newline=True,
    )


def _inline_script(text: str) -> str:
    """Make trusted JavaScript safe to place inside a ``<script>`` element."""
    return re.sub(r"</(script)", r"<\\/\1", text, flags=re.IGNORECASE)


@functools.lru_cache(maxsize=1)
def _plotly_js() -> str:
    try:
        ref = resources.files("plotly") / "package_data" / "plotly.min.js"
        return _inline_script(ref.read_text(encoding="utf-8"))
    except (ModuleNotFoundError, FileNotFoundError) as e:  # pragma: no cover - install issue
        raise ReportError("the report needs the `plotly` package (for plotly.min.js)") from e


@functools.lru_cache(maxsize=4)
def _static(name: str) -> str:
    return (resources.files("stlc.output.report") / "static" / name).read_text(encoding="utf-8")


def script_json(data: object) -> Markup:
    """JSON for a ``<script type="application/json">`` block: compact, strict (no NaN), and
    with ``</`` and ``<!--`` escaped so that nothing in the data can end the element."""
    text = json.dumps(data, ensure_ascii=False, allow_nan=False, separators=(",", ":"))
    text = text.replace("<!--", "\\u003c!--").replace("</", "<\\/")
    return Markup(text)


def render_report(view: dict) -> str:
    """The complete HTML page for a view model from ``build_view``."""
    template = _environment().get_template("report.html.j2")
    return template.render(
        view=view,
        data_json=script_json({k: view[k] for k in DATA_KEYS}),
        css=Markup(_static("report.css").replace("</", "<\\/")),
        plotly_js=Markup(_plotly_js()),
        report_js=Markup(_inline_script(_static("report.js"))),
    )


def load_samples(path: str | os.PathLike[str]) -> dict[str, np.ndarray] | None:
    """The per-realisation exact robustness arrays of a ``risk_samples.npz`` (``None`` when
    the file is missing or unreadable: the report then goes without histograms)."""
    try:
        with np.load(path, allow_pickle=False) as z:
            return {k: np.asarray(z[k]) for k in z.files if "/exact/" in k}
    except (OSError, ValueError, KeyError, zipfile.BadZipFile):
        return None


def write_report(path: str | os.PathLike[str], program: Program, mission: Mission,
                 solution: Solution, risk_samples: Mapping[str, np.ndarray] | None = None,
                 simulation=None, flight=None) -> int:
    """Build, render and write the report atomically; returns the number of bytes written.

    ``risk_samples`` defaults to the samples the risk pass left on the Solution (in
    memory), else to the ``risk_samples.npz`` next to ``path``, if any.
    """
    target = Path(path)
    if risk_samples is None and solution.risk_results:
        from stlc.analysis.risk import sample_arrays

        risk_samples = {k: v for k, v in sample_arrays(solution.risk_results).items()
                        if "/exact/" in k}
    if risk_samples is None and solution.risk:
        risk_samples = load_samples(target.parent / SAMPLES_FILE)
    data = render_report(build_view(program, mission, solution, risk_samples,
                                    simulation, flight)).encode("utf-8")
    target.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{target.name}.", suffix=".tmp", dir=target.parent)
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(data)
        os.chmod(tmp, 0o644)  # mkstemp creates 0600; a report is meant to be shared
        os.replace(tmp, target)
    except BaseException:
        try:
            os.unlink(tmp)
        except FileNotFoundError:
            pass
        raise
    return len(data)
