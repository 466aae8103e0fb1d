"""The initial guess's heading (``stlc.vehicles.multirotor._yaw_guess``) and when a formula
reads a channel (``stlc.semantics.reads``), against windows and angles worked out by hand."""

from __future__ import annotations

import numpy as np
import pytest

from stlc.semantics import ir, reads
from stlc.vehicles.multirotor import _yaw_guess


def pred(name: str) -> ir.Pred:
    return ir.Pred(ir.Bin("-", ir.Sig(name), ir.Const(0.0)))


def mask_samples(f: ir.Formula, name: str, dt: float = 0.5, n: int = 41) -> list[int]:
    return np.flatnonzero(reads.read_mask(f, {name}, dt, n)).tolist()


def test_read_times_follow_the_windows():
    """dt = 0.5 s, 41 samples (20 s).  always[10, 17] h: samples 20..34;
    eventually[1, 2] always[0, 3] h: [1, 5] s → 2..10; h until[2, 4] g: h over [0, 4] s →
    0..8, g over [2, 4] s → 4..8; next h: sample 1; always[15, inf) h: 30..40; a formula
    that never reads h: none; a window past the horizon: none."""
    h, g = pred("h"), pred("g")
    assert mask_samples(ir.Always(10, 17, h), "h") == list(range(20, 35))
    assert mask_samples(ir.Eventually(1, 2, ir.Always(0, 3, h)), "h") == list(range(2, 11))
    u = ir.Until(2, 4, h, g)
    assert mask_samples(u, "h") == list(range(0, 9))
    assert mask_samples(u, "g") == list(range(4, 9))
    assert mask_samples(ir.Next(h), "h") == [1]
    assert mask_samples(ir.Always(15, float("inf"), h), "h") == list(range(30, 41))
    assert mask_samples(ir.And((g, ir.Always(0, 20, g))), "h") == []
    assert mask_samples(ir.Always(25, 30, h), "h") == []


def test_heading_is_held_when_nothing_reads_it():
    """A path that turns a full circle: the old guess turned the heading with it; now the
    heading stays at the start heading (no anchor)."""
    t = np.linspace(0, 2 * np.pi, 60)
    V = np.stack([np.cos(t), np.sin(t), np.zeros_like(t)])
    assert np.allclose(_yaw_guess(V, 0.3, 0.1, None), 0.3)
    assert np.allclose(_yaw_guess(V, 0.3, 0.1, np.zeros(60, bool)), 0.3)


def test_heading_turns_the_shorter_way_to_where_it_is_read():
    """Start heading 0; the path moves along course −135° (= +225°) where the heading is
    read (samples 30..59), before that along +90° (not read).  The guess ramps from 0 to
    −135° (the shorter way: 135°, not 225°) and holds it; its travel is 135° (smoothing
    keeps it monotone)."""
    n = 60
    c = np.where(np.arange(n) < 30, np.pi / 2, -3 * np.pi / 4)
    V = np.stack([0.5 * np.cos(c), 0.5 * np.sin(c), np.zeros(n)])
    needed = np.arange(n) >= 30
    yaw = _yaw_guess(V, 0.0, 0.1, needed)
    assert yaw[0] == 0.0
    assert yaw[-1] == pytest.approx(-3 * np.pi / 4)
    assert np.sum(np.abs(np.diff(yaw))) == pytest.approx(3 * np.pi / 4)
    assert np.all(np.diff(yaw) <= 1e-12)


def test_heading_follows_a_turning_course_where_read():
    """Where the heading is read the guess follows the course continuously (unwrapped):
    a course sweeping from 170° to 190° (through ±180°) is followed as 170° → 190°, not
    via 0°; starting at 170° itself, it rises monotonically by at most the 20° sweep (the
    1 s moving average rounds off the last second: it ends within 2° of 190°)."""
    n = 40
    c = np.deg2rad(np.linspace(170, 190, n))
    V = np.stack([np.cos(c), np.sin(c), np.zeros(n)])
    yaw = _yaw_guess(V, np.deg2rad(170), 0.1, np.ones(n, bool))
    assert np.all(np.diff(yaw) >= -1e-12)
    assert 188 <= np.rad2deg(yaw[-1]) <= 190 + 1e-9
