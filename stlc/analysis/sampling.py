"""Sampling of uncertain scenario parameters, and the human-frame geometry used to check them.

The risk analysis (``stlc.analysis.risk``) evaluates one fixed plan under K realisations of the
uncertain scenario parameters (typically a human's pose, ``Param`` leaves named
``"operator.pos.x"`` … ``"operator.att.z"``).  This module draws those realisations:

* every ``Normal`` is a joint Gaussian over its named parameters; ``mean`` is the *absolute*
  value of each parameter (not an offset from the nominal pose);
* a covariance may be singular positive semi-definite, e.g. ``diag(σ², σ², 0)``.  A
  coordinate with zero variance is never touched by noise, so it stays *exactly* at its
  mean; the remaining block is factored as ``cov = A Aᵀ`` (Cholesky, or a clipped
  eigen-decomposition when Cholesky fails on a singular block);
* parameters not covered by any distribution keep their nominal value, as a plain float,
  so the monitor broadcasts them;
* the draws come from ``np.random.default_rng(seed)``, one ``standard_normal((K, m))``
  block per ``Normal`` in the given order: same seed → same numbers.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np

from stlc.semantics.model import Normal, Scenario

#: relative tolerance for symmetry / positive semi-definiteness of a covariance
PSD_TOL = 1e-9


class SamplingError(ValueError):
    """A distribution cannot be sampled (bad shape, not symmetric, not PSD, duplicates)."""


def covariance_factor(cov: np.ndarray) -> np.ndarray:
    """Return A with ``A @ A.T == cov`` for a symmetric PSD matrix.

    Rows and columns of zero-variance coordinates are exactly zero in A, so noise never
    reaches them.  Raises ``SamplingError`` if ``cov`` is not symmetric PSD.
    """
    cov = np.asarray(cov, dtype=float)
    n = cov.shape[0]
    if cov.shape != (n, n) or not np.all(np.isfinite(cov)):
        raise SamplingError(f"covariance must be a finite square matrix, got shape {cov.shape}")
    scale = max(float(np.max(np.abs(cov))) if n else 0.0, 1e-300)
    if not np.allclose(cov, cov.T, rtol=0.0, atol=PSD_TOL * scale):
        raise SamplingError("covariance is not symmetric")
    cov = 0.5 * (cov + cov.T)
    diag = np.diag(cov)
    if np.any(diag < -PSD_TOL * scale):
        raise SamplingError("covariance has a negative variance")
    active = diag > PSD_TOL * scale
    fixed = ~active
    if np.any(np.abs(cov[fixed]) > PSD_TOL * scale):
        raise SamplingError("a zero-variance coordinate has non-zero covariance with another one")
    A = np.zeros((n, n))
    idx = np.flatnonzero(active)
    if idx.size:
        sub = cov[np.ix_(idx, idx)]
        try:
            L = np.linalg.cholesky(sub)
        except np.linalg.LinAlgError:
            w, V = np.linalg.eigh(sub)
            if w[0] < -PSD_TOL * scale * idx.size:
                raise SamplingError(
                    f"covariance is not positive semi-definite (eigenvalue {w[0]:.3g})"
                ) from None
            L = V * np.sqrt(np.clip(w, 0.0, None))
        A[np.ix_(idx, idx)] = L
    return A


def merge_distributions(base: Sequence[Normal], override: Sequence[Normal]) -> list[Normal]:
    """Distributions of ``override`` replace those of ``base`` parameter by parameter.

    A base Gaussian that shares some parameters with an override is reduced to its marginal
    over the parameters it keeps (sub-mean, sub-covariance).  Base ones come first, in
    order, then the overrides.
    """
    taken = {p for d in override for p in d.params}
    out: list[Normal] = []
    for d in base:
        keep = [i for i, p in enumerate(d.params) if p not in taken]
        if len(keep) == len(d.params):
            out.append(d)
        elif keep:
            out.append(Normal(
                params=tuple(d.params[i] for i in keep),
                mean=tuple(d.mean[i] for i in keep),
                cov=tuple(tuple(d.cov[i][j] for j in keep) for i in keep),
                span=d.span,
            ))
    out.extend(override)
    return out


def sample_params(
    nominal: Mapping[str, float],
    distributions: Sequence[Normal],
    K: int,
    seed: int,
) -> dict[str, float | np.ndarray]:
    """K realisations of the scenario parameters.

    Returns every nominal parameter plus every sampled one: sampled parameters map to an
    array of shape (K,), the others to their nominal float.
    """
    if K < 1:
        raise SamplingError(f"K must be at least 1, got {K}")
    out: dict[str, float | np.ndarray] = {k: float(v) for k, v in nominal.items()}
    rng = np.random.default_rng(seed)
    seen: set[str] = set()
    for d in distributions:
        m = len(d.params)
        mean = np.asarray(d.mean, dtype=float)
        cov = np.asarray(d.cov, dtype=float).reshape(m, m) if m else np.zeros((0, 0))
        if mean.shape != (m,) or cov.shape != (m, m):
            raise SamplingError(f"distribution over {d.params} has mismatched mean/cov sizes")
        dup = seen.intersection(d.params)
        if dup or len(set(d.params)) != m:
            raise SamplingError(f"parameter(s) {sorted(dup) or d.params} sampled twice")
        seen.update(d.params)
        A = covariance_factor(cov)
        z = rng.standard_normal((K, m))
        x = z @ A.T
        for j, name in enumerate(d.params):
            out[name] = x[:, j] + mean[j]  # row j of A is 0 for zero variance: exactly the mean
    return out


# --------------------------------------------------------------------------- geometry


def rotation(att: np.ndarray) -> np.ndarray:
    """R = Rz(yaw) Ry(pitch) Rx(roll) (body → world) for ``att = (roll, pitch, yaw)``;
    ``att`` has shape (..., 3), the result (..., 3, 3)."""
    att = np.asarray(att, dtype=float)
    cr, sr = np.cos(att[..., 0]), np.sin(att[..., 0])
    cp, sp = np.cos(att[..., 1]), np.sin(att[..., 1])
    cy, sy = np.cos(att[..., 2]), np.sin(att[..., 2])
    R = np.empty(att.shape[:-1] + (3, 3))
    R[..., 0, 0] = cy * cp
    R[..., 0, 1] = cy * sp * sr - sy * cr
    R[..., 0, 2] = cy * sp * cr + sy * sr
    R[..., 1, 0] = sy * cp
    R[..., 1, 1] = sy * sp * sr + cy * cr
    R[..., 1, 2] = sy * sp * cr - cy * sr
    R[..., 2, 0] = -sp
    R[..., 2, 1] = cp * sr
    R[..., 2, 2] = cp * cr
    return R


def human_frame_point(p_world, human_pos, human_att) -> np.ndarray:
    """A world point in a human's frame: ``p_local = R(att)ᵀ (p_world − pos)``.

    All arguments have shape (..., 3) and broadcast against each other (e.g. one point
    against K sampled poses).
    """
    d = np.asarray(p_world, dtype=float) - np.asarray(human_pos, dtype=float)
    R = rotation(human_att)
    return np.einsum("...ji,...j->...i", R, d)


def scenario_distributions(scenario: Scenario) -> list[Normal]:
    """The ``uncertain`` distributions declared on the scenario's humans, in order (the
    default that each risk case overrides, see ``merge_distributions``)."""
    return [d for h in scenario.humans for d in h.uncertain]
