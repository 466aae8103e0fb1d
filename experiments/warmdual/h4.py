"""Pairs A→B: B warm from A's plan (rechosen choices), primal vs dual with option sets."""
import sys, math, json, numpy as np
sys.path.insert(0, "/tmp/wd")
from harness import inst, load, run
from stlc.backends import library, nlp_cache
pairs = json.loads(sys.argv[1])
sets = json.loads(sys.argv[2])
tot = np.zeros(1 + len(sets))
for a, b in pairs:
    va, _ = inst(a)
    ra = run(a, [(va, load(a), "base")])
    da = ra["duals"]
    res = [run(b, [(va, ra["channels"], "A")])["iterations"]]
    for o in sets:
        library.WARM_START.clear(); library.WARM_START.update({"ipopt.warm_start_init_point": "yes", **o})
        for prob, inv in nlp_cache._CACHE.values():
            prob.warm = None
        r = run(b, [(va, ra["channels"], "A", da)])
        res.append(f"{r['iterations']}{'' if r['dual']=='kept' else '*'}")
    tot += [int(str(x).rstrip('*')) for x in res]
    print(f"A={a} B={b}: primal {res[0]} | dual sets {res[1:]}", flush=True)
print("sums:", tot)
