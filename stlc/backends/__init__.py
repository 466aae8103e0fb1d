"""Solver backends behind one interface (``stlc.backends.base.Backend``).

``stlc.backends.registry`` is the name → backend table holding every backend;
``stlc.backends.strategy`` chooses a chain of them for a problem by their capabilities (or
the one a user forces with ``--backend NAME`` or a mission's ``backend = NAME``).  The
backends themselves live in one folder per family: ``nlp`` (CasADi/IPOPT), ``milp`` (exact
STL→MILP and the MILP seed, HiGHS), ``team`` (task assignment and refinement) and
``replan`` (the replanning planners run by the simulation on each event's problem).
"""
