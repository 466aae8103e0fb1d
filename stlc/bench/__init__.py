"""Benchmarks, one folder above the pipeline they time: ``tables`` (``stlc bench monitor |
compile``), ``suite`` (``stlc bench suite``: the current table of docs/performance.md, with
the machine it ran on), ``team`` (the team planner), ``replan`` (disturbance replanning) and
``takeover`` (the backup-drone takeover).  Each reports; nothing is asserted."""

from stlc.bench import suite, tables

#: ``stlc bench COMMAND``: name -> (help, add_arguments, run)
COMMANDS = {**tables.COMMANDS, "suite": suite.COMMAND}


def main(argv: list[str] | None = None) -> int:
    return tables.main(argv, COMMANDS)


__all__ = ["COMMANDS", "main"]
