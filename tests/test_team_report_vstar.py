"""The report's forward-speed section shows a v* line only for drones that have a v*: the
mission's ``forward_speed`` (every drone), or paper B eq. 8 from a drone's own aerodynamic
data.  Expected v* values are computed here from eq. 8 by hand."""

from __future__ import annotations

import math
from dataclasses import replace

import pytest
from test_report_team import team_case

from stlc.output.report import build_view


def eq8(m, n_r, a, f, k, rho):
    return math.sqrt(m / (2 * rho * a)) * (4 * k * a / (n_r * f)) ** 0.25


def with_aero(program, name, aero, mass):
    veh = replace(program.vehicles[name], aero=aero, mass=mass)
    return replace(program, vehicles={**program.vehicles, name: veh})


def test_per_drone_v_star_only_where_the_drone_declares_its_data():
    program, mission, sol = team_case(v_star=None)
    aero = (4, 0.05, 0.2, 1.15, 1.225)
    program = with_aero(program, "uav1", aero, 1.5)
    fw = build_view(program, mission, sol)["team"]["forward"]
    by = {d["name"]: d for d in fw["drones"]}
    want = eq8(1.5, *aero)
    vel = program.vehicles["uav1"].vel_max
    want = min(want, math.hypot(vel[0], vel[1]))
    assert by["uav1"]["v_star"] == pytest.approx(want, rel=1e-4)
    assert by["uav2"]["v_star"] is None and by["uav2"]["cost"] is None
    assert fw["v_star"] is None  # no single mission-level v*


def test_mission_forward_speed_gives_every_drone_the_line():
    program, mission, sol = team_case(v_star=2.0)
    program = with_aero(program, "uav1", (4, 0.05, 0.2, 1.15, 1.225), 1.5)
    fw = build_view(program, mission, sol)["team"]["forward"]
    assert fw["v_star"] == 2.0
    assert all(d["v_star"] == pytest.approx(min(2.0, d_lim), rel=1e-4)
               for d, d_lim in zip(fw["drones"], [math.hypot(*program.vehicles[d["name"]]
                                                             .vel_max[:2])
                                                  for d in fw["drones"]], strict=True))


def test_no_v_star_anywhere_means_no_section():
    program, mission, sol = team_case(v_star=None)
    assert build_view(program, mission, sol)["team"]["forward"] is None
