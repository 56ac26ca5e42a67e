"""Forward kinematics and Jacobians through the Python API: finite differences in the world and tool frames,
batch == single, any array layout, and bad input."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import denavit as dv

BUILTINS = ["tiansui_mdh", "tiansui_edh", "kr5", "puma560", "ur5"]


def vee(S):
    return np.array([S[2, 1] - S[1, 2], S[0, 2] - S[2, 0], S[1, 0] - S[0, 1]]) / 2


def rot(axis, angle):
    a = np.asarray(axis, float) / np.linalg.norm(axis)
    K = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    return np.eye(3) + np.sin(angle) * K + (1 - np.cos(angle)) * K @ K


def pose(R, p):
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = R, p
    return T


@pytest.fixture(scope="module")
def mixed():
    """A skew 5-joint chain with two prismatic joints, a base and a tool."""
    placements = np.stack([
        pose(rot([1, 0, 0], 0.3), [0.0, 0.0, 0.2]),
        pose(rot([0, 1, 0.2], 1.1), [0.3, 0.05, 0.0]),
        pose(rot([1, 1, 0], -0.7), [0.0, 0.4, 0.1]),
        pose(rot([0, 0, 1], 0.4), [0.1, 0.0, 0.3]),
        pose(rot([1, -1, 1], 0.9), [0.0, 0.2, 0.05]),
    ])
    return dv.Model.from_placements(placements, ["revolute", "prismatic", "revolute", "prismatic", "revolute"],
                                    offsets=[0.1, 0.05, -0.2, 0.0, 0.3], T_world_base=pose(rot([0, 0, 1], 0.5), [0.1, 0.2, -0.3]),
                                    T_flange_tool=pose(rot([1, 0, 0], 0.4), [0.05, -0.02, 0.1]), name="mixed")


def models(mixed):
    return [dv.load_model(n) for n in BUILTINS] + [mixed]


def fd_jacobian(model, q, frame, h=1e-6):
    """Central differences: v = dp/dq, w = vee(dR/dq R^T) (world) or vee(R^T dR/dq) (tool)."""
    T = dv.fk(model, q)
    R = T[:3, :3]
    J = np.zeros((6, len(q)))
    for i in range(len(q)):
        dq = np.zeros(len(q))
        dq[i] = h
        Tp, Tm = dv.fk(model, q + dq), dv.fk(model, q - dq)
        dp = (Tp[:3, 3] - Tm[:3, 3]) / (2 * h)
        dR = (Tp[:3, :3] - Tm[:3, :3]) / (2 * h)
        if frame == "world":
            J[:3, i], J[3:, i] = dp, vee(dR @ R.T)
        else:
            J[:3, i], J[3:, i] = R.T @ dp, vee(R.T @ dR)
    return J


@pytest.mark.parametrize("frame", ["world", "tool"])
def test_jacobian_matches_finite_differences(mixed, frame, rng):
    for m in models(mixed):
        for q in rng.uniform(-np.pi, np.pi, (5, m.nq)):
            J = dv.jacobian(m, q, frame=frame)
            assert J.shape == (6, m.nq)
            np.testing.assert_allclose(J, fd_jacobian(m, q, frame), atol=1e-8, err_msg=f"{m.name} {frame}")


def test_base_and_tool_jacobians_are_the_world_jacobian_rotated(mixed, rng):
    for m in models(mixed):
        q = rng.uniform(-np.pi, np.pi, m.nq)
        R = dv.fk(m, q)[:3, :3]
        Jw, Jt = dv.jacobian(m, q), dv.jacobian(m, q, frame="tool")
        np.testing.assert_allclose(Jt[:3], R.T @ Jw[:3], atol=1e-14)
        np.testing.assert_allclose(Jt[3:], R.T @ Jw[3:], atol=1e-14)
        Rb = m.T_world_base[:3, :3]
        Jb = dv.jacobian(m, q, frame="base")
        np.testing.assert_allclose(Jb[:3], Rb.T @ Jw[:3], atol=1e-14)
        np.testing.assert_allclose(Jb[3:], Rb.T @ Jw[3:], atol=1e-14)
        np.testing.assert_allclose(dv.jacobian_batch(m, q[None], frame="base")[0], Jb, atol=1e-15)
    assert any(not np.allclose(m.T_world_base[:3, :3], np.eye(3)) for m in models(mixed))  # the base rotation is exercised


def test_batch_equals_single(mixed, rng):
    for m in models(mixed):
        qs = rng.uniform(-np.pi, np.pi, (2500, m.nq))  # more than one chunk per thread
        Ts = dv.fk_batch(m, qs)
        Jw, Jt = dv.jacobian_batch(m, qs), dv.jacobian_batch(m, qs, frame="tool")
        assert Ts.shape == (2500, 4, 4) and Jw.shape == (2500, 6, m.nq)
        for i in (0, 1, 1023, 1024, 2499):
            np.testing.assert_allclose(Ts[i], dv.fk(m, qs[i]), atol=1e-15)
            np.testing.assert_allclose(Jw[i], dv.jacobian(m, qs[i]), atol=1e-15)
            np.testing.assert_allclose(Jt[i], dv.jacobian(m, qs[i], frame="tool"), atol=1e-15)
        assert dv.fk_batch(m, np.zeros((0, m.nq))).shape == (0, 4, 4)


def test_joint_frames_end_at_the_tool(mixed, rng):
    for m in models(mixed):
        q = rng.uniform(-1, 1, m.nq)
        F = dv.joint_frames(m, q)
        assert F.shape == (m.nq, 4, 4)
        np.testing.assert_allclose(F[-1] @ m.T_last_tool, dv.fk(m, q), atol=1e-14)
        # the Jacobian's angular part of a revolute joint is its z axis in world
        J = dv.jacobian(m, q)
        for i, kind in enumerate(m.kinds):
            np.testing.assert_allclose(J[3:, i] if kind == "revolute" else J[:3, i], F[i, :3, 2], atol=1e-15)


def test_any_array_layout_and_lists(rng):
    m = dv.load_model("puma560")
    qs = rng.uniform(-np.pi, np.pi, (50, 6))
    ref = dv.fk_batch(m, qs)
    np.testing.assert_array_equal(dv.fk_batch(m, np.asfortranarray(qs)), ref)
    wide = np.zeros((50, 12))
    wide[:, ::2] = qs
    np.testing.assert_array_equal(dv.fk_batch(m, wide[:, ::2]), ref)  # strided view
    np.testing.assert_array_equal(dv.fk_batch(m, qs.tolist()), ref)
    np.testing.assert_array_equal(dv.fk_batch(m, qs.astype(np.float32).astype(np.float64)), dv.fk_batch(m, qs.astype(np.float32)))
    np.testing.assert_array_equal(dv.fk(m, list(qs[3])), ref[3])
    np.testing.assert_array_equal(dv.fk(m, np.asfortranarray(qs)[3]), ref[3])
    np.testing.assert_array_equal(dv.jacobian(m, np.zeros(6, dtype=int)), dv.jacobian(m, np.zeros(6)))


def test_angles_far_from_zero(rng):
    """The joint sine/cosine stays accurate for angles many turns away (and beyond 1e5 rad)."""
    m = dv.load_model("ur5")
    q = rng.uniform(-np.pi, np.pi, 6)
    for k in (1, 10, 1000, 100000):
        np.testing.assert_allclose(dv.fk(m, q + 2 * np.pi * k), dv.fk(m, q), atol=1e-9 * max(1, k / 1000))


@settings(max_examples=100, deadline=None)
@given(q=st.lists(st.floats(-20, 20), min_size=6, max_size=6), name=st.sampled_from(BUILTINS))
def test_fk_is_a_rigid_transform(q, name):
    T = dv.fk(dv.load_model(name), q)
    np.testing.assert_allclose(T[:3, :3].T @ T[:3, :3], np.eye(3), atol=1e-14)
    assert np.linalg.det(T[:3, :3]) == pytest.approx(1.0, abs=1e-14)
    np.testing.assert_array_equal(T[3], [0, 0, 0, 1])


def test_bad_input_raises_denavit_error_with_expected_and_got():
    m = dv.load_model("kr5")
    with pytest.raises(dv.DenavitError, match=r"wrong size of q: expected 6, got 5") as e:
        dv.fk(m, np.zeros(5))
    assert (e.value.kind, e.value.what, e.value.expected, e.value.got) == ("SizeMismatch", "q", 6, 5)
    with pytest.raises(dv.DenavitError, match=r"invalid q: expected a 1-D array, got shape \(2, 3\)"):
        dv.jacobian(m, np.zeros((2, 3)))
    with pytest.raises(dv.DenavitError, match=r"wrong size of q: expected 6, got 7"):
        dv.joint_frames(m, np.zeros(7))
    with pytest.raises(dv.DenavitError, match="q must be finite, got NaN at index 2") as e:
        dv.fk(m, [0, 0, np.nan, 0, 0, 0])
    assert (e.value.kind, e.value.what, e.value.index) == ("NonFinite", "q", 2) and np.isnan(e.value.value)
    with pytest.raises(dv.DenavitError, match="q must be finite, got inf"):
        dv.jacobian(m, [0, 0, 0, np.inf, 0, 0])
    with pytest.raises(dv.DenavitError, match=r"qs: expected an array of shape \(N, 6\), got shape \(10, 5\)") as e:
        dv.fk_batch(m, np.zeros((10, 5)))
    assert (e.value.kind, e.value.expected, e.value.got) == ("InvalidArgument", "an array of shape (N, 6)", "shape (10, 5)")
    with pytest.raises(dv.DenavitError, match=r"qs: expected an array of shape \(N, 6\), got shape \(6,\)"):
        dv.jacobian_batch(m, np.zeros(6))
    bad = np.zeros((4, 6))
    bad[2, 1] = np.nan
    with pytest.raises(dv.DenavitError, match="must be finite, got NaN"):
        dv.fk_batch(m, bad)
    with pytest.raises(dv.DenavitError, match="must be finite, got NaN"):
        dv.jacobian_batch(m, bad)
    with pytest.raises(dv.DenavitError, match="frame: expected 'world', 'base' or 'tool', got 'flange'"):
        dv.jacobian(m, np.zeros(6), frame="flange")
    with pytest.raises(dv.DenavitError, match="frame: expected 'world', 'base' or 'tool', got 'x'"):
        dv.jacobian_batch(m, np.zeros((2, 6)), frame="x")
    with pytest.raises(dv.DenavitError, match="invalid q: expected an array-like of floats, got list .*could not convert string to float"):
        dv.fk(m, ["a"] * 6)


@pytest.mark.parametrize("q, published", [
    # Corke, Robotics, Vision and Control (2nd ed. 2017) sec. 7.1.1, p560.fkine(qz) and p560.fkine(qn), printed to 4 decimals
    ([0, 0, 0, 0, 0, 0], [[1, 0, 0, 0.4521], [0, 1, 0, -0.1500], [0, 0, 1, 0.4318]]),
    ([0, np.pi / 4, np.pi, 0, np.pi / 4, 0], [[0, 0, 1, 0.5963], [0, 1, 0, -0.1501], [-1, 0, 0, -0.0144]]),
])
def test_puma560_tool_pose_matches_corkes_published_values(q, published):
    """The Puma 560 of Corke's toolbox (our built-in's source) at its named poses, against the printed values."""
    np.testing.assert_allclose(dv.fk(dv.load_model("puma560"), q)[:3], published, atol=0.5e-4 + 1e-12)  # half the last printed digit


def test_flange_is_dh_frame_n_and_tools_are_given_in_it(rng):
    """One flange (docs/conventions.md "Frames"): for the DH UR5 it is DH frame 6, 82.3 mm (d6) beyond joint
    frame 6; ``fk`` without a tool reports it and a tool point given in the flange frame lands at flange @ p."""
    robot = dv.load_robot("ur5")
    m = robot.model()
    np.testing.assert_array_equal(m.T_last_flange[:3, 3], [0, 0, 0.0823])
    np.testing.assert_array_equal(m.T_flange_tool, np.eye(4))
    np.testing.assert_array_equal(m.T_last_tool, m.T_last_flange @ m.T_flange_tool)
    p = np.array([0.05, 0.03, 0.1])
    tool = np.eye(4)
    tool[:3, 3] = p
    tooled = m.with_tool(tool)
    np.testing.assert_array_equal(tooled.T_last_flange, m.T_last_flange)
    np.testing.assert_array_equal(tooled.T_flange_tool, tool)
    for q in rng.uniform(-np.pi, np.pi, (20, 6)):
        flange = robot.table.frames(q)[-1]
        np.testing.assert_allclose(dv.fk(tooled.with_tool(np.eye(4)), q), flange, atol=1e-15)
        np.testing.assert_allclose(dv.fk(tooled, q)[:3, 3], flange[:3, :3] @ p + flange[:3, 3], atol=1e-15)


def test_from_placements_flange_and_tool():
    """``Model.from_placements`` takes the flange in the last joint frame and the tool in the flange."""
    flange, tool = np.eye(4), np.eye(4)
    flange[2, 3], tool[0, 3] = 0.1, 0.02
    m = dv.Model.from_placements(np.eye(4)[None], ["revolute"], T_last_flange=flange, T_flange_tool=tool)
    np.testing.assert_array_equal(m.T_last_tool, flange @ tool)
    np.testing.assert_array_equal(dv.fk(m, [0.0])[:3, 3], [0.02, 0, 0.1])
    np.testing.assert_array_equal(dv.fk(m.with_tool(np.eye(4)), [0.0])[:3, 3], [0, 0, 0.1])


def test_link_frames_place_the_convention_frames_in_the_joint_frames(rng):
    """``Table.link_frames()`` (n, 4, 4): convention frame i = joint frame i @ link_frames[i]."""
    for name in BUILTINS:
        robot = dv.load_robot(name)
        m, t = robot.model(), robot.table
        L = t.link_frames()
        assert L.shape == (m.nq, 4, 4)
        q = rng.uniform(-np.pi, np.pi, m.nq)
        np.testing.assert_allclose(dv.joint_frames(m, q) @ L, t.frames(q)[1:], atol=1e-14)
        if t.convention != "dh":
            np.testing.assert_array_equal(L, np.tile(np.eye(4), (m.nq, 1, 1)))


@pytest.mark.parametrize("convention, k", [("dh", 4), ("mdh", 4), ("edh", 5), ("poe", 6)])
def test_model_without_joints(convention, k):
    """A 0-joint model gives empty results, never a PanicException (to_table used to panic)."""
    tool = np.eye(4)
    tool[:3, 3] = [0.0, 0.0, 0.1]
    m = dv.Table(convention, np.zeros((0, k)), T_last_tool=tool).to_model()
    np.testing.assert_allclose(dv.fk(m, []), tool, atol=1e-15)
    assert dv.jacobian(m, []).shape == (6, 0) and dv.fk_batch(m, np.zeros((3, 0))).shape == (3, 4, 4)
    for to in ("dh", "mdh", "edh", "poe"):
        e = dv.to_table(m, to)
        assert e.table.params.shape == (0, len(e.table.columns))
        np.testing.assert_allclose(dv.fk(e.table.to_model(), []), dv.fk(m, []), atol=1e-15)
    assert dv.ik(m, dv.fk(m, []), []).success
