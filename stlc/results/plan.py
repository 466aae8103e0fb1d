"""``Plan``: one planned and verified mission, as the Python API hands it out.

Arrays per vehicle (``plan.vehicle("uav1").pos`` is an N×3 array), a pandas table
(``plan.to_dataframe()``; pandas is optional), the report's figures (``plan.plot()``,
plotly) and a summary that Jupyter shows for a plan (``_repr_html_``).  The verdict is the
exact monitor's: ``plan.status`` is ``"satisfied"`` when ``plan.robustness`` (exact ρ) ≥
``plan.threshold`` (κ).
"""

from __future__ import annotations

import functools
import html
import os
from collections.abc import Iterator, Mapping
from dataclasses import dataclass, field

import numpy as np

from stlc.planning import words


def needs_pandas(what: str):
    try:
        import pandas as pd
    except ImportError:
        raise ImportError(f"{what} needs pandas (`pip install pandas`); without it, use "
                          "`plan.trajectory` (a dict of numpy arrays) or "
                          "`plan.vehicle(name)`") from None
    return pd


class Track(Mapping):
    """One vehicle's arrays: ``t`` (N,), and per field ``pos``/``vel``/``acc``/``att``
    (N×3, columns x, y, z), ``rotor_speed`` (N×rotors), ``speed`` (N,), … — every channel
    ``<vehicle>.<field>[.<component>]`` of the plan.  Index or attribute access."""

    def __init__(self, name: str, times: np.ndarray, channels: Mapping[str, np.ndarray]):
        self.name = name
        groups: dict[str, list[tuple[str, np.ndarray]]] = {}
        for key, arr in channels.items():
            if not key.startswith(name + "."):
                continue
            field_, _, comp = key[len(name) + 1:].partition(".")
            groups.setdefault(field_, []).append((comp, np.asarray(arr, float)))
        self._fields: dict[str, np.ndarray] = {"t": np.asarray(times, float)}
        order = {c: i for i, c in enumerate("xyz")}
        for f, parts in groups.items():
            if len(parts) == 1 and parts[0][0] == "":
                self._fields[f] = parts[0][1]
                continue
            parts.sort(key=lambda p: (order.get(p[0], 3), int(p[0]) if p[0].isdigit() else 0,
                                      p[0]))
            self._fields[f] = np.stack([a for _, a in parts], axis=1)
        self.components = {f: [c for c, _ in sorted(parts, key=lambda p: p[0])]
                           for f, parts in groups.items()}

    def __getitem__(self, key: str) -> np.ndarray:
        return self._fields[key]

    def __getattr__(self, key: str) -> np.ndarray:
        try:
            return self.__dict__["_fields"][key]
        except KeyError:
            raise AttributeError(f"vehicle `{self.__dict__.get('name')}` has no field "
                                 f"`{key}` in this plan (fields: "
                                 f"{', '.join(self.__dict__.get('_fields', {}))})") from None

    def __iter__(self) -> Iterator[str]:
        return iter(self._fields)

    def __len__(self) -> int:
        return len(self._fields)

    def __repr__(self) -> str:
        shapes = ", ".join(f"{k} {tuple(v.shape)}" for k, v in self._fields.items())
        return f"<Track {self.name}: {shapes}>"


@dataclass
class Plan:
    """One planned and verified mission (``stlc.compile``)."""

    program: object
    mission: object
    solution: object  # the internal ``Solution``
    _written: list = field(default_factory=list, repr=False)

    # ------------------------------------------------------------------ the verdict

    @property
    def status(self) -> str:
        """``"satisfied"`` (exact ρ ≥ κ), ``"violated"``, ``"infeasible"`` (proved: no plan
        exists), ``"stopped"`` (time limit) or ``"solver_failed"``."""
        return str(self.solution.status)

    @property
    def satisfied(self) -> bool:
        return self.status == "satisfied"

    @property
    def robustness(self) -> float:
        """The exact robustness ρ of the mission's requirement (the monitor's, not the
        solver's)."""
        return float(self.solution.robustness_exact)

    @property
    def threshold(self) -> float:
        """The mission's threshold κ: the plan is satisfied when ρ ≥ κ."""
        return float(self.mission.threshold)

    @property
    def specs(self) -> dict[str, float]:
        """Exact robustness of every named spec."""
        return {k: float(v.robustness) for k, v in self.solution.specs.items()}

    @property
    def notes(self) -> list[str]:
        return [str(n) for n in self.solution.notes]

    @property
    def risk(self) -> dict | None:
        """The risk cases' results (the contents of ``risk.json``), when they ran."""
        return self.solution.risk

    # ------------------------------------------------------------------ the arrays

    @property
    def trajectory(self) -> dict:
        """Channel name → numpy array (``"t"``: the sample times)."""
        return {"t": self.solution.times, **self.solution.channels}

    @property
    def vehicles(self) -> list[str]:
        """The mission's vehicles (those with a position in the plan)."""
        chans = self.solution.channels
        return [v for v in self.mission.vehicles if f"{v}.pos.x" in chans] or \
            sorted({k[:-6] for k in chans if k.endswith(".pos.x")})

    def vehicle(self, name: str) -> Track:
        """``name``'s arrays: ``.t``, ``.pos`` (N×3), ``.vel``, … (see ``Track``)."""
        if not any(k.startswith(name + ".") for k in self.solution.channels):
            raise KeyError(f"no vehicle `{name}` in this plan (vehicles: "
                           f"{', '.join(self.vehicles) or 'none'})")
        return Track(name, self.solution.times, self.solution.channels)

    def to_dataframe(self):
        """The trajectory as a pandas ``DataFrame``: a column ``t`` and one per channel
        (``uav1.pos.x``, …), one row per sample.  Needs pandas."""
        pd = needs_pandas("plan.to_dataframe()")
        return pd.DataFrame(self.trajectory)

    # ------------------------------------------------------------------ the report

    @functools.cached_property
    def _view(self) -> dict:
        from stlc.output.report import build_view

        return build_view(self.program, self.mission, self.solution)

    def figures(self) -> dict:
        """Every figure of the report (plotly ``Figure``): ``scene`` (3-D), ``top``, and one
        per signal plot (``position``, ``speed``, …)."""
        from stlc.results.figures import figures

        return figures(self._view)

    def plot(self, name: str = "scene"):
        """One of the report's figures as a plotly ``Figure`` (``scene`` by default; see
        ``figures()`` for the names)."""
        figs = self.figures()
        if name not in figs:
            raise KeyError(f"no figure `{name}` (figures: {', '.join(figs)})")
        return figs[name]

    def report_html(self) -> str:
        """The complete report page (what ``report.html`` holds), as a string."""
        from stlc.output.report import render_report

        return render_report(self._view)

    def _repr_html_(self) -> str:
        """Jupyter's display of a plan: the verdict (exact ρ against κ), the specs and the
        notes.  The full report with its figures: ``plan.report_html()`` or ``plot()``."""
        return summary_html(self._view, self.robustness, self.threshold)

    def __repr__(self) -> str:
        return (f"<Plan {self.solution.mission}: "
                f"{words.verdict_line(self.status, self.robustness, self.threshold)}>")

    # ------------------------------------------------------------------ files

    def to_json(self) -> dict:
        """The ``solution.json`` of this plan, as a dict (strict JSON values)."""
        from stlc.output.solution import solution_json_dict
        from stlc.strictjson import strict

        return strict(solution_json_dict(self.solution))

    def write(self, outdir: str | os.PathLike) -> str:
        """Write the files of ``stlc compile -o OUTDIR`` (same contract: only stlc's own
        files, each replaced atomically, as one set); returns ``outdir``."""
        from stlc.output.compile import write_outputs
        from stlc.output.directory import preflight

        out = os.fspath(outdir)
        preflight(out, self.mission.span)
        write_outputs(out, self.program, self.mission, self.solution)
        return out


def summary_html(view: dict, rho: float, kappa: float) -> str:
    """A compact HTML summary of a report's view model (no scripts, escaped text)."""
    s = view["summary"]
    e = html.escape
    rows = "".join(
        f"<tr><td><code>{e(r['name'])}</code></td><td>{e(r['verdict'])}</td>"
        f"<td style='text-align:right'>{e(r['robustness_text'])}</td>"
        f"<td>{e(r['tightest_text'])}</td><td>{e(r['binding_predicate'])}</td></tr>"
        for r in view["specs"])
    flags = "".join(f"<li><strong>{e(f['title'])}</strong>: {e(f['text'])}</li>"
                    for f in s.get("flags", []))
    notes = "".join(f"<li>{e(n)}</li>" for n in s["notes"])
    return (
        f"<div class='stlc-plan'><h4>{e(s['mission'])}: {e(s['status_label'])}</h4>"
        f"<p>{e(words.verdict_line(s['status'], rho, kappa))}; energy {e(s['energy_text'])}"
        f"; {e(s['specs_text'])}; solve {e(s['solve_text'])}</p>"
        + (f"<ul class='flags'>{flags}</ul>" if flags else "")
        + "<table><thead><tr><th>spec</th><th>verdict</th><th>exact ρ</th>"
          "<th>tightest at</th><th>binding predicate</th></tr></thead>"
          f"<tbody>{rows}</tbody></table>"
        + (f"<ul class='notes'>{notes}</ul>" if notes else "") + "</div>")
