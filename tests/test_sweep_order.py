"""``stlc.sweeping.order``: the order of a sweep's instances and the plans shipped as seeds,
checked against brute force on small grids (no solver)."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from stlc.sweeping.order import MAX_WEIGHT, Order, scaled, spread


def grid(na: int, nb: int) -> list[dict[str, float]]:
    return [{"a": a, "b": b} for a, b in itertools.product(np.linspace(-30, 30, na),
                                                          np.linspace(-0.2, 0.2, nb))]


def affine(v: dict[str, float]) -> dict[str, np.ndarray]:
    """A 'plan' that is exactly affine in the values: the predictor must reproduce it."""
    t = np.linspace(0, 1, 5)
    return {"x": 1 + 0.1 * v["a"] * t - 2 * v["b"], "y": 3 * v["b"] * t ** 2 + v["a"]}


def test_seeds_are_distinct_and_spread():
    x = scaled(grid(6, 4), ["a", "b"])
    assert x.min() == 0 and x.max() == 1
    for k in (1, 2, 3, 5):
        s = spread(x, k)
        assert len(set(s)) == k
    one = spread(x, 1)[0]  # nearest the centroid, by brute force
    d = np.linalg.norm(x - x.mean(axis=0), axis=1)
    assert d[one] == d.min()
    # two seeds cover the box better than the centre and its farthest point
    a, b = spread(x, 2)
    cover = np.max(np.minimum(np.linalg.norm(x - x[a], axis=1), np.linalg.norm(x - x[b], axis=1)))
    assert cover < np.max(np.linalg.norm(x - x[one], axis=1))


def test_next_is_the_waiting_instance_nearest_a_solved_one():
    pts = grid(6, 4)
    o = Order(pts, ["a", "b"])
    first = o.seeds(2)
    for i in first:
        o.add(i, pts[i], affine(pts[i]), str(i))
    seen = set(first)
    x = scaled(pts, ["a", "b"])
    while (i := o.next()) is not None:
        waiting = [j for j in range(len(pts)) if j not in seen]
        d = {j: min(np.linalg.norm(x[j] - x[s]) for s in o.solved) for j in waiting}
        assert d[i] == pytest.approx(min(d.values()))
        seen.add(i)
        o.add(i, pts[i], affine(pts[i]), str(i))
    assert seen == set(range(len(pts)))


def test_neighbours_and_the_predicted_plan():
    pts = grid(6, 4)
    o = Order(pts, ["a", "b"])
    assert o.neighbours(5) == [] and o.predicted(5) is None
    o.add(0, pts[0], affine(pts[0]), "0")
    assert [n[2] for n in o.neighbours(5)] == ["0"]  # one plan: no prediction
    o.add(1, pts[1], affine(pts[1]), "1")
    # two points on the line b ↦ plan (a = -30): exact at instance 2 on that line ...
    v, ch, label = o.predicted(2)
    assert label.startswith("predicted") and v["b"] == pytest.approx(pts[2]["b"])
    for k in ch:
        np.testing.assert_allclose(ch[k], affine(pts[2])[k], atol=1e-12)
    assert o.predicted(5) is None  # ... but off the line the value is not determined
    o.add(4, pts[4], affine(pts[4]), "4")
    near = o.neighbours(5)
    assert [n[2] for n in near[:3]] == ["1", "4", "0"]  # nearest first (scaled distance)
    v, ch, _ = near[-1]
    for k in ch:
        np.testing.assert_allclose(ch[k], affine(pts[5])[k], atol=1e-12)
    # far extrapolation (weights beyond MAX_WEIGHT) is refused
    o2 = Order(grid(40, 1), ["a", "b"])
    for i in (0, 1):
        o2.add(i, o2_pts := grid(40, 1)[i], affine(o2_pts), str(i))
    assert o2.predicted(int(MAX_WEIGHT) + 5) is None
    assert o2.predicted(2) is not None
