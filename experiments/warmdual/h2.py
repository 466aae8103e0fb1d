"""Re-solve instance A from its own exact solution: primal / dual with options."""
import sys, math, json, numpy as np
sys.path.insert(0, "/tmp/wd")
from harness import inst, load, run, SRC, PATH, MISSION
from stlc.backends import schedule, nlp_cache, library
cap = {}
orig = schedule._solve
def wrapped(prob, w0, p, kappa, label, limit, patience=10**9, most_robust=True, duals=None):
    out = orig(prob, w0, p, kappa, label, limit, patience, most_robust, duals)
    cap.update(prob=prob, w0=w0, p=p, x=out[0], stats=out[1], label=label, duals_in=duals,
               cv={k: np.array(v) for k, v in prob.inv.choice_values.items()})
    return out
schedule._solve = wrapped
a = int(sys.argv[1]) if len(sys.argv) > 1 else 9
va, _ = inst(a)
ra = run(a, [(va, load(a), "base")])
prob = cap["prob"]; x = cap["x"]; lg, lx = cap["stats"]["duals"]
print("A iterations", ra["iterations"], cap["stats"]["return_status"], "best_iterate" in cap["stats"])
pfull = list(cap["p"]) + schedule.choice_params(prob.inv) + schedule.param_values(prob.inv)
# NB choice params were reset after the solve; recompute them as _energy did
from stlc.backends import choices
from stlc.backends.casadi_nlp import trajectory_channels
inv = prob.inv
def solve_with(opts, x0, lam=None, keep=False):
    import casadi as ca
    nlp, o = prob.nlp
    s = ca.nlpsol("t", "ipopt", nlp, {**o, **opts})
    if keep:
        inv.choice_values = cap["cv"]
    elif inv.choice_nodes:
        inv.choice_values = choices.choose(inv.choice_nodes, trajectory_channels(x0, inv),
                                           inv.params, inv.grid.n, inv.planned, inv.grid.dt)
    p = list(cap["p"]) + schedule.choice_params(inv) + schedule.param_values(inv)
    from stlc.backends.casadi_nlp import fill_aux
    x0 = fill_aux(prob, inv, x0, inv.params, cap["p"][0])
    prob.progress.reset(); prob.progress.p = np.array(p)
    kw = dict(x0=x0, p=p, lbx=prob.lbx, ubx=prob.ubx, lbg=prob.lbg, ubg=prob.ubg)
    if lam is not None:
        kw.update(lam_g0=lam[0], lam_x0=lam[1])
    r = s(**kw)
    st = s.stats()
    return st["iter_count"], st["return_status"], float(r["f"])
W = {"ipopt.warm_start_init_point": "yes"}
tiny = {k: 1e-9 for k in ["ipopt.warm_start_bound_push", "ipopt.warm_start_bound_frac",
        "ipopt.warm_start_slack_bound_push", "ipopt.warm_start_slack_bound_frac",
        "ipopt.warm_start_mult_bound_push"]}
print("f at x:", float(cap["stats"].get("iterations", {}).get("obj", [0])[-1]) if cap["stats"].get("iterations") else None)
new = choices.choose(inv.choice_nodes, trajectory_channels(x, inv), inv.params, inv.grid.n, inv.planned, inv.grid.dt)
for k in new:
    d = np.flatnonzero(np.asarray(new[k]) != np.asarray(cap["cv"][k]))
    if len(d): print("choice", k, "differs at", d[:20])
print("choices differ", sum(int(np.any(np.asarray(new[k]) != np.asarray(cap["cv"][k]))) for k in new), "of", len(new))
print("primal, its choices:", solve_with({}, x, keep=True))
print("dual tiny, its choices:", solve_with({**W, **tiny}, x, (lg, lx), keep=True))
print("dual tiny mu1e-6, its choices:", solve_with({**W, **tiny, "ipopt.mu_init": 1e-6}, x, (lg, lx), keep=True))
print("primal, new choices:", solve_with({}, x))
print("dual tiny, new choices:", solve_with({**W, **tiny}, x, (lg, lx)))
