"""What a Python user does to get IMU samples out of a ROS 2 MCAP bag: the `rosbags`
package (pure Python, no ROS install), messages deserialized one by one into numpy arrays.

Usage (venv under target/, see README "Log formats"):
    target/venv/bin/python benches/rosbags_read.py target/bench-data/imu_10800000_1khz.mcap
Prints messages, seconds and messages/s.
"""
import pathlib
import sys
import time

import numpy as np
from rosbags.rosbag2 import Reader
from rosbags.typesys import Stores, get_typestore

src = pathlib.Path(sys.argv[1]).resolve()
typestore = get_typestore(Stores.ROS2_HUMBLE)
t0 = time.perf_counter()
# rosbags (0.11) opens a single .mcap file directly, without metadata.yaml; messages are
# deserialized with its built-in ROS 2 Humble types.
with Reader(src) as reader:
    conns = [c for c in reader.connections if c.topic == "/imu0"]
    n = sum(c.msgcount for c in conns)
    stamps = np.empty(n, dtype=np.int64)
    data = np.empty((n, 6))
    for i, (conn, _t, raw) in enumerate(reader.messages(connections=conns)):
        m = typestore.deserialize_cdr(raw, conn.msgtype)
        stamps[i] = m.header.stamp.sec * 1_000_000_000 + m.header.stamp.nanosec
        w, a = m.angular_velocity, m.linear_acceleration
        data[i] = (w.x, w.y, w.z, a.x, a.y, a.z)
dt = time.perf_counter() - t0
print(f"{n} messages in {dt:.2f} s: {n / dt:.3e} messages/s")
