"""Pairs A→B: B warm from A's solved plan: re-chosen vs A's choices, primal vs dual."""
import sys, math, json, numpy as np
sys.path.insert(0, "/tmp/wd")
from harness import inst, load, run
from stlc.backends import schedule, choices
cap = {}
orig = schedule._solve
def wrapped(prob, w0, p, kappa, label, limit, patience=10**9, most_robust=True, duals=None):
    out = orig(prob, w0, p, kappa, label, limit, patience, most_robust, duals)
    cap.update(cv={k: np.array(v) for k, v in prob.inv.choice_values.items()}, lam=p[0])
    return out
schedule._solve = wrapped
orig_choose = choices.choose
forced = {}
def choose(*a, **k):
    if forced.get("cv") is not None:
        return {k_: np.array(v) for k_, v in forced["cv"].items()}
    return orig_choose(*a, **k)
choices.choose = choose
pairs = json.loads(sys.argv[1])
tot = np.zeros(4)
for a, b in pairs:
    va, _ = inst(a)
    forced["cv"] = None
    ra = run(a, [(va, load(a), "base")])
    cva, da = cap["cv"], ra["duals"]
    res = []
    for keep, dual in ((False, False), (True, False), (True, True), (False, True)):
        forced["cv"] = cva if keep else None
        r = run(b, [(va, ra["channels"], "A", da if dual else None)])
        res.append((r["iterations"], r["dual"], r["robustness"], r["solve_s"]))
    forced["cv"] = None
    tot += [x[0] for x in res]
    print(f"A={a} B={b}: rechosen primal {res[0]}, A-choices primal {res[1]}, A-choices dual {res[2]}, rechosen dual {res[3]}", flush=True)
print("sums rechosen-primal, Achoice-primal, Achoice-dual, rechosen-dual:", tot)
