"""URDF inertials (issue #5, #15): the links' masses carried into the robot, checked against the URDF's own gravity
torques and pinocchio's importer; off-chain links ride on their body; unphysical inertials."""

import math

import numpy as np
import pytest
import yourdfpy
from urdf_cases import GOOD, HUMANOID, TREE_IDS, TREES, UR, pin_q, pose_err, qs_within

import denavit as dv
from denavit.io import urdf as U


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
        match=(
            "forearm_link.*-2.275.*expected a finite mass >= 0 kg .*that body is loaded without mass, the others keep"
            " theirs"
        ),
    ):
        masses = U.load_urdf(p).inertials["masses"]
    # as any unphysical inertial (docs/urdf.md): that body alone is massless (it had dropped every body's mass)
    good = U.load_urdf(UR).inertials["masses"]
    moved = [k for k in range(6) if masses[k] != good[k]]
    assert len(moved) == 1 and masses[moved[0]] == 0


def test_combine_inertials_parallel_axis_theorem():
    """Two point-like masses 1 kg at x = +-0.5 m: 2 kg at the origin, I_yy = I_zz = 0.5 kg m^2."""
    A, B = np.eye(4), np.eye(4)
    A[0, 3], B[0, 3] = 0.5, -0.5
    T, M, I = U.combine_inertials([(A, 1.0, np.zeros((3, 3))), (B, 1.0, np.zeros((3, 3))), (A, 0.0, np.eye(3))])
    assert M == 2.0
    np.testing.assert_allclose(T, np.eye(4), atol=1e-15)
    np.testing.assert_allclose(I, np.diag([0.0, 0.5, 0.5]), atol=1e-15)


# --------------------------------------------------------------------------------------------------
# URDFs in the shape of real ones (issue #15): the whole body's dynamics


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
