"""stlc — a compiler for a Signal Temporal Logic mission language.

The Python API (``stlc.api``, loaded on first use so that ``import stlc`` stays cheap):
``stlc.load(path)``, ``stlc.loads(text)``, ``stlc.compile(program, mission)``,
``stlc.monitor(program, trace)``, ``stlc.simulate``, ``stlc.sweep``, ``stlc.risk`` and
``stlc.StlError`` (see docs/python.md).
"""

import os as _os

# IPOPT's sparse solver (MUMPS) and BLAS would start one thread per core.  On small KKT
# systems (~10k rows) the threads only contend: on the 2-core reference machine a solve
# spent 4x more wall time than CPU time in the linear solver.  One thread each, unless the
# user set these already.
for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    _os.environ.setdefault(_var, "1")

__version__ = "0.1.0"

_API = ("load", "loads", "compile", "monitor", "StlError", "Plan", "with_constants",
        "simulate", "sweep", "risk", "Simulation", "Track", "SweepTable")
__all__ = list(_API)


def __getattr__(name: str):
    if name in _API:
        from stlc import api

        return getattr(api, name)
    raise AttributeError(f"module 'stlc' has no attribute {name!r}")
