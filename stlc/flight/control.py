"""Tracking controllers of the closed loop, vectorised over runs (arrays of N states).

* **Multirotors**: the geometric controller on SE(3) of Lee, Leok & McClamroch (2010,
  "Geometric tracking control of a quadrotor UAV on SE(3)"), with the plan's position,
  velocity, acceleration and yaw (rate) as feedforward:
  ``F = −k_x e_x − k_v e_v + m (a_d + g e₃)`` (world), ``e_R = ½ (R_dᵀR − RᵀR_d)^∨``,
  ``e_Ω = Ω − RᵀR_d Ω_d``, ``M = −k_R e_R − k_Ω e_Ω + Ω × JΩ``.  An under-actuated vehicle
  (wrench matrix of rank < 6: a quadrotor, a flat hexarotor) takes R_d from F's direction
  and the plan's yaw and applies the thrust F·Re₃ along its body z; a fully actuated one
  (the tilted hexarotor) takes R_d from the plan's attitude and applies the whole body
  force RᵀF.  The wrench is allocated to rotor forces through the pseudo-inverse of the
  vehicle's rotor matrix (``stlc.vehicles.geometry``) and saturated at the declared force
  bounds; for a fully actuated vehicle with priorities — the feedforward force and the
  moment first, then the largest part of the position feedback force the bounds allow;
  the horizontal part it could not give tilts the next step's desired attitude (the
  plan's, turned so its body z leans that way), as an under-actuated vehicle would.
* **Point masses**: a PD tracker with acceleration feedforward,
  ``a = a_d − k_p e_x − k_d e_v``, clipped to the declared acceleration bounds.

Gains (``Gains``): position ω_p = 4 rad/s, ζ = 0.7 (Lee et al.'s k_x = 16 m, k_v = 5.6 m);
attitude ω_R = 25 rad/s, ζ = 0.8 per body axis (k_R = J ω_R², k_Ω = 2ζω_R J); point mass
ω = 3 rad/s, ζ = 0.9.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from stlc.vehicles.geometry import allocation


@dataclass(frozen=True)
class Gains:
    """Per unit mass (position: k_x = m·kp_pos, k_v = m·kd_pos, per world axis) and per
    unit inertia (attitude: k_R = J·kp_att, k_Ω = J·kd_att); the point mass's PD gains."""

    kp_pos: tuple[float, float, float] = (16.0, 16.0, 16.0)  # ω_p = 4 rad/s
    kd_pos: tuple[float, float, float] = (5.6, 5.6, 5.6)  # ζ = 0.7
    kp_att: float = 625.0  # ω_R = 25 rad/s
    kd_att: float = 40.0  # ζ = 0.8
    pm_w: float = 3.0
    pm_zeta: float = 0.9


def hat(w: np.ndarray) -> np.ndarray:
    """(N, 3) → (N, 3, 3) skew matrices."""
    out = np.zeros((w.shape[0], 3, 3))
    out[:, 0, 1], out[:, 0, 2], out[:, 1, 2] = -w[:, 2], w[:, 1], -w[:, 0]
    out[:, 1, 0], out[:, 2, 0], out[:, 2, 1] = w[:, 2], -w[:, 1], w[:, 0]
    return out


def cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Row-wise a × b of (N, 3) arrays (``np.cross`` without its axis handling)."""
    out = np.empty(np.broadcast_shapes(a.shape, b.shape))
    out[..., 0] = a[..., 1] * b[..., 2] - a[..., 2] * b[..., 1]
    out[..., 1] = a[..., 2] * b[..., 0] - a[..., 0] * b[..., 2]
    out[..., 2] = a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]
    return out


def vee(m: np.ndarray) -> np.ndarray:
    return np.stack([m[:, 2, 1], m[:, 0, 2], m[:, 1, 0]], axis=-1)


def _unit(x: np.ndarray) -> np.ndarray:
    return x / np.maximum(np.linalg.norm(x, axis=-1, keepdims=True), 1e-9)


class Geometric:
    """Lee et al.'s controller for one multirotor ``v`` (``stlc.vehicles.declared``)."""

    def __init__(self, v, gains: Gains = Gains()):
        self.m = float(v.mass)
        self.g = float(v.gravity)
        self.J = np.array(v.inertia, dtype=float)
        self.G_f, self.G_tau = allocation(v.rotors, v.c_f, v.c_tau)
        W = np.vstack([self.G_f, self.G_tau])
        self.full = np.linalg.matrix_rank(W, tol=1e-8) == 6
        rows = W if self.full else np.vstack([self.G_f[2:3], self.G_tau])
        self.alloc = np.linalg.pinv(rows)
        self.lo, self.hi = float(v.force_min), float(v.force_max)
        self.kx = self.m * np.asarray(gains.kp_pos, dtype=float)
        self.kv = self.m * np.asarray(gains.kd_pos, dtype=float)
        jd = np.diag(self.J)
        self.kR = jd * gains.kp_att
        self.kW = jd * gains.kd_att
        #: (N, 3) the horizontal feedback force the rotor bounds refused at the last step
        self.unmet: np.ndarray | None = None

    def __call__(self, p, v, R, w, ref) -> np.ndarray:
        """Rotor force commands (N, n) for measured positions, velocities (N, 3), attitudes
        (N, 3, 3), body rates (N, 3) and the reference ``ref`` (``Reference.at``)."""
        e3 = np.array([0.0, 0.0, 1.0])
        F = -self.kx * (p - ref.pos) - self.kv * (v - ref.vel) + self.m * (ref.acc + self.g * e3)
        if self.full:
            Rd = ref.R[None] if self.unmet is None else _tilted(ref.R, self.unmet, F)
            body_f = np.einsum("nji,nj->ni", R, F)
        else:
            b3 = _unit(F)
            b1c = np.array([np.cos(ref.yaw), np.sin(ref.yaw), 0.0])
            b2 = _unit(cross(b3, b1c))
            b1 = cross(b2, b3)
            Rd = np.stack([b1, b2, b3], axis=-1)
            thrust = np.einsum("ni,ni->n", F, R[:, :, 2])
        RdT_R = np.matmul(np.swapaxes(Rd, -1, -2), R)
        eR = 0.5 * vee(RdT_R - np.transpose(RdT_R, (0, 2, 1)))
        wd = np.array([0.0, 0.0, ref.yaw_rate])
        eW = w - np.einsum("nji,j->ni", RdT_R, wd)
        Jw = w @ self.J.T
        M = -self.kR * eR - self.kW * eW + cross(w, Jw)
        if not self.full:
            wrench = np.concatenate([thrust[:, None], M], axis=1)
            return np.clip(wrench @ self.alloc.T, self.lo, self.hi)
        # prioritised allocation: the feedforward force and the moment first, then as much
        # of the position feedback force as the rotor bounds leave (a saturated wrench
        # would otherwise lose the attitude, yaw first)
        ff = self.m * (ref.acc + self.g * e3)
        zero = np.zeros_like(M)
        base = np.concatenate([np.einsum("nji,j->ni", R, ff), M], axis=1) @ self.alloc.T
        extra = np.concatenate([body_f - np.einsum("nji,j->ni", R, ff), zero],
                               axis=1) @ self.alloc.T
        with np.errstate(divide="ignore", invalid="ignore"):
            room = np.where(extra > 0, (self.hi - base) / extra,
                            np.where(extra < 0, (self.lo - base) / extra, np.inf))
        scale = np.clip(np.min(room, axis=1), 0.0, 1.0)
        unmet = (1.0 - scale)[:, None] * (F - ff)
        unmet[:, 2] = 0.0  # horizontal: what tilting the body can add
        self.unmet = unmet
        return np.clip(base + scale[:, None] * extra, self.lo, self.hi)


def _tilted(R_plan: np.ndarray, unmet: np.ndarray, F: np.ndarray) -> np.ndarray:
    """The plan's attitude turned (by the smallest rotation) so that its body z leans
    toward the horizontal force the rotors could not give: b3 → unit(|F| b3 + unmet)."""
    b3 = R_plan[:, 2]
    target = _unit(np.linalg.norm(F, axis=1, keepdims=True) * b3 + unmet)
    axis = cross(np.broadcast_to(b3, target.shape), target)
    s = np.linalg.norm(axis, axis=1)
    c = target @ b3
    th = np.arctan2(s, c)
    K = hat(axis / np.maximum(s, 1e-12)[:, None])
    rot = np.eye(3) + np.sin(th)[:, None, None] * K + (1 - np.cos(th))[:, None, None] * (K @ K)
    return rot @ R_plan


class PointTracker:
    """The PD tracker of a point mass ``v``: acceleration commands (N, 3)."""

    def __init__(self, v, gains: Gains = Gains()):
        self.kp = gains.pm_w**2
        self.kd = 2 * gains.pm_zeta * gains.pm_w
        self.amax = np.asarray(v.acc_max, dtype=float)

    def __call__(self, p, v, ref) -> np.ndarray:
        a = ref.acc - self.kp * (p - ref.pos) - self.kd * (v - ref.vel)
        return np.clip(a, -self.amax, self.amax)
