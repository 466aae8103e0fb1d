"""The CasADi/IPOPT family: the smooth-robustness trajectory NLP, its lowering, schedule,
kinematic seed, derivatives and caches."""
