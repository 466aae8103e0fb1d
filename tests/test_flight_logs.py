"""``stlc monitor FILE.stl --log PATH``: a ROS 2 bag written here with the ``rosbags``
writer (nav_msgs/Odometry with a body-frame twist, PoseStamped) and a PX4 ULog built
byte by byte from the ULog specification are monitored; the robustness of each spec is
computed by hand for the flown straight line x = t, z = t/2 (m) over [0, 2] s:

* ``low``  = always[0, 2] (x <= 3 m)           → 3 − max x       = 1
* ``up``   = eventually[0, 2] (z >= 0.5 m)     → max z − 0.5     = 0.5
* ``slow`` = always[0, 2] (speed <= 2 m/s)     → 2 − √1.25
* ``east`` = always[0, 2] (|heading| <= 10 deg) (hexa only): yaw 0 → 10° in rad
"""

from __future__ import annotations

import json
import math
import struct
from pathlib import Path

import numpy as np
import pytest

from stlc.cli import main

POINT = """\
vehicle p : point_mass {
  vel_max = (2, 2, 2) m/s
  acc_max = (2, 2, 2) m/s^2
  start { pos = (0, 0, 0) m }
}
mission m {
  vehicles = [p]
  horizon = 2 s
  step = 0.1 s
  spec low = always[0, 2] (p.pos.x <= 3 m)
  spec up = eventually[0, 2] (p.pos.z >= 0.5 m)
  spec slow = always[0, 2] (p.speed <= 2 m/s)
  require low and up and slow
}
"""
SLOW = 2 - math.sqrt(1.25)
T0 = 1700.0  # the log's clock at the start of the line (s)


def _monitor(capsys, stl: Path, log: Path, *extra: str) -> tuple[int, dict, str]:
    code = main(["monitor", str(stl), "--log", str(log), "--json", *extra])
    cap = capsys.readouterr()
    return code, json.loads(cap.out) if cap.out.strip() else {}, cap.err


def _line_times() -> np.ndarray:
    """50 Hz with jitter and a 0.3 s hole after 1 s, over a little more than [0, 2] s."""
    rng = np.random.default_rng(3)
    t = 0.02 * np.arange(104) + rng.uniform(-0.004, 0.004, 104)
    t[0] = 0.0
    t = t[(t < 1.0) | (t > 1.3)]
    return t


def _write_bag(path: Path, topic: str, kind: str, mcap: bool = False) -> None:
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.typesys import Stores, get_typestore

    ts = get_typestore(Stores.ROS2_HUMBLE)
    T = ts.types
    # the body is turned 90° left (yaw +90°): a world velocity (1, 0, 0.5) is (0, −1, 0.5)
    # in the body frame, where Odometry's twist lives
    q = T["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=math.sin(math.pi / 4),
                                          w=math.cos(math.pi / 4))
    storage = StoragePlugin.MCAP if mcap else StoragePlugin.SQLITE3
    with Writer(path, version=8, storage_plugin=storage) as w:
        conn = w.add_connection(topic, kind, typestore=ts)
        for t in _line_times():
            stamp = T["builtin_interfaces/msg/Time"](sec=int(T0 + t),
                                                     nanosec=int(round((T0 + t) % 1 * 1e9)))
            header = T["std_msgs/msg/Header"](stamp=stamp, frame_id="map")
            pose = T["geometry_msgs/msg/Pose"](
                T["geometry_msgs/msg/Point"](x=t, y=0.0, z=t / 2), q)
            if kind == "nav_msgs/msg/Odometry":
                Vec = T["geometry_msgs/msg/Vector3"]
                twist = T["geometry_msgs/msg/Twist"](Vec(x=0.0, y=-1.0, z=0.5),
                                                     Vec(x=0.0, y=0.0, z=0.0))
                msg = T["nav_msgs/msg/Odometry"](
                    header, "p/base_link",
                    T["geometry_msgs/msg/PoseWithCovariance"](pose, np.zeros(36)),
                    T["geometry_msgs/msg/TwistWithCovariance"](twist, np.zeros(36)))
            else:
                msg = T["geometry_msgs/msg/PoseStamped"](header, pose)
            w.write(conn, int((T0 + t) * 1e9), ts.serialize_cdr(msg, kind))


@pytest.mark.parametrize("kind", ["nav_msgs/msg/Odometry", "geometry_msgs/msg/PoseStamped"])
def test_an_independently_written_bag_is_monitored(tmp_path, capsys, kind):
    stl = tmp_path / "line.stl"
    stl.write_text(POINT)
    bag = tmp_path / "flight"
    _write_bag(bag, "/p/odom", kind)
    code, out, err = _monitor(capsys, stl, bag, "--map", "p=/p/odom")
    assert code == 0, err
    specs = out["specs"]
    assert specs["low"]["robustness"] == pytest.approx(1.0, abs=0.01)  # grid ends ≤ 2 s
    assert specs["up"]["robustness"] == pytest.approx(0.5, abs=0.005)
    # the twist was rotated out of the body frame (PoseStamped: finite differences)
    assert specs["slow"]["robustness"] == pytest.approx(SLOW, abs=1e-6)
    assert specs["m"]["robustness"] == pytest.approx(min(1.0, 0.5, SLOW), abs=0.005)
    gap = out["resampled"]
    assert gap["dt"] == 0.1 and gap["largest_gap"] == pytest.approx(0.32, abs=0.01)
    assert gap["gap_at"] == pytest.approx(1.0, abs=0.02)
    assert "largest gap in the log" in err
    # without --map: the one usable topic under /p/
    code2, out2, _ = _monitor(capsys, stl, bag)
    assert code2 == 0 and out2["specs"] == specs


def test_a_single_mcap_file_is_monitored(tmp_path, capsys):
    stl = tmp_path / "line.stl"
    stl.write_text(POINT)
    _write_bag(tmp_path / "flight", "/p/odom", "nav_msgs/msg/Odometry", mcap=True)
    files = list((tmp_path / "flight").glob("*.mcap"))
    assert len(files) == 1
    code, out, err = _monitor(capsys, stl, files[0])
    assert code == 0, err
    assert out["specs"]["slow"]["robustness"] == pytest.approx(SLOW, abs=1e-6)


def test_a_missing_topic_is_a_diagnostic(tmp_path, capsys):
    stl = tmp_path / "line.stl"
    stl.write_text(POINT)
    bag = tmp_path / "flight"
    _write_bag(bag, "/p/odom", "nav_msgs/msg/Odometry")
    code, _, err = _monitor(capsys, stl, bag, "--map", "p=/uav9/odom")
    assert code == 1 and "error[STL603]" in err and "/p/odom" in err
    assert "line.stl:1:1:" in err  # at the vehicle's declaration, not inside the bag
    code, _, err = _monitor(capsys, stl, bag, "--map", "q=/p/odom")
    assert code == 1 and "`q` is not a vehicle" in err
    code, _, err = _monitor(capsys, stl, tmp_path / "nothing.ulg")
    assert code == 1 and "error[STL601]" in err


# ---------------------------------------------------------------- ULog, by the spec


def _msg(kind: str, payload: bytes) -> bytes:
    return struct.pack("<HB", len(payload), ord(kind)) + payload


def _ulog(path: Path, yaw_ned: float) -> None:
    """A minimal ULog (docs.px4.io "ULog File Format"): the 16-byte header, two format
    messages, two subscriptions and their data.  The line flown in ENU is written in NED:
    (x, y, z)_NED = (0, t, −t/2), velocity (0, 1, −0.5); the attitude is a yaw of
    ``yaw_ned`` (FRD → NED quaternion)."""
    out = bytearray(b"ULog\x01\x12\x35" + bytes([1]) + struct.pack("<Q", 0))
    out += _msg("F", b"vehicle_local_position:uint64_t timestamp;float x;float y;float z;"
                b"float vx;float vy;float vz;")
    out += _msg("F", b"vehicle_attitude:uint64_t timestamp;float[4] q;")
    out += _msg("A", struct.pack("<BH", 0, 0) + b"vehicle_local_position")
    out += _msg("A", struct.pack("<BH", 0, 1) + b"vehicle_attitude")
    q = (math.cos(yaw_ned / 2), 0.0, 0.0, math.sin(yaw_ned / 2))
    for t in _line_times():
        us = int(round((T0 + t) * 1e6))
        out += _msg("D", struct.pack("<HQ6f", 0, us, 0.0, t, -t / 2, 0.0, 1.0, -0.5))
        out += _msg("D", struct.pack("<HQ4f", 1, us + 500, *q))
    path.write_bytes(bytes(out))


HEXA = """\
vehicle uav1 : multirotor {
  mass = 2.25 kg
  inertia = diag(2.07e-2, 2.10e-2, 3.10e-2) kg*m^2
  c_f = 11.5e-4
  c_tau = 2.38e-5
  force = [0.29 N, 11.5 N]
  rotors = hexarotor(arm = 0.39 m, tilt = 20 deg)
  start { pos = (0, 0, 0) m }
}
mission m {
  vehicles = [uav1]
  horizon = 2 s
  step = 0.1 s
  spec low = always[0, 2] (uav1.pos.x <= 3 m)
  spec up = eventually[0, 2] (uav1.pos.z >= 0.5 m)
  spec slow = always[0, 2] (uav1.speed <= 2 m/s)
  spec east = always[0, 2] (abs(uav1.heading) <= 10 deg)
  spec spin = always[0, 2] (uav1.rotor_speed.1 <= 100 Hz)
  require low and up and slow and east
}
"""


def test_a_px4_ulog_is_monitored_in_enu(tmp_path, capsys):
    stl = tmp_path / "hexa.stl"
    stl.write_text(HEXA)
    log = tmp_path / "flight.ulg"
    _ulog(log, yaw_ned=math.pi / 2)  # facing east in NED: yaw 0 in ENU
    code, out, err = _monitor(capsys, stl, log)
    assert code == 0, err
    s = out["specs"]
    assert s["low"]["robustness"] == pytest.approx(1.0, abs=0.01)
    assert s["up"]["robustness"] == pytest.approx(0.5, abs=0.005)
    assert s["slow"]["robustness"] == pytest.approx(SLOW, abs=1e-6)
    assert s["east"]["robustness"] == pytest.approx(math.radians(10), abs=1e-6)
    # the log has no rotor forces: that spec is undefined, and said so
    assert s["spin"]["robustness"] is None and s["spin"]["satisfied"] is None
    assert "`spin` is undefined: the log has no uav1.force.1" in err
    assert out["resampled"]["streams"]["uav1"]["source"] == "vehicle_local_position[0]"
    # turned to face north in NED (yaw 0): 90° off east in ENU
    _ulog(log, yaw_ned=0.0)
    code, out, err = _monitor(capsys, stl, log)
    assert out["specs"]["east"]["robustness"] == pytest.approx(math.radians(10 - 90), abs=1e-6)
