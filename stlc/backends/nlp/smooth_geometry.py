"""Signed distances in CasADi: exact outside the region, finite derivatives everywhere.

The IR's ``sd_box``, ``sd_cylinder`` and ``sd_capsule`` (``stlc.semantics.shapes``) lowered
to SX rows.  Outside a region the value is the exact Euclidean distance; inside it is the
exact (negative) distance to the nearest face, except within half a radius of a round
shape's axis, where the square root of the distance from the axis continues as its tangent
line (``_root``: C¹, no infinite slope on the axis; the value there is between −r and
−3r/4, still negative).  The norm of the face excesses switches to ``max`` of the excesses
when they are all ≤ 0 (``_outside``), so no square root is taken at 0; the switches are
kinks (like ``fmax``), which IPOPT crosses as it crosses the face of a box.
"""

from __future__ import annotations

from functools import reduce

import casadi as ca

TINY = 1e-9  #: below this norm of the excesses, the max of the excesses (error ≤ TINY)


def _root(x, x0: float):
    """√x for x ≥ x0, its tangent line at x0 below (x0 > 0)."""
    r0 = x0 ** 0.5
    return ca.if_else(x >= x0, ca.sqrt(ca.fmax(x, x0)), r0 + (x - r0 * r0) / (2 * r0))


def _outside(ds):
    """The signed distance from per-axis excesses d_i: ‖max(d, 0)‖ outside, max d inside."""
    x = reduce(lambda a, b: a + b, [ca.fmax(d, 0.0) ** 2 for d in ds])
    return ca.if_else(x > TINY * TINY, ca.sqrt(ca.fmax(x, TINY * TINY)), reduce(ca.fmax, ds))


def sd_box(a, env):
    return _outside([ca.fabs(a[i]) - a[3 + i] for i in range(3)])


def sd_cylinder(a, env):
    ax, u, v, r, half = a
    rho = _root(u * u + v * v, (float(r) / 2) ** 2)
    return _outside([rho - r, ca.fabs(ax) - half])


def sd_capsule(a, env):
    ax, u, v, r, half = a
    t = ca.fmax(ca.fabs(ax) - half, 0.0)
    return _root(t * t + u * u + v * v, (float(r) / 2) ** 2) - r


SD_CASADI = {"sd_box": sd_box, "sd_cylinder": sd_cylinder, "sd_capsule": sd_capsule}
