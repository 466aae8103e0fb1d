"""The risk pass split over a Dask executor gives the single-process results bitwise."""

from __future__ import annotations

import numpy as np
import pytest

from stlc.analysis import monitor
from stlc.analysis.assess import run_risk
from stlc.analysis.risk_parallel import BATCH, distributed
from stlc.planning.solution import Solution
from stlc.pipeline import load

SOURCE = """\
vehicle p : point_mass {
  vel_max = (1, 1, 1) m/s
  acc_max = (2, 2, 2) m/s^2
  start { pos = (0, 0, 0) m }
}
scenario {
  human op {
    pos = (1.0, 0, 0) m
    att = (0, 0, 0) deg
    region r = box((-0.5, -0.5, -0.5), (0.5, 0.5, 0.5)) m
  }
  op.pos ~ normal((1.0, 0, 0) m, diag(0.1, 0.1, 0) m^2)
}
mission m {
  vehicles = [p]
  horizon = 2 s
  step = 0.5 s
  spec near = eventually (p.pos in op.r)
  spec low = always (p.pos.z <= 1 m)
  require near and low
  minimize -robustness
  risk { K = 2500; delta = 0.01; beta = [0.8, 0.9]; seed = 3
         case wide { op.pos ~ normal((1.0, 0, 0) m, diag(0.3, 0.3, 0) m^2) } }
}
"""


@pytest.fixture(scope="module")
def client():
    from distributed import Client, LocalCluster

    with LocalCluster(n_workers=2, threads_per_worker=1, processes=False,
                      dashboard_address=":0") as cluster, Client(cluster) as c:
        yield c


def test_distributed_risk_equals_single_process(tmp_path, client):
    assert 2500 > 2 * BATCH  # three batches, the last one short
    f = tmp_path / "m.stl"
    f.write_text(SOURCE)
    program = load(str(f)).program
    m = program.missions["m"]
    t = np.arange(5) * 0.5
    ch = {"p.pos.x": np.array([0, 0.3, 0.7, 0.9, 1.0]), "p.pos.y": np.zeros(5),
          "p.pos.z": np.zeros(5)}
    sol = Solution("m", "satisfied", 0.0, 0.0, {}, 0.0, t, ch)
    one, res1 = run_risk(program, m, sol)
    many, res2 = run_risk(program, m, sol, shared=distributed(client))
    assert one == many
    for a, b in zip(res1, res2):
        for k in a.exact:
            np.testing.assert_array_equal(a.exact[k], b.exact[k])
            np.testing.assert_array_equal(a.smooth[k], b.smooth[k])
    # and against the monitor, realisation by realisation (a few of them)
    r = res2[0]
    for i in (0, 1023, 1024, 2499):
        params = {**program.params, **{k: float(v[i]) for k, v in r.params.items()}}
        assert r.exact["requirement"][i] == pytest.approx(
            monitor.robustness(m.requirement, 0.5, ch, params), abs=1e-12)
