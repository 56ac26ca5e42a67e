"""Writing URDFs (denavit.io.urdf.write, issue #5): round trips through every convention, meshes and limits carried, the
original tree kept, the convert command."""

import math

import numpy as np
import pytest
import yourdfpy
from typer.testing import CliRunner
from urdf_cases import (
    DATA,
    GOOD,
    KR5,
    PANDA,
    TREE_IDS,
    TREES,
    UR,
    Rz,
    frames_err,
    pose_err,
    qs_within,
    random_urdf,
    tool_err,
    world_items,
    write,
)

import denavit as dv
from denavit.cli import app
from denavit.io import urdf as U

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


# --------------------------------------------------------------------------------------------------
# meshes and limits


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


def test_model_without_robot_gets_default_names(tmp_path):
    m = dv.load_model("kr5")  # massless links (the Puma 560 now carries its inertial parameters)
    text = U.dumps_urdf(m)
    assert '<link name="base_link"/>' in text and '<link name="link_6"/>' in text and 'effort="0"' in text
    assert text.startswith("<?xml") and "Written by denavit" in text


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
# URDFs in the shape of real ones (issue #15): the export is the original tree


def all_joint_values(u: yourdfpy.URDF, robot, q, rng):
    """A configuration of every actuated joint of the tree: the chain's at ``q``, the others random."""
    cfg = {
        j.name: (
            rng.uniform(max(j.limit.lower, -1.0), min(j.limit.upper, 1.0))
            if j.limit is not None and j.limit.lower is not None and j.type != "continuous"
            else rng.uniform(-1, 1)
        )
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
