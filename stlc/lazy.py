"""Heavy dependencies imported on first use (``importlib.util.LazyLoader``).

``stlc.load`` parses and checks a file; the vehicle models it reads declare CasADi
signatures but run CasADi only when a plan is built.  ``lazy("casadi")`` puts a module in
``sys.modules`` whose body runs on its first attribute access, so checking, monitoring and
formatting never pay CasADi's import (~0.15 s), and a later ``import casadi`` anywhere gets
the same module object."""

from __future__ import annotations

import importlib.util
import sys
from types import ModuleType


def lazy(name: str) -> ModuleType:
    """The module ``name``, loaded on first attribute access (at once if already loaded)."""
    mod = sys.modules.get(name)
    if mod is not None:
        return mod
    spec = importlib.util.find_spec(name)
    if spec is None or spec.loader is None:  # not installed: fail as a plain import would
        raise ModuleNotFoundError(f"No module named {name!r}", name=name)
    loader = importlib.util.LazyLoader(spec.loader)
    spec.loader = loader
    mod = importlib.util.module_from_spec(spec)
    sys.modules[name] = mod
    loader.exec_module(mod)
    return mod
