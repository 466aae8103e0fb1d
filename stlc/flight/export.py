"""Flight-stack outputs of a plan, written beside ``trajectory.csv`` by ``stlc compile``:

* ``flight/<drone>.px4.csv`` — PX4 offboard ``TrajectorySetpoint`` fields per plan sample:
  ``timestamp_us`` (µs from the mission's start), ``x,y,z`` (m, NED), ``vx,vy,vz`` (m/s,
  NED), ``ax,ay,az`` (m/s², NED), ``yaw`` (rad, from north clockwise), ``yawspeed``
  (rad/s);
* ``flight/<drone>.mrs.csv`` — the MRS UAV System trajectory: ``x,y,z,heading`` (m, m, m,
  rad; ENU) every ``MRS_DT`` s, no header (the loader reads four numbers a line);
* ``rosbag2/`` — a ROS 2 bag (MCAP, ``rosbags``) with ``/<drone>/path``
  (``nav_msgs/msg/Path``, one pose per plan sample) and ``/<drone>/trajectory``
  (``trajectory_msgs/msg/MultiDOFJointTrajectory``, pose, twist and acceleration per
  sample), both in frame ``map`` (ENU) stamped at the mission's start.

Frames and epoch: ``stlc.flight.frames``.  The accelerations are the vehicle model's own
(its ODE at each planned state and input); yaw and yaw rate likewise for a vehicle with an
attitude, zero for a point mass (which has none).
"""

from __future__ import annotations

import os
from dataclasses import dataclass

import numpy as np

from stlc.flight import frames
from stlc.vehicles import model_of

MRS_DT = 0.2  # s, the MRS trajectory's sampling period
BAG_DIR = "rosbag2"
FLIGHT_DIR = "flight"


@dataclass(frozen=True)
class Track:
    """One drone's plan in ENU: times (n,) s, position, velocity, acceleration (n, 3),
    Euler angles (n, 3) rad, yaw rate (n,) rad/s, body rates (n, 3) rad/s."""

    drone: str
    t: np.ndarray
    pos: np.ndarray
    vel: np.ndarray
    acc: np.ndarray
    att: np.ndarray
    yaw_rate: np.ndarray
    rate: np.ndarray


def _matrix(channels: dict, names: list[str], n: int) -> np.ndarray | None:
    if not all(c in channels for c in names):
        return None
    return np.stack([np.asarray(channels[c], dtype=float)[:n] for c in names], axis=1)


def track(vehicle, times: np.ndarray, channels: dict) -> Track:
    """The plan of ``vehicle`` in ``channels`` (``trajectory.csv``'s names) as a ``Track``;
    acceleration and Euler rates from the model's ODE where its states and inputs are all
    present, from the velocity's finite differences otherwise."""
    vm = model_of(vehicle)
    t = np.asarray(times, dtype=float)
    n = t.size
    name = vehicle.name
    X = _matrix(channels, vm.state_channels(vehicle), n)
    U = _matrix(channels, vm.input_channels(vehicle), n)
    pos = _matrix(channels, [f"{name}.pos.{a}" for a in "xyz"], n)
    vel = _matrix(channels, [f"{name}.vel.{a}" for a in "xyz"], n)
    if vel is None:
        vel = np.gradient(pos, t, axis=0) if n > 1 else np.zeros_like(pos)
    att = _matrix(channels, [f"{name}.att.{a}" for a in "xyz"], n)
    rate = _matrix(channels, [f"{name}.rate.{a}" for a in "xyz"], n)
    xdot = None
    if X is not None and U is not None:
        f = vm.ode(vehicle).map(n)
        xdot = np.asarray(f(X.T, U.T)).T
    acc = xdot[:, vm.vel_index()] if xdot is not None else \
        (np.gradient(vel, t, axis=0) if n > 1 else np.zeros_like(vel))
    if att is None:
        att, yaw_rate = np.zeros((n, 3)), np.zeros(n)
    elif xdot is not None:
        ix = vm.state_channels(vehicle).index(f"{name}.att.z")
        yaw_rate = xdot[:, ix]
    else:
        yaw_rate = np.gradient(np.unwrap(att[:, 2]), t) if n > 1 else np.zeros(n)
    return Track(name, t, pos, vel, np.asarray(acc, dtype=float), att, yaw_rate,
                 np.zeros((n, 3)) if rate is None else rate)


def tracks(program, mission, times: np.ndarray, channels: dict) -> list[Track]:
    return [track(program.vehicles[d], times, channels) for d in mission.vehicles
            if f"{d}.pos.x" in channels]


def _g(x: float) -> str:
    return format(float(x) + 0.0, ".9g")  # + 0.0: no "-0"


def px4_csv(tr: Track) -> str:
    """PX4 ``TrajectorySetpoint`` rows (NED) of one drone's plan."""
    p, v, a = (frames.enu_to_ned(x) for x in (tr.pos, tr.vel, tr.acc))
    yaw = frames.yaw_enu_to_ned(tr.att[:, 2])
    lines = ["timestamp_us,x,y,z,vx,vy,vz,ax,ay,az,yaw,yawspeed"]
    us = np.rint(tr.t * 1e6).astype(np.int64)
    for k in range(tr.t.size):
        vals = [*p[k], *v[k], *a[k], yaw[k], -tr.yaw_rate[k]]
        lines.append(f"{us[k]}," + ",".join(_g(x) for x in vals))
    return "\n".join(lines) + "\n"


def mrs_csv(tr: Track, dt: float = MRS_DT) -> str:
    """The MRS trajectory (``x,y,z,heading``, ENU) every ``dt`` s, linear interpolation of
    position and of the unwrapped heading."""
    t_end = float(tr.t[-1])
    ts = np.arange(0.0, t_end + 1e-9, dt)
    yaw = np.unwrap(tr.att[:, 2])
    cols = [np.interp(ts, tr.t, tr.pos[:, i]) for i in range(3)] + [np.interp(ts, tr.t, yaw)]
    return "".join(",".join(_g(c[k]) for c in cols) + "\n" for k in range(ts.size))


def _stamp(ts, t: float):
    ns = frames.BAG_EPOCH_NS + int(round(t * 1e9))
    return ts.types["builtin_interfaces/msg/Time"](sec=ns // 10**9, nanosec=ns % 10**9)


def write_bag(path: str, trs: list[Track]) -> None:
    """The ROS 2 bag (MCAP) of the plans ``trs`` into the new directory ``path``."""
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.typesys import Stores, get_typestore

    ts = get_typestore(Stores.ROS2_HUMBLE)
    T = ts.types
    Header, Pose, PoseStamped = (T["std_msgs/msg/Header"], T["geometry_msgs/msg/Pose"],
                                 T["geometry_msgs/msg/PoseStamped"])
    Point, Quat, Vec = (T["geometry_msgs/msg/Point"], T["geometry_msgs/msg/Quaternion"],
                        T["geometry_msgs/msg/Vector3"])
    Transform, Twist = T["geometry_msgs/msg/Transform"], T["geometry_msgs/msg/Twist"]
    Point_ = T["trajectory_msgs/msg/MultiDOFJointTrajectoryPoint"]
    Duration = T["builtin_interfaces/msg/Duration"]
    with Writer(path, version=9, storage_plugin=StoragePlugin.MCAP) as w:
        for tr in trs:
            q = frames.quaternion(tr.att)
            head = Header(stamp=_stamp(ts, 0.0), frame_id=frames.FRAME_ID)
            poses, points = [], []
            for k in range(tr.t.size):
                x, y, z = (float(c) for c in tr.pos[k])
                qk = Quat(x=float(q[k, 1]), y=float(q[k, 2]), z=float(q[k, 3]),
                          w=float(q[k, 0]))
                poses.append(PoseStamped(Header(stamp=_stamp(ts, float(tr.t[k])),
                                                frame_id=frames.FRAME_ID),
                                         Pose(Point(x=x, y=y, z=z), qk)))
                ns = int(round(float(tr.t[k]) * 1e9))
                points.append(Point_(
                    transforms=[Transform(Vec(x=x, y=y, z=z), qk)],
                    velocities=[Twist(Vec(*(float(c) for c in tr.vel[k])),
                                      Vec(*(float(c) for c in tr.rate[k])))],
                    accelerations=[Twist(Vec(*(float(c) for c in tr.acc[k])),
                                         Vec(x=0.0, y=0.0, z=0.0))],
                    time_from_start=Duration(sec=ns // 10**9, nanosec=ns % 10**9)))
            path_msg = T["nav_msgs/msg/Path"](head, poses)
            traj = T["trajectory_msgs/msg/MultiDOFJointTrajectory"](head, [tr.drone], points)
            for topic, msg in ((f"/{tr.drone}/path", path_msg),
                               (f"/{tr.drone}/trajectory", traj)):
                conn = w.add_connection(topic, msg.__msgtype__, typestore=ts)
                w.write(conn, frames.BAG_EPOCH_NS, ts.serialize_cdr(msg, msg.__msgtype__))


def write_flight_outputs(stage: str, program, mission, times: np.ndarray, channels: dict
                         ) -> list[str]:
    """Write the flight-stack outputs of a plan into the staging directory ``stage``;
    returns the relative names written."""
    trs = tracks(program, mission, times, channels)
    if not trs:
        return []
    os.makedirs(os.path.join(stage, FLIGHT_DIR), exist_ok=True)
    names = []
    for tr in trs:
        for suffix, text in (("px4", px4_csv(tr)), ("mrs", mrs_csv(tr))):
            name = f"{FLIGHT_DIR}/{tr.drone}.{suffix}.csv"
            with open(os.path.join(stage, name), "w") as fh:
                fh.write(text)
            names.append(name)
    write_bag(os.path.join(stage, BAG_DIR), trs)
    names += [f"{BAG_DIR}/{n}" for n in sorted(os.listdir(os.path.join(stage, BAG_DIR)))]
    return names
