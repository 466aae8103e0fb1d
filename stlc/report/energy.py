"""The energy section: this plan's energy over time and the mission's comparison plans.

``Solution.extra["energy_profile"]`` is the energy of each sample (J, summing to
``Solution.energy``); each entry of ``extra["comparisons"]`` (from ``compare NAME { … }``)
carries its own energy, exact robustness, peaks and profile.  Energy is the rotor power of
multirotors; a mission of point masses has none, and the section says so.
"""

from __future__ import annotations

import numpy as np

from stlc.model import Mission, Multirotor, Objective, Program
from stlc.solution import Solution

from .common import fmt, indexed, num, nums, speed, vehicles


def objective_text(obj: Objective) -> str:
    """The weights that tell the plans apart: ``w = 0.5`` (energy), ``η = 1`` (forward)."""
    parts = []
    if obj.energy_weight or not obj.forward_weight:
        parts.append(f"w = {fmt(obj.energy_weight)}")
    if obj.forward_weight:
        parts.append(f"η = {fmt(obj.forward_weight)}")
    return ", ".join(parts)


def _peak(arrays: list[np.ndarray]) -> float | None:
    vals = [float(np.nanmax(a)) for a in arrays if a.size and np.isfinite(a).any()]
    return max(vals) if vals else None


def energy(program: Program, mission: Mission, sol: Solution) -> dict:
    """The ``energy`` section of the view model."""
    t = np.asarray(sol.times, float)
    names = vehicles(mission, sol)
    modelled = any(isinstance(program.vehicles.get(v), Multirotor) for v in names)

    def axis(n: int) -> list[float | None]:
        return nums(t) if n == t.size else nums(np.arange(n) * mission.step)

    speeds = [s for v in names if (s := speed(sol, v)) is not None]
    rotor = [c for v in names for _, c in indexed(sol, f"{v}.rotor_speed")]
    variants = dict(mission.options.get("compare") or [])  # type: ignore[call-overload]
    plans = [{"label": f"this plan ({objective_text(mission.objective)})",
              "energy": sol.energy, "robustness_exact": sol.robustness_exact,
              "peak_speed": _peak(speeds), "peak_rotor_speed": _peak(rotor),
              "energy_profile": sol.extra.get("energy_profile")}]
    for c in sol.extra.get("comparisons") or []:  # type: ignore[union-attr]
        c = dict(c)
        label = str(c.get("label", ""))
        obj = variants.get(label)
        if isinstance(obj, Objective):
            label = f"{label} ({objective_text(obj)})"
        plans.append({**c, "label": label})
    base = num(sol.energy)
    columns, profiles = [], []
    for i, p in enumerate(plans):
        e = num(p.get("energy"))
        delta = "—"
        if i and e is not None and base:
            delta = (f"{fmt(e - base, signed=True, unit='J')} "
                     f"({fmt(100 * (e - base) / base, 3, signed=True)} %)")
        columns.append({"label": str(p.get("label", "")),
                        "energy_text": fmt(p.get("energy"), 5, unit="J") if modelled else "—",
                        "delta_text": delta if modelled else "—",
                        "robustness_text": fmt(p.get("robustness_exact"), signed=True),
                        "peak_speed_text": fmt(p.get("peak_speed"), unit="m/s"),
                        "peak_rotor_speed_text": fmt(p.get("peak_rotor_speed"), unit="Hz")})
        prof = p.get("energy_profile")
        if modelled and prof is not None and len(prof):  # type: ignore[arg-type]
            arr = np.asarray(prof, float).ravel()
            profiles.append({"name": str(p.get("label", "")), "x": axis(arr.size),
                             "y": nums(arr), "cumulative": nums(np.cumsum(arr))})
    return {
        "modelled": modelled,
        "total": num(sol.energy) if modelled else None,
        "total_text": fmt(sol.energy, 5, unit="J") if modelled else "—",
        "has_profile": bool(profiles),
        "has_comparison": len(plans) > 1,
        "profiles": profiles,
        "columns": columns,
    }
