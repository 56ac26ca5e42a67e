"""Forward kinematics and Jacobians through the Python API: finite differences in the world and tool frames,
batch == single, any array layout, and bad input."""

import os
import re
from pathlib import Path

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
    placements = np.stack(
        [
            pose(rot([1, 0, 0], 0.3), [0.0, 0.0, 0.2]),
            pose(rot([0, 1, 0.2], 1.1), [0.3, 0.05, 0.0]),
            pose(rot([1, 1, 0], -0.7), [0.0, 0.4, 0.1]),
            pose(rot([0, 0, 1], 0.4), [0.1, 0.0, 0.3]),
            pose(rot([1, -1, 1], 0.9), [0.0, 0.2, 0.05]),
        ]
    )
    return dv.Model.from_placements(
        placements,
        ["revolute", "prismatic", "revolute", "prismatic", "revolute"],
        offsets=[0.1, 0.05, -0.2, 0.0, 0.3],
        T_world_base=pose(rot([0, 0, 1], 0.5), [0.1, 0.2, -0.3]),
        T_flange_tool=pose(rot([1, 0, 0], 0.4), [0.05, -0.02, 0.1]),
        name="mixed",
    )


def models(mixed):
    return [dv.load_model(n) for n in BUILTINS] + [mixed]


def fd_jacobian(model, q, frame, joint=None, h=1e-6):
    """Central differences of the tool pose (or of joint frame `joint`, 1-based): v = dp/dq and w = vee(dR/dq R^T)
    in world axes ("local_world_aligned"), both rotated into the frame's axes ("local"), or the spatial velocity
    at the world origin v - w x p ("world"; pinocchio's meanings)."""

    def pose(x):
        return dv.fk(model, x) if joint is None else dv.joint_frames(model, x)[joint - 1]

    T = pose(q)
    R, p = T[:3, :3], T[:3, 3]
    J = np.zeros((6, len(q)))
    for i in range(len(q)):
        dq = np.zeros(len(q))
        dq[i] = h
        Tp, Tm = pose(q + dq), pose(q - dq)
        dp = (Tp[:3, 3] - Tm[:3, 3]) / (2 * h)
        w = vee((Tp[:3, :3] - Tm[:3, :3]) / (2 * h) @ R.T)
        J[:, i] = {
            "local_world_aligned": np.r_[dp, w],
            "local": np.r_[R.T @ dp, R.T @ w],
            "world": np.r_[dp - np.cross(w, p), w],
        }[frame]
    return J


FRAMES = ["local", "local_world_aligned", "world"]


@pytest.mark.parametrize("frame", FRAMES)
def test_jacobian_matches_finite_differences(mixed, frame, rng):
    for m in models(mixed):
        for q in rng.uniform(-np.pi, np.pi, (5, m.nq)):
            J = dv.jacobian(m, q, frame=frame)
            assert J.shape == (6, m.nq)
            np.testing.assert_allclose(J, fd_jacobian(m, q, frame), atol=1e-8, err_msg=f"{m.name} {frame}")


@pytest.mark.parametrize("frame", FRAMES)
def test_joint_frame_jacobians_match_finite_differences(mixed, frame, rng):
    """Jacobian of joint frame i (1-based, or by name): the frame's own motion, columns after i zero."""
    for m in models(mixed):
        q = rng.uniform(-np.pi, np.pi, m.nq)
        for i in range(1, m.nq + 1):
            J = dv.jacobian(m, q, frame=frame, joint=i)
            np.testing.assert_allclose(
                J, fd_jacobian(m, q, frame, joint=i), atol=1e-8, err_msg=f"{m.name} {frame} joint {i}"
            )
            assert not J[:, i:].any()
            np.testing.assert_array_equal(dv.jacobian(m, q, frame=frame, joint=m.names[i - 1]), J)
            np.testing.assert_array_equal(dv.jacobian_batch(m, q[None], frame, i)[0], J)


@pytest.mark.parametrize("urdf", ["ur_style.urdf", "panda_style.urdf", "kr5.urdf"])
def test_jacobians_match_pinocchio(urdf, rng):
    """pinocchio's getFrameJacobian of the URDF's tip frame in LOCAL, LOCAL_WORLD_ALIGNED and WORLD, and its
    getJointJacobian (WORLD: the body's spatial velocity, whatever the joint frame's axes) of every joint."""
    pin = pytest.importorskip("pinocchio")
    path = str(Path(__file__).parent / "data" / "urdf" / urdf)
    m, pm = dv.load_model(path), pin.buildModelFromUrdf(path)
    pd = pm.createData()
    tip = pm.getFrameId(pm.frames[len(pm.frames) - 1].name)
    for q in rng.uniform(-1, 1, (5, m.nq)):
        qp = pin.integrate(pm, pin.neutral(pm), q)  # continuous joints are (cos, sin) in pinocchio
        pin.framesForwardKinematics(pm, pd, qp)
        pin.computeJointJacobians(pm, pd, qp)
        np.testing.assert_allclose(dv.fk(m, q), pd.oMf[tip].homogeneous, rtol=0, atol=1e-14)
        for frame, ref in [
            ("local", pin.LOCAL),
            ("local_world_aligned", pin.LOCAL_WORLD_ALIGNED),
            ("world", pin.WORLD),
        ]:
            np.testing.assert_allclose(
                dv.jacobian(m, q, frame), pin.getFrameJacobian(pm, pd, tip, ref), rtol=0, atol=1e-14
            )
        for i in range(1, m.nq + 1):
            np.testing.assert_allclose(
                dv.jacobian(m, q, "world", i), pin.getJointJacobian(pm, pd, i, pin.WORLD), rtol=0, atol=1e-14
            )


def test_jacobian_frame_and_joint_errors():
    m = dv.load_model("kr5")
    with pytest.raises(
        dv.DenavitError,
        match=r"invalid joint: expected None \(the tool\), a joint number 1..6 or a joint name \(.*\), got 7$",
    ):
        dv.jacobian(m, np.zeros(6), joint=7)
    with pytest.raises(dv.DenavitError, match="got 0$"):
        dv.jacobian_batch(m, np.zeros((2, 6)), joint=0)
    with pytest.raises(dv.DenavitError, match="got 'elbow'$"):
        dv.jacobian(m, np.zeros(6), joint="elbow")


def test_local_and_base_jacobians_are_the_world_aligned_one_rotated(mixed, rng):
    for m in models(mixed):
        q = rng.uniform(-np.pi, np.pi, m.nq)
        R = dv.fk(m, q)[:3, :3]
        Jw, Jt = dv.jacobian(m, q), dv.jacobian(m, q, frame="local")
        np.testing.assert_array_equal(Jw, dv.jacobian(m, q, frame="local_world_aligned"))  # the default
        np.testing.assert_allclose(Jt[:3], R.T @ Jw[:3], atol=1e-14)
        np.testing.assert_allclose(Jt[3:], R.T @ Jw[3:], atol=1e-14)
        Rb = m.T_world_base[:3, :3]
        Jb = dv.jacobian(m, q, frame="base")
        np.testing.assert_allclose(Jb[:3], Rb.T @ Jw[:3], atol=1e-14)
        np.testing.assert_allclose(Jb[3:], Rb.T @ Jw[3:], atol=1e-14)
        np.testing.assert_allclose(dv.jacobian_batch(m, q[None], frame="base")[0], Jb, atol=1e-15)
    assert any(
        not np.allclose(m.T_world_base[:3, :3], np.eye(3)) for m in models(mixed)
    )  # the base rotation is exercised


def test_batch_equals_single(mixed, rng):
    for m in models(mixed):
        qs = rng.uniform(-np.pi, np.pi, (2500, m.nq))  # more than one chunk per thread
        Ts = dv.fk_batch(m, qs)
        Jw, Jt = dv.jacobian_batch(m, qs), dv.jacobian_batch(m, qs, frame="local")
        assert Ts.shape == (2500, 4, 4) and Jw.shape == (2500, 6, m.nq)
        for i in (0, 1, 1023, 1024, 2499):
            np.testing.assert_allclose(Ts[i], dv.fk(m, qs[i]), atol=1e-15)
            np.testing.assert_allclose(Jw[i], dv.jacobian(m, qs[i]), atol=1e-15)
            np.testing.assert_allclose(Jt[i], dv.jacobian(m, qs[i], frame="local"), atol=1e-15)
        assert dv.fk_batch(m, np.zeros((0, m.nq))).shape == (0, 4, 4)


def relative(a, b):
    """Largest difference of each matrix relative to its largest entry."""
    a, b = np.asarray(a), np.asarray(b)
    scale = np.abs(b).reshape(len(b), -1).max(axis=1)
    return (np.abs(a - b).reshape(len(b), -1).max(axis=1) / scale).max()


def test_batch_kernels_equal_single_calls_to_1e_15_relative(mixed, rng):
    """The lane kernels (fused multiply-adds, structure of arrays) against the single-call path, every row of a
    batch whose length is not a multiple of the lanes, every frame, a joint frame; and the same bits whatever
    the number of threads."""
    for m in models(mixed):
        qs = rng.uniform(-np.pi, np.pi, (1029, m.nq))
        assert relative(dv.fk_batch(m, qs), [dv.fk(m, q) for q in qs]) <= 1e-15
        for frame in [*FRAMES, "base"]:
            for joint in (None, 2):
                J = dv.jacobian_batch(m, qs, frame, joint)
                assert relative(J, [dv.jacobian(m, q, frame, joint) for q in qs]) <= 1e-15, (m.name, frame, joint)
        one = dv.fk_batch(m, qs, threads=1)
        np.testing.assert_array_equal(one, dv.fk_batch(m, qs, threads=2))
        np.testing.assert_array_equal(one, dv.fk_batch(m, qs, threads=3))
        np.testing.assert_array_equal(dv.jacobian_batch(m, qs, threads=1), dv.jacobian_batch(m, qs, threads=2))


@pytest.mark.parametrize("threads", [1, 2])
def test_batch_names_the_first_non_finite_value(threads, rng):
    """The kernels check each chunk as they read it (no separate pass): the error still names the first bad
    value of the whole batch, whichever chunk or thread meets one first."""
    m = dv.load_model("kr5")
    qs = rng.uniform(-np.pi, np.pi, (5000, 6))
    qs[4500, 1], qs[1500, 4], qs[3000, 0] = np.nan, np.inf, -np.inf
    for call in (lambda: dv.fk_batch(m, qs, threads=threads), lambda: dv.jacobian_batch(m, qs, threads=threads)):
        with pytest.raises(dv.DenavitError) as e:
            call()
        assert (e.value.kind, e.value.what, e.value.index, e.value.value) == ("NonFinite", "q (row 1500)", 4, np.inf)
        assert str(e.value) == "q (row 1500) must be finite, got inf at index 4"
    qs[1500, 4] = 1e6  # finite but beyond the fast sine's range: the exact fallback, same value as one call
    np.testing.assert_array_equal(dv.fk_batch(m, qs[1490:1510]), [dv.fk(m, q) for q in qs[1490:1510]])


def test_out_is_filled_and_returned(rng):
    m = dv.load_model("kr5")
    qs = rng.uniform(-np.pi, np.pi, (300, 6))
    out = np.full((300, 4, 4), np.nan)
    assert dv.fk_batch(m, qs, out=out) is out
    np.testing.assert_array_equal(out, dv.fk_batch(m, qs))
    J = np.full((300, 6, 6), np.nan)
    assert dv.jacobian_batch(m, qs, "local", 3, out=J) is J  # columns after joint 3 are written (zeros) too
    np.testing.assert_array_equal(J, dv.jacobian_batch(m, qs, "local", 3))


@pytest.mark.parametrize(
    "bad, got",
    [
        (np.zeros((300, 4, 3)), "shape (300, 4, 3)"),
        (np.zeros((300, 16)), "shape (300, 16)"),
        (np.zeros((300, 4, 4), dtype=">f8"), "dtype >f8, shape (300, 4, 4)"),
        (np.zeros((300, 4, 4), dtype=np.float32), "dtype float32, shape (300, 4, 4)"),
        (np.zeros((300, 4, 4), dtype=complex), "dtype complex128, shape (300, 4, 4)"),
        (np.zeros((4, 4, 300)).T, "an array that is not C-contiguous"),
        ([[0.0]], "list"),
    ],
)
def test_out_is_checked(bad, got, rng):
    m = dv.load_model("kr5")
    with pytest.raises(
        dv.DenavitError,
        match=r"^invalid out: expected a C-contiguous, writeable float64 numpy array of shape \(300, 4, 4\), got "
        + re.escape(got)
        + "$",
    ):
        dv.fk_batch(m, np.zeros((300, 6)), out=bad)


def test_out_read_only_or_an_input_is_refused():
    m = dv.load_model("kr5")
    ro = np.zeros((3, 4, 4))
    ro.flags.writeable = False
    with pytest.raises(dv.DenavitError, match="got a read-only array$"):
        dv.fk_batch(m, np.zeros((3, 6)), out=ro)
    qs = np.zeros((3, 6))
    with pytest.raises(dv.DenavitError, match=r"^invalid out: expected an array not in use elsewhere during the call"):
        dv.rnea_batch(m, qs, qs, qs, out=qs)


def test_threads_argument():
    """threads: 1 .. 4 per core; a count beyond is refused at once (it had started a pool of that many threads:
    10**12 never returned)."""
    m = dv.load_model("kr5")
    most = 4 * os.cpu_count()
    for bad in (0, -1, most + 1, 10**12, 2**64, -(2**63) - 1):  # the last two beyond 64 bits
        with pytest.raises(
            dv.DenavitError,
            match=(
                rf"^invalid threads: expected None \(RAYON_NUM_THREADS, else every core\) or a count 1\.\.={most} \(4"
                rf" per core\), got {bad}$"
            ),
        ):
            dv.fk_batch(m, np.zeros((2, 6)), threads=bad)
    assert dv.fk_batch(m, np.zeros((2, 6)), threads=most).shape == (2, 4, 4)
    with pytest.raises(TypeError):
        dv.fk_batch(m, np.zeros((2, 6)), threads="2")


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
    np.testing.assert_array_equal(
        dv.fk_batch(m, qs.astype(np.float32).astype(np.float64)), dv.fk_batch(m, qs.astype(np.float32))
    )
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
    assert (e.value.kind, e.value.expected, e.value.got) == (
        "InvalidArgument",
        "an array of shape (N, 6)",
        "shape (10, 5)",
    )
    with pytest.raises(dv.DenavitError, match=r"qs: expected an array of shape \(N, 6\), got shape \(6,\)"):
        dv.jacobian_batch(m, np.zeros(6))
    bad = np.zeros((4, 6))
    bad[2, 1] = np.nan
    # a batch of up to 16 rows goes through the single path row by row: the same row-and-index message
    with pytest.raises(dv.DenavitError, match=r"^q \(row 2\) must be finite, got NaN at index 1$"):
        dv.fk_batch(m, bad)
    with pytest.raises(dv.DenavitError, match=r"^q \(row 2\) must be finite, got NaN at index 1$"):
        dv.jacobian_batch(m, bad)
    with pytest.raises(
        dv.DenavitError, match="frame: expected 'local', 'local_world_aligned', 'world' or 'base', got 'flange'"
    ):
        dv.jacobian(m, np.zeros(6), frame="flange")
    with pytest.raises(
        dv.DenavitError, match="frame: expected 'local', 'local_world_aligned', 'world' or 'base', got 'x'"
    ):
        dv.jacobian_batch(m, np.zeros((2, 6)), frame="x")
    with pytest.raises(
        dv.DenavitError,
        match="invalid q: expected an array-like of floats, got list .*could not convert string to float",
    ):
        dv.fk(m, ["a"] * 6)


@pytest.mark.parametrize(
    "q, published",
    [
        # Corke, Robotics, Vision and Control (2nd ed. 2017) sec. 7.1.1, p560.fkine(qz) and p560.fkine(qn), printed to 4
        # decimals
        ([0, 0, 0, 0, 0, 0], [[1, 0, 0, 0.4521], [0, 1, 0, -0.1500], [0, 0, 1, 0.4318]]),
        ([0, np.pi / 4, np.pi, 0, np.pi / 4, 0], [[0, 0, 1, 0.5963], [0, 1, 0, -0.1501], [-1, 0, 0, -0.0144]]),
    ],
)
def test_puma560_tool_pose_matches_corkes_published_values(q, published):
    """The Puma 560 of Corke's toolbox (our built-in's source) at its named poses, against the printed values."""
    np.testing.assert_allclose(
        dv.fk(dv.load_model("puma560"), q)[:3], published, atol=0.5e-4 + 1e-12
    )  # half the last printed digit


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
