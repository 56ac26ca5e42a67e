"""URDF in and out (issue #5): golden files, round trips, meshes and inertials, identified robots, bad input.

The test URDFs (tests/data/urdf) state their sources: ur_style.urdf is the UR5 geometry of Universal Robots'
published DH table laid out as ros-industrial's ur_description does it (y axes, pi/2 pitches); panda_style.urdf
the Franka Panda's published modified-DH table laid out as franka_description does it; kr5.urdf Hayat et
al.'s Table III in an industrial layout (every link parallel to the base at q = 0, axes along +-x/y/z).
"""

import math
import re

import numpy as np
import pytest
import yourdfpy
from hypothesis import given, settings
from hypothesis import strategies as st
from typer.testing import CliRunner

import denavit as dv
from denavit.cli import app
from denavit.geometry import matrix_rpy
from denavit.io import sweeps as swio
from denavit.io import urdf as U

DATA = __import__("pathlib").Path(__file__).parent / "data" / "urdf"
UR, PANDA, KR5 = DATA / "ur_style.urdf", DATA / "panda_style.urdf", DATA / "kr5.urdf"
GOOD = [UR, PANDA, KR5]

# Franka Emika, "Robot and interface specifications": Panda modified DH (Craig), columns alpha, a, theta, d
PANDA_MDH = np.array(
    [
        [0.0, 0.0, 0.0, 0.333],
        [-np.pi / 2, 0.0, 0.0, 0.0],
        [np.pi / 2, 0.0, 0.0, 0.316],
        [np.pi / 2, 0.0825, 0.0, 0.0],
        [-np.pi / 2, -0.0825, 0.0, 0.384],
        [np.pi / 2, 0.0, 0.0, 0.0],
        [np.pi / 2, 0.088, 0.0, 0.0],
    ]
)
PANDA_FLANGE = np.diag([1.0, 1.0, 1.0, 1.0])
PANDA_FLANGE[2, 3] = 0.107  # "flange: d = 0.107"


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


# --------------------------------------------------------------------------------------------------
# golden files: the published tables


def test_ur_style_urdf_is_the_published_ur5_dh_table():
    """ur_description's layout of the UR5 (y axes, pi/2 pitches, shoulder/elbow offsets) and Universal
    Robots' published DH table describe one robot: tool0 = DH flange for every q, with the URDF base_link
    the DH base turned by pi about z; the DH extraction from the URDF gives the published table."""
    m = U.urdf_model(UR)
    dh = dv.load_model("ur5").with_base(Rz(np.pi))
    qs = qs_within(m, 200)
    assert tool_err(m, dh, qs) < 1e-12
    # the joint axis lines coincide (origins may slide along an axis, directions are equal)
    for q in qs[:20]:
        a, b = dv.axes(m, q), dv.axes(dh, q)
        np.testing.assert_allclose(a.directions, b.directions, atol=1e-12)
        d = a.points - b.points
        assert np.abs(np.cross(d, a.directions)).max() < 1e-12
    # in the DH base frame, with the published table as the nominal (sign choices), the table comes back
    in_dh_base = m.with_base(Rz(-np.pi) @ m.T_world_base)
    ex = dv.to_table(in_dh_base, "dh", nominal=dv.load_robot("ur5").table)
    np.testing.assert_allclose(ex.table.params, dv.load_robot("ur5").table.params, atol=1e-12)
    assert ex.max_position_error < 1e-12
    assert [p.relation for p in ex.pairs] == ["intersecting", "parallel", "parallel", "intersecting", "intersecting"]


def test_panda_style_urdf_is_the_published_mdh_table():
    """franka_description's joint origins and Franka's published modified-DH table: same FK; the MDH
    extraction (published table as nominal for the sign choices) returns the table exactly."""
    m = U.urdf_model(PANDA)
    pub = dv.Table("mdh", PANDA_MDH, T_last_tool=PANDA_FLANGE)
    qs = qs_within(m, 200)
    assert tool_err(m, pub.to_model(), qs) < 1e-12
    assert frames_err(m, pub.to_model(), qs[:20]) < 1e-12  # MDH frames are the URDF link frames (all axes z)
    ex = U.urdf_table(PANDA, "mdh", nominal=pub)
    np.testing.assert_allclose(ex.table.params, PANDA_MDH, atol=1e-12)
    assert ex.max_position_error < 1e-12
    assert [p.relation for p in ex.pairs] == ["intersecting", "intersecting", "skew", "skew", "intersecting", "skew"]
    np.testing.assert_allclose(m.lower, [-2.8973, -1.7628, -2.8973, -3.0718, -2.8973, -0.0175, -2.8973])


def test_kr5_urdf_is_hayat_table_iii():
    """kr5.urdf (industrial layout, axes along +-x/y/z, no rpy) has the built-in Table III model's FK,
    axis lines and limits; DH extraction with the table as nominal returns Table III."""
    m = U.urdf_model(KR5)
    kr5 = dv.load_robot("kr5")
    qs = qs_within(m, 200)
    assert tool_err(m, kr5.model(), qs) < 1e-12
    for q in qs[:20]:
        a, b = dv.axes(m, q), dv.axes(kr5.model(), q)
        np.testing.assert_allclose(a.points, b.points, atol=1e-12)
        np.testing.assert_allclose(a.directions, b.directions, atol=1e-12)
    np.testing.assert_allclose(m.lower, kr5.lower, atol=1e-15)
    np.testing.assert_allclose(m.upper, kr5.upper, atol=1e-15)
    ex = U.urdf_table(KR5, "dh", nominal=kr5.table)
    np.testing.assert_allclose(ex.table.params, kr5.table.params, atol=1e-12)


@pytest.mark.parametrize("path", GOOD, ids=lambda p: p.stem)
def test_link_frames_match_yourdfpy_forward_kinematics(path):
    """The mapping URDF link frame i = model joint frame i · R_a^-1 (and tool = tip link), checked against
    yourdfpy's own forward kinematics of the file."""
    ch = U.read_chain(path)
    m = ch.model()
    u = yourdfpy.URDF.load(str(path), build_scene_graph=True, load_meshes=False)
    for q in qs_within(m, 10, seed=3):
        u.update_cfg(q)
        F = dv.joint_frames(m, q)
        for i, (link, a) in enumerate(zip(ch.extra["body_links"][1:], ch.axes_local)):
            R = np.eye(4)
            R[:3, :3] = U.z_to(a)
            assert pose_err(F[i] @ R.T, u.get_transform(link, ch.base_link)) < 1e-12
        assert pose_err(dv.fk(m, q), u.get_transform(ch.tip_link, ch.base_link)) < 1e-12


def pinocchio_frames(path, q, links):
    """World poses of ``links`` at ``q`` by pinocchio's own URDF parser (continuous joints: cos, sin)."""
    pin = pytest.importorskip("pinocchio")
    model = pin.buildModelFromUrdf(str(path))
    data = model.createData()
    x = pin.neutral(model)
    for k, j in enumerate(model.joints[1:]):
        if j.nq == 2:
            x[j.idx_q : j.idx_q + 2] = [math.cos(q[k]), math.sin(q[k])]
        else:
            x[j.idx_q] = q[k]
    pin.forwardKinematics(model, data, x)
    pin.updateFramePlacements(model, data)
    return [data.oMf[model.getFrameId(link)].homogeneous for link in links]


@pytest.mark.parametrize("path", GOOD, ids=lambda p: p.stem)
def test_pinocchio_reads_the_same_frames(path, tmp_path):
    """A second, independent URDF reader (pinocchio): the imported model's frames match pinocchio's on the
    test file, and every link of the exported file is the original's link of the same name (issue #15: the
    export had given the names to the model's joint frames, shoulder_link turned by 180 deg)."""
    ch = U.read_chain(path)
    m = ch.model()
    robot = U.load_urdf(path)
    out = tmp_path / "out.urdf"
    U.save_urdf(robot.model(), out, robot)
    links = [l.name for l in yourdfpy.URDF.load(str(path), load_meshes=False).robot.links]
    for q in qs_within(m, 5, seed=4):
        T = pinocchio_frames(path, q, ch.extra["body_links"][1:] + [ch.tip_link])
        F = dv.joint_frames(m, q)
        for i, a in enumerate(ch.axes_local):
            R = np.eye(4)
            R[:3, :3] = U.z_to(a)
            assert pose_err(F[i] @ R.T, T[i]) < 1e-12
        assert pose_err(dv.fk(m, q), T[-1]) < 1e-12
        for link, Ta, Tb in zip(links, pinocchio_frames(path, q, links), pinocchio_frames(out, q, links)):
            assert pose_err(Ta, Tb) < 1e-12, link
        assert pose_err(dv.fk(robot.model(), q), pinocchio_frames(out, q, [ch.tip_link])[0]) < 1e-12


# --------------------------------------------------------------------------------------------------
# round trips


@pytest.mark.parametrize("name", ["kr5", "puma560"])
def test_dh_table_to_urdf_and_back_keeps_its_signs(name, tmp_path):
    """A published DH table (Hayat et al.'s KR5, Corke's Puma 560) written as URDF and read again, with no
    nominal to break the ties, is the published table: where consecutive axes intersect, the common normal's
    sign keeps the joint offset within +-90 degrees (before: the KR5 came back with alpha5 = +90, theta5 =
    theta6 = 180, a valid but different table). The KR5 in its industrial URDF layout too."""
    robot = dv.load_robot(name)
    out = tmp_path / f"{name}.urdf"
    U.save_urdf(robot.model(), out)
    for path in [out] + ([KR5] if name == "kr5" else []):
        ex = U.urdf_table(path, "dh")
        np.testing.assert_allclose(ex.table.params, robot.table.params, atol=1e-12)


@pytest.mark.parametrize("path", GOOD, ids=lambda p: p.stem)
def test_urdf_model_urdf_round_trip(path, tmp_path):
    """URDF -> Robot (ED-H) -> URDF -> model: every joint frame is the original URDF's (the names are kept,
    issue #15) and the tool to 1e-12; importing the exported file again gives the same ED-H table, and
    exporting that is byte-identical (it had written 0.28 <-> 0.2799999999999999)."""
    robot = U.load_urdf(path)
    exact = U.urdf_model(path)
    m = robot.model()
    qs = qs_within(m, 30)
    assert tool_err(m, exact, qs) < 1e-12
    # ED-H frames: same origins and z axes as the exact model's joint frames
    for q in qs[:10]:
        Fa, Fb = dv.joint_frames(m, q), dv.joint_frames(exact, q)
        np.testing.assert_allclose(Fa[:, :3, 2:], Fb[:, :3, 2:], atol=1e-12)
    out = tmp_path / "out.urdf"
    U.save_urdf(m, out, robot)
    back = U.urdf_model(out)
    assert back.names == m.names
    assert frames_err(back, exact, qs) < 1e-12
    assert tool_err(back, m, qs) < 1e-12
    again = U.load_urdf(out)
    np.testing.assert_allclose(again.table.params, robot.table.params, atol=1e-12)
    assert frames_err(again.model(), m, qs[:10]) < 1e-12
    assert U.dumps_urdf(again.model(), again) == out.read_text()
    # the exact model exports and re-imports exactly too
    U.save_urdf(exact, out)
    assert frames_err(U.urdf_model(out), exact, qs) < 1e-12


@pytest.mark.parametrize("path", GOOD, ids=lambda p: p.stem)
@pytest.mark.parametrize("conv", ["dh", "mdh", "edh", "poe"])
def test_urdf_to_table_to_model_agrees(path, conv, tmp_path):
    """URDF -> DH / MDH / ED-H / POE -> model: the same tool pose and joint axis lines to 1e-12 (all three
    robots are representable in DH); the table's model exports to URDF and back with every joint frame."""
    exact = U.urdf_model(path)
    ex = U.urdf_table(path, conv)
    assert ex.max_position_error < 1e-12
    m = ex.table.to_model("t", exact.names, exact.lower, exact.upper)
    qs = qs_within(exact, 100, seed=1)
    assert tool_err(m, exact, qs) < 1e-12
    for q in qs[:10]:
        a, b = dv.axes(m, q), dv.axes(exact, q)
        np.testing.assert_allclose(a.directions, b.directions, atol=1e-12)
        assert np.abs(np.cross(a.points - b.points, a.directions)).max() < 1e-12
    out = tmp_path / f"{conv}.urdf"
    U.save_urdf(m, out)
    assert frames_err(U.urdf_model(out), m, qs[:20]) < 1e-12


def test_dh_error_reported_where_dh_cannot_represent_the_geometry(tmp_path):
    """The UR elbow axis tilted by 3e-4 rad towards the upper arm: axes 2-3 are near-parallel, DH keeps
    them parallel (no far-away common normal) and loses the tilt. The reported Hayati beta is the tilt and
    the reported tool error is the one measured here (4000 random configurations); ED-H stays exact."""
    text = UR.read_text().replace(
        '<origin xyz="0 -0.1197 0.425" rpy="0 0 0"/>\n    <axis xyz="0 1 0"/>',
        '<origin xyz="0 -0.1197 0.425" rpy="0 0 0"/>\n    <axis xyz="0 1 0.0003"/>',
    )
    p = write(tmp_path, text)
    exact = U.urdf_model(p)
    qs = qs_within(exact, 4000, seed=5)
    ex = U.urdf_table(p, "dh")
    assert ex.pairs[1].relation == "parallel"
    assert abs(ex.pairs[1].hayati_beta) == pytest.approx(math.atan(3e-4), abs=1e-12)
    assert np.abs(ex.table.params[:, [0, 2]]).max() < 1.0  # d and a within the robot's size
    m = ex.table.to_model("dh", exact.names, exact.lower, exact.upper)
    measured = np.linalg.norm(dv.fk_batch(m, qs)[:, :3, 3] - dv.fk_batch(exact, qs)[:, :3, 3], axis=1).max()
    assert 1e-5 < ex.max_position_error
    assert 0.9 < measured / ex.max_position_error < 1.1
    edh = U.urdf_table(p, "edh")
    assert tool_err(edh.table.to_model(), exact, qs[:200]) < 1e-12


@pytest.mark.parametrize("name", dv.builtin_names())
def test_every_builtin_exports_and_reimports_exactly(name, tmp_path):
    """Any model (DH, MDH, ED-H tables with zero offsets folded in), with a base and a tool: export then
    import reproduces every joint frame and the tool to 1e-12; the base becomes a fixed world joint."""
    rng = np.random.default_rng(7)
    base = Rz(0.4)
    base[:3, 3] = rng.uniform(-1, 1, 3)
    tool = Rz(-1.1) @ np.diag([1.0, -1.0, -1.0, 1.0])
    tool[:3, 3] = [0.01, 0.02, 0.15]
    m = dv.load_model(name).with_base(base).with_tool(tool)
    out = tmp_path / "m.urdf"
    U.save_urdf(m, out)
    back = U.urdf_model(out)
    qs = qs_within(m, 50)
    assert frames_err(back, m, qs) < 1e-12
    assert tool_err(back, m, qs) < 1e-12
    ch = U.read_chain(out)
    assert ch.base_link == "world" and ch.tip_link == "tool0" and ch.extra["body_links"][0] == "base_link"


def random_urdf(seed: int) -> str:
    """A random serial URDF: a leading fixed joint, fixed joints between moving ones, revolute, continuous
    and prismatic joints about random axes (some exactly +-z, +-x), random origins and rpy."""
    rng = np.random.default_rng(seed)
    r = lambda v: " ".join(repr(float(x)) for x in v)  # noqa: E731
    lines = [
        '<robot name="random">',
        '<link name="l0"/>',
        '<link name="l1"/>',
        f'<joint name="mount" type="fixed"><parent link="l0"/><child link="l1"/><origin xyz="{r(rng.uniform(-1, 1, 3))}" rpy="{r(rng.uniform(-3, 3, 3))}"/></joint>',
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
            f'<joint name="j{k + 1}" type="{kind}"><parent link="l{link}"/><child link="l{link + 1}"/><origin xyz="{r(rng.uniform(-0.4, 0.4, 3))}" rpy="{r(rng.uniform(-3, 3, 3))}"/><axis xyz="{r(a)}"/>{lim}</joint>',
        ]
        link += 1
        if rng.random() < 0.5:
            lines += [
                f'<link name="l{link + 1}"/>',
                f'<joint name="f{k + 1}" type="fixed"><parent link="l{link}"/><child link="l{link + 1}"/><origin xyz="{r(rng.uniform(-0.2, 0.2, 3))}" rpy="{r(rng.uniform(-3, 3, 3))}"/></joint>',
            ]
            link += 1
    lines.append("</robot>")
    return "\n".join(lines)


@pytest.mark.parametrize("seed", range(4))
def test_random_chains_any_axis_prismatic_fixed(seed, tmp_path):
    """Random chains: every URDF link frame (yourdfpy's FK) = joint frame · R_a^-1, and export/import and
    URDF -> every convention -> model agree to 1e-12."""
    p = write(tmp_path, random_urdf(seed))
    ch = U.read_chain(p)
    m = ch.model()
    assert ch.urdf_types == ["revolute", "continuous", "prismatic"] * 2
    assert not np.allclose(m.T_world_base, np.eye(4))
    u = yourdfpy.URDF.load(str(p), build_scene_graph=True, load_meshes=False)
    qs = qs_within(m, 20, seed=seed)
    for q in qs[:5]:
        u.update_cfg(q)
        F = dv.joint_frames(m, q)
        for i, (link, a) in enumerate(zip(ch.extra["body_links"][1:], ch.axes_local)):
            R = np.eye(4)
            R[:3, :3] = U.z_to(a)
            assert pose_err(F[i] @ R.T, u.get_transform(link, "l0")) < 1e-12
        assert pose_err(dv.fk(m, q), u.get_transform(ch.tip_link, "l0")) < 1e-12
    out = tmp_path / "out.urdf"
    U.save_urdf(m, out)
    assert frames_err(U.urdf_model(out), m, qs) < 1e-12
    text = out.read_text()
    assert text.count('type="continuous"') == 2 and text.count('type="prismatic"') == 2
    for conv in ("dh", "mdh", "edh", "poe"):
        ex = dv.to_table(m, conv, parallel_tol=1e-9)
        assert tool_err(ex.table.to_model("t", m.names, m.lower, m.upper), m, qs) < 1e-12, conv


def test_axis_is_normalised_and_its_sign_kept(tmp_path):
    text = KR5.read_text().replace('<axis xyz="0 -1 0"/>', '<axis xyz="0 -2.5 0"/>', 1)
    a, b = U.urdf_model(write(tmp_path, text)), U.urdf_model(KR5)
    assert tool_err(a, b, qs_within(b, 50)) < 1e-12


# --------------------------------------------------------------------------------------------------
# identified robots


def test_identified_model_exports_with_frames_within_the_robot(kr5, tmp_path):
    """A KR5 (from kr5.urdf) identified from noisy simulated sweeps (Hayat Table II's 30 degree protocol,
    0.02 mm noise, seeded) exports to URDF with every joint origin within the robot's size: DH treats the
    near-parallel axes 2-3 as parallel instead of writing a far-away common normal (UR ROS driver #457:
    d2 = 574 m in a URDF); ED-H puts the frames on the axes. Export -> import reproduces FK exactly, and the
    meshes/limits of the nominal URDF are carried."""
    from denavit import sweeps as sw  # noqa: PLC0415

    nominal = U.load_urdf(KR5)
    truth = nominal.model()
    s = sw.simulate(
        truth,
        home=np.radians(sw.PAPER_HOME_DEG),
        ranges=np.radians(sw.PAPER_RANGES_DEG[30]),
        points_per_sweep=20,
        noise=2e-5,
        seed=11,
    )
    tool_point = np.eye(4)
    tool_point[:3, 3] = (0.05, 0.03, 0.10)  # sw.simulate's default tool point in the flange frame
    truth_point = truth.with_tool(tool_point)
    F0 = dv.joint_frames(truth, np.zeros(6))
    reach = max(np.linalg.norm(F0[:, :3, 3], axis=1).max(), np.linalg.norm(dv.fk(truth, np.zeros(6))[:3, 3]))
    qs = qs_within(truth, 50)
    for conv in ("dh", "edh"):
        res = dv.identify(s, convention=conv, nominal=nominal)
        assert res.extraction.pairs[1].relation == "parallel"
        m = res.model()
        out = tmp_path / f"identified_{conv}.urdf"
        U.save_urdf(m, out, nominal)
        back = U.urdf_model(out, tip_link="tcp")  # the identified tool point, a frame fixed to tool0
        assert tool_err(back, m, qs) < 1e-12
        for q in qs[:5]:
            a, b = dv.axes(back, q), dv.axes(m, q)
            np.testing.assert_allclose(a.directions, b.directions, atol=1e-12)
            assert np.abs(np.cross(a.points - b.points, b.directions)).max() < 1e-12
        for q in (np.zeros(6), np.radians(sw.PAPER_HOME_DEG)):
            F = dv.joint_frames(back, q)
            assert np.linalg.norm(F[:, :3, 3] - back.T_world_base[:3, 3], axis=1).max() < 2 * reach, conv
        ch = U.read_chain(out, tip_link="tcp")
        assert np.linalg.norm(ch.placements[:, :3, 3], axis=1).max() < 2 * reach
        assert ch.names == nominal.names and ch.extra["body_links"][1:] == [
            "link_1",
            "link_2",
            "link_3",
            "link_4",
            "link_5",
            "link_6",
        ]
        np.testing.assert_allclose(back.lower, nominal.lower)
        # sanity only (identification accuracy is test_identify's subject): the measured tool point within a
        # few millimetres over the whole joint range, 30 degree arcs with 0.02 mm noise
        assert (
            np.linalg.norm(dv.fk_batch(back, qs)[:, :3, 3] - dv.fk_batch(truth_point, qs)[:, :3, 3], axis=1).max()
            < 5e-3
        )
    # what a plain common-normal extraction would have written for the same measured axes
    plain = dv.extract(res.axes, "dh", parallel_tol=0.0, max_offset=1e9)
    assert np.abs(plain.table.params[:, 0]).max() > 10 * reach


# --------------------------------------------------------------------------------------------------
# meshes, inertials, limits


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


def test_meshes_inertials_and_limits_carried_through(tmp_path):
    """ur_style.urdf -> Robot -> URDF: every visual and collision keeps its mesh reference and its pose in
    the world at any q, the robot's mass, centre of mass and inertia are unchanged (the tool0 inertial merged
    into the wrist_3 body), tool0 is the same frame, and limits, efforts, velocities, continuous joints and
    materials are kept. The same holds through a DH robot file (TOML) written by `convert`."""
    robot = U.load_urdf(UR)
    out = tmp_path / "ur.urdf"
    U.save_urdf(robot.model(), out, robot)
    a = yourdfpy.URDF.load(str(UR), build_scene_graph=True, load_meshes=False)
    b = yourdfpy.URDF.load(str(out), build_scene_graph=True, load_meshes=False)
    assert [j.name for j in b.actuated_joints] == robot.names
    for q in qs_within(robot.model(), 5, seed=2):
        ia, Ma, ca, Ia = world_items(a, q)
        ib, Mb, cb, Ib = world_items(b, q)
        assert [k for k, _ in ia] == [k for k, _ in ib] and len(ia) == 12  # 8 visuals, 4 collisions
        for (_, Ta), (_, Tb) in zip(ia, ib):
            assert pose_err(Ta, Tb) < 1e-12
        assert Mb == pytest.approx(Ma, abs=1e-12)
        np.testing.assert_allclose(cb, ca, atol=1e-12)
        np.testing.assert_allclose(Ib, Ia, atol=1e-12)
        assert pose_err(a.get_transform("tool0", "base_link"), b.get_transform("tool0", "base_link")) < 1e-12
    ja, jb = a.joint_map, b.joint_map
    for name in robot.names:
        assert jb[name].type == ja[name].type
        assert (jb[name].limit.effort, jb[name].limit.velocity) == (ja[name].limit.effort, ja[name].limit.velocity)
        if ja[name].type != "continuous":
            assert (jb[name].limit.lower, jb[name].limit.upper) == (ja[name].limit.lower, ja[name].limit.upper)
    assert jb["wrist_3_joint"].type == "continuous"
    assert [m.name for m in b.robot.materials] == ["ur_grey"]
    # through a DH robot file and back (the CLI's convert)
    runner = CliRunner()
    toml = tmp_path / "ur_dh.toml"
    r = runner.invoke(app, ["convert", str(UR), "--to", "dh", "-o", str(toml)])
    assert r.exit_code == 0, r.output
    assert dv.load_robot(toml).convention == "dh"
    out2 = tmp_path / "ur_from_dh.urdf"
    r = runner.invoke(app, ["convert", str(toml), "--to", "urdf", "-o", str(out2)])
    assert r.exit_code == 0, r.output
    c = yourdfpy.URDF.load(str(out2), build_scene_graph=True, load_meshes=False)
    q = qs_within(robot.model(), 1, seed=9)[0]
    ia, Ma, ca, _ = world_items(a, q)
    ic, Mc, cc, _ = world_items(c, q)
    for (ka, Ta), (kc, Tc) in zip(ia, ic):
        assert ka == kc and pose_err(Ta, Tc) < 1e-12
    np.testing.assert_allclose(cc, ca, atol=1e-12)


# a laser tracker's frame: the robot's base link 1 rad about z and (2, -1, 0.5) m away from its origin
TRACKER = Rz(1.0)
TRACKER[:3, 3] = (2.0, -1.0, 0.5)


@pytest.mark.parametrize("path", [UR, PANDA], ids=lambda p: p.stem)
@pytest.mark.parametrize("conv", ["edh", "dh", "mdh", "poe"])
def test_identified_in_a_measurement_frame_carries_meshes_onto_the_robot(path, conv, tmp_path):
    """The audit's case: sweeps simulated (noise-free) in a tracker frame (the true robot's base link at
    TRACKER), identified with the URDF as nominal, exported with its meshes. The exported file's root is the
    identified base (the tracker frame), and every visual, collision and inertial read back by yourdfpy sits,
    at any q, where yourdfpy puts it in the nominal URDF moved by TRACKER (the true geometry) to 1e-9 (float
    rounding of a noise-free fit; measured ~1e-14). The old export, which read the nominal's base-link poses as
    if they were in the tracker frame, was 2.3 m off; placing them on the identified joint frames without
    registering the axes would still be 0.36 m off (the ED-H frame origins slide along the UR axes)."""
    from denavit import sweeps as sw  # noqa: PLC0415

    nominal = U.load_urdf(path)
    truth = nominal.model().with_base(TRACKER)
    home = (np.maximum(nominal.lower, -np.pi) + np.minimum(nominal.upper, np.pi)) / 2
    s = sw.simulate(truth, home=home, ranges=np.stack([home - 0.5, home + 0.5], axis=1), points_per_sweep=10, seed=1)
    m = dv.identify(s, convention=conv, nominal=nominal).model()
    out = tmp_path / "identified.urdf"
    U.save_urdf(m, out, nominal)
    a = yourdfpy.URDF.load(str(path), build_scene_graph=True, load_meshes=False)
    b = yourdfpy.URDF.load(str(out), build_scene_graph=True, load_meshes=False)
    assert (
        b.base_link == "world" and pose_err(b.get_transform(a.base_link, "world"), TRACKER) < 1e-9
    )  # the root is the tracker frame
    back = U.urdf_model(out, tip_link="tcp")
    assert tool_err(back, m, qs_within(m, 20)) < 1e-12
    R, p = TRACKER[:3, :3], TRACKER[:3, 3]
    for q in qs_within(nominal.model(), 5, seed=4):
        ia, Ma, ca, Ia = world_items(a, q)
        ib, Mb, cb, Ib = world_items(b, q)
        assert [k for k, _ in ia] == [k for k, _ in ib] and len(ia) >= 8
        for (k, Ta), (_, Tb) in zip(ia, ib):
            assert pose_err(TRACKER @ Ta, Tb) < 1e-9, k
        assert Mb == pytest.approx(Ma, abs=1e-12) and (Ma > 0) == (path == UR)  # panda_style.urdf has no inertials
        if Ma:
            np.testing.assert_allclose(cb, R @ ca + p, atol=1e-9)
            np.testing.assert_allclose(Ib, R @ Ia @ R.T, atol=1e-9)


@pytest.mark.parametrize("seed", range(4))
def test_meshes_follow_any_convention_in_another_frame(seed, tmp_path):
    """Random chains (any axis, prismatic and fixed joints, a mesh on every link) re-expressed in a tracker
    frame in each convention (frames at other origins along the axes and turned about them): every mesh
    read back by yourdfpy sits where yourdfpy puts the nominal URDF's, moved by TRACKER, to 1e-12."""
    text = re.sub(
        r'<link name="(l\d+)"/>',
        lambda mt: (
            f'<link name="{mt.group(1)}"><visual><origin xyz="0.1 0.2 0.05" rpy="0.3 0.2 0.1"/>'
            f'<geometry><mesh filename="{mt.group(1)}.stl"/></geometry></visual></link>'
        ),
        random_urdf(seed),
    )
    p = write(tmp_path, text)
    nominal = U.load_urdf(p)
    moved = nominal.model().with_base(TRACKER @ nominal.model().T_world_base)
    a = yourdfpy.URDF.load(str(p), build_scene_graph=True, load_meshes=False)
    for conv in ("dh", "mdh", "edh", "poe"):
        m = dv.to_table(moved, conv, parallel_tol=1e-9).table.to_model("t", nominal.names, nominal.lower, nominal.upper)
        out = tmp_path / f"{conv}.urdf"
        U.save_urdf(m, out, nominal)
        b = yourdfpy.URDF.load(str(out), build_scene_graph=True, load_meshes=False)
        for q in qs_within(m, 3, seed=seed):
            ia, ib = world_items(a, q)[0], world_items(b, q)[0]
            assert [k for k, _ in ia] == [k for k, _ in ib] and len(ia) >= 9
            for (k, Ta), (_, Tb) in zip(ia, ib):
                assert pose_err(TRACKER @ Ta, Tb) < 1e-12, (conv, k)


def gravity_torques_from_urdf(path, q, g=(0.0, 0.0, -9.81)):
    """Torques holding a URDF chain against gravity, from yourdfpy's link poses alone: joint i carries the
    moment about its axis of the weight of every link below it (links fixed to a moving link included)."""
    u = yourdfpy.URDF.load(str(path), build_scene_graph=True, load_meshes=False)
    u.update_cfg(q)
    parent = {j.child: j.parent for j in u.robot.joints}
    base = u.base_link

    def below(link, top):
        while link != top and link in parent:
            link = parent[link]
        return link == top

    tau = []
    for j in u.actuated_joints:
        Tj = u.get_transform(j.child, base)
        z = Tj[:3, :3] @ (np.asarray(j.axis) / np.linalg.norm(j.axis))
        moment = np.zeros(3)
        for link in u.robot.links:
            if link.inertial is not None and link.inertial.mass and below(link.name, j.child):
                c = (u.get_transform(link.name, base) @ link.inertial.origin)[:3, 3]
                moment += np.cross(c - Tj[:3, 3], link.inertial.mass * np.asarray(g))
        tau.append(-moment @ z)
    return np.array(tau)


@pytest.mark.parametrize("path", GOOD)
def test_urdf_inertials_give_the_urdfs_gravity_torques(path):
    """load_urdf carries the links' inertials (fixed links merged into their moving body) into the robot, so
    `denavit dynamics x.urdf` is the URDF's dynamics: gravity torques against a sum over yourdfpy's link
    poses; full inverse dynamics against pinocchio's URDF importer when it is installed."""
    robot = U.load_urdf(path)
    has_mass = any(
        l.inertial is not None and l.inertial.mass for l in yourdfpy.URDF.load(str(path), load_meshes=False).robot.links
    )
    if not has_mass:
        assert robot.inertials is None
        return
    m = robot.model()
    for q in qs_within(m, 5, seed=4):
        np.testing.assert_allclose(dv.gravity_torques(m, q), gravity_torques_from_urdf(path, q), rtol=0, atol=1e-11)


def test_urdf_inertials_match_pinocchio():
    pin = pytest.importorskip("pinocchio")
    robot = U.load_urdf(UR)
    m = robot.model()
    pm = pin.buildModelFromUrdf(str(UR))
    pd = pm.createData()
    rng = np.random.default_rng(5)
    for q in qs_within(m, 5, seed=6):
        qd, qdd = rng.normal(size=6), rng.normal(size=6)
        np.testing.assert_allclose(dv.rnea(m, q, qd, qdd), pin.rnea(pm, pd, pin_q(pm, q), qd, qdd), rtol=0, atol=1e-10)


def pin_q(pm, q):
    """pinocchio's configuration vector: continuous joints as (cos, sin)."""
    out = []
    for j, v in zip(list(pm.joints)[1:], q):
        out += [math.cos(v), math.sin(v)] if j.nq == 2 else [v]
    return np.array(out)


@pytest.mark.parametrize("name", ["tiansui_edh", "tiansui_mdh"])
def test_robot_file_inertials_survive_urdf_export(tmp_path, name):
    """A robot file's link inertias are written into the URDF (link i = joint frame i) and read back: the
    same torques to 1e-10 (and the same as pinocchio's importer of the written file, when installed)."""
    robot = dv.load_robot(name)
    m = robot.model()
    out = tmp_path / f"{name}.urdf"
    U.save_urdf(m, out, robot)
    back = U.load_urdf(out).model()
    rng = np.random.default_rng(7)
    for _ in range(5):
        q, qd, qdd = rng.uniform(-2, 2, 6), rng.normal(size=6), rng.normal(size=6)
        np.testing.assert_allclose(dv.rnea(back, q, qd, qdd), dv.rnea(m, q, qd, qdd), rtol=0, atol=1e-10)
        assert np.abs(dv.rnea(m, q, qd, qdd)).max() > 1.0  # the robot file does carry masses
    try:
        import pinocchio as pin
    except ImportError:
        return
    pm = pin.buildModelFromUrdf(str(out))
    q, qd, qdd = rng.uniform(-2, 2, 6), rng.normal(size=6), rng.normal(size=6)
    np.testing.assert_allclose(
        pin.rnea(pm, pm.createData(), pin_q(pm, q), qd, qdd), dv.rnea(m, q, qd, qdd), rtol=0, atol=1e-10
    )


@pytest.mark.parametrize(
    "bad, why",
    [
        ('<inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="3"/>', "triangle"),
        ('<inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="-1"/>', "definite"),
    ],
)
def test_unphysical_urdf_inertia_warns_and_loads_kinematics(tmp_path, bad, why):
    """One unphysical inertial leaves that body alone massless, with a URDF-worded warning (it had made the
    whole robot massless: xArm6 printed all-zero torques)."""
    text = UR.read_text().replace(
        '<inertia ixx="0.010267495893" ixy="0" ixz="0" iyy="0.010267495893" iyz="0" izz="0.00666"/>', bad
    )
    assert bad in text
    p = tmp_path / "bad.urdf"
    p.write_text(text)
    with pytest.warns(
        dv.DenavitWarning,
        match="bad.urdf: the <inertial> of link 'shoulder_link' .*'shoulder_pan_joint'.* not physical",
    ) as rec:
        robot = U.load_urdf(p)
    assert why in str(rec[0].message) and "that body is loaded without mass, the others keep theirs" in str(
        rec[0].message
    )
    good = U.load_urdf(UR).inertials["masses"]
    assert robot.inertials["masses"][0] == 0 and np.array_equal(robot.inertials["masses"][1:], good[1:])
    assert pose_err(dv.fk(robot.model(), np.full(6, 0.3)), dv.fk(U.load_urdf(UR).model(), np.full(6, 0.3))) < 1e-12


def test_negative_urdf_mass_names_the_link(tmp_path):
    p = tmp_path / "neg.urdf"
    p.write_text(UR.read_text().replace('<mass value="2.275"/>', '<mass value="-2.275"/>'))
    with pytest.warns(
        dv.DenavitWarning,
        match="forearm_link.*-2.275.*expected a finite mass >= 0 kg .*that body is loaded without mass, the others keep theirs",
    ):
        masses = U.load_urdf(p).inertials["masses"]
    # as any unphysical inertial (docs/urdf.md): that body alone is massless (it had dropped every body's mass)
    good = U.load_urdf(UR).inertials["masses"]
    moved = [k for k in range(6) if masses[k] != good[k]]
    assert len(moved) == 1 and masses[moved[0]] == 0


def test_model_without_robot_gets_default_names(tmp_path):
    m = dv.load_model("kr5")  # massless links (the Puma 560 now carries its inertial parameters)
    text = U.dumps_urdf(m)
    assert '<link name="base_link"/>' in text and '<link name="link_6"/>' in text and 'effort="0"' in text
    assert text.startswith("<?xml") and "Written by denavit" in text


def test_combine_inertials_parallel_axis_theorem():
    """Two point-like masses 1 kg at x = +-0.5 m: 2 kg at the origin, I_yy = I_zz = 0.5 kg m^2."""
    A, B = np.eye(4), np.eye(4)
    A[0, 3], B[0, 3] = 0.5, -0.5
    T, M, I = U.combine_inertials([(A, 1.0, np.zeros((3, 3))), (B, 1.0, np.zeros((3, 3))), (A, 0.0, np.eye(3))])
    assert M == 2.0
    np.testing.assert_allclose(T, np.eye(4), atol=1e-15)
    np.testing.assert_allclose(I, np.diag([0.0, 0.5, 0.5]), atol=1e-15)


# --------------------------------------------------------------------------------------------------
# helpers


@settings(max_examples=200, deadline=None)
@given(st.lists(st.floats(-1, 1), min_size=3, max_size=3).filter(lambda v: np.linalg.norm(v) > 1e-3))
def test_z_to_takes_z_to_the_axis(v):
    a = np.array(v) / np.linalg.norm(v)
    R = U.z_to(a)
    np.testing.assert_allclose(R @ [0, 0, 1], a, atol=1e-15)
    np.testing.assert_allclose(R.T @ R, np.eye(3), atol=1e-15)
    assert np.linalg.det(R) == pytest.approx(1.0, abs=1e-14)


def test_z_to_special_axes():
    assert np.array_equal(U.z_to([0, 0, 1]), np.eye(3))
    np.testing.assert_allclose(U.z_to([0, 0, -1]), np.diag([1.0, -1.0, -1.0]), atol=1e-16)


@settings(max_examples=200, deadline=None)
@given(
    st.floats(-np.pi, np.pi),
    st.sampled_from([None, np.pi / 2, -np.pi / 2, np.pi / 2 - 1e-9, -np.pi / 2 + 1e-7]),
    st.floats(-np.pi, np.pi),
    st.floats(-1.5, 1.5),
)
def test_rpy_round_trip_including_gimbal_lock(roll, pitch_special, yaw, pitch):
    p = pitch if pitch_special is None else pitch_special
    c, s = math.cos, math.sin
    Rx = np.array([[1, 0, 0], [0, c(roll), -s(roll)], [0, s(roll), c(roll)]])
    Ry = np.array([[c(p), 0, s(p)], [0, 1, 0], [-s(p), 0, c(p)]])
    Rzm = np.array([[c(yaw), -s(yaw), 0], [s(yaw), c(yaw), 0], [0, 0, 1]])
    R = Rzm @ Ry @ Rx
    r2, p2, y2 = matrix_rpy(R)
    Rx2 = np.array([[1, 0, 0], [0, c(r2), -s(r2)], [0, s(r2), c(r2)]])
    Ry2 = np.array([[c(p2), 0, s(p2)], [0, 1, 0], [-s(p2), 0, c(p2)]])
    Rz2 = np.array([[c(y2), -s(y2), 0], [s(y2), c(y2), 0], [0, 0, 1]])
    np.testing.assert_allclose(Rz2 @ Ry2 @ Rx2, R, atol=2e-15)


# --------------------------------------------------------------------------------------------------
# the CLI


def test_convert_cli_prints_tables_and_writes_urdf(tmp_path):
    import json  # noqa: PLC0415

    runner = CliRunner()
    r = runner.invoke(app, ["convert", str(PANDA), "--to", "mdh", "--json"])
    assert r.exit_code == 0, r.output
    doc = json.loads(r.output)
    assert doc["units"] == {"length": "m", "angle": "rad"} and len(doc["rows"]) == 7  # JSON: SI (docs/cli.md)
    assert [p["relation"] for p in doc["pairs"]] == [
        "intersecting",
        "intersecting",
        "skew",
        "skew",
        "intersecting",
        "skew",
    ]
    assert doc["max_tool_position_error_m"] < 1e-12
    r = runner.invoke(app, ["convert", str(UR), "--to", "dh"])
    assert r.exit_code == 0 and "Consecutive axes" in r.output and "parallel" in r.output and "FK parity" in r.output
    out = tmp_path / "kr5.urdf"
    r = runner.invoke(app, ["convert", "kr5", "--to", "urdf", "-o", str(out)])
    assert r.exit_code == 0, r.output
    assert tool_err(U.urdf_model(out), dv.load_model("kr5"), qs_within(dv.load_model("kr5"), 20)) < 1e-12
    r = runner.invoke(app, ["convert", str(DATA / "two_tips.urdf"), "--to", "urdf", "--tip-link", "tool0"])
    assert r.exit_code == 0 and "<robot" in r.output and '<link name="camera"/>' in r.output  # off-chain links kept
    r = runner.invoke(
        app, ["convert", str(DATA / "two_tips.urdf"), "--to", "urdf", "--tip-link", "tool0", "--chain-only"]
    )
    assert r.exit_code == 0 and "<robot" in r.output and "camera" not in r.output
    r = runner.invoke(
        app,
        [
            "convert",
            str(DATA / "two_tips.urdf"),
            "--to",
            "dh",
            "--base-link",
            "link_1",
            "--tip-link",
            "tool0",
            "--json",
        ],
    )
    assert r.exit_code == 0 and len(json.loads(r.output)["rows"]) == 1
    # without --tip-link, REP-199's tool0 is the tip (the camera hangs off the arm), and the choice is said
    r = runner.invoke(app, ["convert", str(DATA / "two_tips.urdf"), "--to", "dh", "--json"])
    assert r.exit_code == 0 and len(json.loads(r.output[r.output.index("{") :])["rows"]) == 2
    assert dv.load_robot(DATA / "two_tips.urdf").notes == [
        "two_tips.urdf: tip link 'tool0' (REP-199) of 2 leaves; choose another with tip_link (CLI: --tip-link)"
    ]


# --------------------------------------------------------------------------------------------------
# bad input: clear errors that name the file and the element


@pytest.mark.parametrize(
    "name, match",
    [
        ("malformed_xml.urdf", r"malformed_xml.urdf: malformed XML at line 10.*child line 7 and joint"),
        (
            "missing_link.urdf",
            r"missing_link.urdf: joint 'j2' \(line 12\): child link 'link_2' is not defined \(links: base_link, link_1\)",
        ),
        (
            "two_arms.urdf",
            r"two_arms.urdf: the tree below 'base_link' has 2 tip links \('left' \(1 moving joints\), 'right' \(1 moving joints\)\).*tip_link",
        ),
        (
            "floating_joint.urdf",
            r"floating_joint.urdf: joint 'free_base' \(line 7\) is a floating joint, which is not supported",
        ),
        ("zero_axis.urdf", r"zero_axis.urdf: joint 'j2' \(line 13\): axis xyz=\"0 0 0\" has zero length"),
    ],
)
def test_bad_files(name, match):
    with pytest.raises(dv.DenavitError, match=match):
        dv.load_robot(DATA / name)


ARM = """<robot name="arm">
  <link name="base_link"/><link name="link_1"/><link name="link_2"/>
  <joint name="j1" type="revolute"><parent link="base_link"/><child link="link_1"/><axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="0" velocity="0"/></joint>
  <joint name="j2" type="{type}"><parent link="link_1"/><child link="link_2"/><origin xyz="0.3 0 0"/>{axis}{extra}</joint>
  {more}
</robot>"""


@pytest.mark.parametrize(
    "kw, match",
    [
        ({"type": "planar"}, r"joint 'j2' \(line 4\) is a planar joint, which is not supported"),
        (
            {
                "type": "revolute",
                "extra": '<limit lower="-1" upper="1" effort="0" velocity="0"/><mimic joint="j1" multiplier="2"/>',
            },
            r"joint 'j2' \(line 4\) mimics joint 'j1': mimic joints .* not supported",
        ),
        ({"type": "ball"}, r"joint 'j2' \(line 4\): unknown joint type 'ball'"),
        ({"type": "revolute"}, r"joint 'j2' \(line 4\): a revolute joint needs a <limit"),
        (
            {"type": "revolute", "extra": '<limit lower="1" upper="-1" effort="0" velocity="0"/>'},
            r"joint 'j2' \(line 4\): limit lower=1.0 is above upper=-1.0",
        ),
        (
            {
                "type": "continuous",
                "more": '<joint name="back" type="fixed"><parent link="link_2"/><child link="link_1"/></joint>',
            },
            r"link 'link_1' \(line 2\) is the child of joint 'j1' and of joint 'back': kinematic loops",
        ),
        (
            {
                "type": "continuous",
                "more": '<joint name="j3" type="fixed"><parent link="link_2"/><child link="base_link"/></joint>',
            },
            r"no root link .* loop",
        ),
        # a joint whose parent is its child, and a loop away from the root: both had been dropped without a word
        (
            {
                "type": "continuous",
                "more": '<link name="x"/><joint name="self" type="fixed"><parent link="x"/><child link="x"/></joint>',
            },
            r"joint 'self' \(line 5\): its child link 'x' \(parent 'x'\) is on a loop of joints: kinematic loops are not supported",
        ),
        (
            {
                "type": "continuous",
                "more": '<link name="x"/><link name="y"/><joint name="xy" type="fixed"><parent link="x"/><child link="y"/></joint>'
                '<joint name="yx" type="fixed"><parent link="y"/><child link="x"/></joint>',
            },
            r"joint 'xy' \(line 5\): its child link 'y' \(parent 'x'\) is on a loop",
        ),
        (
            {"type": "continuous", "axis": '<axis xyz="0 1 zero"/>'},
            r"joint 'j2' \(line 4\): axis xyz='0 1 zero': expected 3 numbers",
        ),
        ({"type": "continuous", "more": '<link name="link_2"/>'}, r"link 'link_2' is defined twice \(lines 2 and 5\)"),
    ],
)
def test_bad_chains(tmp_path, kw, match):
    text = ARM.format(**{"type": "revolute", "axis": '<axis xyz="0 1 0"/>', "extra": "", "more": "", **kw})
    with pytest.raises(dv.DenavitError, match=match):
        U.load_urdf(write(tmp_path, text))


def test_bad_base_and_tip(tmp_path):
    p = DATA / "two_tips.urdf"
    with pytest.raises(
        dv.DenavitError, match=r"tip link 'hand' is not defined \(links: base_link, camera, link_1, link_2, tool0\)"
    ):
        U.load_urdf(p, tip_link="hand")
    with pytest.raises(dv.DenavitError, match=r"tip link 'link_1' is not below base link 'link_2'"):
        U.load_urdf(p, base_link="link_2", tip_link="link_1")
    with pytest.raises(
        dv.DenavitError,
        match=r"no revolute, continuous or prismatic joint between base link 'link_2' and tip link 'tool0'",
    ):
        U.load_urdf(p, base_link="link_2", tip_link="tool0")
    with pytest.raises(dv.DenavitError, match=r"expected a <robot> root element, got <model>"):
        U.load_urdf(write(tmp_path, "<model/>"))
    with pytest.raises(dv.DenavitError, match=r"no such URDF file"):
        U.load_urdf(tmp_path / "nope.urdf")


def test_cli_identify_urdf_writes_the_exact_geometry_with_the_nominals_meshes(tmp_path):
    """`denavit simulate` + `denavit identify --nominal X.urdf --urdf OUT` (default --convention dh): the
    URDF written is the exact identified geometry (noise-free data: the true tool point to 1e-9 m at any q)
    and carries every mesh and visual/collision, the total mass (fixed links are merged) and the
    effort/velocity limits of the nominal URDF."""
    csv, out = tmp_path / "s.csv", tmp_path / "out.urdf"
    runner = CliRunner()
    r = runner.invoke(app, ["simulate", str(UR), "-o", str(csv), "--noise", "0"])
    assert r.exit_code == 0, r.output
    r = runner.invoke(app, ["identify", str(csv), "--nominal", str(UR), "--urdf", str(out)])
    assert r.exit_code == 0, r.output
    src, txt = UR.read_text(), out.read_text()
    for tag in ("<mesh", "<visual", "<collision"):
        assert txt.count(tag) == src.count(tag) > 0, tag

    def total(attr, t):
        return sorted(float(v) for v in re.findall(attr + r'="([^"]+)"', t))

    assert sum(total("<mass value", txt)) == pytest.approx(sum(total("<mass value", src)), rel=1e-12)
    assert (
        total("effort", txt) == total("effort", src)
        and total("velocity", txt) == total("velocity", src)
        and max(total("effort", src)) > 0
    )
    T_ft = np.eye(4)
    T_ft[:3, 3] = (0.05, 0.03, 0.10)  # sw.simulate's default tool point in the flange frame
    truth = U.load_urdf(UR).model().with_tool(T_ft)
    qs = qs_within(truth, 40)
    assert np.abs(dv.fk_batch(U.urdf_model(out), qs)[:, :3, 3] - dv.fk_batch(truth, qs)[:, :3, 3]).max() < 1e-9
    # noisy sweeps: the near-parallel UR axes 2-4 are no longer exactly parallel; the URDF is the exact
    # (ED-H) geometry of the identified axes, not the DH table printed by default, which drops the tilt

    r = runner.invoke(app, ["simulate", str(UR), "-o", str(csv), "--noise", "0.02", "--seed", "3"])
    assert r.exit_code == 0, r.output
    r = runner.invoke(app, ["identify", str(csv), "--nominal", str(UR), "--urdf", str(out)])
    assert r.exit_code == 0, r.output
    res = dv.identify(swio.read_long_csv(csv), nominal=U.load_urdf(UR))
    exported = dv.fk_batch(U.urdf_model(out), qs)
    assert np.abs(exported - dv.fk_batch(res.model(convention="edh"), qs)).max() < 1e-12
    assert (
        np.abs(exported[:, :3, 3] - dv.fk_batch(res.model(), qs)[:, :3, 3]).max() > 1e-7
    )  # what the DH table would have written


def test_every_command_picks_the_chain():
    """--base-link/--tip-link wherever a MODEL is read, and the default tip said in one line (it was a
    message recommending an option only convert had); load_model(path, tip_link=...) (was a TypeError)."""
    from cli import run

    f = DATA / "two_tips.urdf"
    m = dv.load_model(f, tip_link="camera")
    assert m.nq == 1 and dv.load_model(f).nq == 2
    for args in (
        ["fk", f, "--q", "0.1,0.2"],
        ["show", f],
        ["export", f],
        ["dynamics", f, "--q", "0,0", "--qd", "0,0", "--qdd", "0,0"],
        ["ik", f, "--pose", ",".join(map(str, dv.fk(dv.load_model(f), [0.1, 0.2]).ravel())), "--length", "m"],
    ):
        p = run(*args)
        assert "note: two_tips.urdf: tip link 'tool0' (REP-199)" in p.stderr, args
        p = run(*args[:2], "--tip-link", "tool0", *args[2:])
        assert "note:" not in p.stderr
    p = run("fk", f, "--tip-link", "camera", "--q", "0.1")
    assert "camera" not in p.stderr and p.returncode == 0
    p = run("fk", "kr5", "--tip-link", "tool0", "--q", "0,0,0,0,0,0", ok=False)
    assert p.returncode == 2 and "--base-link/--tip-link apply to a URDF MODEL, got 'kr5'" in p.stderr
    p = run("fk", DATA / "two_arms.urdf", "--q", "0", ok=False)
    assert p.returncode == 2 and "choose one with tip_link (CLI: --tip-link)" in p.stderr


@pytest.mark.parametrize(
    "edit, match",
    [
        (('iyz="0"', 'iyz="-1e309"', 1), r"link 'base_link' \(line \d+\): <inertial> must hold finite numbers"),
        (
            ('upper="6.283185307179586"', 'upper="1e309"', 1),
            r"joint 'shoulder_pan_joint' \(line \d+\): limit lower=-6.28\S* upper=inf must be finite",
        ),
        (
            ('lower="-6.283185307179586" ', "", 1),
            r"joint 'shoulder_pan_joint' \(line \d+\): <limit> lacks lower: a revolute joint needs both bounds",
        ),
        (
            ('xyz="0 0 0.089159"', 'xyz="0 0 1e309"', 1),
            r"joint 'shoulder_pan_joint' \(line \d+\): origin xyz='0 0 1e309': expected 3 finite numbers",
        ),
    ],
)
def test_non_finite_and_missing_numbers_are_errors(tmp_path, edit, match):
    """1e309 had become an infinite limit or a NaN inertia (a RuntimeWarning deep in numpy), a limit without
    lower/upper a silent [0, 0] (found by tests/test_fuzz.py): one-line errors naming the element."""
    text = UR.read_text()
    old, new, count = edit
    assert old in text
    f = tmp_path / "ur.urdf"
    f.write_text(text.replace(old, new, count))
    with pytest.raises(dv.DenavitError, match=match):
        dv.load_robot(f)


def test_a_fixed_joint_with_a_mimic_tag_loads_as_urdfdom_loads_it(tmp_path):
    """urdfdom ignores <mimic> on a fixed joint; it had been refused."""
    text = UR.read_text()
    i = text.index('type="fixed"')
    j = text.index("</joint>", i)
    f = tmp_path / "mimic.urdf"
    f.write_text(text[:j] + '<mimic joint="shoulder_pan_joint" multiplier="1"/>' + text[j:])
    a, b = dv.load_model(f), dv.load_model(UR)
    q = np.full(6, 0.3)
    np.testing.assert_allclose(dv.fk(a, q), dv.fk(b, q), atol=1e-15)


def test_an_undeclared_namespace_prefix_loads_as_urdfdom_loads_it(tmp_path, capfd):
    """A vendor tag with an undeclared prefix (drake:) is tolerated as urdfdom, pinocchio and yourdfpy do (strict
    XML had refused the file); malformed XML is still an error."""
    text = UR.read_text()
    i = text.index('<link name="base_link">')
    f = tmp_path / "ns.urdf"
    f.write_text(
        text[:i]
        + '<drake:collision_filter_group name="g"><drake:member link="base_link"/></drake:collision_filter_group>\n  '
        + text[i:]
    )
    q = np.full(6, 0.3)
    np.testing.assert_allclose(dv.fk(dv.load_model(f), q), dv.fk(dv.load_model(UR), q), atol=1e-15)
    assert "parsing approach" not in capfd.readouterr().err


def test_calibrate_writes_urdf_with_the_nominals_meshes(tmp_path):
    """`denavit calibrate --urdf` (it had none; --save dropped a URDF nominal's meshes): the calibrated URDF
    reproduces the calibrated model and carries the nominal's meshes."""
    from cli import run
    from denavit import calibration as cal
    from denavit.io.measurements import to_csv

    nominal = dv.load_robot(UR)
    q = cal.configurations(nominal, 60)
    f = tmp_path / "m.csv"
    f.write_text(to_csv(cal.simulate(nominal, q, tool=(0.02, 0.01, 0.05), noise=2e-5), "mm", "deg"))
    out = tmp_path / "cal.urdf"
    run("calibrate", f, "--nominal", UR, "--tool", "20,10,50", "--urdf", out, "--save", tmp_path / "cal.toml")
    text = out.read_text()
    assert text.count("<mesh") == UR.read_text().count("<mesh") > 0
    m = dv.load_model(out)
    cal_toml = dv.load_model(tmp_path / "cal.toml")
    # the URDF is the calibrated model; the ED-H file drops the tilt of the UR's parallel axes where it is within
    # 3 sigma of zero (as identify's ED-H) and says how far that moves the tool, which bounds the difference
    header = (tmp_path / "cal.toml").read_text().splitlines()[0]
    carried = (
        float(header.split("tool-position error up to ")[1].split(" mm")[0]) * 1e-3
        if "tool-position error up to" in header
        else 1e-9
    )
    assert carried < 2e-5  # within the points' noise
    for qq in q[:10]:
        np.testing.assert_allclose(dv.fk(m, qq)[:3, 3], dv.fk(cal_toml, qq)[:3, 3], atol=carried * 1.001 + 1e-9)


PARALLEL = """<robot name="planar">
  <link name="base_link"><visual><origin xyz="0.01 0 0.02"/><geometry><mesh filename="base.stl"/></geometry></visual></link>
  <link name="link_1"><visual><origin xyz="0.1 0 0.03" rpy="0 0 0.2"/><geometry><mesh filename="link_1.stl"/></geometry></visual></link>
  <link name="link_2"><visual><origin xyz="0.1 0.02 0.01"/><geometry><mesh filename="link_2.stl"/></geometry></visual></link>
  <joint name="j1" type="revolute"><parent link="base_link"/><child link="link_1"/><origin xyz="0.05 0.02 0.3" rpy="0.1 0 0"/><axis xyz="0 0 1"/><limit lower="-3" upper="3" effort="10" velocity="1"/></joint>
  <joint name="j2" type="revolute"><parent link="link_1"/><child link="link_2"/><origin xyz="0.4 0 0.07"/><axis xyz="0 0 1"/><limit lower="-3" upper="3" effort="10" velocity="1"/></joint>
</robot>"""


@pytest.mark.parametrize("conv", ["dh", "mdh", "edh", "poe"])
def test_meshes_of_an_all_parallel_chain_are_placed_exactly(conv, tmp_path):
    """Two parallel axes leave the slide along them free in the axis registration (meshes had been placed
    32.8 um off, 2.4 mm here): the tool fixes it, so every link and mesh of the export is the original's to
    1e-12, in any convention and in a tracker frame."""
    p = write(tmp_path, PARALLEL)
    nominal = U.load_urdf(p)
    a = yourdfpy.URDF.load(str(p), build_scene_graph=True, load_meshes=False)
    for T in (np.eye(4), TRACKER):
        moved = nominal.model().with_base(T @ nominal.model().T_world_base)
        m = dv.to_table(moved, conv, parallel_tol=1e-9).table.to_model("t", nominal.names, nominal.lower, nominal.upper)
        out = tmp_path / f"{conv}.urdf"
        U.save_urdf(m, out, nominal)
        b = yourdfpy.URDF.load(str(out), build_scene_graph=True, load_meshes=False)
        assert "tcp" not in b.link_map
        for q in qs_within(m, 3, seed=2):
            ia, ib = world_items(a, q)[0], world_items(b, q)[0]
            assert [k for k, _ in ia] == [k for k, _ in ib] and len(ia) == 3
            for (k, Ta), (_, Tb) in zip(ia, ib):
                assert pose_err(T @ Ta, Tb) < 1e-12, k


def test_no_limit_is_invented(tmp_path):
    """Effort and velocity are written as the URDF gave them; a continuous joint without a <limit> gets none
    (it had been given <limit effort="0" velocity="0"/>, which ros_control reads as a joint that cannot move)."""
    text = UR.read_text().replace('<limit effort="28" velocity="3.2"/>', "")
    robot = U.load_urdf(write(tmp_path, text))
    out = U.dumps_urdf(robot.model(), robot)
    u = yourdfpy.URDF.load(str(write(tmp_path, out, "out.urdf")), load_meshes=False)
    assert u.joint_map["wrist_3_joint"].limit is None and u.joint_map["wrist_3_joint"].type == "continuous"
    assert (u.joint_map["elbow_joint"].limit.effort, u.joint_map["elbow_joint"].limit.velocity) == (150.0, 3.15)
    text = U.dumps_urdf(dv.load_model("puma560").with_tool(Rz(0.3)))
    assert 'type="continuous"' not in text or '<limit effort="0"' not in text


# --------------------------------------------------------------------------------------------------
# URDFs in the shape of real ones (issue #15): names, frames and the whole body's dynamics


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


def all_joint_values(u: yourdfpy.URDF, robot, q, rng):
    """A configuration of every actuated joint of the tree: the chain's at ``q``, the others random."""
    cfg = {
        j.name: rng.uniform(max(j.limit.lower, -1.0), min(j.limit.upper, 1.0))
        if j.limit is not None and j.limit.lower is not None and j.type != "continuous"
        else rng.uniform(-1, 1)
        for j in u.actuated_joints
    }
    cfg.update(zip(robot.names, q))
    return cfg


@pytest.mark.parametrize("path, tip", TREES, ids=TREE_IDS)
def test_export_is_the_original_tree(path, tip, tmp_path):
    """`convert X.urdf --to urdf` of the unchanged model is the original tree: every link of the original
    (tool0, flange, base, the `world` root, sensor frames, off-chain arms and fingers) is in the export, and
    each is the original's frame to 1e-12 at any configuration, read by yourdfpy and by pinocchio (the export
    had turned shoulder_link by 180 deg, invented a tool0 82.3 mm off and dropped every off-chain link);
    export -> import -> export is byte-identical; --chain-only writes the links from base to tip alone."""
    pin = pytest.importorskip("pinocchio")
    robot = U.load_urdf(path, tip_link=tip)
    out = tmp_path / "out.urdf"
    U.save_urdf(robot.model(), out, robot)
    a = yourdfpy.URDF.load(str(path), build_scene_graph=True, load_meshes=False)
    b = yourdfpy.URDF.load(str(out), build_scene_graph=True, load_meshes=False)
    assert sorted(b.link_map) == sorted(a.link_map) and sorted(b.joint_map) == sorted(a.joint_map)
    pa, pb = pin.buildModelFromUrdf(str(path)), pin.buildModelFromUrdf(str(out))
    da, db = pa.createData(), pb.createData()
    rng = np.random.default_rng(3)
    for q in qs_within(robot.model(), 4, seed=5):
        cfg = all_joint_values(a, robot, q, rng)
        a.update_cfg(cfg)
        b.update_cfg(cfg)
        xa, xb = pin.neutral(pa), pin.neutral(pb)
        for pm, x in ((pa, xa), (pb, xb)):
            for k in range(1, pm.njoints):
                uj = a.joint_map[pm.names[k]]  # a mimic joint (not actuated in yourdfpy) follows its joint
                v = (
                    cfg[uj.name]
                    if uj.mimic is None
                    else (uj.mimic.multiplier or 1.0) * cfg[uj.mimic.joint] + (uj.mimic.offset or 0.0)
                )
                j = pm.joints[k]
                x[j.idx_q : j.idx_q + j.nq] = [math.cos(v), math.sin(v)] if j.nq == 2 else [v]
        pin.framesForwardKinematics(pa, da, xa)
        pin.framesForwardKinematics(pb, db, xb)
        for link in a.link_map:
            assert pose_err(a.get_transform(link), b.get_transform(link)) < 1e-12, link
            Ta, Tb = (
                da.oMf[pa.getFrameId(link, pin.BODY)].homogeneous,
                db.oMf[pb.getFrameId(link, pin.BODY)].homogeneous,
            )
            assert pose_err(Ta, Tb) < 1e-12 and pose_err(Ta, a.get_transform(link)) < 1e-12, link
        # the tool and the axes as the model has them
        assert pose_err(b.get_transform(robot.extra["urdf"]["tip_link"]), dv.fk(robot.model(), q)) < 1e-12
    again = U.load_urdf(out, tip_link=tip)
    assert U.dumps_urdf(again.model(), again) == out.read_text()
    chain = U.load_urdf(path, tip_link=tip, chain_only=True)
    c = yourdfpy.URDF.load(
        str(write(tmp_path, U.dumps_urdf(chain.model(), chain), "chain.urdf")),
        build_scene_graph=True,
        load_meshes=False,
    )
    assert list(c.link_map) == robot.extra["urdf"]["path_links"]
    q = qs_within(robot.model(), 1, seed=8)[0]
    c.update_cfg(dict(zip(robot.names, q)))
    a.update_cfg(all_joint_values(a, robot, q, rng))
    base = robot.extra["urdf"]["base_link"]
    for link in c.link_map:
        assert pose_err(c.get_transform(link), a.get_transform(link, base)) < 1e-12, link


def reduced_pinocchio(pin, path, robot, locked=None):
    """pinocchio's model of the full tree with every joint off the chain locked (at ``locked``, else 0)."""
    full = pin.buildModelFromUrdf(str(path))
    x = pin.neutral(full)
    lock = []
    for k in range(1, full.njoints):
        if full.names[k] not in robot.names:
            lock.append(k)
            v = (locked or {}).get(full.names[k], 0.0)
            j = full.joints[k]
            x[j.idx_q : j.idx_q + j.nq] = [math.cos(v), math.sin(v)] if j.nq == 2 else [v]
    red = pin.buildReducedModel(full, lock, x)
    assert list(red.names)[1:] == robot.names
    return red


@pytest.mark.parametrize("path, tip", TREES, ids=TREE_IDS)
def test_dynamics_of_the_whole_body_match_pinocchio(path, tip):
    """The off-chain links (the other arm, the head, the wheels' carrier, fingers, a wrist camera) ride on
    the chain body that carries them: inverse dynamics equal pinocchio's full tree with the off-chain joints
    locked (buildReducedModel) to 1e-9 N m (they had been left out silently: TIAGo's torso 161.8 N against
    187.7 N), and --chain-only leaves them out, as pinocchio's model of the chain alone does."""
    pin = pytest.importorskip("pinocchio")
    robot = U.load_urdf(path, tip_link=tip)
    m = robot.model()
    red = reduced_pinocchio(pin, path, robot)
    data = red.createData()
    rng = np.random.default_rng(11)
    for q in qs_within(m, 5, seed=12):
        qd, qdd = rng.normal(size=m.nq), rng.normal(size=m.nq)
        np.testing.assert_allclose(
            dv.rnea(m, q, qd, qdd), pin.rnea(red, data, pin_q(red, q), qd, qdd), rtol=0, atol=1e-9
        )
    merged = [
        ld
        for b in robot.extra["urdf"]["bodies"][1:]
        for ld in b["attached"]
        if ld.get("inertial", {}).get("mass", 0) > 0
    ]
    if merged:
        assert any("merged" in n and f"{len(merged)} off-chain link" in n for n in robot.notes)
        alone = U.load_urdf(path, tip_link=tip, chain_only=True)
        assert not any("merged" in n for n in alone.notes)
        q = qs_within(m, 1, seed=13)[0]
        kg = sum(ld["inertial"]["mass"] for ld in merged)
        assert np.abs(dv.gravity_torques(m, q) - dv.gravity_torques(alone.model(), q)).max() > 1e-3 * kg


def test_locked_off_chain_joints_at_given_values():
    """The head turned and tilted, the left arm raised: the torques equal pinocchio's reduced model locked
    at the same values; a name that is not an off-chain joint is an error naming the choices."""
    pin = pytest.importorskip("pinocchio")
    locked = {"head_1_joint": 0.4, "head_2_joint": -0.3, "arm_left_1_joint": 1.1, "arm_left_2_joint": -0.5}
    robot = U.load_urdf(HUMANOID, locked=locked)
    m = robot.model()
    red = reduced_pinocchio(pin, HUMANOID, robot, locked)
    data = red.createData()
    rng = np.random.default_rng(2)
    for q in qs_within(m, 3, seed=3):
        qd, qdd = rng.normal(size=m.nq), rng.normal(size=m.nq)
        np.testing.assert_allclose(
            dv.rnea(m, q, qd, qdd), pin.rnea(red, data, pin_q(red, q), qd, qdd), rtol=0, atol=1e-9
        )
    assert (
        np.abs(
            dv.gravity_torques(m, np.zeros(m.nq)) - dv.gravity_torques(U.load_urdf(HUMANOID).model(), np.zeros(m.nq))
        )[1]
        > 1e-2
    )  # torso_2
    with pytest.raises(
        dv.DenavitError,
        match=r"locked joint 'arm_right_1_joint': expected off-chain movable joints \('arm_left_1_joint'",
    ):
        U.load_urdf(HUMANOID, locked={"arm_right_1_joint": 0.1})


def test_identified_export_keeps_every_link_on_its_body(tmp_path):
    """An identified UR5 (noisy sweeps in a tracker frame): the export keeps every link and joint name; each
    chain link sits on its body (the same pose relative to the nominal's body frame to 1e-12: only chain joint
    origins and axes changed, every <link> element, mesh and inertial is the original's text), off-chain
    frames ride on their parents, a `world` root holds the tracker frame and `tcp` the identified tool point."""
    from lxml import etree  # noqa: PLC0415

    from denavit import sweeps as sw  # noqa: PLC0415

    nominal = U.load_urdf(UR_ROS)
    truth = nominal.model().with_base(TRACKER)
    home = (np.maximum(nominal.lower, -np.pi) + np.minimum(nominal.upper, np.pi)) / 2
    s = sw.simulate(
        truth, home=home, ranges=np.stack([home - 0.6, home + 0.6], axis=1), points_per_sweep=12, noise=2e-5, seed=4
    )
    m = dv.identify(s, convention="edh", nominal=nominal).model()
    out = tmp_path / "identified.urdf"
    U.save_urdf(m, out, nominal)
    src = {
        el.get("name"): etree.tostring(el)
        for el in etree.parse(str(UR_ROS), etree.XMLParser(remove_blank_text=True)).getroot()
        if el.tag == "link"
    }
    new = {
        el.get("name"): etree.tostring(el)
        for el in etree.parse(str(out), etree.XMLParser(remove_blank_text=True)).getroot()
        if el.tag == "link"
    }
    assert all(new[name] == text for name, text in src.items()) and set(new) - set(src) == {"world_2", "tcp"}
    b = yourdfpy.URDF.load(str(out), build_scene_graph=True, load_meshes=False)
    assert b.base_link == "world_2"  # the tracker frame above the file's own `world` root
    back = U.urdf_model(out, tip_link="tcp")
    qs = qs_within(m, 20)
    assert tool_err(back, m, qs) < 1e-12
    assert (
        pose_err(
            b.get_transform("wrist_camera_optical_frame", "wrist_3_link"),
            yourdfpy.URDF.load(str(UR_ROS), build_scene_graph=True, load_meshes=False).get_transform(
                "wrist_camera_optical_frame", "wrist_3_link"
            ),
        )
        < 1e-12
    )
