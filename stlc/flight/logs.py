"""Flight logs in: a PX4 ULog or a ROS 2 bag as a ``Trace`` that the exact monitor reads
(``stlc monitor FILE.stl --log PATH [--map DRONE=TOPIC]``).

* **ULog** (``pyulog``): ``vehicle_local_position`` (x, y, z, vx, vy, vz in NED) and
  ``vehicle_attitude`` (quaternion FRD → NED), converted to stlc's ENU/FLU
  (``stlc.flight.frames``); ``--map uav1=N`` picks the topics' instance N (default 0).
* **ROS 2 bag** (a bag folder, sqlite3 or MCAP, or a single ``.mcap`` file; ``rosbags``):
  ``nav_msgs/msg/Odometry`` (pose in the header's frame, twist in ``child_frame_id``'s,
  rotated into the world by the pose) or ``geometry_msgs/msg/PoseStamped`` (velocity by
  finite differences), stamped by their headers; frames are ROS's (ENU, FLU).  Without
  ``--map`` each vehicle takes the one such topic whose name starts with ``/<vehicle>/``.

Each stream is interpolated linearly onto the mission's grid (``dt``: the ``--resample``
step, else the mission's) from the latest first sample to the earliest last sample of the
streams, time 0 at the grid's start; the largest gap of every stream is noted.
Channels: ``<v>.pos.*``, ``<v>.vel.*``, and ``<v>.att.*`` where the log has an attitude.
A log that cannot be read, or lacks a mapped topic, is an STL601/STL603 diagnostic.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass

import numpy as np

from stlc.analysis.trace import Trace
from stlc.diagnostics import Diagnostic, Span, StlcError
from stlc.flight import frames

STREAM_TYPES = ("nav_msgs/msg/Odometry", "geometry_msgs/msg/PoseStamped")


@dataclass
class Stream:
    """One vehicle's log: sample times (s), ENU positions and velocities (n, 3), Euler
    angles (n, 3) or None."""

    source: str
    t: np.ndarray
    pos: np.ndarray
    vel: np.ndarray
    att: np.ndarray | None


def _fail(code: str, path: str, message: str, help_: str, at: Span | None = None
          ) -> StlcError:
    """A diagnostic at ``at`` (a vehicle's declaration in the .stl file, rather than a line
    of a binary log), else at the log itself."""
    span = at if at is not None and at.known else Span(path, 1, 1, 1, 2)
    return StlcError([Diagnostic(code, message, span, help_)])


def is_ulog(path: str) -> bool:
    try:
        with open(path, "rb") as fh:
            return fh.read(7) == b"ULog\x01\x12\x35"
    except OSError:
        return False


# ---------------------------------------------------------------- ULog


def _ulog_streams(path: str, vehicles: list[str], maps: dict[str, str],
                  at: dict[str, Span]) -> dict[str, Stream]:
    from pyulog import ULog

    try:
        log = ULog(path, ["vehicle_local_position", "vehicle_attitude"])
    except Exception as e:  # noqa: BLE001 - pyulog raises many kinds on a broken file
        raise _fail("STL601", path, f"cannot read the ULog `{path}`: {e}",
                    "give a PX4 .ulg file") from None
    topics = {(d.name, d.multi_id): d.data for d in log.data_list}
    out = {}
    for v in vehicles:
        inst = maps.get(v, "0")
        if not inst.isdigit():
            raise _fail("STL603", path, f"`--map {v}={inst}`: a ULog's topics are chosen by "
                        "instance number", f"write `--map {v}=0`", at.get(v))
        lp = topics.get(("vehicle_local_position", int(inst)))
        if lp is None or len(lp["timestamp"]) == 0:
            raise _fail("STL603", path, f"the ULog `{path}` has no vehicle_local_position "
                        f"instance {inst} for `{v}`",
                        "log vehicle_local_position (PX4's default logger does)", at.get(v))
        t = lp["timestamp"].astype(np.float64) * 1e-6
        ned = np.stack([lp[c] for c in ("x", "y", "z")], axis=1).astype(float)
        vned = np.stack([lp[c] for c in ("vx", "vy", "vz")], axis=1).astype(float)
        pos, vel = frames.ned_to_enu(ned), frames.ned_to_enu(vned)
        att = None
        va = topics.get(("vehicle_attitude", int(inst)))
        if va is not None and len(va["timestamp"]):
            q = np.stack([va[f"q[{i}]"] for i in range(4)], axis=1).astype(float)
            eta = frames.euler(frames.ned_frd_to_enu_flu(frames.quaternion_matrix(q)))
            ta = va["timestamp"].astype(np.float64) * 1e-6
            att = np.stack([_interp_angle(t, ta, eta[:, i]) for i in range(3)], axis=1)
        out[v] = Stream(f"vehicle_local_position[{inst}]", t, pos, vel, att)
    return out


def _interp_angle(t: np.ndarray, ts: np.ndarray, a: np.ndarray) -> np.ndarray:
    return frames.wrap(np.interp(t, ts, np.unwrap(a)))


# ---------------------------------------------------------------- ROS 2 bags


def _bag_streams(path: str, vehicles: list[str], maps: dict[str, str],
                 at: dict[str, Span]) -> dict[str, Stream]:
    from pathlib import Path

    from rosbags.highlevel import AnyReader

    try:
        reader = AnyReader([Path(path)])
        reader.open()
    except Exception as e:  # noqa: BLE001 - rosbags raises many kinds on a broken bag
        raise _fail("STL601", path, f"cannot read the ROS 2 bag `{path}`: {e}",
                    "give a rosbag2 folder (metadata.yaml + .db3/.mcap) or an .mcap "
                    "file") from None
    try:
        usable = {c.topic: c for c in reader.connections if c.msgtype in STREAM_TYPES}
        chosen = {}
        for v in vehicles:
            topic = maps.get(v)
            if topic is None:
                cands = sorted(t for t in usable if t.startswith(f"/{v}/"))
                if len(cands) != 1:
                    raise _fail("STL603", path, f"cannot tell which topic of `{path}` is "
                                f"`{v}`'s: " + (", ".join(cands) or "no Odometry or "
                                                "PoseStamped topic under /" + v + "/"),
                                f"name it: `--map {v}=/{v}/odom` (topics: "
                                + (", ".join(sorted(usable)) or "none usable") + ")", at.get(v))
                topic = cands[0]
            if topic not in usable:
                raise _fail("STL603", path, f"the bag `{path}` has no Odometry or "
                            f"PoseStamped topic `{topic}` (for `{v}`)",
                            "topics: " + (", ".join(sorted(usable)) or "none usable"), at.get(v))
            chosen[v] = usable[topic]
        return {v: _bag_stream(reader, c) for v, c in chosen.items()}
    finally:
        reader.close()


def _bag_stream(reader, conn) -> Stream:
    ts, pos, quat, twist = [], [], [], []
    odom = conn.msgtype == "nav_msgs/msg/Odometry"
    for _, _, raw in reader.messages(connections=[conn]):
        msg = reader.deserialize(raw, conn.msgtype)
        pose = msg.pose.pose if odom else msg.pose
        ts.append(msg.header.stamp.sec + 1e-9 * msg.header.stamp.nanosec)
        pos.append((pose.position.x, pose.position.y, pose.position.z))
        o = pose.orientation
        quat.append((o.w, o.x, o.y, o.z))
        if odom:
            lin = msg.twist.twist.linear
            twist.append((lin.x, lin.y, lin.z, 1.0 if msg.child_frame_id else 0.0))
    t = np.array(ts, dtype=float)
    order = np.argsort(t, kind="stable")
    t, p, q = t[order], np.array(pos, dtype=float)[order], np.array(quat, dtype=float)[order]
    r = frames.quaternion_matrix(q) if len(q) else np.zeros((0, 3, 3))
    if odom:
        tw = np.array(twist, dtype=float)[order]
        body = tw[:, 3:4] > 0  # the twist is in the child (body) frame: rotate it
        vel = np.where(body, np.einsum("nij,nj->ni", r, tw[:, :3]), tw[:, :3])
    else:
        vel = np.gradient(p, t, axis=0) if len(t) > 1 else np.zeros_like(p)
    return Stream(conn.topic, t, p, vel, frames.euler(r) if len(q) else None)


# ---------------------------------------------------------------- the trace


def read_log(path: str, declared: list[str], maps: dict[str, str], dt: float,
             spans: dict[str, Span] | None = None) -> Trace:
    """The log at ``path`` (ULog file, rosbag2 folder or .mcap) as a ``Trace`` on steps of
    ``dt`` s of the ``declared`` vehicles that ``maps`` names (all of them without a map;
    see the module docstring)."""
    vehicles = [v for v in declared if v in maps] if maps else list(declared)
    at = dict(spans or {})
    if not os.path.exists(path):
        raise _fail("STL601", path, f"cannot read `{path}`: no such file or directory",
                    "give a PX4 .ulg file, a rosbag2 folder or an .mcap file")
    unknown = sorted(set(maps) - set(declared))
    if unknown:
        raise _fail("STL603", path, f"`--map {unknown[0]}=…`: `{unknown[0]}` is not a vehicle "
                    "of the file", "vehicles: " + ", ".join(declared))
    streams = _ulog_streams(path, vehicles, maps, at) if is_ulog(path) else \
        _bag_streams(path, vehicles, maps, at)
    for v, s in streams.items():
        if s.t.size < 2 or not np.all(np.diff(s.t) > 0):
            raise _fail("STL604", path, f"`{v}`'s stream {s.source} has "
                        f"{'fewer than two samples' if s.t.size < 2 else 'repeated stamps'}",
                        "log the vehicle's position over the flight")
    t0 = max(float(s.t[0]) for s in streams.values())
    t1 = min(float(s.t[-1]) for s in streams.values())
    if not t1 > t0:
        raise _fail("STL604", path, "the vehicles' streams do not overlap in time",
                    "monitor one vehicle at a time")
    n = int(math.floor((t1 - t0) / dt + 1e-9)) + 1
    grid = t0 + dt * np.arange(n)
    channels: dict[str, np.ndarray] = {}
    gaps = {}
    for v, s in streams.items():
        for i, a in enumerate("xyz"):
            channels[f"{v}.pos.{a}"] = np.interp(grid, s.t, s.pos[:, i])
            channels[f"{v}.vel.{a}"] = np.interp(grid, s.t, s.vel[:, i])
            if s.att is not None:
                channels[f"{v}.att.{a}"] = _interp_angle(grid, s.t, s.att[:, i])
        d = np.diff(s.t)
        k = int(np.argmax(d))
        gaps[v] = {"source": s.source, "samples_in": int(s.t.size),
                   "largest_gap": float(d[k]), "gap_at": float(s.t[k] - t0)}
    worst = max(gaps.values(), key=lambda g: g["largest_gap"])
    note = {"dt": dt, "samples_in": sum(g["samples_in"] for g in gaps.values()),
            "largest_gap": worst["largest_gap"], "gap_at": worst["gap_at"],
            "log": os.path.basename(os.path.normpath(path)), "start_s": t0, "streams": gaps}
    return Trace(grid - t0, dt, channels, path, Span(path, 1, 1, 1, 2), note)


def monitor_available(formulas: dict, trace: Trace, params: dict,
                      kappas: dict[str, float]) -> dict[str, dict]:
    """Exact robustness of each formula whose signals the trace has, judged at its κ by the
    one verdict rule (``stlc.analysis.verdict``); the others are undefined (``robustness``
    NaN, ``missing``: the signals the log lacks)."""
    from stlc.analysis import monitor_demand, verdict
    from stlc.semantics import ir

    ok = {k: f for k, f in formulas.items() if ir.signals(f) <= set(trace.channels)}
    vals = monitor_demand.robustness_many(list(ok.values()), trace.dt, trace.channels,
                                          params, n=trace.n) if ok else []
    got = dict(zip(ok, vals))
    out = {}
    for k, f in formulas.items():
        if k in got:
            r = float(got[k])
            out[k] = {"robustness": r, "satisfied": verdict.judge(r, kappas[k]),
                      "kappa": kappas[k]}
        else:
            out[k] = {"robustness": math.nan, "satisfied": None, "kappa": kappas[k],
                      "missing": sorted(ir.signals(f) - set(trace.channels))}
    return out
