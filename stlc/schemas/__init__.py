"""JSON Schemas of stlc's outputs, shipped in the package: ``solution.json``, ``risk.json``,
``replan.json``, ``stlc check --format json`` and ``stlc monitor --json``
(``schema("solution")`` → the schema as a dict; ``SCHEMAS`` names them)."""

from __future__ import annotations

import json
from importlib import resources

SCHEMAS = ("solution", "risk", "replan", "check", "monitor")


def schema(name: str) -> dict:
    if name not in SCHEMAS:
        raise KeyError(f"no schema {name!r}; schemas: {', '.join(SCHEMAS)}")
    text = (resources.files("stlc.schemas") / f"{name}.schema.json").read_text(encoding="utf-8")
    return json.loads(text)
