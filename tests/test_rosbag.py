"""ROS 1 / ROS 2 bags: round trips through write_rosbag, resampling of streams at
different rates (bags written here directly with rosbags' writers), sign of the current,
unknown topics."""

from __future__ import annotations

import logging

import numpy as np
import pandas as pd
import pytest
from rosbags.typesys import Stores, get_typestore
from scipy.spatial.transform import Rotation

from energy_planner.errors import LogError, LogIOError
from energy_planner.measurements import load_logs, load_rosbag, wrap_angle, write_rosbag

CANON = ["t", "qw", "qx", "qy", "qz", "vx", "vy", "wz", "voltage", "current", "x", "y", "yaw"]


def sample_table(n=60, run="r1", t0=2.0, seed=0):
    rng = np.random.default_rng(seed)
    t = t0 + 0.02 * np.arange(n)
    q = Rotation.from_euler(
        "zyx", np.c_[np.linspace(2.5, 3.6, n), rng.uniform(-0.3, 0.3, n), rng.uniform(-0.2, 0.2, n)]
    ).as_quat()
    return pd.DataFrame(
        {
            "run": run,
            "t": t,
            "qw": q[:, 3],
            "qx": q[:, 0],
            "qy": q[:, 1],
            "qz": q[:, 2],
            "vx": rng.normal(0.3, 0.05, n),
            "vy": rng.normal(0, 0.05, n),
            "wz": rng.normal(0, 0.1, n),
            "voltage": rng.uniform(48, 58, n),
            "current": rng.uniform(3, 12, n),
            "x": np.cumsum(rng.normal(0, 1, n)),
            "y": rng.normal(0, 1, n),
            "yaw": np.linspace(2.8, 3.5, n),  # crosses +pi
            "payload_kg": rng.uniform(0, 5, n),
            "surface": pd.Categorical(["grass"] * (n // 2) + ["mud"] * (n - n // 2)),
        }
    )


def assert_round_trip(orig, back):
    assert len(back) == len(orig)
    np.testing.assert_allclose(back["t"], orig["t"], rtol=0, atol=1e-9)
    for c in ["qw", "qx", "qy", "qz", "vx", "vy", "wz", "x", "y", "payload_kg"]:
        np.testing.assert_allclose(back[c], orig[c], rtol=1e-15, atol=1e-15, err_msg=c)
    # BatteryState voltage/current are float32 in the message
    for c in ["voltage", "current"]:
        np.testing.assert_allclose(back[c], orig[c].astype(np.float32), rtol=0, atol=0, err_msg=c)
    np.testing.assert_allclose(wrap_angle(back["yaw"] - orig["yaw"]), 0, atol=1e-12)
    assert list(back["surface"].astype(str)) == list(orig["surface"].astype(str))


@pytest.mark.parametrize(
    "version,name,storage",
    [(2, "ros2_bag", "mcap"), (2, "ros2_bag", "sqlite3"), (1, "ros1.bag", "mcap")],
)
def test_round_trip_table_bag_table(tmp_path, version, name, storage):
    orig = sample_table()
    paths = write_rosbag(orig, tmp_path / name, version=version, storage=storage)
    if version == 2:
        assert len(list(paths[0].glob(f"*.{'mcap' if storage == 'mcap' else 'db3'}"))) == 1
    assert paths == [tmp_path / name]
    back, rep = load_rosbag(paths[0], report=True)
    assert_round_trip(orig, back)
    assert rep.current_sign_flipped is True
    assert rep.files[0]["format"] == f"rosbag{version}"
    assert rep.runs == [paths[0].stem if version == 1 else name]
    assert rep.extra_columns == ["payload_kg", "surface"]
    assert rep.dropped == {}
    # the same through the odometry clock (all streams share the stamps)
    back2 = load_rosbag(paths[0], clock="odom")
    assert_round_trip(orig, back2)


def test_several_runs_to_a_folder_and_load_logs(tmp_path):
    orig = pd.concat([sample_table(run="a", seed=1), sample_table(30, run="b", seed=2)])
    paths = write_rosbag(orig, tmp_path / "bags", version=1)
    assert sorted(p.name for p in paths) == ["a.bag", "b.bag"]
    write_rosbag(sample_table(run="c", seed=3), tmp_path / "bags" / "c", version=2)
    sample_table(run="d", seed=4).drop(columns="run").to_csv(
        tmp_path / "bags" / "d.csv", index=False
    )
    s, rep = load_logs(tmp_path / "bags", report=True)
    assert sorted(s["run"].unique()) == ["a", "b", "c", "d"]
    assert [f["format"] for f in rep.files] == ["rosbag1", "rosbag1", "rosbag2", "csv"]
    assert rep.current_sign_flipped
    assert_round_trip(sample_table(run="a", seed=1), s[s.run == "a"].reset_index(drop=True))
    assert_round_trip(sample_table(run="c", seed=3), s[s.run == "c"].reset_index(drop=True))


# ------------------------------------------------------------- bags written by hand


OLD_BATTERY_STATE = """std_msgs/Header header
float32 voltage
float32 current
float32 charge
float32 capacity
float32 design_capacity
float32 percentage
uint8 power_supply_status
uint8 power_supply_health
uint8 power_supply_technology
bool present
float32[] cell_voltage
string location
string serial_number
"""


def old_battery_store():
    """A ROS 1 typestore with the pre-Noetic BatteryState (no temperature fields)."""
    from rosbags.typesys import get_types_from_msg

    ts = get_typestore(Stores.EMPTY)
    ts.register(get_types_from_msg(OLD_BATTERY_STATE, "sensor_msgs/msg/BatteryState"))
    ts.register(
        {"std_msgs/msg/Header": get_typestore(Stores.ROS1_NOETIC).fielddefs["std_msgs/msg/Header"]}
    )
    return ts


def write_streams(
    path, version, imu=(), odom=(), battery=(), topics=None, old_battery=False, extras=None
):
    """Write a bag directly with rosbags: imu rows (ns, qw, qx, qy, qz), odom rows
    (ns, vx, vy, wz, x, y, yaw), battery rows (ns, voltage, ros_current). With
    ``old_battery`` (ROS 1 only) BatteryState has the pre-Noetic definition."""
    topics = {"imu": "/imu/data", "odom": "/odom", "battery": "/battery_state", **(topics or {})}
    ts = get_typestore(Stores.ROS1_NOETIC if version == 1 else Stores.ROS2_HUMBLE)
    T = ts.types
    ser = ts.serialize_ros1 if version == 1 else ts.serialize_cdr
    if version == 1:
        from rosbags.rosbag1 import Writer

        w = Writer(path)
    else:
        from rosbags.rosbag2 import Writer

        w = Writer(path, version=9)

    def header(ns):
        stamp = T["builtin_interfaces/msg/Time"](sec=ns // 10**9, nanosec=ns % 10**9)
        if version == 1:
            return T["std_msgs/msg/Header"](seq=0, stamp=stamp, frame_id="f")
        return T["std_msgs/msg/Header"](stamp=stamp, frame_id="f")

    V3, Q = T["geometry_msgs/msg/Vector3"], T["geometry_msgs/msg/Quaternion"]
    nan = float("nan")
    with w:
        ci = w.add_connection(topics["imu"], "sensor_msgs/msg/Imu", typestore=ts)
        co = w.add_connection(topics["odom"], "nav_msgs/msg/Odometry", typestore=ts)
        bts = old_battery_store() if old_battery else ts
        cb = w.add_connection(topics["battery"], "sensor_msgs/msg/BatteryState", typestore=bts)
        cs = w.add_connection("/cmd_vel", "geometry_msgs/msg/Twist", typestore=ts)
        msgs = []
        for ns, qw, qx, qy, qz in imu:
            m = T["sensor_msgs/msg/Imu"](
                header=header(ns),
                orientation=Q(x=qx, y=qy, z=qz, w=qw),
                orientation_covariance=np.zeros(9),
                angular_velocity=V3(x=0.0, y=0.0, z=0.0),
                angular_velocity_covariance=np.zeros(9),
                linear_acceleration=V3(x=0.0, y=0.0, z=9.81),
                linear_acceleration_covariance=np.zeros(9),
            )
            msgs.append((ns, ci, ser(m, "sensor_msgs/msg/Imu")))
        for ns, vx, vy, wz, x, y, yaw in odom:
            m = T["nav_msgs/msg/Odometry"](
                header=header(ns),
                child_frame_id="base",
                pose=T["geometry_msgs/msg/PoseWithCovariance"](
                    pose=T["geometry_msgs/msg/Pose"](
                        position=T["geometry_msgs/msg/Point"](x=x, y=y, z=0.0),
                        orientation=Q(x=0.0, y=0.0, z=np.sin(yaw / 2), w=np.cos(yaw / 2)),
                    ),
                    covariance=np.zeros(36),
                ),
                twist=T["geometry_msgs/msg/TwistWithCovariance"](
                    twist=T["geometry_msgs/msg/Twist"](
                        linear=V3(x=vx, y=vy, z=0.0), angular=V3(x=0.0, y=0.0, z=wz)
                    ),
                    covariance=np.zeros(36),
                ),
            )
            msgs.append((ns, co, ser(m, "nav_msgs/msg/Odometry")))
        for ns, v, i in battery:
            fields = dict(
                header=header(ns),
                voltage=v,
                current=i,
                charge=nan,
                capacity=nan,
                design_capacity=nan,
                percentage=nan,
                power_supply_status=2,
                power_supply_health=0,
                power_supply_technology=0,
                present=True,
                cell_voltage=np.zeros(0, np.float32),
                location="",
                serial_number="",
            )
            if old_battery:
                m = bts.types["sensor_msgs/msg/BatteryState"](**fields)
                raw = bts.serialize_ros1(m, "sensor_msgs/msg/BatteryState")
            else:
                m = T["sensor_msgs/msg/BatteryState"](
                    **fields, temperature=nan, cell_temperature=np.zeros(0, np.float32)
                )
                raw = ser(m, "sensor_msgs/msg/BatteryState")
            msgs.append((ns, cb, raw))
        for topic, rows in (extras or {}).items():
            typ = "std_msgs/msg/String" if isinstance(rows[0][1], str) else "std_msgs/msg/Float64"
            cx = w.add_connection(topic, typ, typestore=ts)
            for ns, v in rows:
                msgs.append((ns, cx, ser(T[typ](data=v), typ)))
        tw = T["geometry_msgs/msg/Twist"](
            linear=V3(x=0.0, y=0.0, z=0.0), angular=V3(x=0.0, y=0.0, z=0.0)
        )
        msgs.append((10**9, cs, ser(tw, "geometry_msgs/msg/Twist")))
        for ns, c, raw in sorted(msgs, key=lambda m: m[0]):
            w.write(c, ns, raw)
    return path


S = 10**9


def multirate(version, tmp_path, battery_gap=None, old_battery=False):
    """IMU 100 Hz from 1.000 s, odometry 50 Hz from 1.005 s, battery 10 Hz from 1.05 s,
    all to ~3 s. Signals are linear in time (so linear interpolation is exact), the IMU
    turns at a constant rate about z (so Slerp is exact)."""
    w = 0.4  # rad/s
    imu = [
        (S + k * 10_000_000,)
        + tuple(np.r_[np.cos(w * (1 + k * 0.01) / 2), 0, 0, np.sin(w * (1 + k * 0.01) / 2)])
        for k in range(201)
    ]
    odom = []
    for k in range(100):
        ns = S + 5_000_000 + k * 20_000_000
        t = ns / S
        odom.append((ns, 0.1 + 0.1 * t, -0.05 * t, 0.2, 0.3 * t, 1.0, 3.0 + 0.2 * t))
    bat = [
        (S + 50_000_000 + k * 100_000_000, 50.0 - 0.5 * k, -(4.0 + 0.5 * k))
        for k in range(20)
        if battery_gap is None or not battery_gap[0] < 1.05 + 0.1 * k < battery_gap[1]
    ]
    ext = ".bag" if version == 1 else ""
    return write_streams(tmp_path / f"multi{ext}", version, imu, odom, bat, old_battery=old_battery)


@pytest.mark.parametrize("version", [1, 2])
def test_resampling_onto_the_imu_clock_is_linear_in_time(tmp_path, version, caplog):
    bag = multirate(version, tmp_path)
    with caplog.at_level(logging.INFO, logger="energy_planner.measurements.rosbag"):
        s, rep = load_rosbag(bag, report=True)
    assert "battery current negated" in caplog.text
    t = s["t"].to_numpy()
    # common span: battery 1.05 .. 2.95 s; IMU samples every 10 ms inside it
    assert t[0] == pytest.approx(1.05) and t[-1] == pytest.approx(2.95)
    assert len(s) == 191
    assert rep.dropped == {"outside the time span common to all topics": 10}
    np.testing.assert_allclose(s["vx"], 0.1 + 0.1 * t, atol=1e-12)
    np.testing.assert_allclose(s["vy"], -0.05 * t, atol=1e-12)
    np.testing.assert_allclose(s["x"], 0.3 * t, atol=1e-12)
    np.testing.assert_allclose(s["yaw"], wrap_angle(3.0 + 0.2 * t), atol=1e-12)
    k = (t - 1.05) / 0.1
    np.testing.assert_allclose(s["voltage"], 50.0 - 0.5 * k, atol=1e-5)
    np.testing.assert_allclose(s["current"], 4.0 + 0.5 * k, atol=1e-5)  # sign converted
    np.testing.assert_allclose(s["qz"], np.sin(0.4 * t / 2), atol=1e-12)


def test_a_non_standard_message_definition_is_read_with_the_bags_own(tmp_path):
    # pre-Noetic BatteryState (no temperature fields): the standard decoder would
    # misread it; the loader sees the different digest and uses the bag's definition
    bag = multirate(1, tmp_path, old_battery=True)
    from rosbags.rosbag1 import Reader

    with Reader(bag) as r:
        digest = {c.topic: c.digest for c in r.connections}["/battery_state"]
    noetic = get_typestore(Stores.ROS1_NOETIC)
    assert digest != noetic.generate_msgdef("sensor_msgs/msg/BatteryState")[1]
    s = load_rosbag(bag)
    k = (s["t"].to_numpy() - 1.05) / 0.1
    np.testing.assert_allclose(s["voltage"], 50.0 - 0.5 * k, atol=1e-5)
    np.testing.assert_allclose(s["current"], 4.0 + 0.5 * k, atol=1e-5)


def test_resampling_onto_the_odometry_clock_slerps_the_quaternion(tmp_path):
    bag = multirate(2, tmp_path)
    s = load_rosbag(bag, clock="odom")
    t = s["t"].to_numpy()
    assert t[0] == pytest.approx(1.065) and len(s) == 95
    # halfway between two IMU messages: exact constant-rate rotation
    np.testing.assert_allclose(s["qz"], np.sin(0.4 * t / 2), atol=1e-12)
    np.testing.assert_allclose(s["qw"], np.cos(0.4 * t / 2), atol=1e-12)
    np.testing.assert_allclose(s["vx"], 0.1 + 0.1 * t, atol=1e-12)


def test_a_silent_stream_is_not_bridged(tmp_path):
    bag = multirate(2, tmp_path, battery_gap=(1.5, 2.2))  # battery silent 1.45 .. 2.25 s
    s, rep = load_rosbag(bag, report=True)
    reason = "/battery_state silent for more than 0.5 s"
    assert rep.dropped[reason] == 79  # IMU samples strictly between 1.45 and 2.25 s
    assert not ((s["t"] > 1.451) & (s["t"] < 2.249)).any()
    s2, rep2 = load_rosbag(bag, report=True, max_interp_gap=1.0)
    assert reason not in rep2.dropped and len(s2) == 191


def test_discharge_positive_drivers_and_the_sign_warning(tmp_path, caplog):
    bag = multirate(2, tmp_path)
    with caplog.at_level(logging.WARNING):
        load_rosbag(bag)
    assert "median battery current" not in caplog.text
    with caplog.at_level(logging.WARNING):
        s, rep = load_rosbag(bag, report=True, battery_current="discharge_positive")
    assert rep.current_sign_flipped is False
    assert (s["current"] < 0).all()  # the bag's values as they are
    assert "median battery current -8.75 A is negative" in caplog.text
    assert "battery_current='ros'" in caplog.text
    assert any("median current" in n for n in rep.notes)
    with pytest.raises(LogError, match="'ros' or 'discharge_positive'"):
        load_rosbag(bag, battery_current="positive")


def test_unknown_topic_lists_the_topics_in_the_bag(tmp_path):
    bag = multirate(2, tmp_path)
    with pytest.raises(LogError) as ei:
        load_rosbag(bag, imu_topic="/imu")
    msg = str(ei.value)
    assert "no topic '/imu'" in msg and "sensor_msgs/msg/Imu" in msg
    for topic in (
        "/imu/data (sensor_msgs/msg/Imu)",
        "/odom (nav_msgs/msg/Odometry)",
        "/battery_state (sensor_msgs/msg/BatteryState)",
        "/cmd_vel (geometry_msgs/msg/Twist)",
    ):
        assert topic in msg
    with pytest.raises(
        LogError, match="'/cmd_vel' carries geometry_msgs/msg/Twist, expected nav_msgs/msg/Odometry"
    ):
        load_rosbag(bag, odom_topic="/cmd_vel")
    with pytest.raises(LogError, match="extra channel 'terrain'"):
        load_rosbag(bag, extra_topics={"terrain": "/terrain"})


def test_custom_topics_round_trip_and_bad_arguments(tmp_path):
    orig = sample_table(20)
    topics = {"imu": "/b1/imu", "battery": "/b1/bms"}
    p = write_rosbag(orig, tmp_path / "c", topics=topics)[0]
    back = load_rosbag(p, imu_topic="/b1/imu", battery_topic="/b1/bms", run="trial")
    assert_round_trip(orig, back)
    assert set(back["run"]) == {"trial"}
    with pytest.raises(LogIOError, match="exists already"):
        write_rosbag(orig, p)
    with pytest.raises(LogError, match="t must be >= 0"):
        write_rosbag(orig.assign(t=orig["t"] - 10), tmp_path / "neg")
    with pytest.raises(LogError, match="'mcap' or 'sqlite3'"):
        write_rosbag(orig, tmp_path / "y", storage="db")
    with pytest.raises(LogError, match="unknown topic role"):
        write_rosbag(orig, tmp_path / "x", topics={"gps": "/fix"})
    with pytest.raises(LogIOError, match="does not exist"):
        load_rosbag(tmp_path / "missing")


def test_unstamped_messages_need_bag_times(tmp_path):
    # an IMU driver that leaves header stamps at 0: every IMU message repeats t = 0
    imu = [(0, 1.0, 0.0, 0.0, 0.0)] * 50
    odom = [(S + k * 20_000_000, 0.3, 0.0, 0.0, 0.0, 0.0, 0.0) for k in range(50)]
    bat = [(S + k * 20_000_000, 50.0, -5.0) for k in range(50)]
    bag = write_streams(tmp_path / "nostamp", 2, imu, odom, bat)
    with pytest.raises(
        LogError,
        match=r"49 of 50 messages on ./imu/data. repeat a header "
        r"stamp.*use stamp=.bag.",
    ):
        load_rosbag(bag)


def test_extra_topics_by_name_and_missing_outside_their_span(tmp_path):
    imu = [(S + k * 10**8, 1.0, 0.0, 0.0, 0.0) for k in range(11)]  # 1.0 .. 2.0 s
    odom = [(S + k * 10**8, 0.3, 0.0, 0.0, 0.0, 0.0, 0.0) for k in range(11)]
    bat = [(S + k * 10**8, 50.0, -5.0) for k in range(11)]
    extras = {
        "/payload": [(S + 5 * 10**8, 2.0), (S + 10 * 10**8, 4.0)],  # from 1.5 s
        "/ground": [(S + 3 * 10**8, "grass"), (S + 7 * 10**8, "mud")],
    }  # from 1.3 s
    bag = write_streams(tmp_path / "x", 2, imu, odom, bat, extras=extras)
    s = load_rosbag(bag, extra_topics={"payload_kg": "/payload", "surface": "/ground"})
    assert s["payload_kg"].isna().sum() == 5
    np.testing.assert_allclose(s["payload_kg"].to_numpy()[5:], [2.0, 2.4, 2.8, 3.2, 3.6, 4.0])
    assert s["surface"].isna().tolist() == [True] * 3 + [False] * 8
    assert s["surface"].iloc[3:].tolist() == ["grass"] * 4 + ["mud"] * 4
    # without extra_topics only the /energy_planner/ namespace is read
    assert "payload_kg" not in load_rosbag(bag).columns
