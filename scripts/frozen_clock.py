"""Run ``stlc`` with the replanning segment's wall clock frozen, for a load-independent
comparison of replanning events (``scripts/arch_equivalence.py --frozen-clock``).

Under load, IPOPT's ``max_wall_time`` (the budget t_c) and the budget test decide which
replans are flown, so two runs of the same code differ.  This wrapper gives the segment NLP
an unlimited wall time and a clock that reads 0, so every event is decided by the
mathematics alone; everything else runs as ``python -m stlc``."""

from __future__ import annotations

import importlib
import sys
import time
import types


def _freeze() -> None:
    for name in ("stlc.backends.replan.segment", "stlc.replan.segment"):
        try:
            mod = importlib.import_module(name)
        except ImportError:
            continue
        cls = mod.SegmentNlp
        init = cls.__init__

        def patched(self, *a, _init=init, **k):
            a = list(a)
            if len(a) >= 7:
                a[6] = 1e6  # budget → IPOPT max_wall_time
            else:
                k["budget"] = 1e6
            _init(self, *a, **k)

        cls.__init__ = patched
        mod.time = types.SimpleNamespace(perf_counter=lambda: 0.0,
                                         process_time=time.process_time)
        return
    raise SystemExit("no segment module found")


if __name__ == "__main__":
    _freeze()
    from stlc.cli import main

    sys.exit(main(sys.argv[1:]))
