"""stlc — a compiler for a Signal Temporal Logic mission language."""

import os as _os

# IPOPT's sparse solver (MUMPS) and BLAS would start one thread per core.  On small KKT
# systems (~10k rows) the threads only contend: on the 2-core reference machine a solve
# spent 4x more wall time than CPU time in the linear solver.  One thread each, unless the
# user set these already (measured in README "Performance").
for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    _os.environ.setdefault(_var, "1")

__version__ = "0.1.0"
