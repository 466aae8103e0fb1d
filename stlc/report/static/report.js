/* stlc mission report: builds the plotly figures from the JSON block #report-data.
   All text from the mission reaches plotly as data (trace names, labels), never as HTML. */
(function () {
  "use strict";
  var data = JSON.parse(document.getElementById("report-data").textContent);
  var CONFIG = { displaylogo: false, responsive: true };
  var FONT = { family: "system-ui, -apple-system, Segoe UI, Roboto, DejaVu Sans, sans-serif",
               size: 12, color: "#1d2330" };
  var PALETTE = ["#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b",
                 "#e377c2", "#7f7f7f", "#bcbd22", "#17becf"];
  /* corner k of a box: x = hi iff bit 0, y iff bit 1, z iff bit 2 */
  var EDGES = [[0, 1], [2, 3], [4, 5], [6, 7], [0, 2], [1, 3], [4, 6], [5, 7],
               [0, 4], [1, 5], [2, 6], [3, 7]];
  var TRI_I = [0, 0, 4, 4, 0, 0, 2, 2, 0, 0, 1, 1];
  var TRI_J = [1, 3, 5, 7, 1, 5, 3, 7, 2, 6, 3, 7];
  var TRI_K = [3, 2, 7, 6, 5, 4, 7, 6, 6, 4, 7, 5];

  /* plotly interprets a few HTML-like tags in text; show mission text literally */
  function txt(s) {
    return String(s).replace(/&/g, "&amp;").replace(/</g, "&lt;").replace(/>/g, "&gt;");
  }
  function rgba(hex, a) {
    var n = parseInt(hex.slice(1), 16);
    return "rgba(" + ((n >> 16) & 255) + "," + ((n >> 8) & 255) + "," + (n & 255) + "," + a + ")";
  }
  function baseLayout(extra) {
    var l = { font: FONT, margin: { l: 58, r: 18, t: 36, b: 44 }, paper_bgcolor: "#fff",
              plot_bgcolor: "#fff", hovermode: "x unified",
              legend: { orientation: "h", y: -0.12, yanchor: "top", x: 0, font: { size: 11 } } };
    for (var k in extra) { if (Object.prototype.hasOwnProperty.call(extra, k)) l[k] = extra[k]; }
    return l;
  }
  function draw(id, traces, layout) {
    var el = document.getElementById(id);
    if (!el) return;
    try {
      Plotly.newPlot(el, traces, layout, CONFIG);
    } catch (e) {
      el.textContent = "This plot could not be drawn: " + e.message;
      console.error(e);
    }
  }

  /* ------------------------------------------------------------------ scene */
  function edgeTrace(b) {
    var x = [], y = [], z = [];
    EDGES.forEach(function (e) {
      [e[0], e[1]].forEach(function (k) { var c = b.corners[k]; x.push(c[0]); y.push(c[1]); z.push(c[2]); });
      x.push(null); y.push(null); z.push(null);
    });
    return { type: "scatter3d", mode: "lines", x: x, y: y, z: z, name: txt(b.name),
             legendgroup: "box-" + b.name, showlegend: b.wireframe, hoverinfo: "name",
             line: { color: b.color, width: b.wireframe ? 1.5 : 3 } };
  }
  function meshTrace(b) {
    return { type: "mesh3d", x: b.corners.map(function (c) { return c[0]; }),
             y: b.corners.map(function (c) { return c[1]; }),
             z: b.corners.map(function (c) { return c[2]; }),
             i: TRI_I, j: TRI_J, k: TRI_K, color: b.color, opacity: 0.22, flatshading: true,
             name: txt(b.name) + " (" + b.role_label + ")", legendgroup: "box-" + b.name,
             showlegend: true, hovertemplate: txt(b.name) + " · " + b.role_label + "<extra></extra>" };
  }
  function scene3d(s) {
    var traces = [];
    s.boxes.forEach(function (b) {
      if (!b.wireframe) traces.push(meshTrace(b));
      traces.push(edgeTrace(b));
    });
    s.humans.forEach(function (h) {
      traces.push({ type: "scatter3d", mode: "markers+text", x: [h.pos[0]], y: [h.pos[1]], z: [h.pos[2]],
                    text: [txt(h.name)], textposition: "top center", name: txt(h.name),
                    marker: { size: 7, color: "#111", symbol: "diamond" }, legendgroup: "h-" + h.name });
      traces.push({ type: "scatter3d", mode: "lines", x: [h.pos[0], h.facing[0]],
                    y: [h.pos[1], h.facing[1]], z: [h.pos[2], h.facing[2]], showlegend: false,
                    hoverinfo: "skip", line: { color: "#111", width: 5 }, legendgroup: "h-" + h.name });
    });
    s.trajectories.forEach(function (tr, n) {
      /* no legend entry: plotly cannot draw a legend symbol for a colour-array line */
      traces.push({ type: "scatter3d", mode: "lines+markers", x: tr.x, y: tr.y, z: tr.z,
                    name: txt(tr.vehicle), customdata: tr.t, showlegend: false,
                    line: { color: tr.t, colorscale: "Viridis", width: 6 },
                    marker: { size: 2.5, color: tr.t, colorscale: "Viridis", showscale: n === 0,
                              colorbar: { title: { text: "t (s)" }, thickness: 12, len: 0.6 } },
                    hovertemplate: txt(tr.vehicle) + "<br>t = %{customdata} s<br>(%{x}, %{y}, %{z})<extra></extra>" });
      traces.push({ type: "scatter3d", mode: "markers+text", x: [tr.x[0]], y: [tr.y[0]], z: [tr.z[0]],
                    name: txt(tr.vehicle) + " start", showlegend: false, text: [txt(tr.vehicle)],
                    textposition: "bottom center", hovertemplate: txt(tr.vehicle) + " start<extra></extra>",
                    marker: { size: 5, color: "#fff", line: { color: "#111", width: 2 }, symbol: "circle" } });
    });
    var ax = function (t) { return { title: { text: t }, backgroundcolor: "#f7f9fb", showbackground: true,
                                     gridcolor: "#dde2e8", zerolinecolor: "#b8c0cc" }; };
    draw("scene-3d", traces, baseLayout({
      title: { text: "3D view", x: 0.02, font: { size: 13 } }, hovermode: "closest",
      margin: { l: 0, r: 0, t: 32, b: 0 },
      legend: { orientation: "h", x: 0, y: 0, yanchor: "top", font: { size: 11 } },
      scene: { aspectmode: "data", xaxis: ax("x (m)"), yaxis: ax("y (m)"), zaxis: ax("z (m)"),
               camera: { eye: { x: -1.45, y: -1.75, z: 1.2 }, center: { x: 0, y: 0, z: -0.1 } } } }));
  }
  function centroid(ring, axis) {
    var pts = ring.slice(0, -1), sum = 0;
    pts.forEach(function (p) { sum += p[axis]; });
    return sum / pts.length;
  }
  /* region names for the top view, largest regions first, skipping any label that would
     overlap one already placed (plotly does not avoid label collisions) */
  function topLabels(s) {
    var dx = 0.07 * Math.max(1e-9, s.extent.hi[0] - s.extent.lo[0]);
    var dy = 0.035 * Math.max(1e-9, s.extent.hi[1] - s.extent.lo[1]);
    var cands = s.boxes.filter(function (b) { return !b.wireframe && b.hull_xy.length > 2; })
      .map(function (b) {
        var xs = b.hull_xy.map(function (p) { return p[0]; }), ys = b.hull_xy.map(function (p) { return p[1]; });
        var area = (Math.max.apply(null, xs) - Math.min.apply(null, xs)) *
                   (Math.max.apply(null, ys) - Math.min.apply(null, ys));
        return { box: b, x: centroid(b.hull_xy, 0), y: centroid(b.hull_xy, 1), area: area };
      })
      .sort(function (a, b) { return b.area - a.area; });
    var placed = [];
    cands.forEach(function (c) {
      var clash = placed.some(function (p) { return Math.abs(p.x - c.x) < dx && Math.abs(p.y - c.y) < dy; });
      if (!clash) placed.push(c);
    });
    return placed;
  }
  function sceneTop(s) {
    var traces = [];
    s.boxes.forEach(function (b) {
      traces.push({ type: "scatter", mode: "lines", x: b.hull_xy.map(function (p) { return p[0]; }),
                    y: b.hull_xy.map(function (p) { return p[1]; }), name: txt(b.name),
                    fill: b.wireframe ? "none" : "toself", fillcolor: rgba(b.color, 0.18),
                    line: { color: b.color, width: b.wireframe ? 1.5 : 1.2, dash: b.wireframe ? "dash" : "solid" },
                    hoveron: "fills+points", hovertemplate: txt(b.name) + " · " + b.role_label + "<extra></extra>",
                    showlegend: false });
    });
    var labels = topLabels(s);
    traces.push({ type: "scatter", mode: "text", showlegend: false, hoverinfo: "skip",
                  x: labels.map(function (l) { return l.x; }), y: labels.map(function (l) { return l.y; }),
                  text: labels.map(function (l) { return txt(l.box.label); }),
                  textfont: { size: 10, color: labels.map(function (l) { return l.box.color; }) } });
    s.humans.forEach(function (h) {
      traces.push({ type: "scatter", mode: "lines", x: [h.pos[0], h.facing[0]], y: [h.pos[1], h.facing[1]],
                    line: { color: "#111", width: 3 }, showlegend: false, hoverinfo: "skip" });
      traces.push({ type: "scatter", mode: "markers+text", x: [h.pos[0]], y: [h.pos[1]], text: [txt(h.name)],
                    textposition: "bottom center", marker: { size: 11, color: "#111", symbol: "diamond" },
                    showlegend: false, hovertemplate: txt(h.name) + "<extra></extra>" });
    });
    s.trajectories.forEach(function (tr) {
      traces.push({ type: "scatter", mode: "lines+markers", x: tr.x, y: tr.y, name: txt(tr.vehicle),
                    customdata: tr.t, line: { color: "#9aa5b1", width: 1 },
                    marker: { size: 5, color: tr.t, colorscale: "Viridis" }, showlegend: false,
                    hovertemplate: txt(tr.vehicle) + "<br>t = %{customdata} s<br>(%{x}, %{y})<extra></extra>" });
      traces.push({ type: "scatter", mode: "markers", x: [tr.x[0]], y: [tr.y[0]], showlegend: false,
                    hoverinfo: "skip", marker: { size: 9, color: "#fff", line: { color: "#111", width: 2 } } });
    });
    draw("scene-top", traces, baseLayout({
      title: { text: "Top view (x–y)", x: 0.02, font: { size: 13 } }, hovermode: "closest",
      xaxis: { title: { text: "x (m)" }, zeroline: false, gridcolor: "#eef1f4" },
      yaxis: { title: { text: "y (m)" }, zeroline: false, gridcolor: "#eef1f4", scaleanchor: "x", scaleratio: 1 } }));
  }

  /* ------------------------------------------------------------------ signals */
  function timeDecorations(sig, yRange) {
    var shapes = [], notes = [];
    sig.windows.forEach(function (w, k) {
      shapes.push({ type: "rect", xref: "x", yref: "paper", x0: w.start, x1: w.end, y0: 0, y1: 1,
                    fillcolor: w.color, opacity: 0.07, line: { width: 0 }, layer: "below" });
      notes.push({ xref: "x", yref: "paper", x: w.start, y: 1 - 0.085 * k, xanchor: "left", yanchor: "top",
                   text: txt(w.spec), showarrow: false, font: { size: 10, color: w.color } });
    });
    sig.markers.forEach(function (m) {
      shapes.push({ type: "line", xref: "x", yref: "paper", x0: m.t, x1: m.t, y0: 0, y1: 1,
                    line: { color: "#c5221f", width: 1.5, dash: "dot" } });
      notes.push({ xref: "x", yref: "paper", x: m.t, y: 0.5, xanchor: "left", yanchor: "middle",
                   text: txt(m.label), showarrow: false, bgcolor: "rgba(255,255,255,0.75)",
                   font: { size: 10, color: "#c5221f" } });
    });
    return { shapes: shapes, annotations: notes };
  }
  function signalPlot(sig, p) {
    var traces = [];
    if (p.band) {
      traces.push({ type: "scatter", mode: "lines", x: sig.t, y: p.band.lower, line: { width: 0 },
                    showlegend: false, hoverinfo: "skip" });
      traces.push({ type: "scatter", mode: "lines", x: sig.t, y: p.band.upper, line: { width: 0 },
                    fill: "tonexty", fillcolor: "rgba(90,90,90,0.14)", name: txt(p.band.name), hoverinfo: "skip" });
    }
    p.traces.forEach(function (tr, k) {
      traces.push({ type: "scatter", mode: "lines", x: sig.t, y: tr.y, name: txt(tr.name),
                    line: { color: PALETTE[k % PALETTE.length], width: 1.8, dash: tr.dash || "solid",
                            shape: tr.shape || "linear" } });
    });
    var deco = timeDecorations(sig);
    p.bounds.forEach(function (b) {
      var soft = b.style === "soft";
      /* an invisible trace at the bound keeps it inside the autoscaled range */
      traces.push({ type: "scatter", mode: "lines", x: [sig.t[0], sig.t[sig.t.length - 1]], y: [b.value, b.value],
                    showlegend: false, hoverinfo: "skip", line: { width: 0 } });
      deco.shapes.push({ type: "line", xref: "paper", yref: "y", x0: 0, x1: 1, y0: b.value, y1: b.value,
                         line: { color: soft ? "#e08a00" : "#c5221f", width: 1.4, dash: soft ? "dot" : "dash" } });
      deco.annotations.push({ xref: "paper", yref: "y", x: 1, y: b.value, xanchor: "right", yanchor: "bottom",
                              text: txt(b.label) + " = " + b.value, showarrow: false,
                              font: { size: 10, color: soft ? "#b36b00" : "#c5221f" } });
    });
    draw(p.id, traces, baseLayout({
      title: { text: txt(p.title), x: 0.02, font: { size: 13 } },
      xaxis: { ticksuffix: " s", gridcolor: "#eef1f4", zeroline: false },
      yaxis: { title: { text: p.unit }, gridcolor: "#eef1f4", zeroline: false },
      shapes: deco.shapes, annotations: deco.annotations }));
  }

  /* ------------------------------------------------------------------ energy, risk */
  function energyPlot(e) {
    var traces = e.profiles.map(function (p, k) {
      return { type: "scatter", mode: "lines", x: p.x, y: p.y, name: txt(p.name),
               line: { color: PALETTE[k % PALETTE.length], width: 2 } };
    });
    var layout = { title: { text: "Energy per sample", x: 0.02, font: { size: 13 } },
                   xaxis: { ticksuffix: " s", gridcolor: "#eef1f4" },
                   yaxis: { title: { text: "energy" }, gridcolor: "#eef1f4", zeroline: false } };
    if (e.cumulative && e.profiles.length === 1) {
      traces.push({ type: "scatter", mode: "lines", x: e.cumulative.x, y: e.cumulative.y, yaxis: "y2",
                    name: "cumulative", line: { color: "#555", width: 1.5, dash: "dash" } });
      layout.yaxis2 = { title: { text: "cumulative" }, overlaying: "y", side: "right", showgrid: false };
      layout.margin = { l: 58, r: 64, t: 36, b: 44 };
    }
    var sig = data.signals;
    var deco = timeDecorations({ windows: sig.windows, markers: [] });
    layout.shapes = deco.shapes;
    layout.annotations = deco.annotations;
    draw("energy-profile", traces, baseLayout(layout));
  }
  function riskPlot(c) {
    var h = c.histogram;
    var colors = h.centers.map(function (x) { return x < 0 ? "#d62728" : "#1f77b4"; });
    var shapes = [{ type: "line", xref: "x", yref: "paper", x0: 0, x1: 0, y0: 0, y1: 1,
                    line: { color: "#111", width: 1.5 } }];
    var notes = [];
    c.var_lines.forEach(function (v, k) {
      shapes.push({ type: "line", xref: "x", yref: "paper", x0: v.value, x1: v.value, y0: 0, y1: 1,
                    line: { color: PALETTE[(k + 1) % PALETTE.length], width: 1.4, dash: "dash" } });
      notes.push({ xref: "x", yref: "paper", x: v.value, y: 1 - 0.09 * k, xanchor: "left", yanchor: "top",
                   showarrow: false, text: "VaR " + v.beta, font: { size: 10, color: PALETTE[(k + 1) % PALETTE.length] } });
    });
    draw(c.id, [{ type: "bar", x: h.centers, y: h.counts, width: h.widths, name: "realisations",
                  marker: { color: colors, line: { width: 0 } }, hovertemplate: "ρ ≈ %{x}: %{y}<extra></extra>" }],
         baseLayout({ title: { text: "Robustness over realisations", x: 0.02, font: { size: 13 } },
                      hovermode: "closest", bargap: 0, showlegend: false,
                      xaxis: { title: { text: "exact robustness ρ" }, gridcolor: "#eef1f4" },
                      yaxis: { title: { text: "count" }, gridcolor: "#eef1f4" },
                      shapes: shapes, annotations: notes }));
  }

  if (typeof Plotly === "undefined") {
    console.error("plotly.js is missing from the report");
    return;
  }
  scene3d(data.scene);
  sceneTop(data.scene);
  data.signals.plots.forEach(function (p) { signalPlot(data.signals, p); });
  if (data.energy.profiles.length) energyPlot(data.energy);
  if (data.risk) data.risk.cases.forEach(function (c) { if (c.histogram) riskPlot(c); });
})();
