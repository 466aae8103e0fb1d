"""Yaw travel of a multirotor plan, and the least travel its own path asks for.

    python scripts/yaw_travel.py OUTDIR [OUTDIR ...] [--window 10 17] [--tol 30] [--vmin 0.1]

For each compile output directory (``trajectory.csv``) and each vehicle with a heading:
the total yaw travel Σ|Δψ| and net turn of the plan, and the least travel of any heading
history that starts at the plan's start heading and stays within ``tol`` degrees of the
course at every sample of the window where the horizontal speed exceeds ``vmin`` (the
shipped handovers' comfort spec) — on the plan's own path.  Computed by dynamic programming
over a 0.25° grid: the cost to reach each heading after a sample is the L1 distance
transform of the cost before, cut to the allowed band.
"""

from __future__ import annotations

import argparse
import csv

import numpy as np

STEP = 0.25  # degrees


def least_travel(t, course_deg, hspeed, psi0_deg, window, tol, vmin) -> float:
    grid = np.arange(-720.0, 720.0 + STEP / 2, STEP)
    cost = np.full(grid.size, np.inf)
    cost[int(np.argmin(np.abs(grid - psi0_deg)))] = 0.0
    for k in range(1, len(t)):
        for i in range(1, grid.size):  # distance transform: moving costs |Δψ|
            cost[i] = min(cost[i], cost[i - 1] + STEP)
        for i in range(grid.size - 2, -1, -1):
            cost[i] = min(cost[i], cost[i + 1] + STEP)
        if window[0] - 1e-9 <= t[k] <= window[1] + 1e-9 and hspeed[k] > vmin:
            dev = (grid - course_deg[k] + 180.0) % 360.0 - 180.0
            cost[np.abs(dev) > tol] = np.inf
    return float(cost.min())


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("outdirs", nargs="+")
    ap.add_argument("--window", nargs=2, type=float, default=(10.0, 17.0))
    ap.add_argument("--tol", type=float, default=30.0)
    ap.add_argument("--vmin", type=float, default=0.1)
    a = ap.parse_args()
    for d in a.outdirs:
        with open(f"{d}/trajectory.csv", newline="") as fh:
            rows = list(csv.DictReader(fh))
        t = np.array([float(r["t"]) for r in rows])
        for v in [k[: -len(".heading")] for k in rows[0] if k.endswith(".heading")]:
            col = lambda c: np.array([float(r[f"{v}.{c}"]) for r in rows])  # noqa: E731
            psi = np.degrees(col("heading"))
            vx, vy = col("vel.x"), col("vel.y")
            need = least_travel(t, np.degrees(np.arctan2(vy, vx)), np.hypot(vx, vy), psi[0],
                                a.window, a.tol, a.vmin)
            print(f"{d} {v}: yaw travel {np.sum(np.abs(np.diff(psi))):.1f}°, net "
                  f"{psi[-1] - psi[0]:+.1f}°; least travel its own path needs {need:.1f}°")


if __name__ == "__main__":
    main()
