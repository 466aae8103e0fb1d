"""The risk pass's K realisations split over a Dask executor (``stlc risk --workers K`` /
``--scheduler ADDRESS``).

The realisations are drawn once, in the client, from the case's seed (as in a
single-process run); they are independent, so ``shared_robustness`` evaluates them in
batches — about ``TASKS_PER_THREAD`` per worker thread, at least ``BATCH`` realisations, a
multiple of its own chunk, so every chunk holds the same
realisations as in the single-process run and the results are bitwise identical — on the
workers, and the batches are put back in order.  The plan's channels and the formulas are
scattered to the workers once per case.

On a long trace ``shared_robustness`` takes fewer than ``CHUNK`` realisations at a time (its
chunk is bounded by the samples the formulas read, ``risk.realisation_chunk``, so that the
memory stays bounded whatever the trace's length); a batch is then cut at a multiple of
that chunk, so the chunks still hold the single-process run's
realisations and each worker's memory is bounded as the single process's.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from stlc.analysis.risk import CHUNK, realisation_chunk, shared_robustness

BATCH = 2 * CHUNK  # ~1,000 realisations per task at least
TASKS_PER_THREAD = 8  # batches per worker thread (load balance vs per-task overhead)


def _threads(client) -> int:
    try:
        return max(1, sum(int(w.get("nthreads", 1))
                          for w in client.scheduler_info().get("workers", {}).values()))
    except Exception:  # noqa: BLE001 - a scheduler that does not answer: batches of BATCH
        return 10**9


def _batch(formulas, dt, channels, params, lo, hi, lam, method, with_smooth):
    from stlc.analysis.risk import shared_robustness as sr

    part = {k: (v[lo:hi] if isinstance(v, np.ndarray) else v) for k, v in params.items()}
    return lo, sr(formulas, dt, channels, part, hi - lo, lam, method, with_smooth=with_smooth)


def distributed(client, batch: int = BATCH):
    """A ``shared_robustness`` replacement that maps batches over ``client``'s workers."""
    if batch % CHUNK:
        raise ValueError(f"batch {batch} is not a multiple of the chunk {CHUNK}")

    def shared(formulas: Mapping, dt: float, channels: Mapping, params: Mapping, K: int,
               lam: float = 10.0, method: str = "gkl", *, with_smooth: bool = True):
        n = len(next(iter(channels.values())))
        chunk = realisation_chunk(formulas, dt, n)
        # at least ``batch``, and few enough tasks that their round trips (client →
        # scheduler → worker, ~30 ms loaded) do not leave the workers waiting
        per = -(-K // (TASKS_PER_THREAD * _threads(client)))
        step = max(batch // chunk, -(-per // chunk)) * chunk  # cut at chunk boundaries
        if K <= step:
            return shared_robustness(formulas, dt, channels, params, K, lam, method,
                                     with_smooth=with_smooth)
        f_, ch_ = client.scatter([dict(formulas), dict(channels)], broadcast=True)
        futs = [client.submit(_batch, f_, dt, ch_, {k: (v[lo:min(K, lo + step)]
                                                        if isinstance(v, np.ndarray) else v)
                                                    for k, v in params.items()},
                              0, min(K, lo + step) - lo, lam, method, with_smooth,
                              pure=False)
                for lo in range(0, K, step)]
        keys = list(formulas)
        exact = {k: np.empty(K) for k in keys}
        smooth = {k: np.empty(K) for k in keys} if with_smooth else {}
        for lo_b, fut in zip(range(0, K, step), futs):
            _, (ex, sm) = fut.result()
            for k in keys:
                exact[k][lo_b:lo_b + len(ex[k])] = ex[k]
                if with_smooth:
                    smooth[k][lo_b:lo_b + len(sm[k])] = sm[k]
        return exact, smooth

    return shared
