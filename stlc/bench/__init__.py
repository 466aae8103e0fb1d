"""Benchmarks, one folder above the pipeline they time: ``tables`` (``stlc bench monitor |
compile``), ``suite`` (``stlc bench suite``: the current table of docs/performance.md, with
the machine it ran on), ``team`` (the team planner), ``replan`` (disturbance replanning) and
``takeover`` (the backup-drone takeover).  Each reports; nothing is asserted."""

from stlc.bench.tables import main

__all__ = ["main"]
