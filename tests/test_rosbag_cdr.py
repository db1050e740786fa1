"""ROS bags written many messages at a time: the same bytes as rosbags' own serializers.

``write_rosbag`` fills numpy copies of a template message (``measurements._cdr``) instead
of building and serializing every message. The reference is rosbags'
``Typestore.serialize_cdr`` (ROS 2) or ``serialize_ros1`` applied to each message as
built one by one
(``rosbag._write_messages``), over random values: NaN, infinities, signed zeros, float32
rounding and overflow, times beyond the int32 seconds of a ROS stamp, numeric and text
extras, logs longer than one block.
"""

from __future__ import annotations

import struct
from unittest import mock

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

import energy_planner.measurements.rosbag as rosbag
from energy_planner.io.bag import typestore
from energy_planner.measurements import load_rosbag, write_rosbag
from energy_planner.measurements._cdr import FixedLayout, _NotFixedLayout

ANY_FLOAT = st.one_of(
    st.floats(),  # NaN, +-inf, huge, subnormal, -0.0
    st.floats(-10.0, 10.0),
)
#: Values a float32 field takes without overflow (NaN and infinities included).
FLOAT32 = st.one_of(st.floats(width=32), st.floats(-3.4e38, 3.4e38), st.floats(-10.0, 10.0))
#: Around the largest float32 (3.4028234664e38): up to half an ulp above, it rounds to it.
NEAR_FLT_MAX = st.floats(3.4028234e38, 3.4028236e38) | st.floats(-3.4028236e38, -3.4028234e38)
LAST_SECOND = (2**31 - 1) * 10**9
INT64 = st.integers(-(2**63), 2**63 - 1)
F64_COLUMNS = ("qw", "qx", "qy", "qz", "vx", "vy", "wz", "voltage", "current", "x", "y", "yaw")


class Recorder:
    """Stands for a rosbags writer: keeps what ``write`` gets."""

    def __init__(self):
        self.out = []

    def write(self, conn, ns, data):
        self.out.append((conn, ns, bytes(data)))


@pytest.mark.parametrize("version", [2, 1])
@settings(max_examples=30, deadline=None)
@given(data=st.data())
def test_blocks_write_the_bytes_of_messages_serialized_one_by_one(version, data):
    n = data.draw(st.integers(1, 20), label="n")
    # one draw per group of columns (rows: F64_COLUMNS but voltage and current, then the
    # numeric extra)
    f64 = data.draw(hnp.arrays(np.float64, (len(F64_COLUMNS) - 1, n), elements=ANY_FLOAT))
    col = dict(
        zip([c for c in F64_COLUMNS if c not in ("voltage", "current")], f64[:-1], strict=True)
    )
    numeric = f64[-1]
    # half the examples may hold values a ROS stamp / float32 cannot take
    wide = data.draw(st.booleans(), label="wide")
    ns = st.integers(-(2**31) * 10**9, LAST_SECOND + 10**9 - 1)
    if wide:
        ns = st.one_of(ns, st.integers(LAST_SECOND, LAST_SECOND + 10**10), INT64)
    stamps = data.draw(
        hnp.arrays(np.int64, n, elements=ns),
        label="stamps",
    )
    f32 = st.one_of(FLOAT32, NEAR_FLT_MAX, st.floats()) if wide else FLOAT32
    col["voltage"], col["current"] = data.draw(hnp.arrays(np.float64, (2, n), elements=f32))
    text = data.draw(st.lists(st.text(max_size=12), min_size=n, max_size=n), label="text")
    xconn = [("num", True, numeric), ("txt", False, text)]
    conn = {"imu": "i", "odom": "o", "battery": "b"}
    ts = typestore(version)
    per_message, blocks = Recorder(), Recorder()
    layouts = rosbag._layouts(version)
    with mock.patch.object(rosbag, "_BLOCK", 7):  # several blocks, one partial
        try:
            rosbag._write_messages(per_message, ts, version == 1, conn, xconn, col, stamps)
        except (struct.error, OverflowError):
            # a stamp beyond int32 seconds or a value beyond float32: write_rosbag does
            # not use the blocks, the per-message path raises as it does here
            assert not rosbag._fits_layouts(col, stamps)
            return
        except ValueError:  # math.sin of an infinite yaw: the same error
            with pytest.raises(ValueError, match="math domain"):
                rosbag._write_blocks(blocks, ts, layouts, conn, xconn, col, stamps)
            return
        assert rosbag._fits_layouts(col, stamps)
        rosbag._write_blocks(blocks, ts, layouts, conn, xconn, col, stamps)
    assert len(blocks.out) == 5 * n
    assert blocks.out == per_message.out


def sample_table(n=50, seed=3):
    rng = np.random.default_rng(seed)
    q = rng.normal(size=(n, 4))
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    return pd.DataFrame(
        {
            "run": "r",
            "t": 1.5 + 0.01 * np.arange(n),
            "qw": q[:, 0],
            "qx": q[:, 1],
            "qy": q[:, 2],
            "qz": q[:, 3],
            "vx": rng.normal(0.3, 0.1, n),
            "vy": rng.normal(0.0, 0.1, n),
            "wz": rng.normal(0.0, 0.2, n),
            "voltage": rng.uniform(40, 58, n),
            "current": rng.uniform(1, 20, n),
            "x": rng.normal(0, 5, n),
            "y": rng.normal(0, 5, n),
            "yaw": rng.uniform(-np.pi, np.pi, n),
            "motor_temp": np.where(np.arange(n) % 7 == 0, np.nan, rng.uniform(20, 80, n)),
            "ground": pd.Categorical(np.where(np.arange(n) < n // 2, "grass", "gravel")),
        }
    )


@pytest.mark.parametrize("version", [2, 1])
def test_bag_files_are_those_of_the_per_message_path(tmp_path, version):
    df = sample_table()
    name = "bag.bag" if version == 1 else "bag"
    blocks, messages = tmp_path / "blocks" / name, tmp_path / "messages" / name
    blocks.parent.mkdir()
    messages.parent.mkdir()
    write_rosbag(df, blocks, version=version)
    with mock.patch.object(rosbag, "_layouts", lambda version: None):
        write_rosbag(df, messages, version=version)
    files = [""] if version == 1 else ["bag.mcap", "metadata.yaml"]
    for f in files:
        assert (blocks / f).read_bytes() == (messages / f).read_bytes()
    back = load_rosbag(blocks)
    pd.testing.assert_frame_equal(back, load_rosbag(messages), check_exact=True)
    np.testing.assert_array_equal(back["vx"], df["vx"])
    np.testing.assert_array_equal(back["voltage"], df["voltage"].astype(np.float32))
    np.testing.assert_array_equal(back["motor_temp"], df["motor_temp"])
    assert list(back["ground"]) == list(df["ground"])


def test_layout_refuses_fields_that_are_not_fixed_numbers():
    ts = typestore(2)
    T = ts.types
    with pytest.raises(_NotFixedLayout, match="not numeric"):
        FixedLayout(ts, "std_msgs/msg/String", T["std_msgs/msg/String"](data="a"), ["data"])
    with pytest.raises(_NotFixedLayout, match="not supported"):
        path = T["nav_msgs/msg/Path"](
            header=T["std_msgs/msg/Header"](
                stamp=T["builtin_interfaces/msg/Time"](sec=0, nanosec=0), frame_id="map"
            ),
            poses=[],
        )
        FixedLayout(ts, "nav_msgs/msg/Path", path, ["header.stamp.sec"])


def test_layout_offsets_put_each_value_at_its_place():
    # Float64 in CDR: 4-byte header (little endian) then the double at payload offset 0;
    # in ROS 1 the double alone
    ts1 = typestore(1)
    lay = FixedLayout(
        ts1, "std_msgs/msg/Float64", ts1.types["std_msgs/msg/Float64"](data=0.0), ["data"], True
    )
    assert lay.serialize({"data": np.array([3.0])}) == [struct.pack("<d", 3.0)]
    ts = typestore(2)
    lay = FixedLayout(
        ts, "std_msgs/msg/Float64", ts.types["std_msgs/msg/Float64"](data=0.0), ["data"]
    )
    out = lay.serialize({"data": np.array([1.0, -2.5])})
    assert out == [b"\x00\x01\x00\x00" + struct.pack("<d", v) for v in (1.0, -2.5)]
