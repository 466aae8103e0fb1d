"""The ``stlc`` command and ``python -m stlc``: ``stlc.cli.main``, then the exit."""

import contextlib
import os
import sys

from stlc.cli import main

#: commands whose process ends as soon as ``main`` returns (``run``): what they write is
#: written and closed by then, and the interpreter's own finalisation (destroying the
#: solvers' expression graphs, the kept NLPs, the modules) took 0.15 s of a 2.8 s compile.
#: The commands that start Dask clusters or servers (sweep, fly, risk, lsp) end normally.
QUICK_EXIT = frozenset({"check", "compile", "monitor", "fmt", "explain"})


def run() -> None:
    """``main`` on the process's arguments, then the exit."""
    argv = sys.argv[1:]
    code = main(argv)
    if argv and argv[0] in QUICK_EXIT:
        codegen = sys.modules.get("stlc.solvers.codegen")
        if codegen is not None:  # (what ``atexit`` would do)
            codegen.start_pending()
        for stream in (sys.stdout, sys.stderr):
            with contextlib.suppress(OSError, ValueError):
                stream.flush()
        os._exit(int(code or 0))
    sys.exit(code)


if __name__ == "__main__":
    run()
