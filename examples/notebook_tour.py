"""stlc from Python, as in a Jupyter notebook: compile, look at the plan, simulate a push,
sweep a start position, assess nothing by hand — every number below comes from the exact
monitor.  Run it as a script (``python examples/notebook_tour.py``) or paste the cells into
a notebook; ``tests/test_notebook.py`` runs it in the test suite.

Each ``# %%`` starts a cell.  In Jupyter the last expression of a cell is displayed: a
``Plan`` shows its verdict and specs (``_repr_html_``), a figure draws itself.
"""

# %% load and compile (the stlpy ReachAvoid benchmark: a point mass, one obstacle, one goal)
from pathlib import Path

import stlc

SPEC = Path(__file__).resolve().parent.parent / "specs" / "benchmarks" / "reach_avoid.stl"
program = stlc.load(SPEC)
plan = stlc.compile(program, "reach_avoid", time_limit=60)
print(plan)  # <Plan reach_avoid: satisfied (exact ρ = … ≥ κ = 0.1)>

# %% the arrays of one vehicle, and the whole plan as a table
robot = plan.vehicle("robot")
print("positions", robot.pos.shape, "from", robot.pos[0], "to", robot.pos[-1])
table = plan.to_dataframe()  # pandas; plan.trajectory is the same as a dict of arrays
print(table[["t", "robot.pos.x", "robot.pos.y"]].tail(3))

# %% the report's figures, and the plan as Jupyter shows it
scene = plan.plot()  # the 3-D scene; plan.plot("speed"), plan.figures() for all
speed = plan.plot("speed")
html = plan._repr_html_()  # what a notebook cell displays for `plan`

# %% fly the plan through a push of 1.5 m at t = 4 s (event-triggered replanning)
flight = stlc.simulate(program, "reach_avoid", disturb=[("robot", 4.0, (0.0, 1.5, 0.0))])
replans = [e for e in flight.events if e["triggered"]]
print(f"{len(replans)} replan(s); exact ρ of what was flown: {flight.robustness}")

# %% sweep the start position (values in the unit given: centimetres stay centimetres)
rows = stlc.sweep(program, "reach_avoid", vary={"robot.start.pos.x": ("100 cm", "150 cm", 2)})
print(rows)

RESULTS = {"plan": plan, "robot": robot, "table": table, "scene": scene, "speed": speed,
           "html": html, "flight": flight, "rows": rows}
