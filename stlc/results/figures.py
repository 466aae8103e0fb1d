"""The report's figures as plotly (Python) figures, for ``Plan.plot()`` in a notebook.

The figures are drawn from the report's own view model (``stlc.output.report.build_view``):
the same boxes, trajectories, humans, signal traces and bound lines as the page's script
(``static/report.js``) draws from the same data, so a notebook and the report show one
picture.  The view model rounds every number to about five significant digits.
"""

from __future__ import annotations

#: box k's corner: x = hi iff bit 0, y iff bit 1, z iff bit 2 (``scene.box_corners``)
EDGES = ((0, 1), (2, 3), (4, 5), (6, 7), (0, 2), (1, 3), (4, 6), (5, 7),
         (0, 4), (1, 5), (2, 6), (3, 7))
TRI = ((0, 0, 4, 4, 0, 0, 2, 2, 0, 0, 1, 1), (1, 3, 5, 7, 1, 5, 3, 7, 2, 6, 3, 7),
       (3, 2, 7, 6, 5, 4, 7, 6, 6, 4, 7, 5))
PALETTE = ("#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b", "#e377c2",
           "#7f7f7f", "#bcbd22", "#17becf")
LIMIT, SOFT = "#c5221f", "#e08a00"


def _go():
    try:
        import plotly.graph_objects as go
    except ImportError as e:  # plotly is a dependency; a broken install says so
        raise ImportError("Plan.plot() needs the `plotly` package (pip install plotly)") from e
    return go


def rgba(hex_color: str, alpha: float) -> str:
    """``#rrggbb`` with an opacity, as plotly's ``rgba(r,g,b,a)``."""
    n = int(hex_color.lstrip("#"), 16)
    return f"rgba({(n >> 16) & 255},{(n >> 8) & 255},{n & 255},{alpha})"


def scene_3d(scene: dict):
    """The report's 3-D view: boxes (filled, the workspace as a wireframe), humans and the
    planned paths, coloured by time."""
    go = _go()
    fig = go.Figure()
    for b in scene["boxes"]:
        c = b.get("corners")
        mesh = b.get("mesh")  # a round region: its triangles and outline
        if not c and not mesh:
            continue
        vis = True if b["visible"] else "legendonly"
        m = mesh or {"x": [p[0] for p in c], "y": [p[1] for p in c], "z": [p[2] for p in c],
                     "i": TRI[0], "j": TRI[1], "k": TRI[2]}
        if not b["wireframe"]:
            fig.add_trace(go.Mesh3d(x=m["x"], y=m["y"], z=m["z"], i=m["i"], j=m["j"], k=m["k"],
                                    color=b["color"], opacity=0.22, flatshading=not mesh,
                                    name=b["label"], legendgroup=b["name"], visible=vis,
                                    hovertemplate=f"{b['name']} · {b['role_label']}"
                                                  "<extra></extra>"))
        x, y, z = [], [], []
        if mesh:
            x, y, z = (list(v) for v in mesh["outline"])
        for e in EDGES if not mesh else ():
            for k in e:
                x.append(c[k][0])
                y.append(c[k][1])
                z.append(c[k][2])
            x.append(None)
            y.append(None)
            z.append(None)
        fig.add_trace(go.Scatter3d(x=x, y=y, z=z, mode="lines", name=b["name"],
                                   legendgroup=b["name"], showlegend=b["wireframe"],
                                   visible=vis, hoverinfo="name",
                                   line={"color": b["color"],
                                         "width": 1.5 if b["wireframe"] else 3}))
    for h in scene["humans"]:
        fig.add_trace(go.Scatter3d(x=[h["pos"][0], h["head"][0]], y=[h["pos"][1], h["head"][1]],
                                   z=[h["pos"][2], h["head"][2]], mode="lines", name=h["name"],
                                   line={"color": "#111111", "width": 9}))
    for n, tr in enumerate(scene["trajectories"]):
        line = ({"color": tr["color"], "width": 5} if scene["per_drone"] else
                {"color": tr["t"], "colorscale": "Viridis", "width": 6})
        fig.add_trace(go.Scatter3d(
            x=tr["x"], y=tr["y"], z=tr["z"], mode="lines+markers", name=tr["vehicle"],
            customdata=tr["t"], line=line,
            marker={"size": 2.5, "color": tr["t"], "colorscale": "Viridis",
                    "showscale": n == 0, "colorbar": {"title": {"text": "t (s)"}}},
            hovertemplate=f"{tr['vehicle']}<br>t = %{{customdata}} s<br>(%{{x}}, %{{y}}, "
                          "%{z})<extra></extra>"))
    fig.update_layout(title="3D view", scene={"aspectmode": "data",
                                              "xaxis": {"title": {"text": "x (m)"}},
                                              "yaxis": {"title": {"text": "y (m)"}},
                                              "zaxis": {"title": {"text": "z (m)"}}},
                      margin={"l": 0, "r": 0, "t": 36, "b": 0})
    return fig


def scene_top(scene: dict):
    """The report's top view (x–y): the visible boxes' outlines and the paths."""
    go = _go()
    fig = go.Figure()
    for b in scene["boxes"]:
        if not b["visible"] or not b.get("hull_xy"):
            continue
        fig.add_trace(go.Scatter(x=[p[0] for p in b["hull_xy"]], y=[p[1] for p in b["hull_xy"]],
                                 mode="lines", name=b["name"], showlegend=False,
                                 fill="none" if b["wireframe"] else "toself",
                                 fillcolor=rgba(b["color"], 0.18),
                                 line={"color": b["color"],
                                       "dash": "dash" if b["wireframe"] else "solid"}))
    for h in scene["humans"]:
        fig.add_trace(go.Scatter(x=[h["pos"][0]], y=[h["pos"][1]], mode="markers+text",
                                 text=[h["name"]], textposition="bottom center",
                                 marker={"size": 11, "color": "#111111", "symbol": "diamond"},
                                 showlegend=False))
    for tr in scene["trajectories"]:
        fig.add_trace(go.Scatter(x=tr["x"], y=tr["y"], mode="lines+markers", name=tr["vehicle"],
                                 line={"color": tr["color"]},
                                 marker={"size": 4, "color": tr["t"], "colorscale": "Viridis"}))
    fig.update_layout(title="Top view (x–y)", xaxis={"title": {"text": "x (m)"}},
                      yaxis={"title": {"text": "y (m)"}, "scaleanchor": "x", "scaleratio": 1})
    return fig


def signal(signals: dict, p: dict):
    """One of the report's signal plots (position, speed, …) with its bound lines."""
    go = _go()
    fig = go.Figure()
    t = signals["t"]
    for k, tr in enumerate(p["traces"]):
        fig.add_trace(go.Scatter(x=tr.get("x") or t, y=tr["y"], mode="lines", name=tr["name"],
                                 line={"color": PALETTE[k % len(PALETTE)],
                                       "dash": tr.get("dash") or "solid",
                                       "shape": tr.get("shape") or "linear"}))
    t0, t1 = (t[0], t[-1]) if t else (0.0, 1.0)
    for b in p["bounds"]:
        x0 = t0 if b["x0"] is None else b["x0"]
        x1 = t1 if b["x1"] is None else b["x1"]
        color = SOFT if b["style"] == "soft" else LIMIT
        fig.add_shape(type="line", x0=x0, x1=x1, y0=b["value"], y1=b["value"],
                      line={"color": color, "dash": "dot" if b["style"] == "soft" else "dash"})
        fig.add_annotation(x=x1, y=b["value"], text=b["text"], showarrow=False,
                           xanchor="right", yanchor="bottom", font={"color": color, "size": 10})
    for m in signals.get("markers", []):
        if m["t"] is not None:
            fig.add_vline(x=m["t"], line={"color": LIMIT, "dash": "dot"})
    fig.update_layout(title=p["title"], xaxis={"title": {"text": "t (s)"}},
                      yaxis={"title": {"text": p["unit"]}})
    return fig


def figures(view: dict) -> dict:
    """Every figure of the report's view model: ``scene``, ``top`` and one per signal plot
    (named by its id without ``sig-``: ``position``, ``speed``, ``distance``, …)."""
    out = {"scene": scene_3d(view["scene"]), "top": scene_top(view["scene"])}
    for p in view["signals"]["plots"]:
        out[p["id"].removeprefix("sig-")] = signal(view["signals"], p)
    return out
