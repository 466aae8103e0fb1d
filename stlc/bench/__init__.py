"""Benchmarks, one folder above the pipeline they time: ``tables`` (``stlc bench monitor |
compile``), ``team`` (the team planner), ``replan`` (disturbance replanning) and
``takeover`` (the backup-drone takeover).  Each prints medians; nothing is asserted."""

from stlc.bench.tables import main

__all__ = ["main"]
