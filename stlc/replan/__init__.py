"""Online replanning of a compiled plan (``stlc simulate``).

* ``disturb``  — paper A §4.4: closed-loop simulation of a single-vehicle plan under
  displacement / velocity disturbances, event-triggered replanning to the next waypoint
  with the kept specs (``replan { keep = [...] }``), one NLP built once and reused;
* ``takeover`` — paper B §IV-C: a backup drone takes over the pending targets of a failed
  drone on [t_fail + T_rep, T_N], the other drones' plans fixed;
* ``result``   — what a simulation returns (``replan.json``, ``executed.csv``, the report).
"""
