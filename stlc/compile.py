"""The outputs of ``stlc compile``: ``solution.json``, ``trajectory.csv``, ``report.html``
(+ ``risk.json``, ``risk_samples.npz``) of one verified ``Solution``, and the summary line.

The pipeline (``stlc.pipeline.compile_file``) orders the passes and calls this last, once
everything the outputs contain exists.  Outputs of a mission are written into a temporary
directory that is renamed into place, so nothing is left half-written.
"""

from __future__ import annotations

import json
import os
import shutil
import sys
import tempfile

from stlc import model
from stlc.solution import Solution

EXIT_OK, EXIT_UNSAT = 0, 3


# ---------------------------------------------------------------- outputs


def write_outputs(outdir: str, program: model.Program, mission: model.Mission, sol: Solution
                  ) -> None:
    """Write every output of one mission atomically (temp dir, then rename)."""
    from stlc.report import write_report

    parent = os.path.dirname(os.path.abspath(outdir)) or "."
    os.makedirs(parent, exist_ok=True)
    tmp = tempfile.mkdtemp(prefix=".stlc-", dir=parent)
    os.chmod(tmp, 0o755)  # mkdtemp makes it private; outputs are ordinary files to share
    try:
        with open(os.path.join(tmp, "solution.json"), "w") as fh:
            fh.write(sol.to_json())
        with open(os.path.join(tmp, "trajectory.csv"), "w") as fh:
            fh.write(sol.trajectory_csv())
        if sol.risk is not None:
            with open(os.path.join(tmp, "risk.json"), "w") as fh:
                json.dump(sol.risk, fh, indent=2, allow_nan=False)
            if sol.risk_results is not None:
                from stlc.risk import save_samples

                save_samples(os.path.join(tmp, "risk_samples.npz"), sol.risk_results)
        write_report(os.path.join(tmp, "report.html"), program, mission, sol)
        if os.path.isdir(outdir):
            shutil.rmtree(outdir)
        os.replace(tmp, outdir)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise


def summary(sol: Solution, outdir: str) -> None:
    print(f"{sol.mission}: {sol.status}  exact robustness {sol.robustness_exact:+.4f}  "
          f"smooth {sol.robustness_smooth:+.4f}  energy {sol.energy:.1f} J  "
          f"→ {outdir}/report.html")
    if sol.status != "satisfied":
        worst = min(sol.specs.items(), key=lambda kv: kv[1].robustness, default=None)
        if worst is not None:
            name, s = worst
            at = f" at t = {s.tightest_time:g} s" if s.tightest_time is not None else ""
            if s.robustness < 0:
                print(f"  error[STL501]: spec `{name}` (line {s.line}) is violated{at} by "
                      f"{-s.robustness:.4f}: {s.binding_predicate}", file=sys.stderr)
            else:
                kappa = sol.smoothing.get("threshold", 0.0)
                print(f"  error[STL501]: spec `{name}` (line {s.line}) holds with margin "
                      f"{s.robustness:.4f}{at}, short of the threshold κ = {kappa:g}: "
                      f"{s.binding_predicate}", file=sys.stderr)
