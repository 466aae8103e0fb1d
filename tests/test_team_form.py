"""Judging the executed team of a takeover from the checked mission (issue 18): the
checker keeps each team quantifier's per-drone template (``stlc.semantics.teamform``), and
a pure function re-instantiates the mission for the executed team (the backup added) —
no source text, parser or checker after check time, so ``--set`` values are kept.

Expected values come from the *edited file*: its text with the ``--set`` value written in
and the backup written into ``vehicles = [...]``, parsed and checked on its own, then the
exact monitor on the executed trajectory."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from stlc import pipeline
from stlc.analysis import monitor
from stlc.backends.replan.takeover import TakeoverBackend
from stlc.frontend.syntax import parse
from stlc.planning.problem import from_mission
from stlc.planning.verify import recompute_derived
from stlc.replan import takeover
from stlc.semantics import model
from stlc.semantics.check import check

ROOT = Path(__file__).resolve().parents[1]
CROSS = ROOT / "tests" / "missions" / "takeover_cross.stl"


def edited_mission(text: str, mission: str, team: tuple[str, ...], path: str):
    """The mission of ``text`` with ``team`` written as its vehicles, checked from text."""
    pat = re.compile(r"(mission\s+" + re.escape(mission) + r"\s*\{.*?vehicles\s*=\s*)\[[^\]]*\]",
                     re.S)
    text2, n = pat.subn(lambda m: m.group(1) + "[" + ", ".join(team) + "]", text, count=1)
    assert n == 1
    # a `simulate` block naming the added vehicle as a backup is no longer valid
    text2 = re.sub(r"\n\s*simulate\s*\{[^{}]*(\{[^{}]*\}[^{}]*)*\}", "\n", text2)
    program = check(parse(text2, path))
    return program, program.missions[mission]


@pytest.mark.parametrize("setting, old, new", [
    ("Gamma_dis=2.5 m", "const Gamma_dis = 2 m", "const Gamma_dis = 2.5 m"),
    ("tb.center.y=3.5 m", "tb = box(center = ( 8, 4, 4)", "tb = box(center = ( 8, 3.5, 4)"),
])
def test_takeover_is_judged_with_the_set_values(setting, old, new):
    loaded = pipeline.load(str(CROSS), [setting])
    program = loaded.program
    problem, sol = pipeline.plan(program, program.missions["cross"])
    res = takeover.simulate_failure(problem, sol, model.Failure("uav1", 2.0, "uav3"),
                                    model.ReplanConfig(takeover_delay=18.0),
                                    planner=TakeoverBackend())
    assert res.events[0].triggered  # the backup joined the executed team
    text = CROSS.read_text()
    assert old in text
    prog_e, m_e = edited_mission(text.replace(old, new), "cross", ("uav1", "uav2", "uav3"),
                                 str(CROSS))
    p_e = from_mission(prog_e, m_e)
    raw = {k: v for k, v in res.executed.items() if k.split(".")[1] in ("pos", "vel", "acc")}
    ch, _ = recompute_derived(p_e, raw)
    want = {"mission": monitor.robustness(p_e.requirement, p_e.grid.dt, ch, p_e.params)}
    for name, spec in p_e.specs.items():
        want[name] = monitor.robustness(spec.normal, p_e.grid.dt, ch, p_e.params)
    for name, value in want.items():
        assert res.executed_robustness[name] == pytest.approx(float(value), abs=1e-9), name


# ------------------------------------------------------------ re-instantiation = checking
FILES = sorted([*ROOT.glob("specs/*.stl"), *ROOT.glob("tests/missions/*.stl")])


def _bounds(f):
    from stlc.semantics import ir

    return [(p.bound.signal if p.bound else None) for p in ir.predicates(f)]


def _same_mission(got, want):
    assert got.vehicles == want.vehicles
    assert got.requirement == want.requirement
    assert got.specs == want.specs
    assert _bounds(got.requirement) == _bounds(want.requirement)


def _team_missions():
    out = []
    for path in FILES:
        text = path.read_text()
        program = check(parse(text, str(path)))
        for m in program.missions.values():
            if m.team_form is not None:
                out.append((path, text, program, m))
    return out


def test_own_team_gives_the_checked_formulas():
    from stlc.semantics.teamform import instantiate

    missions = _team_missions()
    assert len(missions) >= 5
    for path, _, _, m in missions:
        names = list(m.specs)
        got = instantiate([m.team_form.requirement, *(m.team_form.specs[k] for k in names)],
                          m.vehicles)
        assert got == [m.requirement, *(m.specs[k] for k in names)], (path, m.name)
        assert _bounds(got[0]) == _bounds(m.requirement)


def test_an_added_vehicle_gives_the_edited_file():
    """Every declared vehicle outside a team mission's team, added: the same formulas as
    the file with that vehicle written into ``vehicles = [...]``, checked from its text."""
    from stlc.semantics.teamform import TeamFormError, for_team

    seen = 0
    for path, text, program, m in _team_missions():
        for extra in [v for v in program.vehicles if v not in m.vehicles]:
            team = (*m.vehicles, extra)
            try:
                _, want = edited_mission(text, m.name, team, str(path))
            except Exception:  # the edited file does not check: neither may for_team
                with pytest.raises(TeamFormError):
                    for_team(m, team)
                continue
            _same_mission(for_team(m, team), want)
            seen += 1
    assert seen >= 3


PM = "vel_max = (3,3,3) m/s; acc_max = (3,3,3) m/s^2; capacity = 2"
SYNTH = f"""
vehicle uav1 : point_mass {{ {PM}; start {{ pos = (0,0,1) m }} }}
vehicle uav2 : point_mass {{ {PM}; start {{ pos = (5,0,1) m }} }}
vehicle uav3 : point_mass {{ {PM}; start {{ pos = (5,5,1) m }} }}
vehicle fat : point_mass {{ {PM}; radius = 0.5 m; start {{ pos = (-5,5,1) m }} }}
scenario {{
  workspace = box((-10,-10,0),(10,10,10)) m
  obstacle o1 = box(center = (0,5,1), size = (1,1,2)) m
  target t1 = box(center = (3,3,3), size = (1,1,1)) m
  target t2 = box(center = (-3,3,3), size = (1,1,1)) m
}}
"""
SPECS = """
  spec pairs = forall d, e in team: always[0, 10 s] (dist(d.pos, e.pos) >= 1 m)
  spec near = forall d in team: eventually[0, 5 s] (exists e in team:
      (dist(d.pos, e.pos) <= 2 m and d.speed <= e.speed + 1 m/s))
  spec triple = forall d in team: always[0, 2 s] (forall e, f in team:
      dist(e.pos, f.pos) >= 0.5 m or d.pos.z >= 1 m)
  spec visit = forall q in targets: eventually[0, 8 s] (exists d in team:
      always[0, 1 s] (d.pos in q and d.payload > 0.5))
  spec mixed = forall d in [COMMON]: always[0, 10 s] (d.pos.z <= 9 m)
"""
CLEAR = "  spec clear = forall d in team: always[0, 10 s] (d.pos not in o1)\n"


def _synth(team: tuple[str, ...], clear: bool, common: str) -> str:
    req = "pairs and near and triple and visit and mixed" + (" and clear" if clear else "")
    return (SYNTH + "mission m {\n  vehicles = [" + ", ".join(team) + "]\n  horizon = 10 s\n"
            "  step = 0.5 s\n" + SPECS.replace("COMMON", common) + (CLEAR if clear else "")
            + f"  require {req}\n}}\n")


@pytest.mark.parametrize("team, new", [
    (t, (*t, *e)) for t in (("uav1",), ("uav1", "uav2"), ("uav2", "uav1"))
    for e in (("uav3",), ("uav3", "fat"), ("fat",))] + [
    (("uav1", "uav2"), ("uav3", "uav2")),  # a failed drone's role taken
    (("uav1", "uav2"), ("uav2",)),  # a drone dropped: a pair quantifier becomes vacuous
    (("uav1", "uav2"), ("uav2", "uav1", "uav3")),  # another order
])
@pytest.mark.parametrize("clear", [False, True])
def test_nested_and_pairwise_quantifiers(team, new, clear):
    """Pairs (a team of one: vacuous, then not), nesting, a team quantifier inside one over
    targets, a quantifier over a written list (not re-expanded), a radius read through the
    team (``not in``): the re-instantiated mission equals the checked edited text, or, for
    a vehicle whose radius differs from the team's where the formula reads it, is refused."""
    from stlc.semantics.teamform import TeamFormError, for_team

    common = next(v for v in team if v in new)  # for the written list `[uav1]`
    m = check(parse(_synth(team, clear, common), "s.stl")).missions["m"]
    want = check(parse(_synth(new, clear, common), "s.stl")).missions["m"]
    if clear and "fat" in new:
        with pytest.raises(TeamFormError) as e:
            for_team(m, new)
        assert e.value.subject == "fat"
        return
    _same_mission(for_team(m, new), want)
