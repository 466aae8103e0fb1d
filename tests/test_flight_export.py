"""The flight-stack outputs of ``stlc compile`` (``stlc.flight.export``): the ROS 2 bag
round-trips through the ``rosbags`` reader to the plan's positions, the PX4 setpoints are
the plan rotated into NED, the MRS file is the plan every 0.2 s; and the frames module's
conversions (property tests against rotation matrices built independently)."""

from __future__ import annotations

import csv
import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from stlc.analysis.trace import read_trace
from stlc.flight import frames

from clirun import stlc

ROOT = Path(__file__).resolve().parent.parent


@pytest.fixture(scope="module")
def climb(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("climb")
    r = stlc("compile", str(ROOT / "tests" / "missions" / "hexa_climb.stl"), "-o", str(out),
             "-q", cwd=out)
    assert r.returncode == 0, r.stderr
    return out


def _rows(path: Path, header: bool = True) -> np.ndarray:
    with open(path) as fh:
        rows = list(csv.reader(fh))
    return np.array(rows[1:] if header else rows, dtype=float)


def test_bag_round_trips_to_the_plan(climb):
    from rosbags.highlevel import AnyReader

    tr = read_trace(climb / "trajectory.csv")
    pos = np.stack([tr.channels[f"uav1.pos.{a}"] for a in "xyz"], axis=1)
    with AnyReader([climb / "rosbag2"]) as reader:
        topics = {c.topic: c for c in reader.connections}
        assert topics["/uav1/path"].msgtype == "nav_msgs/msg/Path"
        assert topics["/uav1/trajectory"].msgtype == \
            "trajectory_msgs/msg/MultiDOFJointTrajectory"
        msgs = {c.topic: reader.deserialize(raw, c.msgtype)
                for c, _, raw in reader.messages()}
    path = msgs["/uav1/path"]
    assert path.header.frame_id == frames.FRAME_ID
    got = np.array([[p.pose.position.x, p.pose.position.y, p.pose.position.z]
                    for p in path.poses])
    assert got.shape == pos.shape
    np.testing.assert_allclose(got, pos, atol=1e-6, rtol=0)
    stamps = np.array([p.header.stamp.sec + 1e-9 * p.header.stamp.nanosec for p in path.poses])
    np.testing.assert_allclose(stamps, tr.times, atol=1e-9)
    # the attitude: the quaternion's yaw is the plan's heading
    q = np.array([[p.pose.orientation.w, p.pose.orientation.x, p.pose.orientation.y,
                   p.pose.orientation.z] for p in path.poses])
    yaw = np.arctan2(2 * (q[:, 0] * q[:, 3] + q[:, 1] * q[:, 2]),
                     1 - 2 * (q[:, 2] ** 2 + q[:, 3] ** 2))
    np.testing.assert_allclose(yaw, tr.channels["uav1.att.z"], atol=1e-6)
    traj = msgs["/uav1/trajectory"]
    assert traj.joint_names == ["uav1"]
    tpos = np.array([[p.transforms[0].translation.x, p.transforms[0].translation.y,
                      p.transforms[0].translation.z] for p in traj.points])
    np.testing.assert_allclose(tpos, pos, atol=1e-6, rtol=0)
    vel = np.array([[p.velocities[0].linear.x, p.velocities[0].linear.y,
                     p.velocities[0].linear.z] for p in traj.points])
    np.testing.assert_allclose(vel, np.stack([tr.channels[f"uav1.vel.{a}"] for a in "xyz"],
                                             axis=1), atol=1e-6)


def test_px4_setpoints_are_the_plan_in_ned(climb):
    tr = read_trace(climb / "trajectory.csv")
    with open(climb / "flight" / "uav1.px4.csv") as fh:
        assert fh.readline().strip() == \
            "timestamp_us,x,y,z,vx,vy,vz,ax,ay,az,yaw,yawspeed"
    px4 = _rows(climb / "flight" / "uav1.px4.csv")
    ch = tr.channels
    np.testing.assert_array_equal(px4[:, 0], np.rint(tr.times * 1e6))
    # NED = (y, x, -z) of ENU
    for col, (name, sign) in zip(range(1, 7), [("pos.y", 1), ("pos.x", 1), ("pos.z", -1),
                                               ("vel.y", 1), ("vel.x", 1), ("vel.z", -1)]):
        np.testing.assert_allclose(px4[:, col], sign * ch[f"uav1.{name}"], atol=1e-8)
    # yaw from north clockwise
    d = px4[:, 10] - (math.pi / 2 - ch["uav1.att.z"])
    np.testing.assert_allclose(np.angle(np.exp(1j * d)), 0.0, atol=1e-8)
    # the accelerations integrate to the velocities (trapezoid over one 0.1 s step)
    dt = float(tr.times[1] - tr.times[0])
    v, a = px4[:, 4:7], px4[:, 7:10]
    np.testing.assert_allclose(np.diff(v, axis=0), dt * (a[1:] + a[:-1]) / 2, atol=0.02)
    # a plan that starts from hover: no acceleration at t = 0
    np.testing.assert_allclose(a[0], 0.0, atol=1e-6)


def test_mrs_trajectory_every_0_2_s(climb):
    tr = read_trace(climb / "trajectory.csv")
    mrs = _rows(climb / "flight" / "uav1.mrs.csv", header=False)
    assert mrs.shape == (int(round(tr.times[-1] / 0.2)) + 1, 4)
    ch = tr.channels
    ref = np.stack([ch["uav1.pos.x"], ch["uav1.pos.y"], ch["uav1.pos.z"], ch["uav1.att.z"]],
                   axis=1)[::2]
    np.testing.assert_allclose(mrs, ref, atol=1e-8)


def test_a_users_own_bag_is_never_replaced(tmp_path):
    bag = tmp_path / "rosbag2"
    bag.mkdir()
    (bag / "metadata.yaml").write_text("my flight\n")
    r = stlc("compile", str(ROOT / "tests" / "missions" / "hexa_climb.stl"), "-o", ".", "-q",
             cwd=tmp_path)
    assert r.returncode == 1 and "error[STL605]" in r.stderr
    assert "stlc did not write it" in r.stderr
    assert (bag / "metadata.yaml").read_text() == "my flight\n"
    assert not (tmp_path / "trajectory.csv").exists()


angles = st.floats(-3.0, 3.0)


@settings(max_examples=60, deadline=None)
@given(angles, st.floats(-1.4, 1.4), angles)
def test_quaternion_and_euler_agree_with_the_rotation(roll, pitch, yaw):
    eta = np.array([roll, pitch, yaw])
    c, s = np.cos, np.sin
    rz = np.array([[c(yaw), -s(yaw), 0], [s(yaw), c(yaw), 0], [0, 0, 1]])
    ry = np.array([[c(pitch), 0, s(pitch)], [0, 1, 0], [-s(pitch), 0, c(pitch)]])
    rx = np.array([[1, 0, 0], [0, c(roll), -s(roll)], [0, s(roll), c(roll)]])
    r = rz @ ry @ rx
    np.testing.assert_allclose(frames.rotation(eta), r, atol=1e-12)
    np.testing.assert_allclose(frames.quaternion_matrix(frames.quaternion(eta)), r, atol=1e-12)
    np.testing.assert_allclose(frames.euler(r), eta, atol=1e-9)


@settings(max_examples=60, deadline=None)
@given(st.lists(st.floats(-100, 100), min_size=3, max_size=3), angles)
def test_ned_is_enu_swapped_and_flipped(v, yaw):
    v = np.array(v)
    ned = frames.enu_to_ned(v)
    assert list(ned) == [v[1], v[0], -v[2]]
    np.testing.assert_array_equal(frames.ned_to_enu(ned), v)
    # a PX4 attitude that is a pure yaw ψ_ned (FRD → NED) is the ENU yaw π/2 − ψ_ned
    psi = frames.yaw_enu_to_ned(yaw)
    r_ned = np.array([[np.cos(psi), -np.sin(psi), 0], [np.sin(psi), np.cos(psi), 0], [0, 0, 1]])
    back = frames.euler(frames.ned_frd_to_enu_flu(r_ned))
    np.testing.assert_allclose(back[:2], 0.0, atol=1e-12)
    assert abs(np.angle(np.exp(1j * (back[2] - yaw)))) < 1e-9
