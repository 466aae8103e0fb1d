"""Long missions planned on a coarse grid of knots: the `nlp` chain (MILP seed, full NLP) on
the knots, the plan then simulated and verified on the mission grid."""
