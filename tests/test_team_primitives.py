"""Rest-to-rest primitives: hand-computed durations and bounds on dense samples."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from stlc.team.primitives import axis_time, min_duration, rest_to_rest

V = (3.1, 3.1, 3.1)


def test_trapezoid_and_triangle_times_by_hand():
    # 13 m at v = a = 3.1: v^2/a = 3.1 m <= 13 -> trapezoid, 13/3.1 + 1 = 5.193548... s
    assert axis_time(13.0, 3.1, 3.1) == pytest.approx(5.193548387096774)
    # 2 m at v = 3.1, a = 3.1: triangle, 2*sqrt(2/3.1) = 1.606434... s
    assert axis_time(2.0, 3.1, 3.1) == pytest.approx(1.6064386578049977)
    # boundary D = v^2/a = 4 (v = 2, a = 1): both formulas give 4 s
    assert axis_time(4.0, 2.0, 1.0) == pytest.approx(4.0)
    assert axis_time(-4.0, 2.0, 1.0) == pytest.approx(4.0)
    assert axis_time(0.0, 0.0, 0.0) == 0.0
    assert math.isinf(axis_time(1.0, 0.0, 1.0))
    # slowest axis wins: (10, 2, 0) with v = (2, 4, 1), a = (1, 1, 1):
    # x: 10/2 + 2 = 7 s; y: triangle 2*sqrt(2) = 2.83 s
    assert min_duration((0, 0, 0), (10, 2, 0), (2, 4, 1), (1, 1, 1)) == pytest.approx(7.0)


def test_synchronised_axes_arrive_together_at_rest():
    prim = rest_to_rest((0, 0, 0), (10, 2, -1), (2, 4, 1), (1, 1, 1))
    assert prim.duration == pytest.approx(7.0)
    p, v, a = prim.sample(np.array([0.0, 7.0, 8.0]))
    np.testing.assert_allclose(p[0], [0, 0, 0])
    np.testing.assert_allclose(p[1:], [[10, 2, -1]] * 2)
    np.testing.assert_allclose(v[1:], 0.0)
    # y peak speed solves 2 = vp (7 - vp): vp = (7 - sqrt(41)) / 2
    _, vm, _ = prim.sample(3.5)
    assert abs(vm[1]) == pytest.approx((7 - math.sqrt(41)) / 2)
    assert vm[0] == pytest.approx(2.0)


def test_stretched_duration_and_too_short():
    prim = rest_to_rest((0, 0, 0), (1, 0, 0), V, V, duration=5.0)
    assert prim.duration == 5.0
    assert prim.sample(5.0)[0][0] == pytest.approx(1.0)
    with pytest.raises(ValueError):
        rest_to_rest((0, 0, 0), (10, 0, 0), V, V, duration=1.0)
    with pytest.raises(ValueError):
        rest_to_rest((0, 0, 0), (0, 0, 1), V, (1.0, 1.0, 0.0))


@settings(max_examples=80, deadline=None)
@given(st.lists(st.floats(-30, 30), min_size=6, max_size=6),
       st.lists(st.floats(0.5, 5), min_size=6, max_size=6),
       st.floats(1.0, 2.0))
def test_bounds_hold_on_dense_samples(coords, bounds, stretch):
    p0, p1 = coords[:3], coords[3:]
    vmax, amax = bounds[:3], bounds[3:]
    t_min = min_duration(p0, p1, vmax, amax)
    prim = rest_to_rest(p0, p1, vmax, amax, duration=t_min * stretch)
    t = np.linspace(0.0, prim.duration, 2001)
    p, v, a = prim.sample(t)
    assert (np.abs(v) <= np.asarray(vmax) * (1 + 1e-9) + 1e-12).all()
    assert (np.abs(a) <= np.asarray(amax) * (1 + 1e-9) + 1e-12).all()
    np.testing.assert_allclose(p[-1], p1, atol=1e-9)
    np.testing.assert_allclose(v[[0, -1]], 0.0, atol=1e-9)
    # velocity is the derivative of position (trapezoid rule on the dense samples)
    dt = t[1] - t[0]
    np.testing.assert_allclose(np.diff(p, axis=0), (v[1:] + v[:-1]) / 2 * dt,
                               atol=2 * max(amax) * dt**2 + 1e-9)
