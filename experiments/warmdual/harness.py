"""In-process: warm-start instance pairs primal-only vs primal-dual; print iterations."""
import sys, json, math, time, numpy as np
from stlc.sweep import task
from stlc.backends import library

SRC = open("specs/handover.stl").read()
PATH = "specs/handover.stl"
MISSION = "handover_left_tb"
base = sys.argv[1] if len(sys.argv) > 1 and __name__ == "__main__" else "/tmp/wd/base24"

def inst(i):
    a = -30 + 12 * (i // 4); x = -0.2 + (0.4 / 3) * (i % 4)
    return {"operator.att.z": math.radians(a), "operator.pos.x": x}, \
        [("operator.att.z", f"{a!r} deg"), ("operator.pos.x", f"{x!r} m")]

def load(i):
    d = np.genfromtxt(f"{base}/plans/{i}.csv", delimiter=",", names=True, deletechars="")
    return {k: np.asarray(d[k], float) for k in d.dtype.names if k != "t"}

def run(i, seeds):
    vals, items = inst(i)
    r = task._plan(SRC, PATH, MISSION, items, vals, True, seeds)
    return r

if __name__ == "__main__":
    pairs = [(9, 10), (9, 5), (10, 14), (5, 6), (13, 17), (14, 15), (6, 7), (18, 19)]
    if len(sys.argv) > 2:
        pairs = json.loads(sys.argv[2])
    out = []
    for a, b in pairs:
        va, _ = inst(a)
        ra = run(a, [(va, load(a), "base")])
        da = ra["duals"]
        rs = run(a, [(va, ra["channels"], "self", da)])
        rp = run(b, [(va, ra["channels"], "A")])
        rd = run(b, [(va, ra["channels"], "A", da)])
        line = (f"A={a} ({ra['iterations']} it) self-dual {rs['iterations']} it {rs['dual']} "
                f"Δρ {rs['robustness']-ra['robustness']:+.2e} | B={b}: primal {rp['iterations']} it "
                f"ρ {rp['robustness']:.4f} {rp['solve_s']:.1f}s; dual {rd['iterations']} it {rd['dual']} ρ {rd['robustness']:.4f} {rd['solve_s']:.1f}s")
        print(line, flush=True)
        out.append((a, b, rp["iterations"], rd["iterations"]))
    print("primal sum", sum(o[2] for o in out), "dual sum", sum(o[3] for o in out))
