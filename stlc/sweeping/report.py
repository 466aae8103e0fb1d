"""``sweep.html``: one self-contained page (plotly.js inlined, no network): the exact
robustness over the varied axes — a heat map for two axes (the status in each cell's
hover), a line for one, a scatter against the first axis otherwise or for random draws —,
the histogram of solve times with its p95 (paper A's t_c estimate), the counts, and a table
of the instances with links to ``plans/<i>.csv``."""

from __future__ import annotations

import math

import jinja2
from markupsafe import Markup

from stlc.output.report.render import _plotly_js, script_json

TEMPLATE = """<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8">
<title>stlc sweep: {{ s.mission }}</title>
<style>
body { font-family: system-ui, sans-serif; margin: 1.5em; color: #222; }
table { border-collapse: collapse; font-size: 0.9em; }
td, th { border: 1px solid #ccc; padding: 2px 6px; text-align: right; }
.satisfied { color: #176b2c; } .violated { color: #b35c00; } .failed, .solver_failed { color: #b00; }
.plot { width: 100%; max-width: 900px; height: 420px; }
</style>
<script>{{ plotly_js }}</script></head><body>
<h1>Sweep of <code>{{ s.mission }}</code> ({{ s.file }})</h1>
<p>{{ s.finished }} of {{ s.instances }} instances{% if s.interrupted %} (interrupted){% endif %}:
{% for k, v in s.counts.items() %}{{ v }} {{ k }}{% if not loop.last %}, {% endif %}{% endfor %}.
Wall time {{ "%.1f"|format(s.wall_s) }} s ({{ "%.2f"|format(s.per_instance_s) }} s per instance),
{{ s.nlp_builds }} NLP build(s), {{ s.warm_started }} warm start(s) from the plan library, on
{{ s.scheduler }}.
{% if s.solve_s %}Solve time p50 {{ "%.2f"|format(s.solve_s.p50) }} s, p95
<b>{{ "%.2f"|format(s.solve_s.p95) }} s</b> (the estimate of the replanning budget t_c, paper
A §4.4).{% endif %}</p>
<h2>Exact robustness over the varied values</h2>
<div id="rob" class="plot"></div>
<h2>Solve time</h2>
<div id="hist" class="plot"></div>
<h2>Instances</h2>
<table><tr><th>#</th>{% for a in axes %}<th>{{ a.label }}</th>{% endfor %}<th>status</th>
<th>robustness</th>{% for n in specs %}<th>{{ n }}</th>{% endfor %}<th>iterations</th>
<th>solve s</th><th>total s</th><th>worker</th><th>plan</th></tr>
{% for r in rows %}<tr id="i{{ r.instance }}"><td>{{ r.instance }}</td>
{% for a in axes %}<td>{{ "%.6g"|format(a.shown(r["values"][a.name])) }}</td>{% endfor %}
<td class="{{ r.status }}" title="{{ r.error }}">{{ r.status }}</td><td>{{ fmt(r.robustness) }}</td>
{% for n in specs %}<td>{{ fmt(r.specs.get(n)) }}</td>{% endfor %}<td>{{ r.iterations }}</td>
<td>{{ "%.2f"|format(r.solve_s) }}</td><td>{{ "%.2f"|format(r.total_s) }}</td><td>{{ r.worker }}</td>
<td>{% if r.status != "failed" %}<a href="plans/{{ r.instance }}.csv">plans/{{ r.instance }}.csv</a>{% endif %}</td></tr>
{% endfor %}</table>
<script type="application/json" id="data">{{ data }}</script>
<script>
const D = JSON.parse(document.getElementById("data").textContent);
const L = {margin: {t: 30}};
if (D.kind === "heatmap") {
  Plotly.newPlot("rob", [{type: "heatmap", x: D.x, y: D.y, z: D.z, text: D.text,
    hovertemplate: "%{xaxis.title.text}=%{x}<br>%{yaxis.title.text}=%{y}<br>ρ=%{z}<br>%{text}<extra></extra>",
    colorscale: "RdYlGn", zmid: 0, colorbar: {title: "ρ"}}],
    {...L, xaxis: {title: {text: D.xname}}, yaxis: {title: {text: D.yname}}});
} else {
  Plotly.newPlot("rob", [{type: "scatter", mode: D.kind === "line" ? "lines+markers" : "markers",
    x: D.x, y: D.z, text: D.text, marker: {color: D.color}}],
    {...L, xaxis: {title: {text: D.xname}}, yaxis: {title: {text: "exact robustness"}}});
}
Plotly.newPlot("hist", [{type: "histogram", x: D.solve, name: "solve_s"}],
  {...L, xaxis: {title: {text: "solve_s (s)"}}, yaxis: {title: {text: "instances"}},
   shapes: D.p95 === null ? [] : [{type: "line", x0: D.p95, x1: D.p95, yref: "paper", y0: 0,
     y1: 1, line: {color: "red", dash: "dash"}}],
   annotations: D.p95 === null ? [] : [{x: D.p95, yref: "paper", y: 1, text: "p95 = t_c estimate",
     showarrow: false, xanchor: "left"}]});
</script></body></html>
"""


def _num(x) -> float | None:
    return float(x) if x is not None and math.isfinite(float(x)) else None


def _fmt(x) -> str:
    return "—" if x is None or not math.isfinite(float(x)) else f"{float(x):+.4f}"


def _data(summary: dict, axes, rows: list[dict]) -> dict:
    color = {"satisfied": "green", "violated": "orange"}
    text = [f"#{r['instance']} {r['status']}" for r in rows]
    d = {"solve": [r["solve_s"] for r in rows if r["status"] != "failed"],
         "p95": (summary.get("solve_s") or {}).get("p95")}
    names = [a.name for a in axes]
    shown = {a.name: a.shown for a in axes}
    rows = [{**r, "values": {k: shown[k](v) if k in shown else v
                             for k, v in r["values"].items()}} for r in rows]
    grid = len(axes) == 2 and len({tuple(r["values"].values()) for r in rows}) == len(rows) \
        and all(a.n > 1 for a in axes) and summary.get("random") is None
    if grid:
        xs = sorted({r["values"][names[0]] for r in rows})
        ys = sorted({r["values"][names[1]] for r in rows})
        z = [[None] * len(xs) for _ in ys]
        t = [[""] * len(xs) for _ in ys]
        for r in rows:
            i, j = ys.index(r["values"][names[1]]), xs.index(r["values"][names[0]])
            z[i][j] = _num(r["robustness"])
            t[i][j] = f"#{r['instance']} {r['status']}"
        d.update(kind="heatmap", x=xs, y=ys, z=z, text=t, xname=axes[0].label,
                 yname=axes[1].label)
    else:
        d.update(kind="line" if len(axes) == 1 else "scatter",
                 x=[r["values"][names[0]] for r in rows],
                 z=[_num(r["robustness"]) for r in rows], text=text, xname=axes[0].label,
                 color=[color.get(r["status"], "red") for r in rows])
    return d


def render(summary: dict, axes, rows: list[dict], spec_names: list[str]) -> str:
    env = jinja2.Environment(autoescape=True)
    t = env.from_string(TEMPLATE)
    return t.render(s=summary, axes=axes, rows=rows, specs=spec_names, fmt=_fmt,
                    data=script_json(_data(summary, axes, rows)),
                    plotly_js=Markup(_plotly_js()))
