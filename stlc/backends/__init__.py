"""Solver backends: the CasADi/IPOPT NLP and the cvxpy/HiGHS MILP seed."""
