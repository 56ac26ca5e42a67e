"""Recordings from instruments (issue 13): every reader on a file written by this module's generator from a
simulated KR5, time alignment of two clocks, segmentation of a continuous recording, and bad input.

The generator (``plan`` / ``q_at`` / ``write_*``) writes tests/data/recordings; run this file as a script
(``PYTHONPATH=python python tests/test_recordings.py``) to rewrite them. The text files are checked to be
exactly what the generator writes.
"""

import csv
import io
import math
import re
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

import denavit as dv
from denavit import geometry
from denavit import recording as rc
from denavit import sweeps as sw
from denavit.identification import identify
from denavit.io.recordings import read_recording
from denavit.io.recordings.segmentation import segmentation_table

DATA = Path(__file__).parent / "data" / "recordings"
HOME = np.radians(sw.PAPER_HOME_DEG)
RANGES = np.radians(sw.PAPER_RANGES_DEG[30])
DIRECTION = np.sign(RANGES[:, 1] - RANGES[:, 0])
TOOL = np.array([0.05, 0.03, 0.10])  # the target in the flange frame (m)
NEST = np.array([[0.05, 0.03, 0.10], [-0.04, 0.05, 0.10], [0.0, -0.06, 0.12]])  # three SMRs on a nest (m, flange frame)


# --- the generator ---------------------------------------------------------------------------------------


def plan(*, sweep_speed=30.0, transit_speed=90.0, dwell=0.5, home=HOME, ranges=RANGES):
    """Moves of the paper's protocol: for each joint, home -> range start, dwell, the sweep, dwell, -> home, dwell
    (legs of zero length left out); a cosine speed profile per leg. Speeds in deg/s, dwell in s.
    Returns (moves [(t0, T, joint 0-based, from, to)], duration, truth [(joint, t0, t1)] of the sweeps)."""
    moves, t, truth = [], dwell, []
    for j in range(len(home)):
        a, b = ranges[j]
        for x0, x1, v, is_sweep in (
            (home[j], a, transit_speed, False),
            (a, b, sweep_speed, True),
            (b, home[j], transit_speed, False),
        ):
            if abs(x1 - x0) < 1e-12:
                continue
            T = abs(x1 - x0) / math.radians(v)
            moves.append((t, T, j, x0, x1))
            if is_sweep:
                truth.append((j + 1, t, t + T))
            t += T + dwell
    return moves, t, truth


def q_at(t, moves, home=HOME):
    """(m, n) joint values at times t (s) of the plan."""
    q = np.tile(np.asarray(home, float), (len(t), 1))
    for t0, T, j, a, b in moves:
        s = np.clip((np.asarray(t) - t0) / T, 0, 1)
        q[:, j] += (b - a) * (1 - np.cos(np.pi * s)) / 2
    return q


def flange(q):
    return dv.fk_batch(dv.load_model("kr5").with_tool(np.eye(4)), q)


def targets(q, nest=NEST[:1]):
    """(m, k, 3) the nest's targets (m) at configurations q."""
    F = flange(q)
    return np.einsum("mij,kj->mki", F[:, :3, :3], nest) + F[:, None, :3, 3]


def tool_poses(q):
    """(m, 4, 4) TCP poses: the flange with the tool point TOOL and a tilted tool frame."""
    T_ft = np.eye(4)
    T_ft[:3, :3] = geometry.rpy_matrix([0.1, -0.2, 0.3])
    T_ft[:3, 3] = TOOL
    return flange(q) @ T_ft


def noisy(x, sigma, seed):
    return x + np.random.default_rng(seed).normal(0.0, sigma, np.shape(x))


def g(v, digits=9):
    """A number as a short decimal text."""
    return f"{round(float(v), digits):.{digits}g}" if v else "0"


def write_rtde(path, rate=20.0):
    """UR RTDE record.py output (rtde/csv_writer.py): space-separated, header of recipe names with _i, CRLF."""
    moves, dur, _ = plan()
    t = np.arange(0, dur, 1 / rate)
    q = q_at(t, moves)
    T = tool_poses(q)
    p = noisy(T[:, :3, 3], 1e-5, 1)
    rv = np.array([geometry.matrix_rotvec(R) for R in T[:, :3, :3]])
    out = io.StringIO()
    w = csv.writer(out, delimiter=" ")
    w.writerow(
        [
            "timestamp",
            *[f"actual_q_{i}" for i in range(6)],
            *[f"actual_TCP_pose_{i}" for i in range(6)],
            "speed_scaling",
        ]
    )
    for k in range(len(t)):
        w.writerow([g(1832.016 + t[k], 12), *map(g, q[k]), *map(g, p[k]), *map(g, rv[k]), "1"])
    Path(path).write_bytes(out.getvalue().encode())


def write_rsi(path, step_ms=48):
    """KUKA RSI <Rob> telegrams (RIst mm/deg A-B-C = Rz Ry Rx, AIPos deg, IPOC ms), logged every step_ms."""
    moves, dur, _ = plan()
    ipoc = np.arange(0, int(dur * 1000), step_ms) + 3_600_000
    t = (ipoc - ipoc[0]) * 1e-3
    q = q_at(t, moves)
    T = tool_poses(q)
    p = noisy(T[:, :3, 3], 1e-5, 2) * 1e3
    lines = []
    for k in range(len(t)):
        roll, pitch, yaw = geometry.matrix_rpy(T[k, :3, :3])
        A, B, C = np.degrees([yaw, pitch, roll])
        ax = " ".join(f'A{i + 1}="{math.degrees(v):.4f}"' for i, v in enumerate(q[k]))
        lines.append(
            f'<Rob Type="KUKA">\n  <RIst X="{p[k, 0]:.4f}" Y="{p[k, 1]:.4f}" Z="{p[k, 2]:.4f}" A="{A:.4f}" B="{B:.4f}"'
            f' C="{C:.4f}"/>\n  <AIPos {ax}/>\n  <Delay D="0"/>\n  <IPOC>{ipoc[k]}</IPOC>\n</Rob>'
        )
    Path(path).write_text("\n".join(lines) + "\n")


def write_tracker(path, per_sweep=9):
    """A SpatialAnalyzer-style point list: Collection,Group,Point,X,Y,Z in mm, stop-and-go poses J<j>_<nnn>_<SMR>,
    three SMRs per pose, no time."""
    rows = ["# units: length=mm", "Collection,Group,Point,X,Y,Z"]
    rng = np.random.default_rng(3)
    for j in range(6):
        qs = np.tile(HOME, (per_sweep, 1))
        qs[:, j] = np.linspace(RANGES[j, 0], RANGES[j, 1], per_sweep)
        P = targets(qs, NEST) + rng.normal(0, 1e-5, (per_sweep, 3, 3))
        for k in range(per_sweep):
            for s, name in enumerate("ABC"):
                x, y, z = P[k, s] * 1e3
                rows.append(f"Sweeps,J{j + 1},J{j + 1}_{k + 1:03d}_{name},{x:.4f},{y:.4f},{z:.4f}")
    Path(path).write_text("\n".join(rows) + "\n")


def write_tracker_6dof(path, per_sweep=9):
    """A 6-DoF probe export: tab-separated Group, Point, Time [s], X [mm], Y [mm], Z [mm], Q0..Q3 (scalar first)."""
    rows = ["Group\tPoint\tTime [s]\tX [mm]\tY [mm]\tZ [mm]\tQ0\tQ1\tQ2\tQ3"]
    rng = np.random.default_rng(4)
    t = 0.0
    from scipy.spatial.transform import Rotation

    for j in range(6):
        qs = np.tile(HOME, (per_sweep, 1))
        qs[:, j] = np.linspace(RANGES[j, 0], RANGES[j, 1], per_sweep)
        T = tool_poses(qs)
        for k in range(per_sweep):
            x, y, z = (T[k, :3, 3] + rng.normal(0, 1e-5, 3)) * 1e3
            qx, qy, qz, qw = Rotation.from_matrix(T[k, :3, :3]).as_quat()
            t += 1.5
            rows.append(
                f"Joint {j + 1}\tP{k + 1}\t{t:.3f}\t{x:.4f}\t{y:.4f}\t{z:.4f}\t{qw:.9f}\t{qx:.9f}\t{qy:.9f}\t{qz:.9f}"
            )
    Path(path).write_text("\n".join(rows) + "\n")


def write_columns(path, rate=20.0):
    """Whitespace-separated rows: t, six joint readings (deg), three targets x y z (mm); no header."""
    moves, dur, _ = plan()
    t = np.arange(0, dur, 1 / rate)
    q = q_at(t, moves)
    P = noisy(targets(q, NEST), 1e-5, 5) * 1e3
    rows = ["# units: length=mm angle=deg"]
    for k in range(len(t)):
        rows.append(
            " ".join([f"{t[k]:.3f}", *(f"{v:.6f}" for v in np.degrees(q[k])), *(f"{v:.4f}" for v in P[k].ravel())])
        )
    Path(path).write_text("\n".join(rows) + "\n")


def write_bag(path, kind, joints_rate=25.0, points_rate=20.0, with_joints=True, point_type="PointStamped"):
    """A ROS bag (kind "ros1", "sqlite3" or "mcap") with /joint_states and a measured point topic."""
    from rosbags.typesys import Stores, get_typestore

    moves, dur, _ = plan()
    store = get_typestore(Stores.ROS1_NOETIC if kind == "ros1" else Stores.ROS2_HUMBLE)
    T_ = store.types
    Header, Time = T_["std_msgs/msg/Header"], T_["builtin_interfaces/msg/Time"]
    names = [f"joint_a{i + 1}" for i in range(6)]

    def header(t, frame="world"):
        ns = int(round((1_700_000_000 + t) * 1e9))
        kw = {"seq": 0} if kind == "ros1" else {}
        return Header(**kw, stamp=Time(sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000), frame_id=frame)

    ser = store.serialize_ros1 if kind == "ros1" else store.serialize_cdr
    msgs = []
    if with_joints:
        tj = np.arange(0, dur, 1 / joints_rate)
        for t, q in zip(tj, q_at(tj, moves)):
            m = T_["sensor_msgs/msg/JointState"](
                header=header(t), name=names, position=q, velocity=np.zeros(0), effort=np.zeros(0)
            )
            msgs.append((t, "/joint_states", "sensor_msgs/msg/JointState", m))
    tp = np.arange(0.013, dur, 1 / points_rate)
    P = noisy(tool_poses(q_at(tp, moves))[:, :3, 3], 1e-5, 6)
    for t, p in zip(tp, P):
        if point_type == "PointStamped":
            m = T_["geometry_msgs/msg/PointStamped"](
                header=header(t), point=T_["geometry_msgs/msg/Point"](x=p[0], y=p[1], z=p[2])
            )
            msgs.append((t, "/tracker/point", "geometry_msgs/msg/PointStamped", m))
        else:
            tr = T_["geometry_msgs/msg/Transform"](
                translation=T_["geometry_msgs/msg/Vector3"](x=p[0], y=p[1], z=p[2]),
                rotation=T_["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=0.0, w=1.0),
            )
            ts = T_["geometry_msgs/msg/TransformStamped"](header=header(t), child_frame_id="smr", transform=tr)
            msgs.append((t, "/tf", "tf2_msgs/msg/TFMessage", T_["tf2_msgs/msg/TFMessage"](transforms=[ts])))
    msgs.sort(key=lambda m: m[0])
    if kind == "ros1":
        from rosbags.rosbag1 import Writer

        writer = Writer(Path(path))
    else:
        from rosbags.rosbag2 import StoragePlugin, Writer

        writer = Writer(
            Path(path), version=9, storage_plugin=StoragePlugin.MCAP if kind == "mcap" else StoragePlugin.SQLITE3
        )
    with writer as w:
        cons = {}
        for t, topic, mtype, m in msgs:
            if topic not in cons:
                cons[topic] = w.add_connection(topic, mtype, typestore=store)
            w.write(cons[topic], int(round((1_700_000_000 + t) * 1e9)) + 2_000_000, ser(m, mtype))


TEXT_FILES = {
    "rtde.csv": write_rtde,
    "rsi.xml": write_rsi,
    "tracker.csv": write_tracker,
    "tracker_6dof.txt": write_tracker_6dof,
    "columns.txt": write_columns,
}
BAGS = {"ros1.bag": "ros1", "ros2_sqlite3": "sqlite3", "ros2_mcap": "mcap"}


def write_all(folder: Path) -> None:
    folder.mkdir(parents=True, exist_ok=True)
    for name, write in TEXT_FILES.items():
        write(folder / name)
    import shutil

    for name, kind in BAGS.items():
        (folder / name).unlink() if (folder / name).is_file() else shutil.rmtree(folder / name, ignore_errors=True)
        write_bag(folder / name, kind)


# --- checks ----------------------------------------------------------------------------------------------


def truth_axes():
    return dv.axes(dv.load_model("kr5"), HOME)


def assert_axes_match_truth(res, k=6.0):
    """Every identified axis within k sigma (its fit's predicted uncertainty) of the simulator's axis."""
    truth = truth_axes()
    for j, f in enumerate(res.fits):
        z = truth.directions[j]
        d = res.axes.directions[j]
        angle = math.acos(min(1.0, float(d @ z)))
        off = np.linalg.norm(np.cross(res.axes.points[j] - truth.points[j], z))
        assert angle < k * f.sigma_direction + 1e-9, (j + 1, angle, f.sigma_direction)
        assert off < k * f.sigma_point_perp + 1e-8, (j + 1, off, f.sigma_point_perp)


def identify_recording(rec, **kw):
    seg = rc.segment(rec)
    assert [s.joint for s in seg.sweeps] == [1, 2, 3, 4, 5, 6], segmentation_table(seg)
    res = identify(rc.to_sweepset(rec, seg, **kw), nominal=dv.load_robot("kr5"))
    assert_axes_match_truth(res)
    return seg, res


@pytest.mark.parametrize("name", sorted(TEXT_FILES))
def test_committed_text_files_are_the_generators(name, tmp_path):
    TEXT_FILES[name](tmp_path / name)
    assert (tmp_path / name).read_bytes() == (DATA / name).read_bytes()


def test_rtde_log_identifies_the_truth():
    """UR RTDE: space-separated, timestamp, actual_q (rad), actual_TCP_pose (m + rotation vector); extra columns
    ignored."""
    rec = read_recording(DATA / "rtde.csv")
    assert rec.format == "rtde" and "detected" in rec.notes[0] and "UR RTDE" in rec.notes[0]
    assert rec.poses is not None and rec.q.shape[1] == 6 and abs(rec.rate - 20.0) < 1e-6
    np.testing.assert_allclose(rec.poses[:, :3, :3], tool_poses(rec.q)[:, :3, :3], atol=1e-8)
    identify_recording(rec)


def test_rsi_log_identifies_the_truth():
    """KUKA RSI: AIPos deg, RIst mm with A-B-C = Rz(A) Ry(B) Rx(C), IPOC ms."""
    rec = read_recording(DATA / "rsi.xml")
    assert rec.format == "rsi" and rec.units["length"] == "mm"
    np.testing.assert_allclose(rec.poses[:, :3, :3], tool_poses(rec.q)[:, :3, :3], atol=2e-6)  # 4 decimals of a degree
    np.testing.assert_allclose(np.diff(rec.time), 0.048)
    identify_recording(rec)


def test_tracker_export_with_three_smrs_per_pose_identifies_the_truth():
    """Point names J1_001_A...: sweeps from the groups (guessed and echoed), three targets per pose, each one a sweep
    set."""
    rec = read_recording(DATA / "tracker.csv")
    assert rec.format == "tracker" and rec.points.shape == (54, 3, 3) and rec.q is None
    assert any("Group column (guessed)" in n for n in rec.notes) and any("3 targets" in n for n in rec.notes)
    seg = rc.segment(rec)
    assert seg.method == "labels" and [s.joint for s in seg.sweeps] == [1, 2, 3, 4, 5, 6]
    for k in range(3):
        s = rc.to_sweepset(rec, seg, target=k, home=HOME, direction=DIRECTION)
        assert_axes_match_truth(identify(s, nominal=dv.load_robot("kr5")))
    # the same file with the sweeps taken from the point names by a given pattern
    rec2 = read_recording(DATA / "tracker.csv", sweep=r"J(?P<joint>\d+)_(?P<index>\d+)_(?P<target>[A-C])")
    np.testing.assert_array_equal(rec2.points, rec.points)
    assert any("pattern" in n and "(guessed)" not in n for n in rec2.notes)


def test_tracker_6dof_probe_identifies_the_truth():
    """6-DoF probe: position + quaternion (scalar first), units from the column names, groups 'Joint 1'."""
    rec = read_recording(DATA / "tracker_6dof.txt")
    assert rec.format == "tracker" and rec.poses is not None and rec.units["length"] == "mm"
    seg = rc.segment(rec)
    s = rc.to_sweepset(rec, seg, home=HOME, direction=DIRECTION)
    assert_axes_match_truth(identify(s, nominal=dv.load_robot("kr5")))
    # a point 0.1 m along the probe's z axis gives the same axes
    s2 = rc.to_sweepset(rec, seg, home=HOME, direction=DIRECTION, tool_point=[0.0, 0.0, 0.1])
    assert_axes_match_truth(identify(s2, nominal=dv.load_robot("kr5")))


def test_columns_file_with_three_targets_identifies_the_truth():
    """Whitespace, no header, t + six joints + three targets per row (the issue's hand-split case)."""
    rec = read_recording(DATA / "columns.txt", columns="t,q1..q6,x1,y1,z1,x2,y2,z2,x3,y3,z3")
    assert rec.format == "columns" and rec.points.shape[1:] == (3, 3)
    seg = rc.segment(rec)
    for k in range(3):
        res = identify(rc.to_sweepset(rec, seg, target=k), nominal=dv.load_robot("kr5"))
        assert_axes_match_truth(res)


def test_controller_log_with_a_pose_per_row(tmp_path):
    """x, y, z + quaternion per row (semicolons, a header the map overrides): the RTDE log's poses, written so."""
    from scipy.spatial.transform import Rotation

    rt = read_recording(DATA / "rtde.csv")
    quat = Rotation.from_matrix(rt.poses[:, :3, :3]).as_quat()[:, [3, 0, 1, 2]]
    f = tmp_path / "log.csv"
    rows = ["time;j1;j2;j3;j4;j5;j6;px;py;pz;w;x;y;z"]
    rows += [
        ";".join(f"{v:.10g}" for v in (t, *q, *p, *o)) for t, q, p, o in zip(rt.time, rt.q, rt.poses[:, :3, 3], quat)
    ]
    f.write_text("\n".join(rows) + "\n")
    rec = read_recording(f, columns="t,q1..q6,x,y,z,qw,qx,qy,qz", length="m", angle="rad")
    np.testing.assert_allclose(rec.poses, rt.poses, atol=1e-9)
    identify_recording(rec)


@pytest.mark.parametrize("name", sorted(BAGS))
def test_ros_bags_identify_the_truth(name):
    pytest.importorskip("rosbags")
    rec = read_recording(DATA / name)
    assert rec.format == "bag" and rec.names == [f"joint_a{i + 1}" for i in range(6)]
    assert any("/joint_states" in n and "/tracker/point" in n for n in rec.notes)
    identify_recording(rec)


def test_ros2_bag_with_tf_points(tmp_path):
    pytest.importorskip("rosbags")
    write_bag(tmp_path / "tf", "mcap", point_type="tf")
    rec = read_recording(tmp_path / "tf")
    assert rec.poses is not None
    identify_recording(rec)


# --- time alignment --------------------------------------------------------------------------------------


def streams(offset=0.137, drift=0.0, points_hz=1000.0, readings_hz=250.0, dwell=1.0, seed=11):
    """Points (tracker clock, 1 kHz, 20 um noise) and readings (controller clock = tracker clock + offset +
    drift t, 250 Hz, 1e-5 rad noise) of one continuous recording of the paper's sweeps."""
    moves, dur, truth = plan(sweep_speed=15.0, transit_speed=45.0, dwell=dwell)
    tp = np.arange(0, dur, 1 / points_hz)
    P = noisy(targets(q_at(tp, moves)), 2e-5, seed)
    off = 5.0 + offset  # the controller clock started 5 s earlier, and 137 ms
    tr = np.arange(off - 0.2, off + dur * (1 + drift) + 0.2, 1 / readings_hz)
    t_true = (tr - off) / (1 + drift)  # the tracker time of each reading
    q = noisy(q_at(t_true, moves), 1e-5, seed + 1)
    pts = rc.Recording(tp, None, P, [f"tracker row {i + 1}" for i in range(len(tp))], "tracker", "sim", {})
    rd = rc.Recording(tr, q, None, [f"controller row {i + 1}" for i in range(len(tr))], "controller", "sim", {})
    sync = rc.Recording(t_true, q, None, rd.where, "controller", "sim", {})
    return pts, rd, sync, truth


def test_clock_offset_of_137_ms_recovered_within_1_ms_and_axes_as_good_as_synchronous():
    """Tracker 1 kHz, controller 250 Hz, 137 ms apart (and 5 s of clock start): offset within 1 ms and within
    4 of its reported sigmas; the identified axes as close to the truth as from the readings on the tracker's clock."""
    pts, rd, sync, _ = streams()
    merged, al = rc.align(pts, rd)
    assert abs(al.offset - 5.137) < 1e-3 and abs(al.offset - 5.137) < 4 * al.sigma + 1e-5, str(al)
    printed = float(re.search(r"clock offset (\S+) ms", str(al)).group(1))  # the message states the offset found, in ms
    assert al.drift == 0.0 and abs(printed - 5137) < 1 and abs(printed - al.offset * 1e3) < 1e-3, str(al)
    kr5 = dv.load_robot("kr5")
    res = identify(rc.to_sweepset(merged, rc.segment(merged), max_points=600), nominal=kr5)
    m0, _ = rc.align(pts, sync, offset=0.0)
    ref = identify(rc.to_sweepset(m0, rc.segment(m0), max_points=600), nominal=kr5)
    assert_axes_match_truth(res)
    assert_axes_match_truth(ref)
    # aligned and synchronous axes differ by less than their uncertainty
    for j, f in enumerate(ref.fits):
        d0, d1 = ref.axes.directions[j], res.axes.directions[j]
        assert math.acos(min(1.0, float(d0 @ d1))) < f.sigma_direction, j + 1
        assert np.linalg.norm(np.cross(res.axes.points[j] - ref.axes.points[j], d0)) < f.sigma_point_perp, j + 1


def test_clock_drift_estimated_when_the_data_asks_for_it():
    """A 300 ppm drift of the controller clock (about 17 ms over the recording) is found; its offset recovered."""
    pts, rd, _, _ = streams(drift=300e-6)
    _, al = rc.align(pts, rd)
    assert abs(al.drift - 300e-6) < 20e-6, str(al)
    assert abs(al.readings_time(al.t_ref) - al.t_ref - (5.137 + 300e-6 * al.t_ref)) < 1e-3, str(al)
    pts, rd, _, _ = streams()
    assert rc.align(pts, rd)[1].drift == 0.0  # no drift: none fitted


# --- segmentation ----------------------------------------------------------------------------------------


def continuous(with_readings, rate=100.0, seed=21):
    """A continuous recording of the paper's 30 degree protocol (2 s pauses, returns to home) at ``rate`` Hz, 0.02 mm
    tracker noise: (recording, truth [(joint, t0, t1)] of the sweeps, the noiseless points (m, 3))."""
    moves, dur, truth = plan(sweep_speed=10.0, transit_speed=30.0, dwell=2.0)
    t = np.arange(0, dur, 1 / rate)
    q = q_at(t, moves)
    P = noisy(targets(q), 2e-5, seed)
    rec = rc.Recording(
        t,
        noisy(q, 1e-5, seed + 1) if with_readings else None,
        P,
        [f"row {i + 1}" for i in range(len(t))],
        "continuous",
        "sim",
        {},
    )
    return rec, truth, targets(q)[:, 0]


#: What a segmentation from the points alone can leave out of a sweep: rows standing closer to their dwell than the
#: dwell test sees (6 sigma on one coordinate, the same false-alarm rate as 6.59 sigma of a 3-D distance), plus 3 sigma
#: for the noise of the row and of the dwell's level (0.02 mm tracker noise).
LEFT_OUT = (6.59 + 3.0) * 2e-5


def left_out(seg, truth, P, t):
    """(joint, the largest distance (m) of a true point left out at either end of its sweep from where it rests)."""
    out = []
    for s, (j, t0, t1) in zip(seg.sweeps, truth):
        rest0, rest1 = np.searchsorted(t, t0) - 1, np.searchsorted(t, t1)
        out.append((j, max(np.linalg.norm(P[s.start - 1] - P[rest0]), np.linalg.norm(P[s.stop] - P[rest1]))))
    return out


def test_segmentation_without_readings_leaves_out_only_what_the_noise_hides():
    """Without readings a sweep's ends are found from the points: the speed test misses the slow start and stop of
    a motion (a point near its axis, joint 6's at 58 mm, moves less per sample than the speed's noise: 0.12-0.15 s
    of a cosine ramp), the rows beyond the dwell's noise are added back. Over 40 noise draws no sweep leaves out a
    row standing more than LEFT_OUT (0.19 mm) from its rest (8.2 sigma at most; the speed test with a per-coordinate
    trim had left out a row of joint 2 0.21 mm, 10.5 sigma, from its rest), and every sweep stays within its motion."""
    worst = 0.0
    for seed in range(21, 61):
        rec, truth, P = continuous(False, seed=seed)
        seg = rc.segment(rec)
        assert [s.joint for s in seg.sweeps] == [1, 2, 3, 4, 5, 6], (seed, segmentation_table(seg))
        assert all(t0 < s.t_start and s.t_stop < t1 for s, (_, t0, t1) in zip(seg.sweeps, truth)), seed
        worst = max(worst, max(d for _, d in left_out(seg, truth, P, rec.time)))
    assert worst < LEFT_OUT, worst


@pytest.mark.parametrize("dwell", [0.16, 0.0])
@pytest.mark.parametrize("reading_noise", [2.0, 100.0, None])
def test_segmentation_splits_motions_of_two_joints_however_short_the_pause(dwell, reading_noise):
    """Pauses shorter than min_dwell (0.25 s) between the motions of two joints, or none at all (the derivative filter
    then leaves no still row between them), had joined the whole protocol into one bogus sweep of joint 1 (with
    readings), or into no circle at all and a numpy broadcast error (without). A motion now ends where the moving
    joint changes or turns back: with readings (white reading noise of 2 and 100 arcsec), where the joint of the
    largest speed changes; without, at every still row and where the tool's speed dips nearly to zero, the pieces
    of one circle turning one way then joined again. Every sweep holds at least 97 % of its own joint's true sweep
    (the slowest motion of each joint by median speed, also when joined to the transit that goes on after it), no
    other joint moves inside it (without a pause: none beyond 1e-4 rad, 21 arcsec, the last
    0.0033 deg of the previous motion's slow end), and the identified axes match the truth. (A joint that goes on
    the same way after a short pause, e.g. from its transit into its sweep, is one motion: one circle, a longer
    arc.)"""
    moves, dur, truth = plan(sweep_speed=10.0, transit_speed=30.0, dwell=dwell)
    t = np.arange(0, dur, 0.01)
    q = q_at(t, moves)
    readings = None if reading_noise is None else noisy(q, math.radians(reading_noise / 3600.0), 22)
    rec = rc.Recording(
        t, readings, noisy(targets(q), 2e-5, 21), [f"row {i + 1}" for i in range(len(t))], "continuous", "sim", {}
    )
    seg = rc.segment(rec)
    assert seg.method == ("geometry" if readings is None else "readings")
    assert [s.joint for s in seg.sweeps] == [1, 2, 3, 4, 5, 6], segmentation_table(seg)
    for s, (j, t0, t1) in zip(seg.sweeps, truth):
        # it holds at least 97 % of its joint's true sweep (the ends of a slow start and stop are within the noise)
        held = (t >= max(t0, s.t_start)) & (t <= min(t1, s.t_stop))
        assert np.ptp(q[held, j - 1]) > 0.97 * np.ptp(q[(t >= t0) & (t <= t1), j - 1]), (j, s, t0, t1)
        others = np.delete(q[s.start : s.stop], j - 1, axis=1)
        assert np.ptp(others, axis=0).max() < (1e-9 if dwell else 1e-4), (j, s)
    options = {} if readings is not None else {"home": HOME, "direction": DIRECTION}
    assert_axes_match_truth(identify(rc.to_sweepset(rec, seg, max_points=300, **options), nominal=dv.load_robot("kr5")))
    if readings is None:
        # a segmentation of fewer joints than the options give is a one-line error, not numpy's broadcast error
        with pytest.raises(
            dv.DenavitError,
            match=r"direction: expected 1 or 2 values \(one per joint of the segmentation, geometry\), got 6",
        ):
            rc.to_sweepset(
                rec,
                replace(seg, segments=[s for s in seg.segments if s.joint <= 2], n_joints=2),
                home=HOME[:2],
                direction=DIRECTION,
            )


@pytest.mark.parametrize("with_readings", [True, False])
def test_segmentation_finds_the_paper_sweeps_with_and_without_readings(with_readings):
    """Six sweeps with 2 s pauses and a return to home between them: right joints, boundaries within the true
    motion (dwell excluded) and, with readings, within 0.15 s of its ends; without, the rows left out stand within
    LEFT_OUT of their rest (in time that is 0.04 s for joint 1's point 1.2 m from its axis, 0.15 s for joint 6's
    at 58 mm: a time bound does not hold for every radius); identified axes match the truth."""
    rec, truth, P = continuous(with_readings)
    seg = rc.segment(rec)
    assert seg.method == ("readings" if with_readings else "geometry")
    assert [s.joint for s in seg.sweeps] == [1, 2, 3, 4, 5, 6], segmentation_table(seg)
    for s, (j, t0, t1) in zip(seg.sweeps, truth):
        assert t0 < s.t_start and s.t_stop < t1, (j, s, t0, t1)
        if with_readings:
            assert s.t_start < t0 + 0.15 and t1 - 0.15 < s.t_stop, (j, s, t0, t1)
    assert all(d < LEFT_OUT for _, d in left_out(seg, truth, P, rec.time)), left_out(seg, truth, P, rec.time)
    table = segmentation_table(seg)
    assert sum(" sweep " in line for line in table.splitlines()) == 6 and "dwell rows excluded" in table
    s = rc.to_sweepset(rec, seg, max_points=300, **({} if with_readings else {"home": HOME, "direction": DIRECTION}))
    assert_axes_match_truth(identify(s, nominal=dv.load_robot("kr5")))
    if with_readings:
        # the given ranges choose the same motions
        assert [(s.start, s.stop) for s in rc.segment(rec, ranges=RANGES).sweeps] == [
            (s.start, s.stop) for s in seg.sweeps
        ]
        np.testing.assert_allclose([(s.q_from, s.q_to) for s in seg.sweeps], RANGES, atol=math.radians(0.05))
    # the user's spans override the segmentation
    given = rc.segment(rec, spans=[(j, t0 + 0.2, t1 - 0.2) for j, t0, t1 in truth])
    assert given.method == "given" and [(s.joint, round(s.t_start, 2)) for s in given.sweeps] == [
        (j, round(t0 + 0.2, 2)) for j, t0, _ in truth
    ]


# --- bad input -------------------------------------------------------------------------------------------


def one_line(excinfo):
    assert "\n" not in str(excinfo.value)
    return str(excinfo.value)


def test_unknown_format(tmp_path):
    f = tmp_path / "notes.txt"
    f.write_text("hello world\n1 2 3\n")
    with pytest.raises(
        dv.DenavitError,
        match=r"notes.txt: unknown recording format: expected a tracker export .* or a delimited file with --columns",
    ) as e:
        read_recording(f)
    one_line(e)
    with pytest.raises(
        dv.DenavitError, match="unknown format 'csv': expected one of auto, tracker, rtde, rsi, bag, columns"
    ):
        read_recording(f, format="csv")


def test_missing_columns(tmp_path):
    f = tmp_path / "rtde.csv"
    f.write_text("timestamp actual_TCP_pose_0 actual_TCP_pose_1\n0 1 2\n")
    with pytest.raises(
        dv.DenavitError,
        match=r"rtde.csv:1: RTDE header lacks actual_q_0: expected 'timestamp actual_q_0 .. actual_q_5'",
    ) as e:
        read_recording(f)
    one_line(e)
    t = tmp_path / "points.csv"
    t.write_text("Point,X,Y\nJ1_001,1,2\n")
    with pytest.raises(dv.DenavitError, match=r"points.csv:1: tracker header lacks Z"):
        read_recording(t, format="tracker")
    c = tmp_path / "wide.txt"
    c.write_text(" ".join(["1.0"] * 435) + "\n")
    with pytest.raises(
        dv.DenavitError, match=r"wide.txt:1: expected 10 values \(t,q1..q6,x,y,z\) separated by 'whitespace', got 435"
    ) as e:
        read_recording(c, columns="t,q1..q6,x,y,z", length="mm", angle="deg")
    assert len(one_line(e)) < 200


def test_bag_without_a_joint_state_topic(tmp_path):
    pytest.importorskip("rosbags")
    write_bag(tmp_path / "nojs", "mcap", with_joints=False)
    with pytest.raises(
        dv.DenavitError,
        match=(
            r"nojs: no sensor_msgs/JointState topic: expected one of type sensor_msgs/msg/JointState \(topics:"
            r" /tracker/point \(geometry_msgs/msg/PointStamped\)\)"
        ),
    ) as e:
        read_recording(tmp_path / "nojs")
    one_line(e)


def test_missing_rosbags_names_the_install_command(tmp_path, monkeypatch):
    write_bag(tmp_path / "b", "mcap") if "rosbags" in sys.modules or _has_rosbags() else (tmp_path / "b").mkdir()
    (tmp_path / "b" / "metadata.yaml").touch()
    monkeypatch.setitem(sys.modules, "rosbags.highlevel", None)
    with pytest.raises(
        dv.DenavitError, match=r'reading ROS bags needs the optional package rosbags: pip install "denavit\[ros\]"'
    ) as e:
        read_recording(tmp_path / "b")
    one_line(e)


def _has_rosbags():
    try:
        import rosbags  # noqa: F401
    except ImportError:
        return False
    return True


def test_tracker_sweep_rows_not_in_one_block(tmp_path):
    lines = (DATA / "tracker.csv").read_text().splitlines()
    f = tmp_path / "tracker.csv"
    f.write_text("\n".join([*lines[:5], *lines[-3:], *lines[5:-3]]) + "\n")
    with pytest.raises(
        dv.DenavitError,
        match=r"tracker.csv:9: a second block of joint 1's rows: expected each joint's sweep in one block",
    ) as e:
        rc.segment(read_recording(f))
    one_line(e)
    g = tmp_path / "names.csv"
    g.write_text("Point,X,Y,Z\nJ1_001,1,2,3\nbase_01,1,2,3\n")
    with pytest.raises(
        dv.DenavitError,
        match=r"names.csv:3: point name 'base_01' does not match the sweep pattern .*: expected e.g. J1_001 or A2-17",
    ):
        read_recording(g, length="mm")


def test_time_that_goes_backwards(tmp_path):
    lines = (DATA / "rtde.csv").read_text().splitlines()
    lines[5], lines[6] = lines[6], lines[5]
    f = tmp_path / "rtde.csv"
    f.write_text("\n".join(lines) + "\n")
    with pytest.raises(
        dv.DenavitError,
        match=(
            r"rtde.csv:7: timestamp goes backwards or repeats: .* s at .*rtde.csv:6: expected strictly increasing times"
        ),
    ) as e:
        read_recording(f)
    one_line(e)


def test_clocks_that_cannot_be_aligned():
    """Readings of another motion (the joints in the other order, other speeds and pauses) do not correlate with the
    points."""
    pts, rd, _, _ = streams(points_hz=200.0)
    moves, _, _ = plan(sweep_speed=40.0, transit_speed=20.0, dwell=1.5, ranges=RANGES[::-1])
    other = rc.Recording(rd.time, q_at(rd.time - 5.0, moves), None, rd.where, "controller", "sim", {})
    with pytest.raises(
        dv.DenavitError,
        match=(
            r"tracker and controller: cannot align clocks: the speed profiles correlate at .* expected at least 0.5:"
            r" are both recordings of the same motion\?"
        ),
    ) as e:
        rc.align(pts, other)
    one_line(e)


if __name__ == "__main__":
    write_all(DATA)
