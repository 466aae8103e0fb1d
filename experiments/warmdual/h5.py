import sys, json, numpy as np, os
sys.path.insert(0, "/tmp/wd")
from harness import inst, load, run
from stlc.backends import library, nlp_cache, casadi_nlp
a, b, mode = int(sys.argv[1]), int(sys.argv[2]), sys.argv[3]
va, _ = inst(a)
from stlc.backends import schedule, choices
cap = {}
orig = schedule._solve
def wrapped(prob, w0, p, *a_, **k):
    out = orig(prob, w0, p, *a_, **k)
    cap.setdefault("cv", {k_: np.array(v) for k_, v in prob.inv.choice_values.items()})
    return out
schedule._solve = wrapped
ra = run(a, [(va, load(a), "base")])
if os.environ.get("KEEP"):
    choices.choose = lambda *a_, **k: {k_: np.array(v) for k_, v in cap["cv"].items()}
print("=====", flush=True)
prob, inv = next(iter(nlp_cache._CACHE.values()))
import casadi as ca
nlp, o = prob.nlp
o = {**o, "ipopt.print_level": 5, "ipopt.sb": "yes", "ipopt.print_frequency_iter": 1}
if mode == "primal":
    prob.solver = ca.nlpsol("v", "ipopt", nlp, o)
    r = run(b, [(va, ra["channels"], "A")])
else:
    library.WARM_START.update(json.loads(mode))
    prob.nlp = (nlp, o); prob.warm = None
    r = run(b, [(va, ra["channels"], "A", ra["duals"])])
print(r["iterations"], r["dual"])
