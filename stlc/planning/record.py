"""The solve record of a plan (``Solution.solver``): what the planners did, typed.

``SolveRecord`` holds the fields every reader asks for as typed attributes — the solver's
``name``, ``status`` (the shared ``SolverStatus``), its own ``return_status``, ``converged``,
``iterations``, the NLP's ``stages``, the backend ``chain`` (``ChainRecord``: its stages,
the further seeds tried, the chain it fell back from), the ``stopped_by`` reason
(``StopReason``) with its ``time_limit_s``, and a team plan's ``assignment``
(``Assignment``: how its routes were found) — and every backend-specific figure
(objective, bound, gap, phases, the MILP seed's record, ...) in ``details``.  ``to_json``
writes the ``"solver"`` object of ``solution.json`` with the keys in the order they were
recorded, as the contract has them.

Backends fill a record with the mapping interface (``{"name": ..., "objective": ...}``,
``record.update(...)``); the passes after them (the strategy, the notes shown to a user,
the writers) read the typed attributes.  ``notes`` derives the sentences a user is shown
from the record itself.
"""

from __future__ import annotations

import enum
from collections.abc import Iterator, MutableMapping
from dataclasses import dataclass, field
from typing import Any

from stlc.solvers.status import SolverStatus


class StopReason(enum.StrEnum):
    """Why the search stopped before its own end."""

    TIME_LIMIT = "time_limit"  # the run's time limit (``stlc.deadline``)
    INTERRUPTED = "interrupted"  # Ctrl-C with ``--keep-on-interrupt`` (``deadline.cut``)


@dataclass
class Assignment:
    """How a team plan's routes were found: ``method`` "milp" (the assignment MILP proved
    them optimal) or "greedy" (the MILP stopped on its time budget); then ``incumbent``
    says where the routes come from: "milp" (its own best incumbent), "heuristic" (greedy
    start + local search) or "greedy" (the bare rule)."""

    method: str
    incumbent: str = ""

    @property
    def optimal(self) -> bool:
        return self.method == "milp"


@dataclass
class ChainStage:
    backend: str
    status: str
    converged: bool
    seed: dict | None = None  # the MILP seed's record (grid, phases, time, ρ̂)

    def to_json(self) -> dict:
        out: dict[str, Any] = {"backend": self.backend, "status": self.status,
                               "converged": self.converged}
        if self.seed is not None:
            out["seed"] = self.seed
        return out


@dataclass
class ChainRecord:
    """The backend chain that planned: its name, whether it was forced, each stage; the
    further seeds tried (``next_choices``, with what the first one cost) and the chain this
    one fell back from."""

    name: str
    forced: bool
    stages: list[ChainStage] = field(default_factory=list)
    next_choices: list[dict] | None = None
    first_try: dict | None = None
    fallback_from: ChainRecord | None = None

    def to_json(self) -> dict:
        out: dict[str, Any] = {"name": self.name, "forced": self.forced,
                               "stages": [s.to_json() for s in self.stages]}
        if self.next_choices is not None:
            out["next_choices"] = self.next_choices
            out["first_try"] = self.first_try
        if self.fallback_from is not None:
            out["fallback_from"] = self.fallback_from.to_json()
        return out

    # read as the JSON object it is written as (``record["chain"]["stages"]``)
    def __getitem__(self, key: str):
        return self.to_json()[key]

    def __contains__(self, key: object) -> bool:
        return key in self.to_json()

    def __iter__(self) -> Iterator[str]:
        return iter(self.to_json())

    def get(self, key: str, default=None):
        return self.to_json().get(key, default)


#: the typed fields; every other key is a backend's detail
_TYPED = ("name", "status", "return_status", "converged", "iterations", "stages", "chain",
          "stopped_by", "time_limit_s", "assignment", "infeasibility")


@dataclass
class SolveRecord(MutableMapping):
    name: str = ""
    status: SolverStatus | str | None = None
    return_status: str | None = None
    converged: bool | None = None
    iterations: int | None = None
    stages: list | None = None  # the NLP's stages, in order
    chain: ChainRecord | None = None
    stopped_by: StopReason | None = None
    time_limit_s: float | None = None  # the limit that stopped it (``stopped_by``)
    assignment: Assignment | None = None
    infeasibility: dict | None = None  # why no proof of impossibility (``milp.conflict``)
    details: dict[str, Any] = field(default_factory=dict)
    _order: list[str] = field(default_factory=list, repr=False, compare=False)

    @classmethod
    def of(cls, value: SolveRecord | dict | None) -> SolveRecord:
        if isinstance(value, SolveRecord):
            return value
        rec = cls()
        rec.update(value or {})
        return rec

    # ------------------------------------------------------------ the mapping interface

    def __setattr__(self, key: str, value) -> None:
        if key in _TYPED:
            value = _typed(key, value)
            order = self.__dict__.get("_order")
            if order is not None and value is not None and key not in order:
                order.append(key)
            if order is not None and value is None and key in order:
                order.remove(key)
        object.__setattr__(self, key, value)

    def __getitem__(self, key: str):
        if key in _TYPED:
            v = getattr(self, key)
            if v is None:
                raise KeyError(key)
            return v.method if key == "assignment" else v
        return self.details[key]

    def __setitem__(self, key: str, value) -> None:
        if key in _TYPED:
            setattr(self, key, value)
        else:
            self.details[key] = value
            if key not in self._order:
                self._order.append(key)

    def __delitem__(self, key: str) -> None:
        if key in _TYPED:
            if getattr(self, key) is None:
                raise KeyError(key)
            setattr(self, key, None)
        else:
            del self.details[key]
            self._order.remove(key)

    def __iter__(self) -> Iterator[str]:
        return iter(list(self._order))

    def __len__(self) -> int:
        return len(self._order)

    def __bool__(self) -> bool:
        return bool(self._order)

    # ------------------------------------------------------------ derived views

    def to_json(self) -> dict:
        """The ``"solver"`` object of ``solution.json``."""
        out: dict[str, Any] = {}
        for k in self._order:
            v = self[k]
            if k == "status":
                v = str(v)
            elif k == "chain":
                v = v.to_json()
            elif k == "stopped_by":
                v = str(v)
            elif k == "stages":
                v = [s if isinstance(s, dict) else vars(s) for s in v]
            out[k] = v
        return out

    def notes(self) -> list[str]:
        """What a user is told about how this plan was found (derived from the record)."""
        a = self.assignment
        if a is None or a.optimal:
            return []
        head = "the task-assignment MILP stopped on its time budget (not converged): "
        if a.incumbent == "milp":
            return [head + "the routes are its best incumbent, not proved optimal"]
        if a.incumbent == "heuristic":
            return [head + "the routes come from the heuristic (greedy start + local "
                    "search, own station per drone), not optimal"]
        return [head + "the routes come from the greedy rule (own station per drone), "
                "not optimal"]


def _typed(key: str, value):
    if value is None:
        return None
    if key == "status" and not isinstance(value, SolverStatus):
        try:
            return SolverStatus(str(value))
        except ValueError:
            return str(value)
    if key == "chain" and isinstance(value, dict):
        return ChainRecord(value["name"], value["forced"],
                           [ChainStage(**s) for s in value.get("stages", [])])
    if key == "stopped_by" and not isinstance(value, StopReason):
        return StopReason(str(value))
    if key == "assignment" and isinstance(value, str):
        return Assignment(value)
    return value
