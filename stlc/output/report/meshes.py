"""Triangle meshes of round regions for the report's 3-D scene (Plotly ``mesh3d``).

A cylinder, sphere or capsule (``stlc.semantics.shapes.Round``) is a surface of revolution
about its axis: a *profile* of (axial position, distance from the axis) points, from one
pole to the other, turned through ``SIDES`` angles (``lathe``).  ``round_mesh`` gives the
world-frame vertices and triangles, plus an outline (rims and four meridians, as polylines
separated by ``None``) for the edges a box would have.
"""

from __future__ import annotations

import math

import numpy as np

from stlc.semantics.shapes import Round, basis

SIDES = 32  #: angles around the axis
ARC = 8  #: profile points per quarter circle of a sphere's or capsule's end


def profile(shape: Round) -> tuple[np.ndarray, list[int]]:
    """The (axial, radial) profile from the −axis pole to the +axis pole, and the indices
    of its rims (drawn as outline rings)."""
    r, h = shape.radius, shape.half
    if shape.kind == "cylinder":
        return np.array([[-h, 0.0], [-h, r], [h, r], [h, 0.0]]), [1, 2]
    phi = np.linspace(-math.pi / 2, 0.0, ARC + 1)
    low = np.stack([-h + r * np.sin(phi), r * np.cos(phi)], axis=1)
    high = np.stack([h - r * np.sin(phi[::-1]), r * np.cos(phi[::-1])], axis=1)
    pts = np.vstack([low, high[1:] if h == 0 else high])
    rims = [ARC] if h == 0 else [ARC, ARC + 1]
    return pts, rims


def lathe(shape: Round, prof: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """World-frame vertices (one ring of ``SIDES`` per profile point) and triangles."""
    ax, e1, e2 = basis(shape.axis)
    t = 2 * math.pi * np.arange(SIDES) / SIDES
    ring = np.cos(t)[:, None] * e1 + np.sin(t)[:, None] * e2  # (SIDES, 3)
    c = np.asarray(shape.center, float)
    verts = np.concatenate([c + a * ax + rho * ring for a, rho in prof])
    tris = []
    for i in range(len(prof) - 1):
        for j in range(SIDES):
            a, b = i * SIDES + j, i * SIDES + (j + 1) % SIDES
            tris += [(a, b, a + SIDES), (b, b + SIDES, a + SIDES)]
    return verts, np.array(tris, dtype=int)


def round_mesh(shape: Round, to_world=None) -> dict:
    """``{"x","y","z","i","j","k","outline"}`` of ``shape``; ``to_world`` maps local
    (a human's frame) points to the world."""
    prof, rims = profile(shape)
    verts, tris = lathe(shape, prof)
    if to_world is not None:
        verts = to_world(verts)
    lines: list[list[float | None]] = [[], [], []]

    def add(points: np.ndarray) -> None:
        for d in range(3):
            lines[d] += [float(v) for v in points[:, d]] + [None]

    for i in rims:
        ring = verts[i * SIDES:(i + 1) * SIDES]
        add(np.vstack([ring, ring[:1]]))
    for j in range(0, SIDES, SIDES // 4):
        add(verts[j::SIDES])
    r6 = lambda v: [round(float(x), 6) for x in v]  # noqa: E731
    return {"x": r6(verts[:, 0]), "y": r6(verts[:, 1]), "z": r6(verts[:, 2]),
            "i": tris[:, 0].tolist(), "j": tris[:, 1].tolist(), "k": tris[:, 2].tolist(),
            "outline": [[None if v is None else round(v, 6) for v in ln] for ln in lines],
            "vertices": verts}
