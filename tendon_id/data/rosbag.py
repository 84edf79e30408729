"""ROS 2 bags read through a mapping, without a ROS installation (:doc:`/guide/data`).

A bag is a rosbag2 folder (``metadata.yaml`` beside its ``.db3`` or ``.mcap`` files) or a bare
``.mcap`` file; both are read with the `rosbags <https://gitlab.com/ternaris/rosbags>`_ package,
which parses the messages with the definitions the bag carries. The mapping names each signal's
topic and field (:mod:`tendon_id.data.mapping`)::

    [file]
    clock = "/joint_states"          # the stream whose instants are the frames (default: the fastest)

    [columns]
    "theta_{k}_x" = { topic = "/joint_states", field = "position[{2*k0}]" }
    "tension_act_{j}_{i}" = { topic = "/cells", field = "data[{(j0)*4 + i0}]", unit = "mN" }

**Time stamps.** A message with a ``header`` is placed at its ``header.stamp`` (when the sensor
sampled it); any other at the bag's receive time (when the recorder got it).

**One clock.** Streams logged at different rates are brought onto the instants of one stream, the
clock: the ``[file] clock`` topic, else the topic with the most messages. Only the span every
stream covers is kept, so no value is extrapolated. Angles are interpolated linearly between their
two neighbouring samples (an encoder samples a joint that moves smoothly between its readings).
Tensions are held from their last sample at or before the instant (zero-order hold): a load cell's
reading between two samples is unknown, holding it invents no value and never uses a sample from
the future, which a causal estimator could not have either.
"""

from __future__ import annotations

import re
from collections import defaultdict
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from tendon_id.errors import ConfigError, RecordingError

__all__ = ["is_bag", "read_bag"]

#: One step of a field path: a name, then any ``[index]``.
_STEP = re.compile(r"^([A-Za-z_]\w*)((?:\[\d+\])*)$")


def is_bag(path: Path) -> bool:
    """Whether ``path`` is a ROS 2 bag: a bare ``.mcap`` file, or a folder with ``metadata.yaml``."""
    return (path.is_file() and path.suffix.lower() == ".mcap") or (path.is_dir() and (path / "metadata.yaml").is_file())


def _parse_field(text: str, where: str) -> list[tuple[str, list[int]]]:
    steps = []
    for part in text.split("."):
        m = _STEP.match(part.strip())
        if not m:
            raise ConfigError(f"{where}: field {text!r}: {part!r} is not a name with optional [index]")
        steps.append((m.group(1), [int(x) for x in re.findall(r"\[(\d+)\]", m.group(2))]))
    return steps


def _open(path: Path):
    """The bag's readers (opened) and a typestore with the message types it carries."""
    from rosbags.highlevel import AnyReader
    from rosbags.interfaces import MessageDefinitionFormat
    from rosbags.rosbag2.storage_mcap import McapReader
    from rosbags.typesys import Stores, get_types_from_idl, get_types_from_msg, get_typestore

    if path.is_dir():
        reader = AnyReader([path])
        reader.open()
        return reader, reader.connections, reader.typestore, reader.messages
    # A bare MCAP file carries its channels and schemas itself: rosbags' MCAP storage reads them without a
    # metadata.yaml, and the types are registered as AnyReader registers a folder's.
    reader = McapReader(path)
    reader.open()
    types: dict = {}
    for c in reader.connections:
        if c.msgdef.format == MessageDefinitionFormat.MSG:
            types.update(get_types_from_msg(c.msgdef.data, c.msgtype))
        elif c.msgdef.format == MessageDefinitionFormat.IDL:
            types.update(get_types_from_idl(c.msgdef.data))
    store = get_typestore(Stores.EMPTY)
    store.register(types)
    return reader, reader.connections, store, lambda connections: reader.messages(connections)


def _topic_messages(path: Path, topics: set[str], src: str) -> dict[str, tuple[np.ndarray, list]]:
    """Per topic: the messages' instants [ns] (header stamp, else receive time) and the messages."""
    try:
        reader, connections, store, messages = _open(path)
    except ConfigError:
        raise
    except Exception as exc:  # rosbags raises its own errors, OSError and ValueError for a damaged bag
        raise RecordingError(f"not a readable ROS 2 bag ({type(exc).__name__}: {exc})", file=src) from None
    try:
        have = {c.topic for c in connections}
        for t in sorted(topics - have):
            raise RecordingError(f"the bag has no topic {t!r}; its topics: {', '.join(sorted(have))}", file=src)
        wanted = [c for c in connections if c.topic in topics]
        stamps: dict[str, list[int]] = defaultdict(list)
        msgs: dict[str, list] = defaultdict(list)
        for conn, t_ns, raw in messages(wanted):
            msg = store.deserialize_cdr(raw, conn.msgtype)
            header = getattr(msg, "header", None)
            stamp = getattr(header, "stamp", None)
            stamps[conn.topic].append(t_ns if stamp is None else stamp.sec * 1_000_000_000 + stamp.nanosec)
            msgs[conn.topic].append(msg)
    finally:
        reader.close()
    out = {}
    for t in topics:
        if not msgs[t]:
            raise RecordingError(f"topic {t!r} has no messages", file=src)
        order = np.argsort(np.asarray(stamps[t], dtype=np.int64), kind="stable")
        out[t] = (np.asarray(stamps[t], dtype=np.int64)[order], [msgs[t][k] for k in order])
    return out


def _field_values(msgs: list, steps: list, topic: str, field: str, src: str) -> np.ndarray:
    """The field's value in every message, as float64: attributes followed, the last array indexed at once."""
    (name, idx), head = steps[-1], steps[:-1]
    objs = msgs
    try:
        for attr, index in head:
            objs = [getattr(o, attr) for o in objs]
            for k in index:
                objs = [o[k] for o in objs]
        last = [getattr(o, name) for o in objs]
        if idx and isinstance(last[0], np.ndarray):
            # Arrays of one length stack into one block, indexed for every message at once.
            lengths = {len(a) for a in last}
            if len(lengths) == 1:
                block = np.stack(last)
                for k in idx:
                    block = block[:, k]
                return np.asarray(block, dtype=np.float64)
        for k in idx:
            last = [o[k] for o in last]
        return np.asarray(last, dtype=np.float64)
    except AttributeError as exc:
        raise RecordingError(f"topic {topic!r}: its messages have no field {field!r} ({exc})", file=src) from None
    except IndexError:
        raise RecordingError(f"topic {topic!r}: field {field!r} is out of range in a message", file=src) from None
    except (TypeError, ValueError):
        raise RecordingError(f"topic {topic!r}: field {field!r} is not a number", file=src) from None


def read_bag(path: Path, mapping, *, trajectory: str | None = None):
    """One bag read through ``mapping`` onto one clock (see the module docstring), in SI units.

    Returns
    -------
    FrameRecording
        The mapping family's recording, one trajectory (``trajectory``, default the bag's name).

    Raises
    ------
    RecordingError
        Naming the bag and the topic or field: a missing topic or field, a field that is not a
        number, a topic without messages, streams that never overlap in time.
    """
    src = str(path)
    topics = {c.topic for c in mapping.columns}
    if mapping.clock is not None:
        topics.add(mapping.clock)
    data = _topic_messages(path, topics, src)
    clock_topic = mapping.clock or max(sorted(data), key=lambda t: len(data[t][0]))
    start = max(int(s[0]) for s, _ in data.values())
    end = min(int(s[-1]) for s, _ in data.values())
    stamps = data[clock_topic][0]
    keep = (stamps >= start) & (stamps <= end)
    if keep.sum() < 2:
        raise RecordingError(f"the topics {', '.join(sorted(topics))} overlap in fewer than two {clock_topic} instants",
                             file=src)  # fmt: skip
    instants = stamps[keep]
    out: dict[str, Any] = {"t": (instants - instants[0]) * 1e-9}
    parsed: dict[tuple[str, str], np.ndarray] = {}
    for c in mapping.columns:
        key = (c.topic, c.field)
        if key not in parsed:
            when, msgs = data[c.topic]
            values = _field_values(msgs, _parse_field(c.field, f"{mapping.source}: columns.{c.name}"), *key, src)
            parsed[key] = _onto(when, values, instants, hold=c.kind != "angle")
        out[c.name] = c.factor * parsed[key]
    frame = pd.DataFrame(out)
    for c in mapping.columns:
        bad = np.flatnonzero(~np.isfinite(frame[c.name].to_numpy()))
        if bad.size:
            raise RecordingError(f"topic {c.topic!r} field {c.field!r} is not finite", file=src, column=c.name,
                                 row=int(bad[0]))  # fmt: skip
    frame.insert(0, "trajectory", trajectory or path.stem)
    meta = {"source_files": [path.name], "mapping": Path(mapping.source).name, "clock": clock_topic}
    return mapping.recording.from_mapped(frame, meta, mapping.options, src)


def _onto(when: np.ndarray, values: np.ndarray, instants: np.ndarray, *, hold: bool) -> np.ndarray:
    """``values`` sampled at ``when`` [ns] brought onto ``instants``: held from the last sample, or interpolated."""
    if hold:
        return values[np.searchsorted(when, instants, side="right") - 1]
    return np.interp(instants.astype(np.float64), when.astype(np.float64), values)
