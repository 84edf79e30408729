"""Small ROS 2 bags written with rosbags' own writer, for the bag reader's tests and benchmark.

A 2-module robot logs three streams at their own rates: joint angles (``sensor_msgs/JointState``,
stamped in its header), the six actuator cells and the three tip cells (``std_msgs/Float64MultiArray``,
unstamped: the recorder's receive time places them).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

#: The mapping that reads the bags below (patterns over modules and tendons).
MAPPING = """kind = "snake"
[meta]
n_modules = 2
[file]
clock = "/joint_states"
[columns]
"theta_{k}_x" = { topic = "/joint_states", field = "position[{2*k0}]" }
"theta_{k}_y" = { topic = "/joint_states", field = "position[{2*k0 + 1}]" }
"tension_act_{j}_{i}" = { topic = "/cells/act", field = "data[{3*j0 + i0}]", unit = "N" }
"tension_joint_2_{i}" = { topic = "/cells/tip", field = "data[{i0}]", unit = "N" }
"""

#: Rates [Hz] of the three streams.
RATES = {"/joint_states": 100.0, "/cells/act": 50.0, "/cells/tip": 20.0}


def signals(duration_s: float, seed: int = 0) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Per topic: sample instants [ns] and values (angles [rad], tensions [N]), all streams over one span."""
    rng = np.random.default_rng(seed)
    out = {}
    for topic, rate in RATES.items():
        n = int(round(duration_s * rate)) + 1
        t_ns = np.round(np.arange(n) * 1e9 / rate).astype(np.int64)
        width = 4 if topic == "/joint_states" else 6 if topic == "/cells/act" else 3
        if topic == "/joint_states":
            values = 0.2 * np.sin(np.outer(t_ns * 1e-9, np.arange(1, width + 1)))
        else:
            values = 50.0 + 10.0 * rng.random((n, width))
        out[topic] = (t_ns, values)
    return out


def write_bag(path: Path, streams: dict, *, storage: str = "mcap") -> Path:
    """Write ``streams`` to a rosbag2 folder at ``path`` (``storage``: ``mcap`` or ``sqlite3``)."""
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS2_HUMBLE)
    JointState = store.types["sensor_msgs/msg/JointState"]
    Header, Time = store.types["std_msgs/msg/Header"], store.types["builtin_interfaces/msg/Time"]
    Array, Layout = store.types["std_msgs/msg/Float64MultiArray"], store.types["std_msgs/msg/MultiArrayLayout"]
    plugin = StoragePlugin.MCAP if storage == "mcap" else StoragePlugin.SQLITE3
    empty = np.array([], dtype=np.float64)
    with Writer(path, version=9, storage_plugin=plugin) as w:
        conns = {
            t: w.add_connection(t, (JointState if t == "/joint_states" else Array).__msgtype__, typestore=store)
            for t in streams
        }
        # Messages in receive order across topics, as a recorder writes them.
        events = sorted((int(ts), topic, k) for topic, (t_ns, _) in streams.items() for k, ts in enumerate(t_ns))
        for ts, topic, k in events:
            values = streams[topic][1][k]
            if topic == "/joint_states":
                stamp = Time(sec=ts // 1_000_000_000, nanosec=ts % 1_000_000_000)
                msg = JointState(Header(stamp=stamp, frame_id=""), ["q"] * len(values), values, empty, empty)
            else:
                msg = Array(Layout(dim=[], data_offset=0), np.asarray(values, dtype=np.float64))
            # Unstamped streams arrive 1 ms after they were sampled; the stamped one 3 ms (its stamp is used).
            delay = 3_000_000 if topic == "/joint_states" else 1_000_000
            w.write(conns[topic], ts + delay, store.serialize_cdr(msg, msg.__msgtype__))
    return path
