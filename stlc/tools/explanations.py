"""The long explanation of every diagnostic code (``stlc explain STLxxx``), with a wrong and
a fixed example.

``EXPLANATIONS[code] = (text, wrong, fixed)``.  Where ``wrong`` is a complete `.stl` file it
is checked by the suite: checking it reports ``code``, checking ``fixed`` reports nothing
(``SOURCE_EXAMPLES``); the other codes come from the command line, a trace or the solver,
and their examples show a command or the situation.
"""

from __future__ import annotations

_PM = """vehicle uav1 : point_mass {
  vel_max = (1, 1, 1) m/s
  acc_max = (1, 1, 1) m/s^2
  start { pos = (0, 0, 1) m }
}
"""


_REQ = "  require always[0, 5] uav1.pos.z > 0\n"


def _m(body: str, head: str = _PM) -> str:
    return (head + "mission m {\n  vehicles = [uav1]\n  horizon = 5 s\n  step = 0.1 s\n" + body
            + "}\n")


EXPLANATIONS: dict[str, tuple[str, str, str]] = {
    "STL001": (
        "The lexer found a character that starts no token of the language. C-style "
        "operators (`&&`, `||`, `!`, `==`) do not exist: write `and`, `or`, `not`, and compare "
        "with `<`, `<=`, `>`, `>=`.",
        "signal x, y\nspec a = x > 1 && y > 2\n", "signal x, y\nspec a = x > 1 and y > 2\n"),
    "STL002": (
        "The parser found a token where the grammar allows none of that kind: an extra `)`, "
        "two operators in a row, a chained comparison (`a < b < c`), a `}` with no block "
        "open.  The help lists what may come there.",
        "signal x, y, z\nspec a = x < y < z\n", "signal x, y, z\nspec a = x < y and y < z\n"),
    "STL003": (
        "The file ends inside a declaration: a bracket or block is still open, or the last "
        "line ends with an operator.  The help names the bracket that is never closed.",
        "signal x\nmission m {\n  horizon = 5 s\n", "signal x\nmission m {\n  horizon = 5 s\n"
        "  step = 0.1 s\n  require x > 0\n}\n"),
    "STL004": (
        "Brackets nested more than 100 deep, or a formula nested more than 200 levels "
        "(e.g. `not not not ...`).  Name sub-formulas with `spec` and use the names.",
        "spec a = ((((((...(x > 1)...))))))   # 101 levels",
        "spec inner = x > 1\nspec a = not inner"),
    "STL005": (
        "The file is not valid UTF-8 (e.g. saved as Latin-1 with a `°` or `µ`).  The "
        "diagnostic points at the first byte that does not decode.",
        "const a = 30 \\xb0   # a Latin-1 degree sign", "const a = 30 deg"),
    "STL006": (
        "A line is longer than 10 000 characters (generated files).  Newlines are allowed "
        "inside brackets, after operators and before `and`/`or`/`implies`/`until`.",
        "spec a = x > 1 and x > 1 and ... (10 001 characters)",
        "spec a = x > 1\n  and x > 1\n  and ..."),
    "STL101": (
        "A name is not declared where it is used: a signal, constant, spec, region, vehicle, "
        "human, mission, function argument or a vehicle missing from the mission's "
        "`vehicles`.  The help suggests the closest declared name.",
        "signal speed\nspec a = sped >= 1\n", "signal speed\nspec a = speed >= 1\n"),
    "STL102": (
        "A name is declared twice in one scope (two specs `a`, a vehicle and a region with "
        "the same name), or a field is given twice in one block.",
        "signal x\nspec a = x > 1\nspec a = x > 2\n", "signal x\nspec a = x > 1\nspec b = x > 2\n"),
    "STL103": (
        "A block has a field it does not know (`vel_mx` in a vehicle), or a member access "
        "names no field of the vehicle or human (`uav1.velocity`, `uav1.pos.w`).",
        _PM.replace("vel_max", "vel_mx"), _PM),
    "STL104": (
        "A required field is missing: a vehicle's mass or rotors, a start position, a "
        "mission's horizon or step; or `stlc simulate` has nothing to simulate.",
        _PM.replace("  start { pos = (0, 0, 1) m }\n", ""), _PM),
    "STL105": (
        "A vehicle's model is not one stlc knows.  The models are `multirotor` (full "
        "rigid-body dynamics) and `point_mass` (per-axis velocity and acceleration bounds).",
        _PM.replace("point_mass", "pointmass"), _PM),
    "STL106": (
        "A named spec uses a spec defined after it, or itself.  Specs may use only the specs "
        "defined before them (no recursion): move the definition up.",
        "signal x\nspec a = b and x > 1\nspec b = x > 2\n",
        "signal x\nspec b = x > 2\nspec a = b and x > 1\n"),
    "STL107": (
        "A call names no built-in function.  The functions are `abs`, `sqrt`, `norm`, "
        "`dist`, `dot`, `min`, `max`, `sin`, `cos`, `exp`, `log`, `atan2`, `angdiff` (and "
        "`box`, `diag`, `normal`, `hexarotor`, `quadrotor` in declarations).",
        "signal x\nspec a = nrm(x) > 1\n", "signal x\nspec a = abs(x) > 1\n"),
    "STL108": (
        "A declaration stands where it has no meaning: a field at the top level, an unknown "
        "block kind, a `foo bar = 3`.  Fields go into a `vehicle`, `scenario` or `mission`.",
        "horizon = 3 s\n", "const horizon = 3 s\n"),
    "STL109": (
        "The command has nothing to work on: `stlc compile` on a file without a `mission`, "
        "or `stlc monitor` on a file without specs.",
        "stlc compile monitor_only.stl      # the file declares only signals and specs",
        "stlc monitor monitor_only.stl --trace trace.csv"),
    "STL110": (
        "A backup drone of a `fail` event cannot take over: it is already in the mission's "
        "team, or it carries no payload (`capacity`).",
        "fail uav1 { time = 60 s; backup = uav2 }   # uav2 is in `vehicles`",
        "fail uav1 { time = 60 s; backup = uav3 }   # uav3: declared, capacity = 2, not in team"),
    "STL201": (
        "A spec, a `require` or an operand of `and`/`always`/... must be a formula (true or "
        "false at each time), but it is a number.  Compare it with something.",
        "signal x\nspec a = x\n", "signal x\nspec a = x > 0\n"),
    "STL202": (
        "Arithmetic or a comparison was applied to a formula (`x + (x > 1)`, `-(x > 1)`).  "
        "Combine formulas with `and`, `or`, `not`.",
        "signal x\nspec a = (x > 1) > 0\n", "signal x\nspec a = x > 1\n"),
    "STL203": (
        "A unit is not known.  Units are SI with prefixes and a few others: `m`, `cm`, `s`, "
        "`ms`, `kg`, `N`, `Hz`, `deg`, `rad`, products and powers like `m/s^2`, `kg*m^2`.",
        "signal x\nspec a = x > 3 furlong\n", "signal x\nspec a = x > 3 m\n"),
    "STL204": (
        "A value has the wrong unit: a length where a time is expected, a unit on a "
        "plain-number field (`capacity`, `lambda`, `K`, `seed`), both sides of a comparison "
        "in different dimensions.",
        _m(_REQ, _PM.replace("(1, 1, 1) m/s^2", "(1, 1, 1) s")), _m(_REQ)),
    "STL205": (
        "A vector has the wrong number of components: a 2-vector where a position needs 3, "
        "a member `.4` of a 3-vector, a covariance of the wrong size.",
        _PM.replace("pos = (0, 0, 1) m", "pos = (0, 1) m"), _PM),
    "STL206": (
        "A function got the wrong number of arguments (`abs(x, y)`, `atan2(x)`, a `box` "
        "with one corner).",
        "signal x, y\nspec a = abs(x, y) > 1\n", "signal x, y\nspec a = abs(x - y) > 1\n"),
    "STL207": (
        "A value is out of its range: a negative mass, a fractional capacity, an unknown "
        "smoothing, λ ≤ 0, an objective without `robustness`, a non-finite number "
        "(`inf - inf`, a box corner at `inf`).",
        _PM.replace("start {", "capacity = 1.5\n  start {"),
        _PM.replace("start {", "capacity = 2\n  start {")),
    "STL208": (
        "The right side of `in` (or a target/obstacle declaration) must be a region: a "
        "`box(...)`, a declared region or a human's region.",
        _PM + "spec a = uav1.pos in 3\n", _PM + "scenario {\n  region r = box((0, 0, 0), "
        "(1, 1, 1)) m\n}\nspec a = uav1.pos in r\n"),
    "STL209": (
        "A covariance of an uncertain pose is not a valid covariance: a negative variance, "
        "a non-symmetric matrix, or the wrong size.  `stlc risk` also reports a risk block "
        "it cannot sample with this code.",
        "scenario {\n  human op {\n    pos = (0, 0, 0) m\n    att = (0, 0, 0) deg\n  }\n"
        "  op.pos ~ normal((0, 0, 0) m, diag(1, -1, 1) m^2)\n}\n",
        "scenario {\n  human op {\n    pos = (0, 0, 0) m\n    att = (0, 0, 0) deg\n  }\n"
        "  op.pos ~ normal((0, 0, 0) m, diag(1, 1, 1) m^2)\n}\n"),
    "STL210": (
        "A constant value was expected (a `const`, an interval bound, an exponent) but the "
        "expression reads a signal or is a formula.  Use `spec` to name a formula.",
        "signal x\nspec a = always[x, 2] x > 1\n", "signal x\nspec a = always[0, 2] x > 1\n"),
    "STL211": (
        "A box is empty: a lower corner above the upper one, or a negative size.",
        "scenario {\n  obstacle o = box((1, 0, 0), (0, 1, 1)) m\n}\n",
        "scenario {\n  obstacle o = box((0, 0, 0), (1, 1, 1)) m\n}\n"),
    "STL212": (
        "An `exists` ranges over a group with fewer elements than the names it binds "
        "(`exists s in stations` in a file without a `station`, `exists d, e in team` in a "
        "one-drone team), so the formula could never hold.  (A `forall` over too few "
        "elements is vacuously true and is not an error.)  Declare what it ranges over, or "
        "remove the quantifier.",
        _m("  require exists s in stations: eventually[0, 5] (uav1.pos in s)\n"),
        _m("  require exists s in stations: eventually[0, 5] (uav1.pos in s)\n",
           _PM + "scenario {\n  station s1 = box((0, 0, 0), (1, 1, 1)) m\n}\n")),
    "STL301": (
        "A time bound of an interval is negative.  Intervals are relative to now and start "
        "at 0 or later.",
        "signal x\nspec a = always[-1, 2] x > 0\n", "signal x\nspec a = always[0, 2] x > 0\n"),
    "STL302": (
        "An interval's bounds are out of order (`[3, 2]`).",
        "signal x\nspec a = always[3, 2] x > 0\n", "signal x\nspec a = always[2, 3] x > 0\n"),
    "STL303": (
        "An interval bound of a mission's formula is not a multiple of the mission's step, "
        "so no sample lies on it.",
        "signal x\n" + _m("  spec a = always[0, 0.15] x > 0\n  require a\n", ""
                          ).replace("  vehicles = [uav1]\n", ""),
        "signal x\n" + _m("  spec a = always[0, 0.2] x > 0\n  require a\n", ""
                          ).replace("  vehicles = [uav1]\n", "")),
    "STL304": (
        "A mission's formula looks beyond the mission's horizon (`always[0, 6]` in a 5 s "
        "mission): its robustness would depend on samples the plan does not have.",
        "signal x\n" + _m("  require always[0, 6] x > 0\n", "").replace(
            "  vehicles = [uav1]\n", ""),
        "signal x\n" + _m("  require always[0, 5] x > 0\n", "").replace(
            "  vehicles = [uav1]\n", "")),
    "STL305": (
        "A mission's horizon or step is not a positive finite time, or the horizon is not "
        "a whole number of steps.",
        "signal x\nmission m {\n  horizon = 5.05 s\n  step = 0.1 s\n  require x > 0\n}\n",
        "signal x\nmission m {\n  horizon = 5 s\n  step = 0.1 s\n  require x > 0\n}\n"),
    "STL306": (
        "An event of a `simulate` block (`disturb`, `fail`, `move`, or `--disturb`/`--fail`/"
        "`--move`) lies outside the mission's horizon.",
        _m("  require always[0, 5] uav1.pos.z > 0\n  simulate {\n    disturb uav1 { time = "
           "25 s; displacement = (1, 0, 0) m }\n  }\n"),
        _m("  require always[0, 5] uav1.pos.z > 0\n  simulate {\n    disturb uav1 { time = "
           "2 s; displacement = (1, 0, 0) m }\n  }\n")),
    "STL401": (
        "The planner (or the replanner) does not support this construct for this mission: "
        "e.g. a kept spec of `replan` that is not an `always` over the vehicle's own "
        "state, a takeover on a mission without payloads, disturbances and a failure (or an "
        "operator move and vehicle events, or two moves) in one simulation.",
        "replan { keep = [handover] }   # handover is an `eventually`",
        "replan { keep = [safety] }     # safety = always[0, T_N] (uav1.pos in workspace)"),
    "STL402": (
        "A vehicle's start state violates its own bounds (a speed above `vel_max`, a start "
        "outside the flight envelope), so no plan can start there.",
        "start { pos = (0, 0, 1) m; vel = (5, 0, 0) m/s }   # vel_max = (1, 1, 1) m/s",
        "start { pos = (0, 0, 1) m; vel = (0.5, 0, 0) m/s }"),
    "STL501": (
        "`stlc compile` found no plan that satisfies the mission: the exact robustness of "
        "the spec named is below the threshold κ (negative: violated at the time given). "
        "The report is still written (exit 3).  Relax the spec, lengthen the horizon, or "
        "check that the vehicle can do it.",
        "spec reach = eventually[0, 1] (uav1.pos in far_away)   # 30 m in 1 s at 1 m/s",
        "spec reach = eventually[0, 40] (uav1.pos in far_away)"),
    "STL502": (
        "The solver failed to produce a dynamically feasible plan (IPOPT's restoration "
        "failed, an evaluation error).  Rerun with `STLC_IPOPT` options for details.",
        "stlc compile mission.stl   # IPOPT: Restoration_Failed",
        "STLC_IPOPT='{\"ipopt.print_level\": 5}' stlc compile mission.stl"),
    "STL503": (
        "A team mission has no task assignment at all: a target no drone can reach and "
        "leave in time, more payload needed than capacity and refills allow, no station.",
        "capacity = 1 for each of 2 drones, 7 targets, no station",
        "capacity = 4 for each of 2 drones, or a station to refill"),
    "STL504": (
        "No plan can satisfy the mission: HiGHS proved a relaxation of it infeasible (every "
        "vehicle a double integrator in its acceleration and speed box, predicates on other "
        "signals dropped), so the named specs conflict — e.g. be in two disjoint regions at "
        "once, or reach a place farther than the vehicle can fly in the time allowed.  "
        "Unlike STL501 (no plan *found*) this is a proof; the report says \"No plan exists\" "
        "(exit 3).  Relax one of the specs named.",
        "require eventually[0, 2] (uav1.pos in a) and always[0, 5] (uav1.pos in b)  # a, b "
        "disjoint",
        "require eventually[0, 2] (uav1.pos in a) and always[3, 5] (uav1.pos in b)"),
    "STL505": (
        "The start state cannot meet the threshold κ: a predicate that must hold at t = 0 "
        "(under an `always[0, …]`, a conjunct of the requirement) is below κ on the declared "
        "start — on a region's boundary, inside an obstacle grown by the vehicle's radius, "
        "over a limit.  Every plan starts there, so no plan exists; `stlc check` says so at "
        "once, naming the spec, the predicate, the time and the value.  Move the start, or "
        "lower κ (or that unit's `margin`).",
        "  start { pos = (0, 0, 0) m }   # on the floor of workspace = box((-5, -5, 0), ...)\n"
        "  threshold = 0.1\n  require always[0, 10] (uav1.pos in workspace)",
        "  start { pos = (0, 0, 1) m }\n  threshold = 0.1\n"
        "  require always[0, 10] (uav1.pos in workspace)"),
    "STL601": (
        "A file cannot be read (no such file, a folder, no permission).",
        "stlc check misson.stl", "stlc check mission.stl"),
    "STL602": (
        "A trace (CSV) is malformed: no header, a value that is not a number, a row with the "
        "wrong number of columns, a column of other length.",
        "t,x\n0,1\n0.1,abc\n", "t,x\n0,1\n0.1,2\n"),
    "STL603": (
        "A trace has no column for a signal a spec reads (`uav1.pos.x`, a declared "
        "`signal`).",
        "t,x\n0,1\n   # the spec reads y", "t,x,y\n0,1,2\n"),
    "STL604": (
        "A trace's `t` column is not uniform (the monitor's windows are in samples).",
        "t,x\n0,1\n0.1,2\n0.3,3\n", "t,x\n0,1\n0.1,2\n0.2,3\n"),
    "STL605": (
        "The output directory cannot be written: an empty name, a file in its place, a "
        "path through a file, no permission, or an output name that exists as a folder.  "
        "Checked before any solve.",
        "stlc compile mission.stl -o notes.txt   # a file", "stlc compile mission.stl -o out/"),
    "STL606": (
        "The problem is too large for the resource budget, and stlc refuses it before "
        "allocating: the estimated memory of a mission's trajectory NLP (samples × "
        "vehicles' states and inputs × predicates) is over the budget (by default half the "
        "machine's memory, at most 16G; `--max-memory` moves it), or a quantifier would "
        "expand to more than 50 000 source nodes (instances × the body's size).  The help "
        "says what fits: a coarser step, a shorter horizon, fewer vehicles or specs, fewer "
        "nested quantifiers.",
        "stlc compile mission.stl --max-memory 64M   # horizon = 600 s, step = 0.01 s",
        "stlc compile mission.stl --max-memory 64M   # step = 0.5 s (or a larger --max-memory)"),
    "STL607": (
        "`stlc sweep --scheduler ADDRESS` cannot connect to the Dask scheduler at that "
        "address within 10 s (nothing listening, a wrong host or port, a firewall).  Start "
        "a scheduler and its workers first, or drop `--scheduler` to run on a local "
        "cluster.",
        "stlc sweep mission.stl --scheduler tcp://10.0.0.5:8786   # no scheduler running",
        "dask scheduler &   # then `dask worker tcp://10.0.0.5:8786` on each machine\n"
        "stlc sweep mission.stl --scheduler tcp://10.0.0.5:8786"),
    "STLW01": (
        "Warning.  `always[a,b] p and q` is `(always[a,b] p) and q` by the precedence "
        "contract: the temporal operator binds tighter, so `q` is checked at the start "
        "(t = 0) alone.  Reported when the right operand has no temporal operator (a state "
        "condition most likely meant inside).  Parenthesise either way to silence it.  "
        "Warnings do not change the exit code; `--deny-warnings` makes them errors.",
        "signal x, y\nspec a = always[0, 5] x > 0 and y > 0\n",
        "signal x, y\nspec a = always[0, 5] (x > 0 and y > 0)\n"),
    "STLW02": (
        "Warning.  `a implies b` is true wherever `a` is false; on this plan (or trace) the "
        "antecedent never holds where the implication is evaluated, so it holds only "
        "vacuously and says nothing about the plan — typically a plan on the face of a "
        "region, where `pos in gate` has robustness 0 (not > 0).  The warning names the "
        "time the antecedent comes closest.  To make the plan enter the antecedent, "
        "require it too.",
        "require always[0, 20] ((uav1.pos in gate) implies eventually[0, 5] (uav1.pos in "
        "guard))",
        "require eventually[0, 10] (uav1.pos in gate)\n  and always[0, 20] ((uav1.pos in "
        "gate) implies eventually[0, 5] (uav1.pos in guard))"),
    "STLW03": (
        "Warning.  A target, station, home or plain region does not meet the `workspace` "
        "box, so no plan that stays in the workspace can reach it.  Check its corners (and "
        "units) against the workspace.",
        _PM + "scenario {\n  workspace = box((-5, -5, 0), (5, 5, 3)) m\n  target t1 = "
        "box((6, 0, 1), (7, 1, 2)) m\n}\n",
        _PM + "scenario {\n  workspace = box((-5, -5, 0), (5, 5, 3)) m\n  target t1 = "
        "box((4, 0, 1), (5, 1, 2)) m\n}\n"),
    "STLW04": (
        "Warning.  Declared and never used: a mission's named spec that neither its "
        "`require`, another spec nor its `replan { keep }` reads (the plan does not have to "
        "satisfy it), or an obstacle or plain region no formula mentions (an obstacle no "
        "formula mentions is not avoided).  Use it, or remove it.",
        _m("  spec low = always[0, 5] uav1.pos.z < 3 m\n" + _REQ.replace("0\n", "0 m\n")),
        _m("  spec low = always[0, 5] uav1.pos.z < 3 m\n"
           "  require always[0, 5] uav1.pos.z > 0 m and low\n")),
    "STLW05": (
        "Warning.  One unitless `threshold` κ > 0 over predicates measured in different "
        "units: robustness is in the unit of each predicate, so κ = 0.05 asks 5 cm of a "
        "position, 0.05 m/s of a speed, 2.9° of an angle and 0.05 Hz of a rotor speed at "
        "once.  Give a margin per unit instead: `margin = [0.05 m, 0.02 m/s, 1 deg, 1 Hz]` "
        "(units it does not name keep `threshold`, default 0).",
        _m("  threshold = 0.2\n  require always[0, 5] (uav1.pos.z > 0 m and uav1.speed "
           "<= 1 m/s)\n"),
        _m("  margin = [0.2 m, 0.05 m/s]\n  require always[0, 5] (uav1.pos.z > 0 m and "
           "uav1.speed <= 1 m/s)\n")),
}

#: codes whose examples are `.stl` files the checker judges (tested by the suite)
SOURCE_EXAMPLES = tuple(c for c in EXPLANATIONS if c[3] in "0123" and c not in
                        ("STL004", "STL005", "STL006", "STL109", "STL110"))
