"""stlc — a compiler for a Signal Temporal Logic mission language.

The Python API (``stlc.api``, loaded on first use so that ``import stlc`` stays cheap):
``stlc.load(path)``, ``stlc.loads(text)``, ``stlc.compile(program, mission)``,
``stlc.monitor(program, trace)``, ``stlc.simulate``, ``stlc.sweep``, ``stlc.risk``,
``stlc.fly`` and ``stlc.StlError`` (see docs/python.md).
"""

__version__ = "0.1.0"

_API = ("load", "loads", "compile", "monitor", "StlError", "Plan", "with_constants",
        "simulate", "sweep", "risk", "fly", "Simulation", "Track", "SweepTable")
__all__ = list(_API)


def __getattr__(name: str):
    if name in _API:
        from stlc import api

        return getattr(api, name)
    raise AttributeError(f"module 'stlc' has no attribute {name!r}")
