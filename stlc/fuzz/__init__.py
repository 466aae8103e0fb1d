"""The project's own fuzzer: hostile `.stl` files and traces, classified by outcome.

``python -m stlc.fuzz [-n 10000] [--seed 0] [--jobs 1] [--timeout 10] [--save DIR]``
(the runner is ``stlc.fuzz.runner``; this module makes the inputs).

Inputs come in five kinds, each made from a seed (so every failure can be replayed):

* ``grammar``  — random files over the language: signals, specs over random formulas
  (temporal windows with odd bounds, arithmetic, calls, quantities, named references),
  fields, blocks and missions, with random line ends and comments;
* ``mutation`` — every shipped spec (``specs/``, ``tests/missions/``, ``tests/diagnostics/``)
  with lines deleted, duplicated or swapped, tokens and odd bytes (CR, FF, VT, U+2028, NUL,
  invalid UTF-8, a BOM, ``#`` runs) inserted, numbers replaced by extreme ones;
* ``deep``     — deep bracket / ``not`` nesting, long chains of named specs and specs that
  use the previous one twice (exponential as a tree), half of them monitored on a trace;
* ``trace``    — ``stlc monitor`` on a generated file with a damaged trace (tiny, huge,
  non-uniform or non-finite times and values, missing columns, odd line ends);
* ``example``  — ``stlc monitor`` of ``specs/monitor_example.stl`` on a damaged copy of its
  trace;
* ``simulate``, ``team``, ``resource`` — whole commands (``stlc.fuzz.missions``): simulate
  with events from the file and the command line and ``replan`` blocks, team missions
  (capacities, stations, horizons, targets), and what must be refused before allocation;
  each writes into a directory of user files, which must survive (else ``dataloss``).

Each input runs in a worker process with a time limit and is classified as *diagnosed*
(exit 1, every diagnostic located at a line of the file), *accepted* (exit 0; for a
monitor, ``--json`` output must parse as strict JSON), *internal* (any other exception),
*hang* (over the time limit; a whole command runs with ``--time-limit`` a third of it, so
its own limit was not kept), *mem* (over the memory cap), *dataloss*, *unlocated* (a
diagnostic at line 0 or past the end of the file), *badjson* or *wrong* (an answer
known to be wrong: ``stlc.fuzz.numerics`` — large coordinates, boundary optima, written
files monitored again, ``fmt`` idempotence, the language server's analysis).  The report is a table of kind × class; failing inputs are saved.
"""

from __future__ import annotations

import random
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent.parent
SEED_DIRS = ("specs", "tests/missions", "tests/diagnostics")
KINDS = ("grammar", "mutation", "deep", "trace", "example", "simulate", "team", "resource",
         "coords", "boundary", "roundtrip", "fmt", "lsp")  # the last five: stlc.fuzz.numerics
CLASSES = ("diagnosed", "accepted", "internal", "hang", "mem", "dataloss", "unlocated",
           "badjson", "wrong")
BAD = ("internal", "hang", "mem", "dataloss", "unlocated", "badjson", "wrong")

SIGNALS = ("x", "y", "z")
ODD = ["\r", "\r\n", "\f", "\v", "\u2028", "\x85", "\x00", "\t", "\ufeff", "\u00b5", "é",
       "#" * 40, "# # # # # # # #", "\\", "\"", "'", "$", "{", "}", "(", ")", "[", "]", ";",
       ",", "=", "~", "..", " and ", " or ", " implies ", " until ", "not ", "next "]
NUMBERS = ["0", "1", "-1", "1e308", "1e309", "1e-310", "2.5e-324", "inf", "(inf - inf)",
           "(1e308 * 10)", "nan", "0.0", "99999999999999999999", ".5", "1e", "3 kg", "7 kg",
           "15000 m/s", "0 s", "-0.1 s", "1e300 s", "(1/0)", "sqrt(-1)", "log(0)"]
UNITS = ["", "", " s", " m", " m/s", " kg", " deg", " Hz", " N", " bogus", " m/s^2"]


# ---------------------------------------------------------------- generators


def _num(rng: random.Random) -> str:
    if rng.random() < 0.03:
        return rng.choice(NUMBERS)
    return rng.choice(["0", "1", "2", "0.5", "0.1", "3", "10", str(round(rng.uniform(-5, 5), 2))])


def _time(rng: random.Random) -> str:
    if rng.random() < 0.9:
        return rng.choice(["0", "0.1", "0.5", "1", "2"]) + rng.choice(["", " s"])
    return rng.choice(["0", "0.1", "0.5", "1", "2", "5", "0.05", "inf", "1e-310", "1e300", "-1",
                       "T", "0.3"]) + rng.choice(["", "", " s", " m"])


def gen_expr(rng: random.Random, depth: int = 0) -> str:
    r = rng.random()
    if depth > 3 or r < 0.3:
        unit = rng.choice(UNITS) if rng.random() < 0.1 else ""
        return rng.choice([*SIGNALS, *SIGNALS, _num(rng), _num(rng) + unit, "w"])
    if r < 0.6:
        return f"{gen_expr(rng, depth + 1)} {rng.choice('+-*/^')} {gen_expr(rng, depth + 1)}"
    if r < 0.8:
        fn = rng.choice(["abs", "sqrt", "sin", "exp", "log", "min", "max", "atan2", "angdiff",
                         "norm", "dist", "nope"] if rng.random() < 0.2 else
                        ["abs", "sqrt", "sin", "exp", "log"])
        k = 1 if fn in ("abs", "sqrt", "sin", "exp", "log") and rng.random() < 0.9 else \
            rng.randint(0, 3)
        args = ", ".join(gen_expr(rng, depth + 1) for _ in range(k))
        return f"{fn}({args})"
    return f"({gen_expr(rng, depth + 1)})"


def gen_formula(rng: random.Random, names: list[str], depth: int = 0) -> str:
    r = rng.random()
    if depth > 4 or r < 0.25:
        if names and rng.random() < 0.3:
            return rng.choice(names)
        cmp = rng.choice(["<", "<=", ">", ">="])
        return rng.choice([f"{gen_expr(rng)} {cmp} {gen_expr(rng)}", "true", "false",
                           f"{rng.choice(SIGNALS)} in [{_num(rng)}, {_num(rng)}]"])
    iv = f"[{_time(rng)}, {_time(rng)}]" if rng.random() < 0.9 else ""
    form = rng.choice(["always{iv} ({a})", "eventually{iv} ({a})", "({a}) until{iv} ({b})",
                       "not ({a})", "next ({a})", "({a}) and ({b})", "({a}) or ({b})",
                       "({a}) implies ({b})", "{a}\n  and {b}"])
    a = gen_formula(rng, names, depth + 1)
    b = gen_formula(rng, names, depth + 1) if "{b}" in form else ""
    return form.format(iv=iv, a=a, b=b)


def gen_mission(rng: random.Random, specs: list[str]) -> str:
    h, dt = rng.choice([("3 s", "0.1 s"), ("1 s", "1 s"), ("0 s", "0.1 s"), ("1 s", "0 s"),
                        ("2 s", "0.3 s"), ("inf", "0.1 s"), ("1e-310 s", "1e-310 s")])
    req = rng.choice(specs) if specs else "true"
    return (f"vehicle p : point_mass {{\n  vel_max = (1, 1, 1) m/s\n  acc_max = (2, 2, 2) m/s^2"
            f"\n  start {{ pos = (0, 0, 0) m }}\n}}\nmission m {{\n  vehicles = [p]\n"
            f"  horizon = {h}\n  step = {dt}\n  seed = {rng.choice(['7', '7 kg'])}\n"
            f"  require {req}\n}}\n")


def gen_source(rng: random.Random) -> str:
    """A random `.stl` file: mostly well-formed, with a sprinkling of mistakes."""
    out, names = [f"signal {', '.join(SIGNALS)}"], []
    if rng.random() < 0.3:
        out.append(f"const T = {_time(rng)}")
    if rng.random() < 0.2:
        out.append(f"const w = {_num(rng)}")
    for i in range(rng.randint(1, 6)):
        name = f"s{i}"
        out.append(f"spec {name} = {gen_formula(rng, names)}")
        if rng.random() < 0.2:
            out.append(rng.choice(["#" * rng.randint(1, 40), "# # # # #", "", "   "]))
        names.append(name)
    if rng.random() < 0.15:
        out.append(gen_mission(rng, names))
    text = "\n".join(out) + "\n"
    return text.replace("\n", rng.choice(["\n", "\r\n", "\r"])) if rng.random() < 0.1 else text


def mutate(text: str, rng: random.Random) -> str | bytes:
    lines = text.split("\n")
    for _ in range(rng.randint(1, 4)):
        op, i = rng.randrange(8), rng.randrange(len(lines))
        if op == 0 and len(lines) > 1:
            del lines[i]
        elif op == 1:
            lines.insert(i, lines[rng.randrange(len(lines))])
        elif op == 2:
            j = rng.randrange(len(lines))
            lines[i], lines[j] = lines[j], lines[i]
        elif op in (3, 4):
            s = lines[i]
            k = rng.randint(0, len(s))
            lines[i] = s[:k] + rng.choice(ODD + NUMBERS) + s[k:]
        elif op == 5:
            s = lines[i]
            k = rng.randint(0, len(s))
            lines[i] = s[:k] + s[k + rng.randint(1, 5):]
        elif op == 6:
            toks = lines[i].split(" ")
            toks = [rng.choice(NUMBERS) if t[:1].isdigit() and rng.random() < 0.5 else t
                    for t in toks]
            lines[i] = " ".join(toks)
        else:
            lines.insert(i, "#" * rng.randint(20, 60))
    out = "\n".join(lines)
    if rng.random() < 0.1:
        out = out.replace("\n", rng.choice(["\r", "\r\n", "\f\n", "\u2028"]))
    if rng.random() < 0.05:
        data = out.encode("utf-8")
        k = rng.randint(0, len(data))
        return data[:k] + rng.choice([b"\xff", b"\xc3", b"\x00", b"\xed\xa0\x80"]) + data[k:]
    return out


def gen_deep(rng: random.Random) -> str:
    n = rng.choice([50, 99, 101, 150, 500, 1000, 3000])
    k = rng.randrange(7)
    if k == 0:
        return f"signal x\nspec s = {'(' * n}x > 0{')' * n}\n"
    if k == 1:
        return f"signal x\nspec s = {'not ' * n}(x > 0)\n"
    if k == 2:
        return f"signal x\nspec s = {'always[0, 1] ' * n}(x > 0)\n"
    if k == 3:
        return "signal x\nspec s = x > 0" + " + 1" * n + "\n"
    lines = ["signal x", "spec s0 = always[0, 1] (x > 0)"]
    if k == 4:  # a chain of named specs
        lines += [f"spec s{i} = s{i - 1} and x > {-i}" for i in range(1, n)]
    elif k == 5:  # a chain of temporal operators over named specs
        lines += [f"spec s{i} = eventually[0, 0.1] s{i - 1}" for i in range(1, n)]
    else:  # each spec uses the previous one twice: a DAG of exponential tree size
        lines += [f"spec s{i} = s{i - 1} and not s{i - 1}" for i in range(1, min(n, 200))]
    return "\n".join(lines) + "\n"


def gen_trace(rng: random.Random, names: tuple[str, ...] = SIGNALS) -> str:
    n = rng.choice([1, 2, 3, 10, 50])
    dt = rng.choice([0.1, 1.0, 1e-310, 1e-300, 1e300, 1e-9, 0.3])
    cols = list(names)
    if rng.random() < 0.2 and cols:
        cols.pop(rng.randrange(len(cols)))
    rows = [",".join(["t", *cols])]
    for k in range(n):
        vals = [rng.choice(["1", "0", "-1e308", "1e308", "nan", "inf", "", "1e-320", "x"])
                if rng.random() < 0.02 else f"{rng.uniform(-3, 3):.6g}" for _ in cols]
        t = k * dt if rng.random() > 0.03 else rng.choice([0, -1, k * dt * 2])
        rows.append(",".join([f"{t:.17g}", *vals]))
    if rng.random() < 0.1 and len(rows) > 2:
        del rows[rng.randrange(1, len(rows))]
    return rng.choice(["\n", "\r\n", "\r"] if rng.random() < 0.15 else ["\n"]).join(rows) + "\n"


def damage_trace(text: str, rng: random.Random) -> str:
    lines = text.split("\n")
    for _ in range(rng.randint(1, 3)):
        i = rng.randrange(len(lines))
        s = lines[i]
        k = rng.randint(0, len(s))
        lines[i] = s[:k] + rng.choice([",", "e", "1e-310", "nan", "inf", "\r", "\x00", "",
                                       "9" * 30, "-", " ", '"']) + s[k + rng.randint(0, 3):]
    return "\n".join(lines)


def seed_files() -> list[str]:
    files = []
    for d in SEED_DIRS:
        files += sorted(str(p) for p in (ROOT / d).glob("*.stl"))
    return files


def make_input(kind: str, seed: int, seeds: list[str]) -> dict:
    """The input of one case: {'kind', 'seed', 'stl': str|bytes, 'trace': str|None}."""
    if kind in ("simulate", "team", "resource"):
        from stlc.fuzz import missions

        return missions.make(kind, seed)
    from stlc.fuzz import numerics

    if kind in numerics.KINDS:  # inputs with a known right answer (``wrong`` otherwise)
        return numerics.make(kind, seed, seeds)
    rng = random.Random(f"{kind}:{seed}")
    trace = None
    if kind == "grammar":
        stl = gen_source(rng)
    elif kind == "mutation" and seeds:
        stl = mutate(Path(seeds[seed % len(seeds)]).read_text(encoding="utf-8"), rng)
    elif kind == "deep":  # half of them also monitored (IR walks, memo tables)
        stl = gen_deep(rng)
        trace = gen_trace(random.Random(seed), ("x",)) if seed % 2 else None
    elif kind == "trace":
        stl = gen_source(rng) if rng.random() < 0.5 else "signal x, y, z\nspec a = always[0, " \
            f"{_time(rng)}] (x <= {_num(rng)})\nspec b = not a\n"
        trace = gen_trace(rng)
    elif (ROOT / "specs" / "monitor_example.csv").is_file():
        stl = (ROOT / "specs" / "monitor_example.stl").read_text(encoding="utf-8")
        trace = damage_trace((ROOT / "specs" / "monitor_example.csv").read_text(), rng)
    else:  # an installed package without the repository's files
        stl, trace = gen_source(rng), damage_trace(gen_trace(rng), rng)
    return {"kind": kind, "seed": seed, "stl": stl, "trace": trace}
