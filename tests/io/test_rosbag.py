"""`sideslip convert rosbag`: ROS 1 and ROS 2 bags, written here with rosbags, to drives."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest

pytest.importorskip("rosbags")
from rosbags.typesys import Stores, get_typestore

from sideslip.errors import InputError
from sideslip.frames import enu_to_geodetic
from sideslip.io.rosbag import convert_rosbag
from tests.helpers import run_cli

pytestmark = pytest.mark.automotive

ORIGIN = (37.4, -122.1, 30.0)
T0 = 1_700_000_000.0  # header stamps: a recorder's epoch seconds
V_EAST = 20.0  # m/s, driving due east
MAP = """
[time]
base = "wz"

[topics.imu]
topic = "/imu/data"
type = "imu"
frame = "{frame}"

[topics.fix]
topic = "/gnss/fix"
type = "navsatfix"

[topics.vel]
topic = "/gnss/vel"
type = "twist"

[columns.v_can]
topic = "/vehicle/twist"
field = "twist.linear.x"
unit = "km/h"

[columns.steer]
topic = "/vehicle/steering_wheel_deg"
field = "data"
unit = "deg"
scale = 0.0625
"""


def _stamp(ts, t: float, ros1: bool):
    Time = ts.types["builtin_interfaces/msg/Time"]
    Header = ts.types["std_msgs/msg/Header"]
    sec = int(t)
    stamp = Time(sec=sec, nanosec=round((t - sec) * 1e9))
    return Header(seq=0, stamp=stamp, frame_id="base_link") if ros1 else Header(stamp=stamp, frame_id="base_link")


def _messages(ts, ros1: bool):
    """(topic, msgtype, t, message) of a 4 s drive: IMU 100 Hz, GNSS 10 Hz with a 1 s no-fix
    stretch, a body twist 50 Hz (km/h on x) and a steering-wheel angle 20 Hz."""
    T = ts.types
    V3, Q = T["geometry_msgs/msg/Vector3"], T["geometry_msgs/msg/Quaternion"]
    out = []
    for k in range(400):
        t = T0 + 0.01 * k
        imu = T["sensor_msgs/msg/Imu"](
            header=_stamp(ts, t, ros1), orientation=Q(x=0.0, y=0.0, z=0.0, w=1.0),
            orientation_covariance=np.zeros(9), angular_velocity=V3(x=0.01, y=-0.02, z=0.1 + 0.05 * math.sin(t - T0)),
            angular_velocity_covariance=np.zeros(9), linear_acceleration=V3(x=0.3, y=2.0, z=9.81),
            linear_acceleration_covariance=np.zeros(9),
        )  # fmt: skip
        out.append(("/imu/data", "sensor_msgs/msg/Imu", t, imu))
    for k in range(40):
        t = T0 + 0.1 * k
        lat, lon, h = enu_to_geodetic(np.array([[V_EAST * (t - T0), 0.0, 0.0]]), ORIGIN)
        status = T["sensor_msgs/msg/NavSatStatus"](status=-1 if 2.0 <= t - T0 < 3.0 else 0, service=1)
        fix = T["sensor_msgs/msg/NavSatFix"](
            header=_stamp(ts, t, ros1), status=status, latitude=float(lat[0]), longitude=float(lon[0]),
            altitude=float(h[0]), position_covariance=np.diag([0.25, 0.25, 1.0]).ravel(), position_covariance_type=2,
        )  # fmt: skip
        out.append(("/gnss/fix", "sensor_msgs/msg/NavSatFix", t, fix))
        tw = T["geometry_msgs/msg/Twist"](linear=V3(x=V_EAST, y=0.0, z=0.0), angular=V3(x=0.0, y=0.0, z=0.0))
        out.append(("/gnss/vel", "geometry_msgs/msg/TwistStamped", t, T["geometry_msgs/msg/TwistStamped"](header=_stamp(ts, t, ros1), twist=tw)))
    for k in range(200):
        t = T0 + 0.02 * k
        tw = T["geometry_msgs/msg/Twist"](linear=V3(x=V_EAST * 3.6, y=0.0, z=0.0), angular=V3(x=0.0, y=0.0, z=0.0))
        out.append(("/vehicle/twist", "geometry_msgs/msg/TwistStamped", t, T["geometry_msgs/msg/TwistStamped"](header=_stamp(ts, t, ros1), twist=tw)))
    for k in range(80):
        t = T0 + 0.05 * k
        out.append(("/vehicle/steering_wheel_deg", "std_msgs/msg/Float64", t, T["std_msgs/msg/Float64"](data=32.0)))
    return sorted(out, key=lambda m: m[2])


def write_bag(path, ros2: bool):
    """A small bag with rosbags' own writers (ROS 1 .bag, or a ROS 2 sqlite3 bag folder)."""
    ts = get_typestore(Stores.ROS2_HUMBLE if ros2 else Stores.ROS1_NOETIC)
    if ros2:
        from rosbags.rosbag2 import Writer

        writer, serialize = Writer(path, version=9), ts.serialize_cdr
    else:
        from rosbags.rosbag1 import Writer

        writer, serialize = Writer(path), ts.serialize_ros1
    msgs = _messages(ts, ros1=not ros2)
    with writer:
        conns = {}
        for topic, msgtype, _, _ in msgs:
            if topic not in conns:
                conns[topic] = writer.add_connection(topic, msgtype, typestore=ts)
        for topic, msgtype, t, msg in msgs:
            # the bag's receive time lags the header by 5 ms: the drive must use the header
            writer.write(conns[topic], round((t + 0.005) * 1e9), serialize(msg, msgtype))
    return path


@pytest.fixture(params=["ros1", "ros2"])
def bag(request, tmp_path):
    if request.param == "ros1":
        return write_bag(tmp_path / "drive.bag", ros2=False)
    return write_bag(tmp_path / "drive_ros2", ros2=True)


def _map(tmp_path, frame="flu", text=MAP):
    p = tmp_path / "map.toml"
    p.write_text(text.format(frame=frame))
    return p


def test_bag_converts_to_a_drive_through_the_command(bag, tmp_path):
    out = tmp_path / "drive.parquet"
    res = run_cli("convert", "rosbag", bag, "--map", _map(tmp_path), "--out", out)
    assert res.returncode == 0, res.stderr
    frame = pd.read_parquet(out)
    assert len(frame) == 400  # the IMU (base column) samples are the rows
    t = frame["t"].to_numpy() - T0
    assert np.allclose(t, 0.01 * np.arange(400), atol=1e-6)  # header stamps, not the bag's +5 ms
    assert np.allclose(frame["wz"], 0.1 + 0.05 * np.sin(t), atol=1e-6)
    assert np.allclose(frame[["wx", "wy", "ax", "ay", "az"]].to_numpy(), [0.01, -0.02, 0.3, 2.0, 9.81])
    fix = frame["gnss_e"].notna().to_numpy()
    assert fix.sum() == 30  # 40 epochs less the 10 without a fix
    # geodetic -> ENU about the first fix: due east at 20 m/s (round trip well under 1 mm)
    assert np.allclose(frame["gnss_e"][fix], V_EAST * t[fix], atol=1e-3)
    assert np.allclose(frame["gnss_n"][fix], 0.0, atol=1e-3)
    assert np.allclose(frame["gnss_pos_std"][fix], 0.5)  # sqrt of the 0.25 m^2 variance
    assert np.allclose(frame["gnss_ve"].dropna(), V_EAST) and frame["gnss_ve"].notna().sum() == 40
    assert np.allclose(frame["v_can"].dropna(), V_EAST) and frame["v_can"].notna().sum() == 200  # km/h -> m/s
    assert np.allclose(frame["steer"].dropna(), math.radians(32.0) * 0.0625)


def test_frd_imu_is_turned_into_iso_axes(tmp_path):
    bag = write_bag(tmp_path / "frd.bag", ros2=False)
    drive = convert_rosbag(bag, _map(tmp_path, frame="frd"))
    assert np.allclose(drive["wy"], 0.02) and np.allclose(drive["az"], -9.81)


def test_missing_topic_and_field_are_one_line_each(tmp_path):
    bag = write_bag(tmp_path / "d.bag", ros2=False)
    bad_topic = _map(tmp_path, text=MAP.replace("/gnss/vel", "/gnss/velocity"))
    with pytest.raises(InputError, match=r"topic '/gnss/velocity' .* not in the bag: expected one of /gnss/fix, /gnss/vel"):
        convert_rosbag(bag, bad_topic)
    bad_field = _map(tmp_path, text=MAP.replace("twist.linear.x", "twist.linear.q"))
    with pytest.raises(InputError, match=r"column 'v_can': field 'twist.linear.q' of geometry_msgs/msg/TwistStamped on '/vehicle/twist': no 'q'"):
        convert_rosbag(bag, bad_field)
    bad_type = _map(tmp_path, text=MAP.replace('type = "twist"', 'type = "odometry"'))
    with pytest.raises(InputError, match=r"\[topics.vel\] type = 'odometry': expected one of imu, navsatfix, twist"):
        convert_rosbag(bag, bad_type)
