"""The HiGHS MILP family: the exact STL→MILP backend and its coarse start, the MILP seed of
the NLP chain, and the proof and explanation of infeasibility."""
