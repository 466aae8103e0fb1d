"""The structured derivatives (``stlc.backends.nlp.derivatives``) equal CasADi's own.

The NLP that ``casadi_nlp.build`` hands to nlpsol is captured; nlpsol then builds a
reference solver from the same NLP *without* the structured functions (it differentiates
the whole graph itself), and both solvers' ``nlp_jac_g`` and ``nlp_hess_l`` are evaluated at
random points, random multipliers and parameters: the constraint values, the Jacobian and
the upper triangle of the Lagrangian Hessian must agree to rounding.  Two vehicle models
(the tilted hexarotor with RK4 sub-steps, a point-mass pair) and both integrators.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import casadi as ca
import numpy as np
import pytest

from stlc.backends.nlp import model as casadi_nlp
from stlc.pipeline import load
from stlc.planning.problem import from_mission

ROOT = Path(__file__).resolve().parents[1]
PAIR = """\
vehicle d1 : point_mass {
  vel_max = (1, 1, 1) m/s
  acc_max = (2, 2, 2) m/s^2
  start { pos = (0, 0, 1) m }
}
vehicle d2 : point_mass {
  vel_max = (1, 1, 1) m/s
  acc_max = (2, 2, 2) m/s^2
  start { pos = (2, 0, 1) m }
}
mission m {
  vehicles = [d1, d2]
  horizon = 4 s
  step = 0.5 s
  spec reach = eventually[0, 4] (d1.pos.x >= 1 m and d2.pos.y <= -0.5 m)
  spec apart = always[0, 4] (d1.pos.x <= d2.pos.x - 0.5 m)
  require reach and apart
  maximize robustness
}
"""


def _captured(program, mission, step, horizon, integrator, monkeypatch):
    grabbed = {}
    real = ca.nlpsol

    def grab(name, plugin, nlp, opts):
        grabbed.update(nlp=nlp, opts=opts)
        return real(name, plugin, nlp, opts)

    monkeypatch.setattr(casadi_nlp.ca, "nlpsol", grab)
    problem = from_mission(program, mission, step=step, horizon=horizon)
    prob, _ = casadi_nlp.build(replace(problem, integrator=integrator))
    monkeypatch.setattr(casadi_nlp.ca, "nlpsol", real)
    ref_opts = {k: v for k, v in grabbed["opts"].items()
                if k not in ("hess_lag", "jac_g", "iteration_callback")}
    ref = real("reference", "ipopt", grabbed["nlp"], ref_opts)
    return prob.solver, ref, grabbed["nlp"], (prob.lbx, prob.ubx)


def _compare(solver, reference, nlp, bounds, seed: int) -> None:
    rng = np.random.default_rng(seed)
    nw, ng, npar = nlp["x"].numel(), nlp["g"].numel(), nlp["p"].numel()
    lo, hi = bounds  # inside the variable bounds: rotor forces > 0
    for _ in range(3):
        x = np.clip(np.clip(0.0, lo, hi) + rng.normal(0.0, 0.3, nw), lo, hi)
        p = np.concatenate([[rng.uniform(5, 50)], rng.uniform(0, 1, npar - 1)])
        lam_g, lam_f = rng.normal(size=ng), rng.uniform(0.5, 2.0)
        g1, j1 = solver.get_function("nlp_jac_g")(x, p)
        g2, j2 = reference.get_function("nlp_jac_g")(x, p)
        assert np.allclose(np.asarray(g1), np.asarray(g2), rtol=1e-12, atol=1e-12)
        J1, J2 = np.asarray(ca.densify(j1)), np.asarray(ca.densify(j2))
        assert np.allclose(J1, J2, rtol=1e-10, atol=1e-10 * max(1.0, np.abs(J2).max()))
        h1 = solver.get_function("nlp_hess_l")(x, p, lam_f, lam_g)
        h2 = reference.get_function("nlp_hess_l")(x, p, lam_f, lam_g)
        H1, H2 = np.asarray(ca.densify(h1)), np.asarray(ca.densify(h2))
        assert np.isfinite(H1).all() and np.abs(H1).max() > 0
        assert np.allclose(np.triu(H1), H1)  # ours is the upper triangle
        H2 = np.triu(H2)  # nlpsol's own may be the full symmetric matrix
        assert np.allclose(H1, H2, rtol=1e-9, atol=1e-9 * max(1.0, np.abs(H2).max()))


@pytest.mark.parametrize("integrator", ["rk4", "euler"])
def test_hexarotor_derivatives_match_casadi(integrator, monkeypatch):
    program = load(str(ROOT / "specs" / "handover.stl")).program
    mission = program.missions["handover_left_tb"]
    # 0.25 s: two RK4 sub-steps per interval (casadi_nlp.substeps)
    _compare(*_captured(program, mission, 0.25, 3.0, integrator, monkeypatch), 1)


def test_point_mass_pair_derivatives_match_casadi(tmp_path, monkeypatch):
    path = tmp_path / "pair.stl"
    path.write_text(PAIR, encoding="utf-8")
    program = load(str(path)).program
    _compare(*_captured(program, program.missions["m"], None, None, "rk4", monkeypatch), 2)
