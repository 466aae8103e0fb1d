"""Frames, attitude convention and units of every flight output and input.

World frame: **ENU** — x east, y north, z up (ROS REP 103), metres, origin where the
mission's ``scenario`` puts it; gravity is (0, 0, −g).  Body frame: **FLU** — x forward,
y left, z up.  Attitude: ZYX Euler angles η = (roll φ, pitch θ, yaw ψ) in radians with
R = Rz(ψ) Ry(θ) Rx(φ) rotating body vectors into the world (``stlc.vehicles.dynamics``);
yaw is measured from east, counter-clockwise seen from above.

PX4 uses **NED** (x north, y east, z down) for the world and **FRD** (forward, right, down)
for the body.  A position or velocity (x, y, z) in ENU is (y, x, −z) in NED; a yaw ψ from
east counter-clockwise is π/2 − ψ from north clockwise (wrapped to (−π, π]); a yaw rate
changes sign.  The map is its own inverse for vectors.

Time: a plan's samples are seconds from the mission's start.  PX4 CSVs count
microseconds from the mission's start; the ROS 2 bag stamps a sample at
``BAG_EPOCH_NS + t·10⁹`` ns (the mission starts at ``BAG_EPOCH_NS``, the Unix epoch
1970-01-01T00:00:00Z, so a stamp *is* the time from the mission's start).
"""

from __future__ import annotations

import numpy as np

WORLD = "ENU"
BODY = "FLU"
EULER = "ZYX"  # R = Rz(yaw) Ry(pitch) Rx(roll), body → world
#: the ROS frame ids written into bags: the world, and each drone's body ``<drone>/base_link``
FRAME_ID = "map"
BAG_EPOCH_NS = 0

#: ENU ↔ NED for vectors (its own inverse); FLU ↔ FRD for body vectors
ENU_NED = np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]])
FLU_FRD = np.diag([1.0, -1.0, -1.0])


def enu_to_ned(v: np.ndarray) -> np.ndarray:
    """(…, 3) ENU vectors → NED: (y, x, −z)."""
    v = np.asarray(v, dtype=float)
    return np.stack([v[..., 1], v[..., 0], -v[..., 2]], axis=-1)


ned_to_enu = enu_to_ned  # the same swap


def wrap(a: np.ndarray) -> np.ndarray:
    """Angles wrapped to (−π, π]."""
    a = np.asarray(a, dtype=float)
    return np.pi - np.mod(np.pi - a, 2.0 * np.pi)


def yaw_enu_to_ned(yaw: np.ndarray) -> np.ndarray:
    """Yaw from east counter-clockwise → from north clockwise (PX4), wrapped."""
    return wrap(np.pi / 2.0 - np.asarray(yaw, dtype=float))


yaw_ned_to_enu = yaw_enu_to_ned  # the same reflection


def rotation(eta: np.ndarray) -> np.ndarray:
    """(…, 3) ZYX Euler angles → (…, 3, 3) rotation matrices body → world."""
    eta = np.asarray(eta, dtype=float)
    cf, sf = np.cos(eta[..., 0]), np.sin(eta[..., 0])
    ct, st = np.cos(eta[..., 1]), np.sin(eta[..., 1])
    cp, sp = np.cos(eta[..., 2]), np.sin(eta[..., 2])
    rows = [[cp * ct, cp * st * sf - sp * cf, cp * st * cf + sp * sf],
            [sp * ct, sp * st * sf + cp * cf, sp * st * cf - cp * sf],
            [-st, ct * sf, ct * cf]]
    return np.stack([np.stack(row, axis=-1) for row in rows], axis=-2)


def euler(r: np.ndarray) -> np.ndarray:
    """(…, 3, 3) rotation matrices → ZYX Euler angles (roll, pitch, yaw)."""
    r = np.asarray(r, dtype=float)
    roll = np.arctan2(r[..., 2, 1], r[..., 2, 2])
    pitch = np.arcsin(np.clip(-r[..., 2, 0], -1.0, 1.0))
    yaw = np.arctan2(r[..., 1, 0], r[..., 0, 0])
    return np.stack([roll, pitch, yaw], axis=-1)


def quaternion(eta: np.ndarray) -> np.ndarray:
    """(…, 3) ZYX Euler angles → (…, 4) unit quaternions (w, x, y, z) of the same rotation."""
    eta = np.asarray(eta, dtype=float)
    cr, sr = np.cos(eta[..., 0] / 2), np.sin(eta[..., 0] / 2)
    cp, sp = np.cos(eta[..., 1] / 2), np.sin(eta[..., 1] / 2)
    cy, sy = np.cos(eta[..., 2] / 2), np.sin(eta[..., 2] / 2)
    return np.stack([cr * cp * cy + sr * sp * sy, sr * cp * cy - cr * sp * sy,
                     cr * sp * cy + sr * cp * sy, cr * cp * sy - sr * sp * cy], axis=-1)


def quaternion_matrix(q: np.ndarray) -> np.ndarray:
    """(…, 4) quaternions (w, x, y, z), normalised here → (…, 3, 3) rotation matrices."""
    q = np.asarray(q, dtype=float)
    q = q / np.linalg.norm(q, axis=-1, keepdims=True)
    w, x, y, z = (q[..., i] for i in range(4))
    rows = [[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]]
    return np.stack([np.stack(row, axis=-1) for row in rows], axis=-2)


def ned_frd_to_enu_flu(r_ned: np.ndarray) -> np.ndarray:
    """A PX4 attitude (FRD body → NED world) as stlc's (FLU body → ENU world)."""
    return ENU_NED @ np.asarray(r_ned, dtype=float) @ FLU_FRD
