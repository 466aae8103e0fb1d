"""Semantics layer: what a parsed mission means.

``check`` (the checker) turns a syntax tree into the checked ``model.Program``; its formulas
are ``ir`` nodes, put in negation normal form by ``nnf``; ``timegrid`` is the sampling grid
every later layer evaluates on.
"""
