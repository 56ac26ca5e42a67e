"""The vendors' configuration conventions (denavit.io.programs: abb, kuka, fanuc) against values and rules that
independent sources give for concrete arms and poses (each module's docstring and docs/compensation.md cite them).
The built-in KR5 tests of the same conventions are in tests/test_programs.py."""

import re
from pathlib import Path

import numpy as np
import pytest

import denavit as dv
from denavit.io.programs import abb, arm, fanuc, kuka
from denavit.io.robots import load

# ABB IRB 1660ID: the OPW parameters and axis values of CEAD-group/py-opw-kinematics, src/axis_configuration.rs at
# commit 2f70958369876562a7d75cfe9a2e0a49040ef903 (a1 150, a2 -110, c1 486.5, c2 700, c3 678, c4 135 mm; ABB's axis
# senses: J2, J3 and J5 positive tip the lower arm, the forearm and the flange forward and down, J3 0 the forearm
# square to the lower arm). Written here as POE axes: J2 150 mm in front of J1 at 486.5 mm, J3 700 mm above it, the
# J4 axis 110 mm above J3 (ABB's forearm offset), the wrist centre 678 mm along it, tool0 135 mm further, z forward.
IRB1660ID = """name = "irb1660id"
convention = "poe"
[units]
length = "mm"
angle = "deg"
[[joints]]
name = "J1"
w = [0, 0, 1]
v = [0, 0, 0]
[[joints]]
name = "J2"
w = [0, 1, 0]
v = [-486.5, 0, 150]
[[joints]]
name = "J3"
w = [0, 1, 0]
v = [-1186.5, 0, 150]
[[joints]]
name = "J4"
w = [1, 0, 0]
v = [0, 1296.5, 0]
[[joints]]
name = "J5"
w = [0, 1, 0]
v = [-1296.5, 0, 828]
[[joints]]
name = "J6"
w = [1, 0, 0]
v = [0, 1296.5, 0]
[tool]
xyz = [963, 0, 1296.5]
rpy = [0, 90, 0]
"""

# The test cases of that file (test_axis_configuration_5 and _4: axis values in deg, the cfx they expect).
IRB1660ID_CFX = [
    ([-103.1, -85.03, 19.06, -70.19, -35.87, 185.01], 5),
    ([-116.97, -85.69, 16.82, -63.5, -39.63, 192.76], 5),
    ([-128.14, -86.43, 13.04, -59.66, -40.66, 201.57], 5),
    ([-124.68, -61.16, -20.4, 56.41, -38.79, -24.56], 5),
    ([-127.36, -62.29, -16.83, 59.35, -35.14, -23.42], 5),
    ([-103.1, -85.03, 19.06, 109.81, 35.87, 5.01], 4),
    ([-116.97, -85.69, 16.82, 116.5, 39.63, 12.76], 4),
    ([-128.14, -86.43, 13.04, 120.34, 40.66, 21.57], 4),
    ([-124.68, -61.16, -20.4, -123.59, 38.79, 155.44], 4),
    ([-127.36, -62.29, -16.83, -120.65, 35.14, 156.58], 4),
]

# FANUC LR Mate 200iD: ROS-Industrial's fanuc_lrmate200id_support/urdf/lrmate200id_macro.xacro (ros-industrial/fanuc
# at commit 6c60a1d6aa0e868b7f4f84517487c1babd2e6d6c): joint_1 +z at 330 mm, joint_2 +y 50 mm forward, joint_3 -y
# 330 mm up, joint_4 -x 35 mm up, joint_5 -y 335 mm forward, joint_6 -x 80 mm forward (FANUC's senses: J5 = -90 deg
# turns the faceplate down with the forearm level). Its J2/J3 coupling is left out: J3 here is the URDF's joint_3
# (the forearm relative to the upper arm), which is the controller's J3 where J2 = 0.
LRMATE200ID = """name = "lrmate200id"
convention = "poe"
[units]
length = "mm"
angle = "deg"
[[joints]]
name = "J1"
w = [0, 0, 1]
v = [0, 0, 0]
[[joints]]
name = "J2"
w = [0, 1, 0]
v = [-330, 0, 50]
[[joints]]
name = "J3"
w = [0, -1, 0]
v = [660, 0, -50]
[[joints]]
name = "J4"
w = [-1, 0, 0]
v = [0, -695, 0]
[[joints]]
name = "J5"
w = [0, -1, 0]
v = [695, 0, -385]
[[joints]]
name = "J6"
w = [-1, 0, 0]
v = [0, -695, 0]
[tool]
xyz = [465, 0, 695]
rpy = [0, 90, 0]
"""


def robot_file(tmp_path: Path, text: str):
    path = tmp_path / (re.search(r'name = "(\w+)"', text).group(1) + ".toml")
    path.write_text(text)
    return load(path)


def test_abb_cfx_matches_an_independent_implementation_on_an_irb_1660id(tmp_path):
    """cfx of ten IRB 1660ID positions as py-opw-kinematics expects them: the wrist centre behind axis 1 (4) and in
    front of the lower arm, axis 5 negative (5) or positive (4). The elbow is below the line from axis 2 to the wrist
    centre in the world at all of them: the lower arm's side, not the world's, is what cfx 2 takes (ABB's table:
    "wrist center relative to lower arm"), and FANUC's U/D takes the same side (U, B here)."""
    m = robot_file(tmp_path, IRB1660ID).model()
    home = np.radians([0, 0, 0, 0, 30, 0])  # the wrist centre 828 mm in front of axis 1, the lower arm upright
    assert abb.configuration(m, home, {}) == (0, 0, 0, 0)
    for deg, cfx in IRB1660ID_CFX:
        q = np.radians(deg)
        c = abb.configuration(m, q, {})
        assert c[3] == cfx, (deg, c)
        assert c[:3] == tuple(int(np.floor(v / 90)) for v in (deg[0], deg[3], deg[5]))
        assert fanuc.configuration(m, q, {})[1:3] == ("U", "B")


def test_kuka_status_bit_1_changes_at_a3_zero_when_a3_and_a4_intersect(tmp_path):
    """SINUMERIK's STAT (KUKA's Status): "robots whose axes 3 and 4 intersect: = 0 A3 < 0 deg (elbow down), = 1
    A3 >= 0 deg (elbow up)". The KR5 without its 120 mm A3-A4 offset: phi is 0 and bit 1 changes there; on the KR5
    itself it changes at phi = atan(120 / 620), the wrist root point crossing the line through A2 and A3 (ISG: "in
    front of the straight line through axes A2 and A3": 2). ABB's cfx 2 and FANUC's D are the same side."""
    text = (Path(dv.__file__).parent / "models" / "kr5.toml").read_text()
    a3 = text.index('name = "A3"')
    flat = text[:a3] + text[a3:].replace("a = 120", "a = 0", 1)
    flat = flat.replace('name = "kr5"', 'name = "kr5_a3a4"', 1)
    for r, phi in ((robot_file(tmp_path, flat), 0.0), (load("kr5"), np.degrees(np.arctan2(120, 620)))):
        m = r.model()
        cache = {"signs": kuka.signs(r)}
        assert np.degrees(kuka._phi(m, cache)) == pytest.approx(phi, abs=1e-6)
        for a3_deg, up in ((phi + 0.5, True), (phi - 0.5, False), (90, True), (-10, False)):
            q = np.radians([0, -90, a3_deg, 0, 60, 0])
            s = kuka.configuration(m, q, cache)[0]
            assert bool(s & 2) == up, (r.name, a3_deg, s)
            assert bool(abb.configuration(m, q, {})[3] & 2) == (not up)
            assert fanuc.configuration(m, q, {})[1] == ("U" if up else "D")
            assert (arm(m, q).lower_arm > 0) == up


def test_fanuc_flip_follows_j5_in_fanucs_sense_on_an_lr_mate_200id(tmp_path):
    """RoboDK's FANUC post: "F means axis 5 >= 0, N means axis 5 < 0", N U T its normal configuration. On the LR Mate
    200iD (ROS-Industrial's axes) J5 = -90 deg with the forearm level points the faceplate down: N U T; the same pose
    with J4 and J6 turned half a turn (J5 = +90 deg) is F U T. Past the J1 axis (J1 180 deg away, the upper arm
    tilted back over it) B, and the lower arm's side (U) is kept."""
    r = robot_file(tmp_path, LRMATE200ID)
    m = r.model()
    down = np.radians([0, 0, 0, 0, -90, 0])
    T = dv.fk(m, down)
    np.testing.assert_allclose(T[:3, 2], [0, 0, -1], atol=1e-12)  # tool0's z (the faceplate's normal) down
    assert fanuc.configuration(m, down, {}) == ("N", "U", "T", 0, 0, 0)
    flipped = np.radians([0, 0, 0, -180, 90, -180])
    np.testing.assert_allclose(dv.fk(m, flipped), T, atol=1e-12)
    assert fanuc.configuration(m, flipped, {}) == ("F", "U", "T", 0, 0, 0)
    over = np.radians([0, -100, 0, 0, -45, 0])  # the upper arm tilted back past the J1 axis
    assert arm(m, over).front < 0
    assert fanuc.configuration(m, over, {})[:3] == ("N", "U", "B")
