"""``stlc sweep``: one mission over a grid (or a random sample) of ``--set`` values, on
Dask distributed (a ``LocalCluster`` by default, an existing cluster by address).

* ``axes``   — ``--vary NAME=LO:HI:N`` and ``--random N``: the instances, validated against
  the file before anything starts (the same diagnostics as ``--set``);
* ``task``   — what a worker runs for one instance (source text, mission, values in; a row
  and the plan out); the worker process keeps its built NLP and its plan library between
  tasks (``stlc.backends.nlp.cache``, ``stlc.backends.nlp.library``);
* ``run``    — the client: submit, progress bar, Ctrl-C, outputs under the output-directory
  contract;
* ``report`` — ``sweep.html``.

From Python, ``stlc.sweep(program, mission, vary={...})`` runs a sweep and returns its table
(``stlc.results.runs.sweep``); the package itself is callable to that end (see below).
"""

import sys as _sys
import types as _types


class _CallableSweep(_types.ModuleType):
    """``stlc.sweep(...)`` is the Python API's sweep (``stlc.results.runs.sweep``) although
    ``stlc.sweep`` is also this package: importing it (e.g. ``stlc.sweep.axes``) binds the
    name ``sweep`` on ``stlc`` to the package, so the package answers a call the same way,
    through the package's lazy facade (``stlc.__getattr__``)."""

    def __call__(self, *args, **kwargs):
        import stlc

        return stlc.__getattr__("sweep")(*args, **kwargs)


_sys.modules[__name__].__class__ = _CallableSweep
