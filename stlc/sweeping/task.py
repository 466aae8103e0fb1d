"""One sweep instance, as a Dask worker runs it: source text, mission, ``--set`` items and
the candidate seeds in; a CSV row, the plan and its channels out.  CasADi objects never
travel: the worker process keeps its built NLPs (``nlp_cache``, keyed by structure) between
tasks, so the first task of a worker builds and later ones bind their values into the same
NLP.  The client (``stlc.sweeping.order``) ships with each task the solved plans of its
nearest solved instances and a predicted plan; the instance starts from the one with the
best exact robustness at its own values — a start's objective is what the energy stage it
runs first descends from.  Without shipped seeds (``seeds=None``) the worker's own library
of the plans it solved is used."""

from __future__ import annotations

import contextlib
import os
import threading
import time
import traceback
from collections.abc import Callable, Iterator
from dataclasses import replace

import numpy as np

from stlc.backends import strategy

_LIBRARIES: dict[tuple[str, str], object] = {}  # plan libraries (``strategy.plan_library``)


def _worker_name() -> str:
    try:
        from distributed import get_worker

        w = get_worker()
        return str(w.name if w.name is not None else w.address)
    except (ImportError, ValueError):
        return f"pid{os.getpid()}"


def run_instance(source: str, path: str, mission: str, items: list[tuple[str, str]],
                 values: dict[str, float], index: int, warm: bool = True,
                 time_limit: float | None = None, seeds: list | None = None,
                 preempt: str | None = None) -> dict:
    """Plan and verify one instance; never raises for a bad instance (status ``failed``).
    ``time_limit`` (s, ``stlc sweep --time-limit``) bounds this instance from its start on
    its worker, as ``compile --time-limit`` bounds a compile (no watchdog in a worker: an
    NLP build is not cut); an instance it stops is ``stopped`` (or ``satisfied`` if the
    exact monitor says so); without it the default limit applies (``stlc.deadline``).
    ``seeds``: solved plans (values, channels, label) the client ships (``stlc.sweeping.order``);
    ``None``: this worker's own library.  A satisfied row carries its plan's ``channels``.
    ``preempt``: the name of a Dask ``Event`` the client sets to pre-empt this (cold)
    instance — its solve stops as on its time limit and the row says ``preempted`` (the
    client solves the instance again, warm started: ``stlc.sweeping.run``)."""
    from stlc import deadline, settings

    t0 = time.perf_counter()
    row: dict = {"instance": index, "values": values, "status": "failed", "error": "",
                 "robustness": float("nan"), "specs": {}, "iterations": 0, "solve_s": 0.0,
                 "total_s": 0.0, "worker": _worker_name(), "built": False, "warm": "",
                 "plan_csv": None}
    builds = strategy.nlp_builds()
    fired = threading.Event()
    try:
        # no fork inside a Dask worker process
        with deadline.bounded(time_limit), preemptible(_event(preempt), fired), \
                settings.override(no_fork=True):
            row.update(_plan(source, path, mission, items, values, warm, seeds))
    except Exception as e:  # noqa: BLE001 - one instance's failure is a row, not a lost sweep
        from stlc.diagnostics import StlcError

        if isinstance(e, StlcError):
            row["error"] = "; ".join(f"{d.code}: {d.message}" for d in e.diagnostics)
        else:
            row["error"] = f"{type(e).__name__}: {e}"
            if settings.debug():
                row["error"] += "\n" + traceback.format_exc()
    row["built"] = strategy.nlp_builds() > builds
    row["preempted"] = fired.is_set()
    row["total_s"] = time.perf_counter() - t0
    return row


POLL_S = 0.25  #: how often a pre-emptible instance asks whether it is pre-empted


def _event(name: str | None) -> Callable[[], bool] | None:
    """``is_set`` of the Dask ``Event`` called ``name`` (None: not pre-emptible)."""
    if name is None:
        return None
    try:
        from distributed import Event, get_client

        # the client is bound here, in the task's thread: the watcher's thread has none
        return Event(name, client=get_client()).is_set
    except (ImportError, ValueError):  # not inside a Dask worker: nobody can pre-empt
        return None


@contextlib.contextmanager
def preemptible(is_set: Callable[[], bool] | None, fired: threading.Event) -> Iterator[None]:
    """While the block runs, a thread asks ``is_set()`` every ``POLL_S``; once it is true,
    the block's time limit ends now (``deadline.stopper``: the solve stops at its next
    iteration, keeping its best verified iterate) and ``fired`` is set."""
    from stlc import deadline

    if is_set is None:
        yield
        return
    stop, done = deadline.stopper(), threading.Event()

    def watch() -> None:
        while not done.wait(POLL_S):
            with contextlib.suppress(Exception):  # a scheduler that does not answer: go on
                if is_set():
                    fired.set()
                    stop()
                    return

    t = threading.Thread(target=watch, name="stlc-preempt", daemon=True)
    t.start()
    try:
        yield
    finally:
        done.set()
        t.join()


def _parsed(source: str, path: str):
    """The parsed file and its check as written (``overrides.base``), kept between a
    worker's tasks (the same text every time): a task resolves only its ``--set`` items
    against them and checks again only for a const or a region's placement."""
    from stlc.frontend.syntax import parse
    from stlc.semantics import overrides

    key = (path, hash(source))
    if _PARSED.get("key") != key:
        _PARSED.clear()
        tree = parse(source, path)
        _PARSED.update(key=key, tree=tree, base=overrides.base(tree))
    return _PARSED["tree"], _PARSED["base"]


_PARSED: dict = {}


def _plan(source: str, path: str, mission: str, items, values, warm: bool,
          seeds: list | None = None) -> dict:
    from stlc.backends.strategy import solve_cost, structure_key
    from stlc.output.solution import trajectory_csv
    from stlc.pipeline import backend_chain, plan, select_missions
    from stlc.planning.problem import from_mission
    from stlc.semantics import overrides

    tree, base = _parsed(source, path)
    program, vals = overrides.checked(tree, items, checked_base=base)
    m = select_missions(path, program, mission)[0]
    # a row has no `compare` plans: none is solved, cold (the instance's own seed) or warm
    m = replace(m, options={k: v for k, v in m.options.items() if k != "compare"})
    problem = from_mission(program, m, values=vals)
    chain = backend_chain(problem)
    lib = None
    seed_label = ""
    if strategy.warm_startable(chain):
        if seeds is not None:  # the client's nearest solved plans, whoever solved them
            lib = strategy.plan_library()
            for v, ch, label in seeds:
                lib.add(v, ch, label)
        else:  # this worker's own library, per structure (``nlp_cache.structure_key``)
            lib = _LIBRARIES.setdefault((mission, structure_key(problem)),
                                        strategy.plan_library())
        # of the candidates (or the 4 nearest), the most robust at this instance's values
        near = lib.nearest(vals, _scorer(program, m, problem.grid.dt),
                           k=len(seeds) if seeds else 4) if warm else None
        if near is not None:
            chain = strategy.library_chain(chain, near)
            seed_label = near[1]
    _, sol = plan(program, m, values=vals, chain=chain)
    if lib is not None and sol.status == "satisfied" and seeds is None:
        lib.add(vals, sol.channels, str(values))
    chain_rec = sol.solver.chain
    tries = (chain_rec.next_choices or []) if chain_rec is not None else []
    spent = [chain_rec.first_try, *tries] if tries else [solve_cost(sol)]
    return {"status": str(sol.status), "robustness": float(sol.robustness_exact),
            "specs": {k: float(v.robustness) for k, v in sol.specs.items()},
            # every try's (a warm start that missed κ, then the instance's own seed)
            "iterations": sum(t["iterations"] for t in spent),
            "solve_s": sum(t["solve_s"] for t in spent),
            "replanned": len(tries),
            "warm": chain[0].name, "seed": seed_label, "plan_csv": trajectory_csv(sol),
            "channels": ({k: np.asarray(v, float) for k, v in sol.channels.items()}
                         if sol.status == "satisfied" else None)}


def _scorer(program, mission, dt: float):
    """A library plan's exact robustness at this instance's values (its own pose)."""
    from stlc.analysis import monitor

    return lambda ch: float(monitor.robustness(mission.requirement, dt, ch, program.params))
