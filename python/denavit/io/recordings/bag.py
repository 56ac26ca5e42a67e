"""ROS 1 bags and ROS 2 bags (sqlite3 and MCAP storage), read with the pure-Python ``rosbags`` package.

``rosbags`` (PyPI, gitlab.com/ternaris/rosbags; documentation ternaris.gitlab.io/rosbags) is an optional
dependency: ``pip install "denavit[ros]"``. Its :class:`rosbags.highlevel.AnyReader` opens a ROS 1 ``.bag``
file or a ROS 2 bag folder (``metadata.yaml`` with ``.db3`` or ``.mcap`` files) and deserialises messages
with the definitions the bag carries (the ROS 2 Humble standard types when it carries none).

Read: one ``sensor_msgs/JointState`` topic (joint readings: ``position``, rad / m, by joint name, REP 103) and
one measured point topic: ``geometry_msgs/PointStamped`` (a point), ``PoseStamped`` or ``TransformStamped``
(a pose), or ``tf2_msgs/TFMessage`` (``/tf``: the transforms whose ``child_frame_id`` is ``child_frame``).
Times are the messages' ``header.stamp`` (the bag's receive time when a stamp is zero). Both topics are on
the ROS clock, so the readings are interpolated at the point times without an offset
(:func:`denavit.recording.align` with ``offset=0``).
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from ...errors import DenavitError

INSTALL = 'pip install "denavit[ros]"'
POINT_TYPES = (
    "geometry_msgs/msg/PointStamped",
    "geometry_msgs/msg/PoseStamped",
    "geometry_msgs/msg/TransformStamped",
    "tf2_msgs/msg/TFMessage",
)


def _rosbags():
    try:
        from rosbags.highlevel import AnyReader  # noqa: PLC0415
        from rosbags.typesys import Stores, get_typestore  # noqa: PLC0415
    except ImportError:
        raise DenavitError(f"reading ROS bags needs the optional package rosbags: {INSTALL}") from None
    return AnyReader, get_typestore(Stores.ROS2_HUMBLE)


def bag_path(path: Path) -> Path:
    """The bag to open: a ROS 1 file, a ROS 2 folder, or the folder of a ROS 2 ``.db3`` / ``.mcap`` file."""
    if path.is_file() and path.suffix.lower() in (".db3", ".mcap") and (path.parent / "metadata.yaml").exists():
        return path.parent
    return path


def _stamp(header, t_bag: int) -> float:
    s = header.stamp
    ns = int(s.sec) * 1_000_000_000 + int(s.nanosec)
    return (ns if ns else t_bag) * 1e-9


def _pose(translation, rotation) -> np.ndarray:
    from scipy.spatial.transform import Rotation  # noqa: PLC0415

    T = np.eye(4)
    T[:3, :3] = Rotation.from_quat([rotation.x, rotation.y, rotation.z, rotation.w]).as_matrix()
    T[:3, 3] = [translation.x, translation.y, translation.z]
    return T


def read(
    path: str | os.PathLike,
    *,
    joint_topic: str | None = None,
    point_topic: str | None = None,
    child_frame: str | None = None,
    joint_names=None,
):
    """Read a bag: a Recording of the points (or poses) with the joint readings interpolated at their times."""
    from ...recording import Recording, align, check_time  # noqa: PLC0415

    AnyReader, store = _rosbags()
    path = Path(path)
    try:
        reader = AnyReader([bag_path(path)], default_typestore=store)
        reader.open()
    except Exception as e:  # noqa: BLE001 (rosbags raises several unrelated types for unreadable bags)
        raise DenavitError(
            f"{path}: not a readable ROS bag: {str(e).splitlines()[0][:120] if str(e) else type(e).__name__}"
        ) from None
    try:
        topics = {c.topic: c.msgtype for c in reader.connections}
        listing = ", ".join(f"{t} ({m})" for t, m in sorted(topics.items())) or "none"

        def pick(given, types, what):
            if given is not None:
                if given not in topics:
                    raise DenavitError(f"{path}: no topic {given}: expected a {what} topic (topics: {listing})")
                if topics[given] not in types:
                    raise DenavitError(f"{path}: topic {given} is {topics[given]}: expected {' or '.join(types)}")
                return given
            found = [t for t, m in topics.items() if m in types]
            if not found:
                raise DenavitError(
                    f"{path}: no {what} topic: expected one of type {' or '.join(types)} (topics: {listing})"
                )
            if len(found) > 1:
                raise DenavitError(f"{path}: several {what} topics ({', '.join(sorted(found))}): expected one; name it")
            return found[0]

        jt = pick(joint_topic, ("sensor_msgs/msg/JointState",), "sensor_msgs/JointState")
        pt = pick(point_topic, POINT_TYPES, "measured point (PointStamped, PoseStamped, TransformStamped or tf)")
        tq, q, wq, names = [], [], [], list(joint_names) if joint_names else None
        tp, T, P, wp = [], [], [], []
        frames = set()
        for con, t_bag, raw in reader.messages(connections=[c for c in reader.connections if c.topic in (jt, pt)]):
            msg = reader.deserialize(raw, con.msgtype)
            if con.topic == jt:
                if names is None:
                    names = list(msg.name)
                pos = dict(zip(msg.name, msg.position))
                miss = [n for n in names if n not in pos]
                if miss:
                    raise DenavitError(
                        f"{path}: {jt} message {len(tq) + 1}: no position of joint(s) {', '.join(miss)}: expected"
                        f" {', '.join(names)}"
                    )
                tq.append(_stamp(msg.header, t_bag))
                q.append([pos[n] for n in names])
                wq.append(f"{path} {jt} #{len(tq)}")
                continue
            mtype = con.msgtype
            if mtype.endswith("PointStamped"):
                tp.append(_stamp(msg.header, t_bag))
                P.append([msg.point.x, msg.point.y, msg.point.z])
            elif mtype.endswith("PoseStamped"):
                tp.append(_stamp(msg.header, t_bag))
                T.append(_pose(msg.pose.position, msg.pose.orientation))
            else:
                for tf in msg.transforms if mtype.endswith("TFMessage") else [msg]:
                    frames.add(tf.child_frame_id)
                    if child_frame is not None and tf.child_frame_id != child_frame:
                        continue
                    tp.append(_stamp(tf.header, t_bag))
                    T.append(_pose(tf.transform.translation, tf.transform.rotation))
            wp.append(f"{path} {pt} #{len(tp)}")
        if mtype_is_tf(topics[pt]) and child_frame is None and len(frames) > 1:
            raise DenavitError(
                f"{path}: {pt} carries several frames ({', '.join(sorted(frames))}): expected one; name it"
                " (child_frame)"
            )
    finally:
        reader.close()
    if not tq:
        raise DenavitError(f"{path}: topic {jt} has no messages: expected joint readings")
    if not tp:
        raise DenavitError(
            f"{path}: topic {pt} has no {'messages' if child_frame is None else f'transforms of frame {child_frame}'}:"
            " expected measured points"
        )
    tq, tp = np.array(tq), np.array(tp)
    check_time(tq, wq, "header.stamp")
    check_time(tp, wp, "header.stamp")
    poses = np.array(T) if T else None
    pts = poses[:, None, :3, 3] if poses is not None else np.array(P)[:, None, :]
    units = {"length": "m", "angle": "rad", "time": "s"}
    points = Recording(
        tp,
        None,
        pts,
        wp,
        str(path),
        "bag",
        units,
        poses,
        notes=[f"{path}: joint readings from {jt} ({', '.join(names)}), points from {pt}"],
    )
    readings = Recording(
        tq, np.array(q), None, wq, str(path), "bag", units, kinds=["revolute"] * len(names), names=names
    )
    merged, _ = align(points, readings, offset=0.0)
    return Recording(
        merged.time,
        merged.q,
        merged.points,
        merged.where,
        str(path),
        "bag",
        units,
        merged.poses,
        merged.kinds,
        None,
        names,
        points.notes,
    )


def mtype_is_tf(mtype: str) -> bool:
    return mtype.endswith("TFMessage") or mtype.endswith("TransformStamped")
