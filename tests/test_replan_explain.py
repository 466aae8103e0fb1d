"""``stlc simulate`` explains a rejected replan, and T_g defaults from the vehicle's limits.

Hand-computed: correcting d = 1.3 m in a 1 s segment at a = 3.1 m/s² per axis reaches at
most a·T²/4 = 0.775 m, so the segment is too short; it needs 2·√(d/a) = 1.295 s (T_g ≥
0.648 s).  The default T_g for ζ = 1 m and a = 3.1 m/s² is 2·√(1.5/1.55) = 1.967 s,
rounded up to the 0.1 s step: 2.0 s; with a = 20 m/s² it would be 0.77 s, so 1 s (floor).
"""

from __future__ import annotations

import numpy as np
import pytest

from stlc.replan.explain import default_waypoint_period, reason, shortest_segment


def _why(**kw):
    base = dict(converged=False, status="infeasible", within_budget=True, solve_s=0.1,
                budget=0.4, rejoin=1.0, rejoin_tol=1e-4, kept={}, kappa=0.01,
                deviation=np.array([0.0, -1.3, 0.0]), segment_s=1.0,
                acc_max=np.array([3.1, 3.1, 3.1]))
    base.update(kw)
    return reason(**base)


def test_infeasible_replan_names_the_segment_and_the_limit():
    why = _why()
    assert "1.30 m in y" in why and "0.78 m" in why  # 3.1 · 1² / 4 = 0.775
    assert "too short" in why and "1.30 s" in why
    assert shortest_segment(1.3, 3.1) == pytest.approx(2 * np.sqrt(1.3 / 3.1))


def test_reachable_but_infeasible_says_so():
    why = _why(deviation=np.array([0.2, 0.0, 0.0]))
    assert "reachable" in why and "too short" not in why


def test_budget_rejoin_and_kept_spec_reasons():
    why = _why(converged=True, status="optimal", within_budget=False, solve_s=0.52,
               rejoin=2e-3, kept={"safety": -0.02, "other": 0.5})
    assert "0.520 s, over the budget t_c = 0.4 s" in why
    assert "rejoins the plan only to 2.00e-03" in why
    assert "`safety` has robustness -0.0200 < κ = 0.01" in why and "other" not in why
    assert _why(converged=True, status="optimal", rejoin=0.0) == ""


def test_default_waypoint_period_from_the_limits():
    assert default_waypoint_period(1.0, np.array([3.1, 3.1, 3.1]), 0.1) == pytest.approx(2.0)
    assert default_waypoint_period(1.0, np.array([20.0, 20, 20]), 0.1) == pytest.approx(1.0)
