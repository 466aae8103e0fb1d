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
(``stlc.results.runs.sweep``); this package is the command's, so that name stays free for
the function.
"""
