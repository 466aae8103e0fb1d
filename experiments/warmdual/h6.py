"""Dual residual ∇f + Jᵀλ_g + λ_x at B's start with A's multipliers (A's choices), by block."""
import sys, json, numpy as np, casadi as ca
sys.path.insert(0, "/tmp/wd")
from harness import inst, load, run
from stlc.backends import schedule, choices, nlp_cache, library
from stlc.backends.casadi_nlp import fill_aux
a, b = int(sys.argv[1]), int(sys.argv[2])
cap = {}
orig = schedule._solve
def wrapped(prob, w0, p, *a_, **k):
    out = orig(prob, w0, p, *a_, **k)
    pf = list(p) + schedule.choice_params(prob.inv) + schedule.param_values(prob.inv)
    cap.update(x=out[0], duals=out[1]["duals"], p=pf, lam=p, cv={k_: np.array(v) for k_, v in prob.inv.choice_values.items()})
    return out
schedule._solve = wrapped
va, _ = inst(a)
ra = run(a, [(va, load(a), "base")])
prob, inv = next(iter(nlp_cache._CACHE.values()))
nlp, _ = prob.nlp
lg_, lx_ = ca.MX.sym("lg", prob.n_cons), ca.MX.sym("lx", prob.n_vars)
L = nlp["f"] + ca.dot(lg_, nlp["g"])
res = ca.Function("r", [nlp["x"], nlp["p"], lg_, lx_], [ca.gradient(L, nlp["x"]) + lx_])
xa, (lga, lxa), pa = cap["x"], cap["duals"], cap["p"]
def blocks(r):
    out = {}
    for Lh in inv.layouts:
        out["x"] = np.abs(r[Lh.x_slice]).max(); out["u"] = np.abs(r[Lh.u_slice]).max()
    out["aux"] = np.abs(r[inv.aux_slice]).max()
    return {k: f"{v:.2e}" for k, v in out.items()}
print("A at its solution:", blocks(np.asarray(res(xa, pa, lga, lxa)).ravel()))
# B's start: A's plan, B's params, A's choices, aux refilled
vb, items = inst(b)
from stlc.frontend.syntax import parse_file
from stlc.semantics import overrides
from stlc.pipeline import select_missions
from stlc.planning.problem import from_mission
tree = parse_file("specs/handover.stl")
program, vals = overrides.checked(tree, items)
m = select_missions("specs/handover.stl", program, "handover_left_tb")[0]
problem = from_mission(program, m, values=vals)
nlp_cache.bind(prob, inv, problem)
inv.choice_values = cap["cv"]
pb = list(cap["lam"]) + schedule.choice_params(inv) + schedule.param_values(inv)
xb = fill_aux(prob, inv, xa, problem.params, cap["lam"][0])
r = np.asarray(res(xb, pb, lga, lxa)).ravel()
print("B start, A's duals:", blocks(r))
top = np.argsort(-np.abs(r))[:10]
print("top residual entries:", [(int(i), "aux" if i >= inv.aux_slice.start else "traj", f"{r[i]:.2e}") for i in top])
print("aux change |xb-xa| max on aux:", np.abs(xb[inv.aux_slice] - xa[inv.aux_slice]).max(), "params A", pa[-6:], "B", pb[-6:])
