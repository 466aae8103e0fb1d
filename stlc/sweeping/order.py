"""The order in which a sweep's instances are solved, and the solved plans each one starts
from (``stlc sweep``, the client side).

A warm start is only as good as its neighbour: a plan solved for values close to the
instance's own.  So the client does not submit every instance at once in grid order (then
each worker would warm-start only from what *it* happened to solve, often two grid steps
away); it keeps one task per worker in flight and

* starts with one **seed instance per worker**, spread over the box (k-means centres of the
  instances, snapped to instances), solved cold (the mission's own seed chain), in parallel —
  a race: once the first plan arrives, the cold instances still running are pre-empted
  (their solve stops as on a time limit; the worker keeps its built NLP) and wait again,
  to be solved warm like the others (``requeue``).  A cold solve costs a seed and often
  several times a warm one's iterations (one took 216 against ~35);
* then always submits the unsolved instance **nearest to a solved one** (distances in the
  varied values, each axis scaled by its range, as ``PlanLibrary``), so every warm start
  has a solved neighbour one grid step away whichever worker solved it;
* ships with each task the solved plans of its ``K_SEEDS`` nearest solved instances (the
  client holds every plan: they come back with the rows); the worker starts from the one
  with the best exact robustness at the instance's own values (``stlc.sweeping.task``).

Nothing here changes what an instance's plan is judged on: only IPOPT's starting point.
"""

from __future__ import annotations

import numpy as np

K_SEEDS = 4  #: solved neighbours shipped with a task (the worker scores them)
K_FIT = 6  #: solved neighbours the predicted plan is fitted to
MAX_WEIGHT = 3.0  #: no prediction that extrapolates harder (an affine weight beyond ±3)
PREDICTED = "predicted"  #: label prefix of a predicted seed
KEEP_PLANS = 2000  #: solved plans the client keeps as seeds (the most recent)


def scaled(points: list[dict[str, float]], names: list[str]) -> np.ndarray:
    """Instances as rows, each axis scaled by its range (a constant axis by 1)."""
    a = np.array([[p[n] for n in names] for p in points], dtype=float).reshape(len(points),
                                                                                 len(names))
    span = a.max(axis=0) - a.min(axis=0) if len(a) else np.ones(len(names))
    span[~(span > 0)] = 1.0
    return (a - (a.min(axis=0) if len(a) else 0.0)) / span


def spread(x: np.ndarray, k: int, rounds: int = 30) -> list[int]:
    """``k`` distinct instances spread over the box: Lloyd's k-means from a farthest-point
    start (the instance nearest the centroid first), each centre snapped to the nearest
    instance not taken yet.  Deterministic."""
    n = len(x)
    k = max(1, min(k, n))
    first = int(np.argmin(np.linalg.norm(x - x.mean(axis=0), axis=1)))
    chosen = [first]
    while len(chosen) < k:
        d = np.min(np.linalg.norm(x[:, None, :] - x[chosen][None, :, :], axis=2), axis=1)
        chosen.append(int(np.argmax(d)))
    if k == 1:
        return chosen
    c = x[chosen].copy()
    for _ in range(rounds):
        lab = np.argmin(np.linalg.norm(x[:, None, :] - c[None, :, :], axis=2), axis=1)
        new = np.array([x[lab == j].mean(axis=0) if np.any(lab == j) else c[j]
                        for j in range(k)])
        if np.allclose(new, c):
            break
        c = new
    out: list[int] = []
    for j in range(k):
        d = np.linalg.norm(x - c[j], axis=1)
        d[out] = np.inf
        out.append(int(np.argmin(d)))
    return out


class Order:
    """Which instance to submit next and which solved plans go with it.  Every step is
    linear in the number of instances (a sweep may have 100,000): each waiting instance
    keeps its distance to the nearest solved one, updated as plans arrive; the client keeps
    the plans of the last ``KEEP_PLANS`` solved instances (a handover plan is ~50 kB)."""

    def __init__(self, points: list[dict[str, float]], names: list[str]) -> None:
        self.x = scaled(points, names)
        self.n = len(points)
        self.waiting = np.ones(self.n, dtype=bool)  # not submitted yet
        self.dmin = np.full(self.n, np.inf)  # distance to the nearest solved instance
        self.solved: dict[int, tuple] = {}  # instance → (values, channels, label)

    def seeds(self, k: int) -> list[int]:
        """The first wave: ``k`` spread-out instances (cold starts)."""
        first = spread(self.x, k)
        self.waiting[first] = False
        return first

    def next(self) -> int | None:
        """The waiting instance nearest to a solved one (ties: the lower index); without a
        solved plan yet, the lowest waiting index."""
        if not self.waiting.any():
            return None
        d = np.where(self.waiting, self.dmin, np.inf)
        i = int(np.argmin(d)) if np.isfinite(d).any() else int(np.argmax(self.waiting))
        self.waiting[i] = False
        return i

    def requeue(self, i: int) -> None:
        """``i`` waits again (a pre-empted cold try: ``stlc.sweeping.run``)."""
        self.waiting[i] = True

    def add(self, i: int, values: dict[str, float], channels: dict, label: str) -> None:
        self.solved[i] = (values, channels, label)
        self.dmin = np.minimum(self.dmin, np.linalg.norm(self.x - self.x[i], axis=1))
        while len(self.solved) > KEEP_PLANS:
            del self.solved[next(iter(self.solved))]

    def neighbours(self, i: int, k: int = K_SEEDS) -> list[tuple]:
        """The solved plans of the ``k`` solved instances nearest to ``i``."""
        if not self.solved:
            return []
        ids = list(self.solved)
        d = np.linalg.norm(self.x[ids] - self.x[i], axis=1)
        out = [self.solved[ids[j]] for j in np.argsort(d, kind="stable")[:k]]
        pred = self.predicted(i)
        return out + ([pred] if pred is not None else [])

    def predicted(self, i: int, k: int = K_FIT) -> tuple | None:
        """A first-order predictor (continuation): the plans of the ``k`` solved instances
        nearest to ``i`` fitted, channel by channel, by an affine function of the scaled
        values (least squares, weights 1/distance), evaluated at ``i``.  None when the fit
        does not determine the value at ``i`` (fewer points than its affine hull needs) or
        would extrapolate with a weight beyond ``MAX_WEIGHT``.  It is only a candidate
        start: the worker keeps it if its exact robustness at the instance's own values
        beats the solved neighbours' (``stlc.sweeping.task``); it is not dynamically exact,
        IPOPT makes it so."""
        ids = [j for j in self.solved if j != i]
        if len(ids) < 2:
            return None
        d = np.linalg.norm(self.x[ids] - self.x[i], axis=1)
        pick = np.argsort(d, kind="stable")[:k]
        ids = [ids[j] for j in pick]
        d = d[pick]
        A = np.hstack([np.ones((len(ids), 1)), self.x[ids] - self.x[i]])
        sw = np.sqrt(1.0 / np.maximum(d, 1e-9))
        Aw = A * sw[:, None]
        pinv = np.linalg.pinv(Aw)
        e = np.zeros(A.shape[1])
        e[0] = 1.0
        if not np.allclose(e @ pinv @ Aw, e, atol=1e-8):
            return None  # the value at i is not determined by these points
        c = (e @ pinv) * sw  # affine weights: the prediction is Σ c_j · plan_j
        if np.max(np.abs(c)) > MAX_WEIGHT:
            return None
        plans = [self.solved[j][1] for j in ids]
        names = set(plans[0]).intersection(*plans[1:])
        ch = {n: sum(cj * np.asarray(p[n], float) for cj, p in zip(c, plans))
              for n in sorted(names)}
        values = {n: sum(cj * self.solved[j][0][n] for cj, j in zip(c, ids))
                  for n in self.solved[ids[0]][0]}
        return values, ch, f"{PREDICTED} from {len(ids)} solved neighbours"
