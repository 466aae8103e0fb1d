"""The walk of a command through the package's folders: run ``stlc ARGS`` with a
profiler that sees every Python call from one ``stlc`` function into another, and report
the folders entered and the *climbs*: distinct caller → callee function pairs whose
callee's folder is above the caller's in the layer order of ``tests/test_layers.py``
(a climb is a call against "imports go downwards").

    python scripts/walks.py compile specs/handover.stl --mission handover_left_tb -o OUT -q
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent / "tests"))
from test_layers import RANK  # noqa: E402  (the layer order of the tree this file is in)


def unit_of(path: str, root: str) -> str | None:
    if not path.startswith(root):
        return None
    rel = Path(path[len(root):]).with_suffix("").parts
    return rel[0] if len(rel) > 1 else (rel[0] if rel[0] != "__init__" else "stlc")


def main(argv: list[str]) -> int:
    import stlc

    root = os.path.dirname(os.path.abspath(stlc.__file__)) + os.sep
    entered: set[str] = set()
    climbs: set[tuple[str, str]] = set()
    unranked: set[str] = set()

    def prof(frame, event, arg):
        if event != "call":
            return
        callee = frame.f_code.co_filename
        u = unit_of(callee, root)
        if u is None:
            return
        entered.add(u)
        caller = frame.f_back
        while caller is not None and unit_of(caller.f_code.co_filename, root) is None:
            caller = caller.f_back  # through numpy/casadi/stdlib frames
        if caller is None:
            return
        c = unit_of(caller.f_code.co_filename, root)
        if c == u:
            return
        if c not in RANK or u not in RANK:
            unranked.update(x for x in (c, u) if x not in RANK)
            return
        if RANK[u] > RANK[c]:
            climbs.add((f"{c}:{caller.f_code.co_name}", f"{u}:{frame.f_code.co_name}"))

    from stlc.cli import main as cli_main

    import threading

    sys.setprofile(prof)
    threading.setprofile(prof)  # the command runs in a worker thread (stlc.interrupt)
    try:
        code = cli_main(argv)
    finally:
        sys.setprofile(None)
        threading.setprofile(None)
    folders = sorted(u for u in entered if u in RANK and not Path(root, u).suffix
                     and Path(root, u).is_dir())
    print(f"exit {code}; folders entered {len(folders)}: {', '.join(folders)}; "
          f"climbs {len(climbs)}", file=sys.stderr)
    for a, b in sorted(climbs):
        print(f"  climb {a} -> {b}", file=sys.stderr)
    if unranked:
        print(f"  (modules outside the layer order, not counted: {sorted(unranked)})",
              file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
