"""The exit codes of ``stlc`` (the contract of docs/cli.md), one table for every command:
0 success, 1 the input is wrong, 2 bad command-line usage, 3 no satisfying plan (or a
simulation that did not keep its specs), 4 internal error, 130 interrupted (Ctrl-C; SIGTERM 143 and SIGHUP 129 alike, see
``stlc.interrupt.exit_code``), 141 the reader of stdout went away."""

EXIT_OK = 0
EXIT_INPUT = 1
EXIT_USAGE = 2
EXIT_UNSAT = 3
EXIT_INTERNAL = 4
EXIT_INTERRUPTED = 130
EXIT_BROKEN_PIPE = 141
