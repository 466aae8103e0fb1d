"""Planning layer: the planning problem between a checked mission and the backends, the
backend chain that solves it, and the verification of its plans by the exact monitor."""
