"""Solver backends behind one interface (``stlc.backends.base.Backend``).

``registry()`` lists every backend class with its name; the pipeline chains them
(``stlc.pipeline.backend_chain``).  See the README, "Adding a backend".
"""

from __future__ import annotations


def registry() -> dict[str, type]:
    from stlc.backends.casadi_backend import CasadiNlp, KinematicGuess

    return {"kinematic": KinematicGuess, "casadi": CasadiNlp}
