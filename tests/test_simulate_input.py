"""`stlc simulate`'s input: the mission's `simulate { }` block, the command-line events, and
the diagnostics for events that cannot happen (issue: bad input gets a clear error, exit 1)."""

from __future__ import annotations

import textwrap

import pytest

from stlc import cli
from stlc.diagnostics import StlcError
from stlc.frontend.syntax import parse
from stlc.semantics.check import check
from stlc.semantics.teamform import for_team

HEAD = textwrap.dedent("""\
    vehicle uav1 : point_mass { vel_max = (3,3,3) m/s; acc_max = (3,3,3) m/s^2; capacity = 2
                                start { pos = (0,0,1) m } }
    vehicle uav2 : point_mass { vel_max = (3,3,3) m/s; acc_max = (3,3,3) m/s^2
                                start { pos = (5,0,1) m } }
    vehicle uav3 : point_mass { vel_max = (3,3,3) m/s; acc_max = (3,3,3) m/s^2; capacity = 1
                                start { pos = (5,5,1) m } }
    scenario { workspace = box((-10,-10,0),(10,10,10)) m }
    """)


def mission(sim: str, replan: str = "") -> str:
    return HEAD + textwrap.dedent(f"""\
        mission m {{
          vehicles = [uav1]
          horizon = 30 s
          step = 0.1 s
          spec inside = forall d in team: always (d.pos in workspace)
          require inside
          {replan}
          simulate {{
            {sim}
          }}
        }}
        """)


def codes(src: str) -> list[str]:
    with pytest.raises(StlcError) as e:
        check(parse(src, "m.stl"))
    return sorted(d.code for d in e.value.diagnostics)


def test_block_gives_events_in_si_units():
    src = mission("disturb uav1 { time = 1500 ms; displacement = (110, 0, 0) cm }\n"
                  "    disturb uav1 { time = 2 s; velocity = (0, 0.5, 0) m/s }\n"
                  "    fail uav1 { time = 12 s; backup = uav3 }",
                  "replan { takeover_delay = 5 s }")
    m = check(parse(src, "m.stl")).missions["m"]
    d1, d2 = m.simulate.disturbances
    assert (d1.vehicle, d1.time, d1.displacement, d1.velocity) == \
        ("uav1", 1.5, (1.1, 0.0, 0.0), (0.0, 0.0, 0.0))
    assert (d2.time, d2.velocity) == (2.0, (0.0, 0.5, 0.0))
    (f,) = m.simulate.failures
    assert (f.vehicle, f.time, f.backup) == ("uav1", 12.0, "uav3")
    assert m.replan.takeover_delay == 5.0


@pytest.mark.parametrize("event, code", [
    ("disturb uav1 { time = 31 s; displacement = (1, 0, 0) m }", "STL306"),  # past T_N
    ("disturb uav1 { time = -1 s; displacement = (1, 0, 0) m }", "STL306"),
    ("disturb uav2 { time = 1 s; displacement = (1, 0, 0) m }", "STL101"),  # not in team
    ("disturb uav7 { time = 1 s; displacement = (1, 0, 0) m }", "STL101"),  # undeclared
    ("disturb uav1 { time = 1 s }", "STL104"),  # no push
    ("disturb uav1 { time = 1 s; displacement = (1, 0) m }", "STL205"),
    ("disturb uav1 { time = 1 s; displacement = (1, 0, 0) s }", "STL204"),
    ("fail uav1 { time = 5 s; backup = uav2 }", "STL110"),  # backup without capacity
    ("fail uav1 { time = 5 s; backup = uav1 }", "STL110"),  # backup already in the team
    ("fail uav1 { time = 5 s; backup = uav9 }", "STL101"),
    ("fail uav2 { time = 5 s; backup = uav3 }", "STL101"),  # failing drone not in mission
    ("fail uav1 { time = 25 s; backup = uav3 }", "STL306"),  # 25 + T_rep 10 >= 30
    ("wobble uav1 { time = 1 s }", "STL108"),
    ("speed = 3", "STL108"),
])
def test_bad_events_are_diagnosed(event, code):
    assert code in codes(mission(event))


def test_for_team_quantifies_over_the_added_vehicle():
    program = check(parse(mission("fail uav1 { time = 5 s; backup = uav3 }"), "m.stl"))
    m = for_team(program.missions["m"], ("uav1", "uav3"))
    from stlc.semantics import ir

    assert m.vehicles == ("uav1", "uav3")
    assert {s.split(".")[0] for s in ir.signals(m.specs["inside"])} == {"uav1", "uav3"}
    assert program.missions["m"].vehicles == ("uav1",)  # the checked program is unchanged


def run(argv, capsys):
    rc = cli.main(argv)
    return rc, capsys.readouterr().err


def test_cli_events_are_checked_like_the_files(tmp_path, capsys):
    f = tmp_path / "m.stl"
    f.write_text(mission("disturb uav1 { time = 1 s; displacement = (1, 0, 0) m }"))
    rc, err = run(["simulate", str(f), "--disturb", "40:1,0,0", "-o", str(tmp_path / "o")],
                  capsys)
    assert rc == 1 and "error[STL306]" in err and "command line" in err
    rc, err = run(["simulate", str(f), "--fail", "uav1@5", "--backup", "uav2"], capsys)
    assert rc == 1 and "error[STL110]" in err
    assert not (tmp_path / "o").exists()  # nothing written on bad input


@pytest.mark.parametrize("argv", [
    ["--disturb", "4:1,0"], ["--disturb", "x:1,0,0"], ["--disturb", "4:1,nan,0"],
    ["--fail", "uav1@3"], ["--backup", "uav3"], ["--fail", "uav1", "--backup", "uav3"],
])
def test_cli_usage_errors_exit_2(tmp_path, argv, capsys):
    f = tmp_path / "m.stl"
    f.write_text(mission("disturb uav1 { time = 1 s; displacement = (1, 0, 0) m }"))
    with pytest.raises(SystemExit) as e:
        cli.main(["simulate", str(f), *argv])
    assert e.value.code == 2


def test_nothing_to_simulate_and_wrong_kind(tmp_path, capsys):
    src = mission("disturb uav1 { time = 1 s; displacement = (1, 0, 0) m }")
    f = tmp_path / "m.stl"
    f.write_text(src.replace("  simulate {\n    disturb uav1 { time = 1 s; displacement = "
                             "(1, 0, 0) m }\n  }\n", ""))
    rc, err = run(["simulate", str(f)], capsys)
    assert rc == 1 and "error[STL104]" in err and "nothing to simulate" in err
    f.write_text(src)  # no payload in the formula: not a team mission, no takeover
    rc, err = run(["simulate", str(f), "--fail", "uav1@5", "--backup", "uav3"], capsys)
    assert rc == 1 and "error[STL401]" in err
