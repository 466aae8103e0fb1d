"""Fuzz inputs that run whole commands: ``stlc simulate`` with events
from the file and the command line and ``replan`` blocks, team missions (capacities,
stations, horizons, target counts) and resource limits (tiny steps, nested quantifiers,
huge periods and counts).  Each case is a file, the command's arguments and, for the
output directory, a user's files that must survive (``run_command`` classifies a lost or
changed one as ``dataloss``).

``run_command`` is called by ``stlc.fuzz.runner`` in its worker process, which runs every
input under a memory cap (``mem``: a ``MemoryError``, or a peak resident size above the
cap, measured per input by resetting the kernel's high-water mark) and a time limit
(``hang``).  Every command gets ``--time-limit`` (``TIME_LIMIT``, a third of the runner's
limit for its kind): a run must end within its own limit (with the best verified plan,
``stopped``, exit 3, when the limit binds), so ``hang`` means the limit was not kept.
"""

from __future__ import annotations

import contextlib
import io
import os
import random
import tempfile

USER_FILES = {"trajectory.final.csv": "t,x\n0,1\n", "trajectory.backup.csv": "mine\n",
              "notes.txt": "user notes\n", "risk.json": "{\"mine\": true}\n"}
MEM_KINDS = ("simulate", "team", "resource")
MAX_MEMORY = "768M"  # the commands' planning budget, under the runner's cap (1 GB)
#: each command's ``--time-limit`` (s): a third of ``runner.MIN_TIMEOUT`` of its kind
TIME_LIMIT = {"simulate": 20.0, "team": 40.0, "resource": 10.0}


def _pick(rng: random.Random, common: list[str], odd: list[str], p: float = 0.15) -> str:
    return rng.choice(odd) if rng.random() < p else rng.choice(common)


def _point(name: str, pos: tuple[float, float, float], capacity: str | None = None) -> str:
    cap = f"  capacity = {capacity}\n" if capacity is not None else ""
    return (f"vehicle {name} : point_mass {{\n  vel_max = (2, 2, 2) m/s\n"
            f"  acc_max = (3, 3, 3) m/s^2\n{cap}"
            f"  start {{ pos = ({pos[0]}, {pos[1]}, {pos[2]}) m }}\n}}\n")


def gen_simulate(rng: random.Random) -> tuple[str, list[str]]:
    """A one- or two-drone point-mass mission with a ``replan`` block (periods from tiny to
    1e300 s), a ``simulate`` block or command-line events (pushes, failures, repeats)."""
    horizon = rng.choice([2, 3, 4])
    n = rng.choice([1, 1, 2])
    names = [f"uav{i + 1}" for i in range(n)]
    src = "".join(_point(v, (i * 3, 0, 1)) for i, v in enumerate(names))
    T = lambda: _pick(rng, ["0.5 s", "1 s", "0.1 s", "2 s"],  # noqa: E731
                      ["1e-9 s", "1e300 s", "1e4 s", "0 s", "-1 s", "0.05 s", "1e11 s", "inf"])
    fields = [f"threshold = {_pick(rng, ['0.2 m', '1 m', '0.05 m'], ['0 m', '-1 m', '1e300 m'])}",
              f"event_period = {T()}", f"waypoint_period = {T()}",
              f"budget = {_pick(rng, ['0.4 s', '1 s'], ['1e-9 s', '1e9 s', '0 s'])}",
              "keep = [low]"]
    rng.shuffle(fields)
    replan = "  replan { " + "; ".join(fields[:rng.randint(1, 5)]) + " }\n"
    sim = ""
    if rng.random() < 0.5:
        ev = []
        for _ in range(rng.choice([1, 1, 2, 3])):
            t = _pick(rng, ["0.5 s", "1 s", "1.5 s"], ["-1 s", "1e9 s", "0 s", f"{horizon} s"])
            d = _pick(rng, ["(0.5, 0, 0) m", "(0, 1.5, 0) m"], ["(1e300, 0, 0) m", "(0, 0, 0) m"])
            ev.append(f"disturb {rng.choice(names + ['ghost'])} {{ time = {t}; "
                      f"displacement = {d} }}")
        if rng.random() < 0.2:
            ev.append(f"fail {names[0]} {{ time = 1 s; backup = {names[-1]} }}")
        sim = "  simulate { " + "\n    ".join(ev) + " }\n"
    goal = _pick(rng, ["1", "2"], ["100", "-1e300"])
    src += (f"mission m {{\n  vehicles = [{', '.join(names)}]\n  horizon = {horizon} s\n"
            f"  step = {_pick(rng, ['0.1 s'], ['0.2 s', '0.05 s'])}\n"
            f"  spec go = eventually[0, {horizon}] ({names[0]}.pos.x >= {goal} m)\n"
            f"  spec low = always[0, {horizon}] ({names[0]}.pos.z <= 3 m)\n"
            f"  require go and low\n  minimize -robustness\n{replan}{sim}}}\n")
    args: list[str] = []
    if not sim or rng.random() < 0.3:
        for _ in range(rng.choice([0, 1, 1, 2])):
            who = rng.choice(["", f"{names[0]}@", "ghost@"])
            t = _pick(rng, ["1", "1.5"], ["-1", "1e9", "nan", "x"])
            args += ["--disturb", f"{who}{t}:{_pick(rng, ['0.6,0,0'], ['1e300,0,0', '1,2'])}"]
        if rng.random() < 0.15:
            args += ["--fail", f"{names[0]}@1", "--backup", names[-1]]
        if rng.random() < 0.1:
            args += ["--fail", f"{names[-1]}@2"]  # repeated: a usage error
    return src, args


def gen_team(rng: random.Random) -> tuple[str, list[str]]:
    """A payload team (paper B) with random capacities, 0–2 stations, 1–4 targets and a
    horizon from far too short to ample."""
    n = rng.choice([1, 2, 2, 3])
    cap = lambda: _pick(rng, ["1", "2", "3"], ["0", "1e19", "-1", "2.5", "1000"])  # noqa
    src = "".join(_point(f"uav{i + 1}", (-4 + 4 * i, -4, 0.5), cap()) for i in range(n))
    targets = rng.choice([1, 2, 3, 4])
    stations = rng.choice([0, 1, 1, 2])
    regions = [f"  target t{i} = box(center = ({-3 + 2 * i}, 2, 3), size = (1, 1, 1)) m"
               for i in range(targets)]
    regions += [f"  station s{i} = box(center = ({-4 + 8 * i}, -6, 1), size = (2, 2, 2)) m"
                for i in range(stations)]
    T = _pick(rng, ["30", "40"], ["3", "8", "0.5", "1e6"])
    team = ", ".join(f"uav{i + 1}" for i in range(n))
    src += "scenario {\n  workspace = box((-12, -8, 0), (12, 8, 8)) m\n" + "\n".join(regions)
    src += (f"\n}}\nmission team {{\n  vehicles = [{team}]\n  horizon = {T} s\n"
            f"  step = {_pick(rng, ['0.1 s', '0.2 s'], ['0.001 s'])}\n"
            f"  install_time = {_pick(rng, ['2 s'], ['0 s', '1e9 s'])}\n  refill_time = 3 s\n"
            "  forward_speed = 2 m/s\n"
            f"  threshold = {_pick(rng, ['0.1', '0'], ['-5', 'inf'])}\n"
            "  spec install = forall q in targets: eventually[0, T_END] (exists d in team: "
            "always[0, 2 s] (d.payload > 0.5 and d.pos in q))\n"
            "  spec refill = forall d in team: eventually[0, T_END] (exists s in stations: "
            "always[0, 3 s] (d.payload < 0.5 implies d.pos in s))\n"
            "  require install and refill\n  minimize forward_cost - robustness\n}\n")
    end = f"{max(float(T) - 3, 0):g} s" if T != "1e6" else "1e6 s"
    src = src.replace("T_END", end) + "\n"
    return src, []


def gen_resource(rng: random.Random) -> tuple[str, list[str]]:
    """What should be refused before allocation: a tiny step, nested quantifiers over many
    vehicles, a huge K, a long horizon — or accepted quickly when it fits."""
    choice = rng.choice(["step", "quant", "K", "horizon", "capacity"])
    n = rng.choice([2, 5, 20, 60]) if choice == "quant" else 1
    src = "".join(_point(f"v{i}", (i, 0, 1)) for i in range(n))
    step = {"step": rng.choice(["0.001 s", "0.0001 s", "0.0002 s"])}.get(choice, "0.1 s")
    horizon = {"horizon": rng.choice(["2000 s", "1999.9 s", "1e6 s"])}.get(choice, "2 s")
    depth = rng.choice([2, 3, 4]) if choice == "quant" else 1
    quant = "".join(f"forall q{i} in team: " for i in range(depth))
    body = " + ".join(f"dist(q{i}.pos, q{(i + 1) % depth}.pos)" for i in range(depth))
    K = rng.choice(["1e9", "2e6", "100"]) if choice == "K" else "100"
    src += ("scenario {\n  human op { pos = (0, 0, 0) m }\n"
            "  op.pos ~ normal((0, 0, 0) m, diag(1, 1, 0) m^2)\n}\n")
    src += (f"mission r {{\n  vehicles = [{', '.join(f'v{i}' for i in range(n))}]\n"
            f"  horizon = {horizon}\n  step = {step}\n"
            f"  spec s = {quant}always[0, 1] ({body} >= 0 m)\n"
            "  spec far = always[0, 1] (dist(v0.pos, op.pos) >= 0.5 m)\n"
            "  require s and far\n  minimize -robustness\n"
            f"  risk {{ K = {K}; case c {{ op.pos ~ normal((0, 0, 0) m, "
            "diag(1, 1, 0) m^2) } }\n}\n")
    return src, []


GENERATORS = {"simulate": gen_simulate, "team": gen_team, "resource": gen_resource}


def make(kind: str, seed: int) -> dict:
    rng = random.Random(f"{kind}:{seed}")
    stl, args = GENERATORS[kind](rng)
    command = {"simulate": "simulate", "team": "compile", "resource": "compile"}[kind]
    return {"kind": kind, "seed": seed, "stl": stl, "trace": None,
            "command": [command, *args, "--time-limit", f"{TIME_LIMIT[kind]:g}"]}


def run_command(case: dict) -> tuple[str, str]:
    """Run the case's command on its file with ``-o`` a directory of user files: exit 1
    with located diagnostics or 2 (usage) is ``diagnosed``, 0 or 3 ``accepted``, anything
    else ``internal``; a user file lost or changed is ``dataloss``."""
    from stlc import cli

    with tempfile.TemporaryDirectory(prefix="stlc-fuzz-") as d:
        path, out = os.path.join(d, "in.stl"), os.path.join(d, "out")
        with open(path, "w", encoding="utf-8") as fh:
            fh.write(case["stl"])
        os.mkdir(out)
        for name, text in USER_FILES.items():
            with open(os.path.join(out, name), "w", encoding="utf-8") as fh:
                fh.write(text)
        cmd, *rest = case["command"]
        err = io.StringIO()
        with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(err):
            try:
                rc = cli.main([cmd, path, *rest, "-o", out, "-q", "--max-memory",
                               MAX_MEMORY])
            except SystemExit as e:  # argparse: a usage error
                rc = e.code if isinstance(e.code, int) else 2
        for name, text in USER_FILES.items():
            p = os.path.join(out, name)
            if not os.path.isfile(p) or open(p, encoding="utf-8").read() != text:
                if not (name == "risk.json" and os.path.isfile(p)):  # an owned name
                    return "dataloss", f"{name} lost or changed by `stlc {cmd}`"
        stages = [n for n in os.listdir(out) if n.startswith(".stlc-stage-")]
        if stages:
            return "dataloss", f"stage folder left: {stages}"
        text = err.getvalue()
        if "MemoryError" in text:
            return "mem", text[-300:]
        if rc in (0, 3):
            return "accepted", ""
        if rc == 2:
            return "diagnosed", "usage"
        if rc == 1:
            first = text.splitlines()[0] if text else ""
            if not first.startswith(path + ":"):
                return "unlocated", first[:300]
            return "diagnosed", first.split("error[")[1][:6] if "error[" in first else ""
        return "internal", f"exit {rc}: {text[-500:]}"
