"""Running ``python -m stlc`` as a user does, for the tests that need a whole process
(exit codes, signals, files written): the repository first on ``PYTHONPATH``, without the
developers' ``STLC_DEBUG``."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def env() -> dict[str, str]:
    e = {k: v for k, v in os.environ.items() if k != "STLC_DEBUG"}
    e["PYTHONPATH"] = str(ROOT) + os.pathsep + e.get("PYTHONPATH", "")
    return e


def stlc(*args: str, cwd: Path, timeout: float = 600) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "stlc", *args], cwd=cwd, env=env(),
                          capture_output=True, text=True, timeout=timeout)
