"""Universal Robots' kinematics-parameters YAML (denavit.io.ur_calibration)."""

import numpy as np
import pytest

import denavit as dv
from denavit.geometry import rpy_matrix
from denavit.io import ur_calibration as urc

# Universal Robots' published UR5 DH table (m, rad), the numbers of models/ur5.toml's source.
UR5 = {"d1": 0.089159, "a2": -0.425, "a3": -0.39225, "d4": 0.10915, "d5": 0.09465, "d6": 0.0823}


def chain_fk(origins, q):
    """T_base_tool0 as ur_description builds it: each joint's origin, then its rotation about z."""
    T = np.eye(4)
    for o, qi in zip(origins, q):
        c, s = np.cos(qi), np.sin(qi)
        T = T @ o @ np.array([[c, -s, 0, 0], [s, c, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1.0]])
    return T


def test_nominal_ur5_has_the_published_structure():
    """As in ur_description's default_kinematics.yaml files: shoulder z = d1, upper_arm roll = alpha1,
    forearm x = a2, wrist_1 (x, z) = (a3, d4), wrist_2 y = -d5 with roll alpha4, wrist_3 y = d6 turned by
    alpha5 = -90 deg about x."""
    r = dv.load_robot("ur5")
    k = urc.kinematics(r.model(), r.table)
    block = {n: np.array([k[n][c] for c in ("x", "y", "z")]) for n in urc.UR_JOINTS}
    np.testing.assert_allclose(block["shoulder"], [0, 0, UR5["d1"]], atol=1e-15)
    np.testing.assert_allclose(block["upper_arm"], [0, 0, 0], atol=1e-15)
    np.testing.assert_allclose(block["forearm"], [UR5["a2"], 0, 0], atol=1e-15)
    np.testing.assert_allclose(block["wrist_1"], [UR5["a3"], 0, UR5["d4"]], atol=1e-15)
    np.testing.assert_allclose(block["wrist_2"], [0, -UR5["d5"], 0], atol=1e-15)
    np.testing.assert_allclose(block["wrist_3"], [0, UR5["d6"], 0], atol=1e-15)
    R = {n: rpy_matrix([k[n]["roll"], k[n]["pitch"], k[n]["yaw"]]) for n in urc.UR_JOINTS}
    Rx = lambda a: np.array([[1, 0, 0], [0, np.cos(a), -np.sin(a)], [0, np.sin(a), np.cos(a)]])  # noqa: E731
    for n, alpha in zip(urc.UR_JOINTS, [0, np.pi / 2, 0, 0, np.pi / 2, -np.pi / 2]):
        np.testing.assert_allclose(R[n], Rx(alpha), atol=1e-15)


def test_identified_ur5_file_reproduces_the_model(tmp_path):
    """A UR5 with 0.5 mm / 0.05 deg errors on every DH parameter (a6, alpha6 kept 0, as UR controllers
    do): base -> tool0 through the written file equals the model to 1e-12 m, and the frames stay on the
    body (no origin moves more than a few mm from the nominal link frame)."""
    r = dv.load_robot("ur5")
    t = r.table
    rng = np.random.default_rng(7)
    E = rng.normal(0, 1, t.params.shape) * np.where(np.array(t.angle_columns), np.radians(0.05), 0.5e-3)
    E[5, 2:] = 0
    m = dv.Table("dh", t.params + E, t.kinds, t.T_world_base, t.T_last_tool).to_model("ur5 identified")
    f = tmp_path / "my_robot_calibration.yaml"
    urc.save(f, m, t)
    origins = urc.loads(f.read_text())
    for q in rng.uniform(-3, 3, (50, 6)):
        np.testing.assert_allclose(chain_fk(origins, q), dv.fk(m, q), atol=1e-12)
    shift = np.linalg.norm(urc.link_frames(m, t)[:, :3, 3] - urc.link_frames(r.model(), t)[:, :3, 3], axis=1)
    assert shift.max() < 5e-3


def test_bad_input():
    r = dv.load_robot("ur5")
    with pytest.raises(dv.DenavitError, match="six-revolute UR arm"):
        urc.kinematics(r.model(), dv.load_robot("tiansui_mdh").table)
    tcp = np.eye(4)
    tcp[:3, 3] = [0.05, 0, 0.1]
    assert urc.kinematics(r.model().with_tool(tcp), r.table) == urc.kinematics(
        r.model(), r.table
    )  # the flange, not the TCP
    t = r.table
    P = t.params.copy()
    P[5, 2] = 0.01  # a6 = 10 mm: the flange leaves axis 6
    with pytest.raises(dv.DenavitError, match="10 mm off the axis"):
        urc.kinematics(dv.Table("dh", P, t.kinds, t.T_world_base, t.T_last_tool).to_model(), t)
    with pytest.raises(dv.DenavitError, match="expected a calibration of the nominal UR arm"):
        urc.kinematics(dv.load_model("kr5"), r.table)
    with pytest.raises(dv.DenavitError, match="kinematics.forearm: expected x, y, z, roll, pitch, yaw"):
        urc.loads(
            "kinematics:\n  shoulder: {x: 0, y: 0, z: 0, roll: 0, pitch: 0, yaw: 0}\n  upper_arm: {x: 0, y: 0, z: 0,"
            " roll: 0, pitch: 0, yaw: 0}\n"
        )
    with pytest.raises(dv.DenavitError, match="top-level 'kinematics'"):
        urc.loads("- 1\n- 2\n")
    # a file of megabytes is not a kinematics file (PyYAML's pure-Python loader had spent over 10 s on a fuzzed 3.4 MB
    # one)
    big = "kinematics:\n" + "  hash: calib_1\n" * 80_000
    with pytest.raises(dv.DenavitError, match=r"1\.\d+ MB: expected a UR kinematics-parameters file of a few kB"):
        urc.loads(big)
