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
  var LIMIT = "#c5221f", SOFT = "#e08a00", GRID = "#eef1f4";
  /* VaR/CVaR lines, one colour per β (no red: red bars are the violations) */
  var RISK_COLORS = ["#e08a00", "#2ca02c", "#6a3d9a", "#1f4e79", "#8c564b"];
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
  function extend(base, extra) {
    for (var k in extra) { if (Object.prototype.hasOwnProperty.call(extra, k)) base[k] = extra[k]; }
    return base;
  }
  function baseLayout(extra) {
    return extend({ font: FONT, margin: { l: 58, r: 18, t: 36, b: 44 }, paper_bgcolor: "#fff",
                    plot_bgcolor: "#fff", hovermode: "x unified",
                    legend: { orientation: "h", y: -0.14, yanchor: "top", x: 0, font: { size: 11 } } },
                  extra);
  }
  function title(text) { return { text: txt(text), x: 0.01, xanchor: "left", font: { size: 13 } }; }
  function timeAxis(extra) {
    return extend({ ticksuffix: " s", gridcolor: GRID, zeroline: false }, extra || {});
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
  function tEnd(t) { return t.length ? t[t.length - 1] : 1; }

  /* ------------------------------------------------------------------ scene */
  function edgeTrace(b) {
    var x = [], y = [], z = [];
    if (b.mesh) { x = b.mesh.outline[0]; y = b.mesh.outline[1]; z = b.mesh.outline[2]; }
    else EDGES.forEach(function (e) {
      [e[0], e[1]].forEach(function (k) { var c = b.corners[k]; x.push(c[0]); y.push(c[1]); z.push(c[2]); });
      x.push(null); y.push(null); z.push(null);
    });
    return { type: "scatter3d", mode: "lines", x: x, y: y, z: z, name: txt(b.name),
             legendgroup: "box-" + b.name, showlegend: b.wireframe, hoverinfo: "name",
             visible: b.visible ? true : "legendonly",
             line: { color: b.color, width: b.wireframe ? 1.5 : 3 } };
  }
  function meshTrace(b) {
    var m = b.mesh || { x: b.corners.map(function (c) { return c[0]; }),
                        y: b.corners.map(function (c) { return c[1]; }),
                        z: b.corners.map(function (c) { return c[2]; }), i: TRI_I, j: TRI_J, k: TRI_K };
    return { type: "mesh3d", x: m.x, y: m.y, z: m.z,
             i: m.i, j: m.j, k: m.k, color: b.color, opacity: 0.22, flatshading: !b.mesh,
             name: txt(b.label), legendgroup: "box-" + b.name, showlegend: true,
             visible: b.visible ? true : "legendonly",
             hovertemplate: txt(b.name) + " · " + b.role_label + "<extra></extra>" };
  }
  function scene3d(s) {
    var traces = [];
    s.boxes.forEach(function (b) {
      if (!b.wireframe) traces.push(meshTrace(b));
      traces.push(edgeTrace(b));
    });
    s.humans.forEach(function (h) {
      var g = "h-" + h.name;
      traces.push({ type: "scatter3d", mode: "lines", x: [h.pos[0], h.head[0]], y: [h.pos[1], h.head[1]],
                    z: [h.pos[2], h.head[2]], name: txt(h.name), legendgroup: g,
                    line: { color: "#111", width: 9 }, hovertemplate: txt(h.name) + "<extra></extra>" });
      traces.push({ type: "scatter3d", mode: "markers+text", x: [h.head[0]], y: [h.head[1]], z: [h.head[2]],
                    text: [txt(h.name)], textposition: "top center", showlegend: false, legendgroup: g,
                    marker: { size: 6, color: "#111" }, hovertemplate: txt(h.name) + "<extra></extra>" });
      traces.push({ type: "scatter3d", mode: "lines", x: [h.chest[0], h.facing_3d[0]],
                    y: [h.chest[1], h.facing_3d[1]], z: [h.chest[2], h.facing_3d[2]], showlegend: false,
                    hoverinfo: "skip", line: { color: "#111", width: 5 }, legendgroup: g });
    });
    s.trajectories.forEach(function (tr, n) {
      /* a team: one colour per drone along its path, time on the dots */
      /* the legend entry is the start marker (plain colours): a legend draws a trace's line
         with one colour, and a line coloured by time would give plotly an array there */
      traces.push({ type: "scatter3d", mode: "lines+markers", x: tr.x, y: tr.y, z: tr.z,
                    name: txt(tr.vehicle), customdata: tr.t, showlegend: false, legendgroup: "v-" + tr.vehicle,
                    line: s.per_drone ? { color: tr.color, width: 5 }
                                      : { color: tr.t, colorscale: "Viridis", width: 6 },
                    marker: { size: s.per_drone ? 1.5 : 2.5, color: tr.t, colorscale: "Viridis", showscale: n === 0,
                              colorbar: { title: { text: "t (s)", side: "top" }, orientation: "h",
                                          thickness: 10, len: 0.45, x: 0.02, xanchor: "left", y: 0.0,
                                          yanchor: "top" } },
                    hovertemplate: txt(tr.vehicle) + "<br>t = %{customdata} s<br>(%{x}, %{y}, %{z})<extra></extra>" });
      traces.push({ type: "scatter3d", mode: "markers+text", x: [tr.x[0]], y: [tr.y[0]], z: [tr.z[0]],
                    name: txt(tr.vehicle), showlegend: true, text: [txt(tr.vehicle)],
                    legendgroup: "v-" + tr.vehicle, textposition: "bottom center",
                    hovertemplate: txt(tr.vehicle) + " start<extra></extra>",
                    marker: { size: 5, color: s.per_drone ? tr.color : "#fff", line: { color: "#111", width: 2 },
                              symbol: "circle" } });
    });
    var ax = function (t) { return { title: { text: t }, backgroundcolor: "#f7f9fb", showbackground: true,
                                     gridcolor: "#dde2e8", zerolinecolor: "#b8c0cc" }; };
    draw("scene-3d", traces, baseLayout({
      title: title("3D view"), hovermode: "closest",
      margin: { l: 0, r: 0, t: 32, b: 48 },
      legend: { orientation: "v", x: 1, xanchor: "right", y: 1, yanchor: "top", font: { size: 11 },
                bgcolor: "rgba(255,255,255,0.8)", bordercolor: "#dde2e8", borderwidth: 1 },
      scene: { aspectmode: "data", domain: { x: [0, 0.86], y: [0, 1] },
               xaxis: ax("x (m)"), yaxis: ax("y (m)"), zaxis: ax("z (m)"),
               camera: { eye: { x: -1.3, y: -1.6, z: 1.0 }, center: { x: 0, y: 0, z: -0.15 } } } }));
  }
  function centroid(ring, axis) {
    var pts = ring.slice(0, -1), sum = 0;
    pts.forEach(function (p) { sum += p[axis]; });
    return sum / pts.length;
  }
  /* region names for the top view, largest regions first, skipping any label that would
     overlap one already placed (plotly does not avoid label collisions) */
  function topLabels(boxes, s) {
    var dx = 0.07 * Math.max(1e-9, s.extent.hi[0] - s.extent.lo[0]);
    var dy = 0.035 * Math.max(1e-9, s.extent.hi[1] - s.extent.lo[1]);
    var cands = boxes.filter(function (b) { return !b.wireframe && b.hull_xy.length > 2; })
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
    var boxes = s.boxes.filter(function (b) { return b.visible; });
    boxes.forEach(function (b) {
      traces.push({ type: "scatter", mode: "lines", x: b.hull_xy.map(function (p) { return p[0]; }),
                    y: b.hull_xy.map(function (p) { return p[1]; }), name: txt(b.name),
                    fill: b.wireframe ? "none" : "toself", fillcolor: rgba(b.color, 0.18),
                    line: { color: b.color, width: b.wireframe ? 1.5 : 1.2, dash: b.wireframe ? "dash" : "solid" },
                    hoveron: "fills+points", hovertemplate: txt(b.name) + " · " + b.role_label + "<extra></extra>",
                    showlegend: false });
    });
    var labels = topLabels(boxes, s);
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
                    customdata: tr.t, line: { color: s.per_drone ? tr.color : "#9aa5b1", width: s.per_drone ? 2.5 : 1 },
                    marker: { size: s.per_drone ? 3 : 5, color: tr.t, colorscale: "Viridis" }, showlegend: s.per_drone,
                    hovertemplate: txt(tr.vehicle) + "<br>t = %{customdata} s<br>(%{x}, %{y})<extra></extra>" });
      traces.push({ type: "scatter", mode: "markers", x: [tr.x[0]], y: [tr.y[0]], showlegend: false,
                    hoverinfo: "skip", marker: { size: 9, color: "#fff", line: { color: "#111", width: 2 } } });
    });
    draw("scene-top", traces, baseLayout({
      title: title("Top view (x–y)"), hovermode: "closest",
      xaxis: { title: { text: "x (m)" }, zeroline: false, gridcolor: GRID },
      yaxis: { title: { text: "y (m)" }, zeroline: false, gridcolor: GRID, scaleanchor: "x", scaleratio: 1 } }));
  }

  /* ------------------------------------------------------------------ signals */
  function timeline(sig) {
    var tl = sig.timeline, traces = [], names = tl.specs.map(function (s) { return txt(s.name); });
    tl.specs.forEach(function (s, k) {
      if (s.start !== null && s.end !== null) {
        traces.push({ type: "scatter", mode: "lines", x: [s.start, s.end], y: [names[k], names[k]],
                      line: { color: rgba(s.color, 0.55), width: 14 }, showlegend: false,
                      hovertemplate: txt(s.name) + " window [" + s.start + ", " + s.end + "] s<extra></extra>" });
      }
    });
    var pts = tl.specs.filter(function (s) { return s.tightest !== null; });
    traces.push({ type: "scatter", mode: "markers", x: pts.map(function (s) { return s.tightest; }),
                  y: pts.map(function (s) { return txt(s.name); }), showlegend: false,
                  customdata: pts.map(function (s) { return [s.robustness_text, txt(s.predicate)]; }),
                  marker: { symbol: "diamond", size: 11, line: { color: "#fff", width: 1 },
                            color: pts.map(function (s) { return s.satisfied ? "#1e8e3e" : LIMIT; }) },
                  hovertemplate: "%{y}: ρ = %{customdata[0]} at t = %{x} s<br>%{customdata[1]}<extra></extra>" });
    var span = tl.horizon || tEnd(sig.t);
    var el = document.getElementById("sig-timeline");
    if (el) el.style.height = (64 + 30 * names.length) + "px";
    draw("sig-timeline", traces, baseLayout({
      title: title("Requirement windows and tightest times (◆)"), hovermode: "closest",
      margin: { l: 110, r: 18, t: 32, b: 28 },
      xaxis: timeAxis({ range: [-0.015 * span, 1.015 * span] }),
      yaxis: { type: "category", range: [names.length - 0.5, -0.5], gridcolor: GRID,
               categoryorder: "array", categoryarray: names } }));
  }
  function timeDecorations(sig, specs) {
    var shapes = [], notes = [], k = 0;
    sig.windows.forEach(function (w) {
      if (specs.indexOf(w.spec) < 0) return;
      shapes.push({ type: "rect", xref: "x", yref: "paper", x0: w.start, x1: w.end, y0: 0, y1: 1,
                    fillcolor: w.color, opacity: 0.08, line: { width: 0 }, layer: "below" });
      notes.push({ xref: "x", yref: "paper", x: w.start, y: 1 - 0.09 * k, xanchor: "left", yanchor: "top",
                   text: txt(w.spec), showarrow: false, font: { size: 10, color: w.color } });
      k += 1;
    });
    var t0 = sig.t.length ? sig.t[0] : 0, t1 = tEnd(sig.t);
    sig.markers.forEach(function (m, j) {
      /* a failure near the end of the plan is labelled on the left of its line */
      var late = m.t > t0 + 0.8 * (t1 - t0);
      shapes.push({ type: "line", xref: "x", yref: "paper", x0: m.t, x1: m.t, y0: 0, y1: 1,
                    line: { color: LIMIT, width: 1.5, dash: "dot" } });
      notes.push({ xref: "x", yref: "paper", x: m.t, y: 0.5 - 0.1 * j, xanchor: late ? "right" : "left",
                   yanchor: "middle",
                   text: txt(m.label), showarrow: false, bgcolor: "rgba(255,255,255,0.75)",
                   font: { size: 10, color: LIMIT } });
    });
    return { shapes: shapes, annotations: notes };
  }
  function signalPlot(sig, p) {
    var traces = [], t0 = sig.t[0], t1 = tEnd(sig.t);
    if (p.band) {
      traces.push({ type: "scatter", mode: "lines", x: p.band.x, y: p.band.y, fill: "toself",
                    fillcolor: "rgba(90,90,90,0.14)", line: { width: 0 }, name: txt(p.band.name),
                    hoverinfo: "skip" });
    }
    p.traces.forEach(function (tr, k) {
      traces.push({ type: "scatter", mode: "lines", x: tr.x || sig.t, y: tr.y, name: txt(tr.name),
                    line: { color: PALETTE[k % PALETTE.length], width: 1.8, dash: tr.dash || "solid",
                            shape: tr.shape || "linear" } });
    });
    var deco = timeDecorations(sig, p.windows);
    p.spans.forEach(function (s) {
      deco.shapes.push({ type: "rect", xref: "x", yref: "paper", x0: s.start, x1: s.end, y0: 0, y1: 1,
                         fillcolor: "#9aa5b1", opacity: 0.13, line: { width: 0 }, layer: "below" });
    });
    p.bounds.forEach(function (b) {
      var soft = b.style === "soft", color = soft ? SOFT : LIMIT;
      var x0 = b.x0 === null ? t0 : b.x0, x1 = b.x1 === null ? t1 : b.x1;
      /* an invisible trace at the bound keeps it inside the autoscaled range */
      traces.push({ type: "scatter", mode: "lines", x: [x0, x1], y: [b.value, b.value],
                    showlegend: false, hoverinfo: "skip", line: { width: 0 } });
      deco.shapes.push({ type: "line", xref: "x", yref: "y", x0: x0, x1: x1, y0: b.value, y1: b.value,
                         line: { color: color, width: 1.5, dash: soft ? "dot" : "dash" } });
      deco.annotations.push({ xref: "x", yref: "y", x: x1, y: b.value, xanchor: "right", yanchor: "bottom",
                              text: txt(b.text), showarrow: false,
                              font: { size: 10, color: soft ? "#b36b00" : LIMIT } });
    });
    draw(p.id, traces, baseLayout({
      title: title(p.title), xaxis: timeAxis({ range: [t0, t1] }),
      yaxis: { title: { text: p.unit }, gridcolor: GRID, zeroline: false },
      shapes: deco.shapes, annotations: deco.annotations }));
  }

  /* ------------------------------------------------------------------ team */
  /* who installs and refills what, when: one row per drone, one bar per event; the planned
     dwells are pale, wider bars behind the events verification recomputed */
  function gantt(tm) {
    var g = tm.gantt, groups = {}, order = [];
    g.bars.forEach(function (b) {
      var key = (b.planned ? "p-" : "e-") + b.kind;
      if (!groups[key]) { groups[key] = []; order.push(key); }
      groups[key].push(b);
    });
    order.sort(function (a, b) { return (a[0] === "p" ? 0 : 1) - (b[0] === "p" ? 0 : 1); });
    var rows = g.rows.map(txt);
    var traces = order.map(function (key) {
      var bs = groups[key], planned = key[0] === "p";
      return { type: "bar", orientation: "h", y: bs.map(function (b) { return txt(b.drone); }),
               base: bs.map(function (b) { return b.start; }),
               x: bs.map(function (b) { return b.duration; }),
               text: planned ? null : bs.map(function (b) { return txt(b.region); }),
               textposition: "inside", insidetextanchor: "middle", textfont: { color: "#fff", size: 10 },
               width: planned ? 0.78 : 0.46, opacity: planned ? 0.3 : 0.95,
               name: (planned ? "planned " : "") + bs[0].kind, legendgroup: key,
               marker: { color: bs[0].color, line: { width: planned ? 0 : 0.6, color: "#fff" } },
               customdata: bs.map(function (b) { return txt(b.text); }),
               hovertemplate: "%{y}: %{customdata}<extra></extra>" };
    });
    var span = g.horizon || 1;
    var el = document.getElementById("team-gantt");
    if (el) el.style.height = (110 + 46 * rows.length) + "px";
    draw("team-gantt", traces, baseLayout({
      title: title("Who installs and refills what, and when"), hovermode: "closest", barmode: "overlay",
      margin: { l: 70, r: 18, t: 32, b: 40 },
      xaxis: timeAxis({ range: [-0.01 * span, 1.01 * span] }),
      yaxis: { type: "category", categoryorder: "array", categoryarray: rows,
               range: [rows.length - 0.5, -0.5], gridcolor: GRID } }));
  }
  function forwardPlot(fw) {
    var traces = [], shapes = [], notes = [], t0 = fw.t[0], t1 = tEnd(fw.t), seen = {};
    fw.drones.forEach(function (d) {
      traces.push({ type: "scatter", mode: "lines", x: fw.t, y: d.y, name: txt(d.name),
                    legendgroup: "f-" + d.name, line: { color: d.color, width: 1.8 } });
      d.comparisons.forEach(function (c) {
        traces.push({ type: "scatter", mode: "lines", x: fw.t, y: c.y, name: txt(d.name + " · " + c.label),
                      legendgroup: "f-" + d.name, visible: "legendonly",
                      line: { color: rgba(d.color, 0.7), width: 1.2, dash: "dot" } });
      });
      if (d.v_star === null || seen[d.v_star]) return;
      seen[d.v_star] = true;
      traces.push({ type: "scatter", mode: "lines", x: [t0, t1], y: [d.v_star, d.v_star],
                    showlegend: false, hoverinfo: "skip", line: { width: 0 } });
      shapes.push({ type: "line", xref: "x", yref: "y", x0: t0, x1: t1, y0: d.v_star, y1: d.v_star,
                    line: { color: "#111", width: 1.5, dash: "dash" } });
      notes.push({ xref: "x", yref: "y", x: t1, y: d.v_star, xanchor: "right", yanchor: "bottom",
                   showarrow: false, text: "v* = " + d.v_star + " m/s", font: { size: 10, color: "#111" } });
    });
    draw("team-forward", traces, baseLayout({
      title: title("Forward speed hypot(vx, vy) against v*"), xaxis: timeAxis({ range: [t0, t1] }),
      yaxis: { title: { text: "m/s" }, gridcolor: GRID, zeroline: false, rangemode: "tozero" },
      shapes: shapes, annotations: notes }));
  }

  /* ------------------------------------------------------------------ energy, risk */
  function energyPlot(e) {
    var traces = [];
    e.profiles.forEach(function (p, k) {
      var c = PALETTE[k % PALETTE.length];
      traces.push({ type: "scatter", mode: "lines", x: p.x, y: p.y, name: txt(p.name) + " per sample",
                    line: { color: c, width: 2 } });
      traces.push({ type: "scatter", mode: "lines", x: p.x, y: p.cumulative, yaxis: "y2",
                    name: txt(p.name) + " cumulative", line: { color: c, width: 1.3, dash: "dash" } });
    });
    draw("energy-profile", traces, baseLayout({
      title: title("Energy per sample (solid) and cumulative (dashed)"),
      margin: { l: 58, r: 70, t: 36, b: 44 }, xaxis: timeAxis(),
      yaxis: { title: { text: "J per sample" }, gridcolor: GRID, zeroline: false },
      yaxis2: { title: { text: "cumulative (J)" }, overlaying: "y", side: "right", showgrid: false,
                zeroline: false, rangemode: "tozero", tickmode: "auto", nticks: 6 } }));
  }
  function vline(x, name, color, dash, group) {
    return { type: "scatter", mode: "lines", x: [x, x], y: [0, 1], yaxis: "y2", name: name,
             legendgroup: group, hovertemplate: name + "<extra></extra>",
             line: { color: color, width: 1.6, dash: dash } };
  }
  function riskPlot(c) {
    var h = c.histogram;
    var colors = h.centers.map(function (x) { return x <= 0 ? "#f1a7a7" : "#9ec5e8"; });
    var traces = [{ type: "bar", x: h.centers, y: h.counts, width: h.widths, name: "realisations",
                    showlegend: false, marker: { color: colors, line: { width: 0 } },
                    hovertemplate: "ρ ≈ %{x}: %{y}<extra></extra>" }];
    if (c.nominal !== null) traces.push(vline(c.nominal, "nominal ρ = " + c.nominal_text, "#111", "solid", "n"));
    /* pad the range so that lines at the extremes (the nominal plan is often the best) show */
    var xs = h.centers.concat([c.nominal]).concat(c.var_lines.map(function (v) { return v.cvar; }))
      .filter(function (x) { return x !== null; });
    var w = h.widths[0] || 0, lo = Math.min.apply(null, xs) - w, hi = Math.max.apply(null, xs) + w;
    c.var_lines.forEach(function (v, k) {
      var col = RISK_COLORS[k % RISK_COLORS.length];
      traces.push(vline(v.value, "VaR " + v.beta + " = " + v.var_text, col, "dash", "b" + k));
      if (v.cvar !== null) traces.push(vline(v.cvar, "CVaR " + v.beta + " = " + v.cvar_text, col, "dot", "b" + k));
    });
    draw(c.id, traces, baseLayout({
      title: title("Exact robustness over " + c.K + " realisations (red: ρ ≤ 0, violated)"),
      hovermode: "closest", bargap: 0,
      margin: { l: 58, r: 10, t: 36, b: 44 },
      legend: { orientation: "v", x: 1.02, xanchor: "left", y: 1, yanchor: "top", font: { size: 10 } },
      xaxis: { title: { text: "exact robustness ρ" }, gridcolor: GRID, zeroline: true, range: [lo, hi],
               zerolinecolor: "#111", zerolinewidth: 1.5 },
      yaxis: { title: { text: "count" }, gridcolor: GRID },
      yaxis2: { overlaying: "y", range: [0, 1], visible: false, fixedrange: true } }));
  }

  /* ------------------------------------------------------------------ replanning */
  function replanPlots(rp, sc) {
    var t3 = [], tt = [];
    sc.boxes.forEach(function (b) {
      if (!b.visible) return;
      t3.push(edgeTrace(b));
      tt.push({ type: "scatter", mode: "lines", x: b.hull_xy.map(function (p) { return p[0]; }),
                y: b.hull_xy.map(function (p) { return p[1]; }), name: txt(b.name), showlegend: false,
                line: { color: b.color, width: 1 }, hoverinfo: "skip" });
    });
    rp.paths.forEach(function (p) {
      [["nominal", rp.colors.nominal, "dash", 3], ["executed", p.color, "solid", 5]].forEach(function (k) {
        var xyz = p[k[0]];
        if (!xyz) return;
        var name = txt(p.vehicle) + " " + k[0];
        t3.push({ type: "scatter3d", mode: "lines", x: xyz[0], y: xyz[1], z: xyz[2], name: name,
                  line: { color: k[1], width: k[3], dash: k[2] } });
        tt.push({ type: "scatter", mode: "lines", x: xyz[0], y: xyz[1], name: name, showlegend: false,
                  line: { color: k[1], width: k[3] - 2, dash: k[2] } });
      });
    });
    rp.segments.forEach(function (g, i) {
      t3.push({ type: "scatter3d", mode: "lines", x: g.x, y: g.y, z: g.z, name: txt(g.label),
                legendgroup: "seg", showlegend: i === 0, line: { color: rp.colors.replanned, width: 8 } });
      tt.push({ type: "scatter", mode: "lines", x: g.x, y: g.y, name: txt(g.label), showlegend: false,
                line: { color: rp.colors.replanned, width: 4 } });
    });
    if (rp.markers.length) {
      var mk = rp.markers, lab = mk.map(function (m) { return txt(m.label); });
      t3.push({ type: "scatter3d", mode: "markers", name: rp.kind === "failure" ? "failure" : "replan triggered",
                x: mk.map(function (m) { return m.x; }), y: mk.map(function (m) { return m.y; }),
                z: mk.map(function (m) { return m.z; }), text: lab, hovertemplate: "%{text}<extra></extra>",
                marker: { size: 6, color: rp.colors.trigger, symbol: "x" } });
      tt.push({ type: "scatter", mode: "markers", showlegend: false, text: lab,
                x: mk.map(function (m) { return m.x; }), y: mk.map(function (m) { return m.y; }),
                hovertemplate: "%{text}<extra></extra>",
                marker: { size: 10, color: rp.colors.trigger, symbol: "x" } });
    }
    draw("replan-3d", t3, baseLayout({ title: title("Nominal, executed and replanned paths"), hovermode: "closest",
      margin: { l: 0, r: 0, t: 32, b: 48 },
      scene: { aspectmode: "data", xaxis: { title: { text: "x (m)" } }, yaxis: { title: { text: "y (m)" } },
               zaxis: { title: { text: "z (m)" } } } }));
    draw("replan-top", tt, baseLayout({ title: title("Top view"), hovermode: "closest",
      xaxis: { title: { text: "x (m)" }, gridcolor: GRID },
      yaxis: { title: { text: "y (m)" }, gridcolor: GRID, scaleanchor: "x" } }));
    if (rp.deviation) {
      var dv = rp.deviation, td = [];
      dv.series.forEach(function (s) {
        td.push({ type: "scatter", mode: "lines", x: dv.t, y: s.d, name: txt(s.vehicle) + " deviation",
                  line: { color: s.color, width: 2 } });
      });
      td.push({ type: "scatter", mode: "lines", x: [dv.t[0], tEnd(dv.t)], y: [dv.zeta, dv.zeta],
                name: "ζ", line: { color: LIMIT, dash: "dash", width: 1.5 } });
      draw("replan-deviation", td, baseLayout({ title: title("Deviation from the nominal plan ‖p̃ − p*‖"),
        xaxis: timeAxis({ title: { text: "t" } }), yaxis: { title: { text: "m" }, gridcolor: GRID },
        shapes: dv.events.map(function (t) {
          return { type: "line", x0: t, x1: t, yref: "paper", y0: 0, y1: 1,
                   line: { color: rp.colors.trigger, width: 1, dash: "dot" } }; }) }));
    }
  }

  /* ------------------------------------------------------------------ closed-loop flight */
  function flightPlots(fl, sc) {
    var tt = [];
    sc.boxes.forEach(function (b) {
      if (!b.visible) return;
      tt.push({ type: "scatter", mode: "lines", x: b.hull_xy.map(function (p) { return p[0]; }),
                y: b.hull_xy.map(function (p) { return p[1]; }), name: txt(b.name), showlegend: false,
                line: { color: b.color, width: 1 }, hoverinfo: "skip" });
    });
    fl.paths.forEach(function (p) {
      [["plan", fl.colors.plan, "dash", 2], ["flown", p.color, "solid", 3]].forEach(function (k) {
        var xy = p[k[0]];
        if (!xy) return;
        tt.push({ type: "scatter", mode: "lines", x: xy[0], y: xy[1], name: txt(p.vehicle) + " " + k[0],
                  line: { color: k[1], width: k[3], dash: k[2] } });
      });
    });
    draw("flight-top", tt, baseLayout({ title: title("Plan and flown paths (top view)"), hovermode: "closest",
      xaxis: { title: { text: "x (m)" }, gridcolor: GRID },
      yaxis: { title: { text: "y (m)" }, gridcolor: GRID, scaleanchor: "x" } }));
    draw("flight-error", [{ type: "scatter", mode: "lines", x: fl.error.t, y: fl.error.e,
                            name: "tracking error", line: { width: 2 } }],
      baseLayout({ title: title("Tracking error ‖p_flown − p_plan‖"), xaxis: timeAxis({ title: { text: "t" } }),
                   yaxis: { title: { text: "m" }, gridcolor: GRID } }));
  }

  if (typeof Plotly === "undefined") {
    console.error("plotly.js is missing from the report");
    return;
  }
  scene3d(data.scene);
  sceneTop(data.scene);
  if (data.signals.timeline) timeline(data.signals);
  data.signals.plots.forEach(function (p) { signalPlot(data.signals, p); });
  if (data.team) {
    gantt(data.team);
    if (data.team.forward) forwardPlot(data.team.forward);
  }
  if (data.replan) replanPlots(data.replan, data.scene);
  if (data.flight) flightPlots(data.flight, data.scene);
  if (data.energy.profiles.length) energyPlot(data.energy);
  if (data.risk) data.risk.cases.forEach(function (c) { if (c.histogram) riskPlot(c); });
})();
