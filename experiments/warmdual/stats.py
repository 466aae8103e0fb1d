import csv, json, sys, numpy as np
for d in sys.argv[1:]:
    rows = list(csv.DictReader(open(f"{d}/sweep.csv")))
    it = np.array([int(r["iterations"]) for r in rows]); rho = np.array([float(r["robustness"]) for r in rows])
    js = json.load(open(f"{d}/sweep.json"))
    st = {}
    for r in rows: st[r["status"]] = st.get(r["status"], 0) + 1
    print(f"{d}: n={len(rows)} {st} it median {np.median(it)} range {it.min()}-{it.max()} sum {it.sum()} | rho min {rho.min():.4f} median {np.median(rho):.4f} | wall {js['wall_s']:.1f}s ({js['per_instance_s']:.2f}/inst) builds {js['nlp_builds']} preempted {js['preempted']} warm {js['warm_started']} pred {js['warm_from_prediction']} dual kept {js.get('dual_warm_started')} fell back {js.get('dual_fell_back')}")
