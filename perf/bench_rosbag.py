"""Reading a ROS 2 bag of 1 000 000 messages into a Recording (issue 41).

Usage: python perf/bench_rosbag.py [--messages 1000000] [--storage mcap|sqlite3] [--json FILE]

Writes, with rosbags' own writer, a bag of a 2-module robot logging its three streams at 1 kHz
(joint angles in ``sensor_msgs/JointState``, the six actuator cells and the three tip cells in
``std_msgs/Float64MultiArray``; ``tests/bags.py``) until it holds ``--messages`` messages, then
times ``tendon_id.data.mapping.read_files`` on it through the bag mapping of the tests: every
message parsed, three streams brought onto the joint stream's clock. Reports the write and read
times, messages per second, and the peak resident memory of the read.
"""

from __future__ import annotations

import argparse
import platform
import resource
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

from bags import MAPPING, RATES, signals, write_bag  # noqa: E402

from tendon_id.atomic import write_json_atomic  # noqa: E402
from tendon_id.data.mapping import load_mapping, read_files  # noqa: E402


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--messages", type=int, default=1_000_000)
    ap.add_argument("--storage", choices=("mcap", "sqlite3"), default="mcap")
    ap.add_argument("--json", default=None)
    args = ap.parse_args(argv)
    for topic in RATES:
        RATES[topic] = 1000.0  # every stream at 1 kHz, as the bench data's logger
    duration = args.messages / (len(RATES) * 1000.0)
    streams = signals(duration_s=duration)
    n_messages = sum(len(t) for t, _ in streams.values())
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        t0 = time.perf_counter()
        bag = write_bag(tmp / "bag", streams, storage=args.storage)
        write_s = time.perf_counter() - t0
        (tmp / "bag.toml").write_text(MAPPING)
        mapping = load_mapping(tmp / "bag.toml")
        t0 = time.perf_counter()
        (rec,) = read_files([bag], mapping)
        read_s = time.perf_counter() - t0
        size = sum(p.stat().st_size for p in bag.iterdir())
    peak_mb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
    result = {
        "messages": n_messages,
        "storage": args.storage,
        "bag_mb": size / 1e6,
        "write_s": write_s,
        "read_s": read_s,
        "messages_per_s": n_messages / read_s,
        "frames": rec.n_frames,
        "peak_rss_mb": peak_mb,
        "machine": f"{platform.machine()}, {platform.python_version()}",
    }
    for k, v in result.items():
        print(f"{k:16s} {v:.2f}" if isinstance(v, float) else f"{k:16s} {v}")
    if args.json:
        write_json_atomic(Path(args.json), result)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
