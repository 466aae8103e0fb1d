"""``python -m stlc``: the command line (``stlc.cli.run``)."""

from stlc.cli import run

run()
