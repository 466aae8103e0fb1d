"""One adapter per solver library: ``highs`` (highspy) and ``ipopt`` (CasADi's ``nlpsol``).

Each adapter owns its library's options, the map from the library's status codes to the
shared ``SolverStatus`` and its result type; the backends build models and read results
through them, never through the library itself.
"""
