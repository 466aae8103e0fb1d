"""Checking a mission's ``simulate { ... }`` block: the events of ``stlc simulate``.

    simulate {
      disturb uav1 { time = 6 s; displacement = (1.1, 0, 0) m }     # a push (and/or
      disturb uav1 { time = 11 s; velocity = (0, 0.8, 0) m/s }      # a velocity kick)
      fail uav1 { time = 60 s; backup = uav3 }                      # paper B §IV-C
      move operator { time = 8 s; pos = (1, 0.2, 0) m; att = (0, 0, 20) deg }  # paper A §6
      wind { velocity = (3, 0, 0) m/s; turbulence = light }         # `stlc fly`'s air
      noise { pos = 0.02 m; vel = 0.05 m/s }                        # and sensors
    }

``event_problems`` holds the rules shared with events given on the command line
(``--disturb``, ``--fail``/``--backup``, ``--move``), which the pipeline reports at the
mission's name.
Part of the checker (``stlc.semantics.check``); imports only ``context`` and lower layers.
"""

from __future__ import annotations

from stlc.diagnostics import did_you_mean
from stlc.frontend import ast
from stlc.semantics import model
from stlc.semantics.check import units
from stlc.semantics.check.context import Context

EVENT_KINDS = ("disturb", "fail", "move")
FLIGHT_KINDS = ("wind", "noise")  # one each, no name: the air and sensors of `stlc fly`
TURBULENCE = ("none", "light", "moderate", "severe")


def event_problems(vehicles: dict[str, model.Vehicle], mission_vehicles: tuple[str, ...],
                   horizon: float, ev: model.Disturbance | model.Failure,
                   takeover_delay: float = 10.0) -> list[tuple[str, str, str | None]]:
    """What is wrong with one event, as (code, message, hint); empty when it is usable."""
    out: list[tuple[str, str, str | None]] = []
    if ev.vehicle not in mission_vehicles:
        hint = did_you_mean(ev.vehicle, mission_vehicles) or \
            "the mission's vehicles: " + ", ".join(mission_vehicles)
        what = "declared but not" if ev.vehicle in vehicles else "not"
        out.append(("STL101", f"vehicle `{ev.vehicle}` is {what} part of the mission", hint))
    if not 0.0 <= ev.time < horizon:
        out.append(("STL306", f"event at {ev.time:g} s is outside the mission horizon "
                    f"[0, {horizon:g}) s", f"give a time between 0 and {horizon:g} s"))
    if isinstance(ev, model.Failure):
        b = vehicles.get(ev.backup)
        if b is None:
            out.append(("STL101", f"unknown backup vehicle `{ev.backup}`",
                        did_you_mean(ev.backup, vehicles) or
                        "declare it with `vehicle NAME : point_mass { capacity = ... }`"))
        elif ev.backup in mission_vehicles:
            out.append(("STL110", f"backup `{ev.backup}` is already in the mission's team",
                        "declare a drone that is not in `vehicles = [...]`"))
        elif not getattr(b, "capacity", None):
            out.append(("STL110", f"backup `{ev.backup}` carries no payload (no `capacity`)",
                        f"give `{ev.backup}` a `capacity = N` of at least 1"))
        if 0.0 <= ev.time < horizon and ev.time + takeover_delay >= horizon:
            out.append(("STL306", f"the backup would start at {ev.time + takeover_delay:g} s "
                        f"(failure + T_rep {takeover_delay:g} s), at or after the horizon "
                        f"{horizon:g} s", "fail earlier or shorten `takeover_delay`"))
    return out


def check_simulate(ck: Context, b: ast.Block, vehicles: tuple[str, ...],
                   horizon: float | None, takeover_delay: float) -> model.SimulateConfig | None:
    """The mission's ``simulate`` block, or None when it has none."""
    blocks = [m for m in b.members if isinstance(m, ast.Block) and m.kind == "simulate"]
    if not blocks:
        return None
    sb = blocks[0]
    dist: list[model.Disturbance] = []
    fails: list[model.Failure] = []
    moves: list[model.HumanMove] = []
    flight: dict[str, object] = {}
    for m in sb.members:
        if isinstance(m, ast.Block) and m.kind in FLIGHT_KINDS:
            if m.name:
                ck.d.error("STL108", f"`{m.kind}` applies to every vehicle of the mission",
                           m.name_span, f"write `{m.kind} {{ ... }}` without a name")
            elif m.kind in flight:
                ck.d.error("STL102", f"a `simulate` block has one `{m.kind}`", m.span)
            else:
                flight[m.kind] = _wind(ck, m) if m.kind == "wind" else _noise(ck, m)
            continue
        if not isinstance(m, ast.Block):
            ck.d.error("STL108", "a `simulate` block holds only `disturb`, `fail` and `move` "
                       "blocks", m.span,
                       "write `disturb uav1 { time = 6 s; displacement = (1, 0, 0) m }`, "
                       "`fail uav1 { time = 60 s; backup = uav3 }` or "
                       "`move operator { time = 8 s; pos = (1, 0, 0) m }`")
            continue
        if m.kind not in EVENT_KINDS:
            ck.bad_kind(m.kind, m.span, EVENT_KINDS + FLIGHT_KINDS, "in `simulate`")
            continue
        if not m.name:
            who = "human who moves" if m.kind == "move" else "vehicle it applies to"
            ck.d.error("STL104", f"`{m.kind}` needs the {who}", m.span,
                       f"write `{m.kind} {'operator' if m.kind == 'move' else 'uav1'} "
                       "{ time = ... }`")
            continue
        if m.kind == "move":
            mv = _move(ck, m, horizon)
            if mv is not None:
                moves.append(mv)
            continue
        ev = _disturb(ck, m) if m.kind == "disturb" else _fail(ck, m)
        if ev is None:
            continue
        if horizon is not None:
            for code, msg, hint in event_problems(ck.vehicles, vehicles, horizon, ev,
                                                  takeover_delay):
                span = m.name_span if "vehicle" in msg and "backup" not in msg else m.span
                ck.d.error(code, msg, span, hint)
        (dist if m.kind == "disturb" else fails).append(ev)  # type: ignore[arg-type]
    if len({f.vehicle for f in fails}) < len(fails):
        ck.d.error("STL102", "a vehicle fails once", sb.span)
    if moves and (dist or fails):
        ck.d.error("STL401", "a simulation has an operator move or vehicle events, not both",
                   moves[0].span, "simulate them one at a time (or override the file's "
                   "events with --move / --disturb)")
    for extra in moves[1:]:
        ck.d.error("STL401", "one operator move per simulation", extra.span,
                   "simulate the moves one at a time")
    return model.SimulateConfig(tuple(dist), tuple(fails), tuple(moves),
                                flight.get("wind"), flight.get("noise"))  # type: ignore[arg-type]


def _wind(ck: Context, m: ast.Block) -> model.FlightWind | None:
    f = ck.fields(m, {"velocity": False, "turbulence": False})
    v = ck.vec(f, "velocity", 3, units.SPEED, (0.0, 0.0, 0.0))
    level = "none"
    node = f["turbulence"].value if "turbulence" in f else None
    if node is not None:
        name = node.parts[0] if isinstance(node, ast.Path) and len(node.parts) == 1 else None
        if name not in TURBULENCE:
            ck.d.error("STL108", "`turbulence` is one of " + ", ".join(TURBULENCE), node.span,
                       did_you_mean(name or "", TURBULENCE) or "write `turbulence = light`")
            return None
        level = name
    if v is None:
        return None
    return model.FlightWind(v, level, m.span)  # type: ignore[arg-type]


def _noise(ck: Context, m: ast.Block) -> model.SensorNoise | None:
    f = ck.fields(m, {"pos": False, "vel": False})
    pos = ck.num(f, "pos", units.LENGTH, 0.0)
    vel = ck.num(f, "vel", units.SPEED, 0.0)
    if pos is None or vel is None:
        return None
    if pos < 0 or vel < 0:
        ck.d.error("STL108", "a noise level is a standard deviation (not negative)", m.span,
                   "write `noise { pos = 0.02 m; vel = 0.05 m/s }`")
        return None
    return model.SensorNoise(pos, vel, m.span)


def _disturb(ck: Context, m: ast.Block) -> model.Disturbance | None:
    f = ck.fields(m, {"time": True, "displacement": False, "velocity": False})
    t = ck.num(f, "time", units.TIME)
    dp = ck.vec(f, "displacement", 3, units.LENGTH, (0.0, 0.0, 0.0))
    dv = ck.vec(f, "velocity", 3, units.SPEED, (0.0, 0.0, 0.0))
    if "displacement" not in f and "velocity" not in f:
        ck.d.error("STL104", "a disturbance needs a `displacement` or a `velocity`", m.span,
                   "add `displacement = (1, 0, 0) m` or `velocity = (0, 1, 0) m/s`")
        return None
    if None in (t, dp, dv):
        return None
    return model.Disturbance(m.name, t, dp, dv, m.span)  # type: ignore[arg-type]


def _fail(ck: Context, m: ast.Block) -> model.Failure | None:
    f = ck.fields(m, {"time": True, "backup": True})
    t = ck.num(f, "time", units.TIME)
    node = f["backup"].value if "backup" in f else None
    if node is not None and not (isinstance(node, ast.Path) and len(node.parts) == 1):
        ck.d.error("STL101", "`backup` names a declared vehicle", node.span,
                   "write `backup = uav3`")
        return None
    if t is None or node is None:
        return None
    return model.Failure(m.name, t, node.parts[0], m.span)  # type: ignore[union-attr]


def _move(ck: Context, m: ast.Block, horizon: float | None) -> model.HumanMove | None:
    """``move HUMAN { time = T; pos = (x, y, z) m; att = (roll, pitch, yaw) deg }``: a
    declared human, a time strictly inside the horizon, a new position and/or attitude."""
    f = ck.fields(m, {"time": True, "pos": False, "att": False})
    t = ck.num(f, "time", units.TIME)
    pos = ck.vec(f, "pos", 3, units.LENGTH)
    att = ck.vec(f, "att", 3, units.ANGLE)
    ok = True
    if m.name not in ck.humans:
        ck.d.error("STL101", f"no human `{m.name}` in the scenario", m.name_span,
                   did_you_mean(m.name, ck.humans) or
                   ("the scenario's humans: " + ", ".join(ck.humans) if ck.humans else
                    "declare one in the scenario: `human operator { pos = (...) m }`"))
        ok = False
    if "pos" not in f and "att" not in f:
        ck.d.error("STL104", "a move needs a new `pos` or `att`", m.span,
                   "add `pos = (1, 0.2, 0) m` or `att = (0, 0, 20) deg`")
        return None
    if t is not None and horizon is not None and not 0.0 < t < horizon:
        ck.d.error("STL306", f"the move at {t:g} s is outside the mission horizon "
                   f"(0, {horizon:g}) s", f["time"].value.span,
                   f"give a time between 0 and {horizon:g} s")
        ok = False
    if not ok or t is None or ("pos" in f and pos is None) or ("att" in f and att is None):
        return None
    return model.HumanMove(m.name, t, pos, att, m.span)  # type: ignore[arg-type]
