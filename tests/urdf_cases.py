"""What the URDF tests share (tests/test_urdf_*.py): the test files, tolerances on poses, configurations, world poses of
every visual and inertial, random chains.

The test URDFs (tests/data/urdf) state their sources: ur_style.urdf is the UR5 geometry of Universal Robots'
published DH table laid out as ros-industrial's ur_description does it (y axes, pi/2 pitches); panda_style.urdf
the Franka Panda's published modified-DH table laid out as franka_description does it; kr5.urdf Hayat et
al.'s Table III in an industrial layout (every link parallel to the base at q = 0, axes along +-x/y/z).
"""

import math

import numpy as np
import yourdfpy

import denavit as dv

DATA = __import__("pathlib").Path(__file__).parent / "data" / "urdf"
UR, PANDA, KR5 = DATA / "ur_style.urdf", DATA / "panda_style.urdf", DATA / "kr5.urdf"
GOOD = [UR, PANDA, KR5]


def pose_err(A, B):
    return max(np.abs(np.asarray(A) - np.asarray(B)).max(), 0.0)


def qs_within(model, n, seed=0):
    lo = np.maximum(model.lower, -2 * np.pi)
    hi = np.minimum(model.upper, 2 * np.pi)
    return np.random.default_rng(seed).uniform(lo, hi, (n, model.nq))


def frames_err(m1, m2, qs):
    return max(pose_err(dv.joint_frames(m1, q), dv.joint_frames(m2, q)) for q in qs)


def tool_err(m1, m2, qs):
    return pose_err(dv.fk_batch(m1, qs), dv.fk_batch(m2, qs))


def write(tmp_path, text, name="robot.urdf"):
    p = tmp_path / name
    p.write_text(text)
    return p


def Rz(t):
    T = np.eye(4)
    T[:2, :2] = [[math.cos(t), -math.sin(t)], [math.sin(t), math.cos(t)]]
    return T


# a laser tracker's frame: the robot's base link 1 rad about z and (2, -1, 0.5) m away from its origin
TRACKER = Rz(1.0)
TRACKER[:3, 3] = (2.0, -1.0, 0.5)


def world_items(u: yourdfpy.URDF, q):
    """(key, world pose) of every visual and collision, and the total mass, COM and inertia about the COM
    (world) of a URDF at configuration q (0, the origin and 0 without inertials)."""
    u.update_cfg(q)
    base = u.base_link
    items, M, mc, parts = [], 0.0, np.zeros(3), []
    for link in u.robot.links:
        T = u.get_transform(link.name, base)
        for kind, group in (("visual", link.visuals), ("collision", link.collisions)):
            for v in group:
                g = v.geometry
                key = (
                    kind,
                    g.mesh.filename if g.mesh is not None else ("cylinder" if g.cylinder is not None else "other"),
                )
                items.append((key, T @ (np.eye(4) if v.origin is None else v.origin)))
        if link.inertial is not None and link.inertial.mass:
            P = T @ link.inertial.origin
            parts.append((P, link.inertial.mass, link.inertial.inertia))
            M += link.inertial.mass
            mc += link.inertial.mass * P[:3, 3]
    c = mc / M if M else np.zeros(3)
    I = sum(
        (
            P[:3, :3] @ Ic @ P[:3, :3].T
            + m * ((P[:3, 3] - c) @ (P[:3, 3] - c) * np.eye(3) - np.outer(P[:3, 3] - c, P[:3, 3] - c))
            for P, m, Ic in parts
        ),
        np.zeros((3, 3)),
    )
    return sorted(items, key=lambda kv: kv[0]), M, c, I


def random_urdf(seed: int) -> str:
    """A random serial URDF: a leading fixed joint, fixed joints between moving ones, revolute, continuous
    and prismatic joints about random axes (some exactly +-z, +-x), random origins and rpy."""
    rng = np.random.default_rng(seed)
    r = lambda v: " ".join(repr(float(x)) for x in v)  # noqa: E731
    lines = [
        '<robot name="random">',
        '<link name="l0"/>',
        '<link name="l1"/>',
        (
            '<joint name="mount" type="fixed"><parent link="l0"/><child link="l1"/><origin'
            f' xyz="{r(rng.uniform(-1, 1, 3))}" rpy="{r(rng.uniform(-3, 3, 3))}"/></joint>'
        ),
    ]
    link = 1
    special = [[0, 0, 1], [0, 0, -1], [1, 0, 0], [0, -1, 0]]
    for k in range(6):
        kind = ["revolute", "continuous", "prismatic"][k % 3]
        a = special[k % 4] if rng.random() < 0.5 else rng.normal(size=3)
        a = np.asarray(a, dtype=float) / np.linalg.norm(a)
        lim = (
            '<limit lower="-0.3" upper="0.4" effort="1" velocity="1"/>'
            if kind == "prismatic"
            else ('<limit lower="-2.5" upper="2" effort="1" velocity="1"/>' if kind == "revolute" else "")
        )
        lines += [
            f'<link name="l{link + 1}"/>',
            (
                f'<joint name="j{k + 1}" type="{kind}"><parent link="l{link}"/><child link="l{link + 1}"/><origin'
                f' xyz="{r(rng.uniform(-0.4, 0.4, 3))}" rpy="{r(rng.uniform(-3, 3, 3))}"/><axis'
                f' xyz="{r(a)}"/>{lim}</joint>'
            ),
        ]
        link += 1
        if rng.random() < 0.5:
            lines += [
                f'<link name="l{link + 1}"/>',
                (
                    f'<joint name="f{k + 1}" type="fixed"><parent link="l{link}"/><child link="l{link + 1}"/><origin'
                    f' xyz="{r(rng.uniform(-0.2, 0.2, 3))}" rpy="{r(rng.uniform(-3, 3, 3))}"/></joint>'
                ),
            ]
            link += 1
    lines.append("</robot>")
    return "\n".join(lines)


def pin_q(pm, q):
    """pinocchio's configuration vector: continuous joints as (cos, sin)."""
    out = []
    for j, v in zip(list(pm.joints)[1:], q):
        out += [math.cos(v), math.sin(v)] if j.nq == 2 else [v]
    return np.array(out)


UR_ROS, IRB, HUMANOID, GRIPPER = (
    DATA / "ur5_ros.urdf",
    DATA / "irb_rosi.urdf",
    DATA / "humanoid.urdf",
    DATA / "gripper.urdf",
)


# (file, tip link or None for the default); the default tips: tool0, tool0, arm_right_tool_link, leftfinger
TREES = [
    (UR_ROS, None),
    (UR_ROS, "wrist_3_link"),
    (IRB, None),
    (IRB, "link_6"),
    (HUMANOID, None),
    (HUMANOID, "xtion_rgb_optical_frame"),
    (HUMANOID, "arm_left_hand"),
    (GRIPPER, None),
    (GRIPPER, "hand_tcp"),
]


TREE_IDS = [f"{p.stem}-{t or 'default'}" for p, t in TREES]
