"""Dynamics through the Python API: algorithms against each other, MD-H vs ED-H frames (Guo et al. sec. IV.B),
batches, a cross-check against pinocchio, and bad input."""

import pickle
from pathlib import Path

import numpy as np
import pytest

import denavit as dv
from cli import env as cli_env
from denavit import _core
from denavit.io import robotfile

G = np.array([0.0, 0.0, -9.81])

# Illustrative inertials of TianSui-One (not published: plausible values for a cobot of its size), each link in
# its ED-H joint frame; the same set as crates/denavit-core/tests/dynamics.rs and the tiansui_edh robot file.
TIANSUI_EDH_MASSES = np.array([3.70, 8.39, 2.28, 1.22, 1.22, 0.19])
TIANSUI_EDH_COMS = np.array(
    [
        [0.0, -0.010, -0.020],
        [-0.203, 0.0, 0.120],
        [-0.193, 0.0, 0.012],
        [0.0, 0.010, 0.003],
        [0.0, -0.010, 0.003],
        [0.0, 0.0, -0.020],
    ]
)
TIANSUI_EDH_INERTIAS = np.array(
    [
        [[0.0103, 0, 0], [0, 0.0103, 0], [0, 0, 0.0067]],
        [[0.0150, 0, 0.0015], [0, 0.1340, 0], [0.0015, 0, 0.1330]],
        [[0.0041, 0, -0.0005], [0, 0.0312, 0], [-0.0005, 0, 0.0305]],
        [[0.0022, 0.0001, 0], [0.0001, 0.0021, 0.0002], [0, 0.0002, 0.0020]],
        [[0.0022, -0.0001, 0], [-0.0001, 0.0021, -0.0002], [0, -0.0002, 0.0020]],
        [[0.00010, 0, 0], [0, 0.00010, 0], [0, 0, 0.00013]],
    ]
)


def random_inertias(n, rng):
    """Solid ellipsoids of random mass and semi-axes, rotated and displaced: physically valid links."""
    masses = rng.uniform(0.2, 5.0, n)
    coms = rng.uniform(-0.3, 0.3, (n, 3))
    out = np.empty((n, 3, 3))
    for i in range(n):
        a, b, c = rng.uniform(0.02, 0.3, 3)
        d = masses[i] / 5 * np.diag([b * b + c * c, a * a + c * c, a * a + b * b])
        R, _ = np.linalg.qr(rng.normal(size=(3, 3)))
        out[i] = R @ d @ R.T
    return masses, coms, out


def with_random_inertias(model, rng):
    return model.with_inertias(*random_inertias(model.nq, rng))


def tiansui_edh():
    return dv.load_model("tiansui_edh").with_inertias(TIANSUI_EDH_MASSES, TIANSUI_EDH_COMS, TIANSUI_EDH_INERTIAS)


def states(n, count, rng):
    return rng.uniform(-3, 3, (count, n)), rng.uniform(-2, 2, (count, n)), rng.uniform(-3, 3, (count, n))


@pytest.fixture(params=["kr5", "puma560", "tiansui_edh", "tiansui_mdh", "ur5"])
def robot(request, rng):
    return with_random_inertias(dv.load_model(request.param), rng)


def test_rnea_zero_acceleration_is_coriolis_plus_gravity(robot, rng):
    for q, qd, _ in zip(*states(robot.nq, 20, rng)):
        tau = _core.rnea(robot, q, qd, np.zeros(robot.nq))
        c = _core.coriolis_matrix(robot, q, qd)
        g = _core.gravity_torques(robot, q)
        np.testing.assert_allclose(tau, c @ qd + g, rtol=0, atol=1e-12 * (1 + np.abs(tau).max()))
        np.testing.assert_allclose(tau, _core.bias_forces(robot, q, qd), rtol=0, atol=1e-12 * (1 + np.abs(tau).max()))


def test_mass_matrix_columns_are_unit_acceleration_torques_and_spd(robot, rng):
    n = robot.nq
    for q in states(n, 10, rng)[0]:
        M = _core.mass_matrix(robot, q)
        cols = np.column_stack([_core.rnea(robot, q, np.zeros(n), e, gravity=np.zeros(3)) for e in np.eye(n)])
        np.testing.assert_allclose(M, cols, rtol=0, atol=1e-12 * np.abs(M).max())
        assert np.array_equal(M, M.T)
        assert np.linalg.eigvalsh(M).min() > 0
        np.linalg.cholesky(M)


def test_forward_dynamics_inverts_inverse_dynamics(robot, rng):
    f = np.array([3.0, -2.0, 5.0, 0.4, -0.3, 0.2])
    for q, qd, qdd in zip(*states(robot.nq, 10, rng)):
        tau = _core.rnea(robot, q, qd, qdd, f_ext=f)
        for method in ("aba", "crba"):
            np.testing.assert_allclose(
                _core.forward_dynamics(robot, q, qd, tau, f_ext=f, method=method), qdd, rtol=0, atol=1e-10
            )


def test_energy_rate_is_joint_power_and_mdot_minus_2c_is_skew(robot, rng):
    n, h = robot.nq, 1e-5
    for q, qd, qdd in zip(*states(n, 5, rng)):

        def energy(t, q=q, qd=qd, qdd=qdd):
            qt, qdt = q + qd * t + 0.5 * qdd * t * t, qd + qdd * t
            return _core.kinetic_energy(robot, qt, qdt) + _core.potential_energy(robot, qt)

        power = qd @ _core.rnea(robot, q, qd, qdd)
        assert (energy(h) - energy(-h)) / (2 * h) == pytest.approx(power, abs=1e-5 * (1 + abs(power)))
        Mdot = (_core.mass_matrix(robot, q + h * qd) - _core.mass_matrix(robot, q - h * qd)) / (2 * h)
        N = Mdot - 2 * _core.coriolis_matrix(robot, q, qd)
        assert np.abs(N + N.T).max() < 1e-6 * (1 + np.abs(Mdot).max())


def test_tool_wrench_costs_jacobian_transpose(robot, rng):
    q, qd, qdd = (s[0] for s in states(robot.nq, 1, rng))
    f = np.array([1.0, -4.0, 2.5, 0.3, 0.7, -0.2])
    J = dv.jacobian(robot, q, frame="local")
    d = _core.rnea(robot, q, qd, qdd, f_ext=f) - _core.rnea(robot, q, qd, qdd)
    np.testing.assert_allclose(d, -J.T @ f, rtol=0, atol=1e-12 * (1 + np.abs(d).max()))


def test_batches_equal_single_calls(robot, rng):
    n, N = robot.nq, 301
    qs, qds, qdds = states(n, N, rng)
    fs = rng.normal(size=(N, 6))
    tau = _core.rnea_batch(robot, qs, qds, qdds, f_ext=fs)
    assert tau.shape == (N, n)
    one_f = _core.rnea_batch(robot, qs, qds, qdds, f_ext=fs[0])
    Ms, Cs = _core.mass_matrix_batch(robot, qs), _core.coriolis_matrix_batch(robot, qs, qds)
    bias, grav = _core.bias_forces_batch(robot, qs, qds), _core.gravity_torques_batch(robot, qs)
    qdd_back = _core.forward_dynamics_batch(robot, qs, qds, tau, f_ext=fs)
    np.testing.assert_allclose(qdd_back, qdds, rtol=0, atol=1e-10)
    for k in range(0, N, 37):
        atol = 1e-12 * (1 + np.abs(tau[k]).max())
        np.testing.assert_allclose(tau[k], _core.rnea(robot, qs[k], qds[k], qdds[k], f_ext=fs[k]), rtol=0, atol=atol)
        np.testing.assert_allclose(one_f[k], _core.rnea(robot, qs[k], qds[k], qdds[k], f_ext=fs[0]), rtol=0, atol=atol)
        np.testing.assert_array_equal(Ms[k], _core.mass_matrix(robot, qs[k]))
        np.testing.assert_array_equal(Cs[k], _core.coriolis_matrix(robot, qs[k], qds[k]))
        np.testing.assert_allclose(bias[k], _core.bias_forces(robot, qs[k], qds[k]), rtol=0, atol=atol)
        np.testing.assert_allclose(grav[k], _core.gravity_torques(robot, qs[k]), rtol=0, atol=atol)


def test_inputs_any_layout_and_dtype(rng):
    m = tiansui_edh()
    q, qd, qdd = (s[0] for s in states(6, 1, rng))
    qdd = qdd.astype(np.float32)  # another dtype is converted
    ref = _core.rnea(m, q, qd, qdd.astype(np.float64))
    np.testing.assert_array_equal(_core.rnea(m, list(q), tuple(qd), qdd), ref)
    big = np.zeros(12)
    big[::2] = q
    np.testing.assert_array_equal(_core.rnea(m, big[::2], qd, qdd), ref)  # strided view
    qs, qds, qdds = states(6, 50, rng)
    ref = _core.rnea_batch(m, qs, qds, qdds)
    np.testing.assert_array_equal(_core.rnea_batch(m, np.asfortranarray(qs), qds.tolist(), qdds), ref)
    assert _core.rnea_batch(m, np.zeros((0, 6)), np.zeros((0, 6)), np.zeros((0, 6))).shape == (0, 6)


def test_gravity_is_given_in_world(rng):
    """Moving the base and turning gravity with it changes no torque."""
    m = tiansui_edh()
    q, qd, qdd = (s[0] for s in states(6, 1, rng))
    c, s = np.cos(0.7), np.sin(0.7)
    T = np.array([[1, 0, 0, 0.3], [0, c, -s, -1.0], [0, s, c, 2.0], [0, 0, 0, 1.0]])
    moved = m.with_base(T @ m.T_world_base)
    np.testing.assert_allclose(
        _core.rnea(moved, q, qd, qdd, gravity=T[:3, :3] @ G), _core.rnea(m, q, qd, qdd), rtol=0, atol=1e-12
    )


def test_tiansui_mdh_and_edh_frames_give_the_same_torques(rng):
    """Guo et al. sec. IV.B: one physical robot, its inertials given once in the ED-H (on-body) frames."""
    edh = tiansui_edh()
    mdh = _core.transfer_inertias(edh, dv.load_model("tiansui_mdh"))
    # the inertials differ in the frames of joints 4 and 5 only (those frames are 0.128 m apart)
    moved = np.linalg.norm(edh.inertias["coms"] - mdh.inertias["coms"], axis=1)
    assert moved[[0, 1, 2, 5]].max() < 1e-15 and moved[[3, 4]].min() > 0.1
    f = np.array([2.0, -1.0, 10.0, 0.2, -0.4, 0.1])
    qs, qds, qdds = states(6, 500, rng)
    a = _core.rnea_batch(edh, qs, qds, qdds, f_ext=f)
    b = _core.rnea_batch(mdh, qs, qds, qdds, f_ext=f)
    assert np.abs(a - b).max() < 1e-10
    assert np.abs(_core.mass_matrix_batch(edh, qs) - _core.mass_matrix_batch(mdh, qs)).max() < 1e-10
    # the same through inertials given in world at home (as from CAD)
    F = dv.joint_frames(edh, np.zeros(6))
    coms_w = np.einsum("nij,nj->ni", F[:, :3, :3], edh.inertias["coms"]) + F[:, :3, 3]
    I_w = F[:, :3, :3] @ edh.inertias["inertias"] @ F[:, :3, :3].transpose(0, 2, 1)
    mdh2 = dv.load_model("tiansui_mdh").with_inertias(TIANSUI_EDH_MASSES, coms_w, I_w, frame="world")
    assert np.abs(_core.rnea_batch(mdh2, qs, qds, qdds, f_ext=f) - a).max() < 1e-10


def test_with_inertias_round_trip_and_about_origin(rng):
    m = dv.load_model("ur5")
    masses, coms, I = random_inertias(6, rng)
    a = m.with_inertias(masses, coms, I)
    b = m.with_inertias(**a.inertias)
    f = m.with_inertias(
        masses, np.asfortranarray(coms), np.asfortranarray(I.transpose(0, 2, 1)).transpose(0, 2, 1).copy(order="F")
    )
    for k in ("masses", "coms", "inertias"):  # any memory layout is read in its logical order
        np.testing.assert_array_equal(f.inertias[k], a.inertias[k])
    for k in ("masses", "coms", "inertias"):
        np.testing.assert_allclose(a.inertias[k], b.inertias[k], rtol=0, atol=1e-15)
    # about the frame origin: add the parallel-axis term m (|c|^2 1 - c c^T)
    I_o = I + masses[:, None, None] * (
        np.einsum("ni,ni->n", coms, coms)[:, None, None] * np.eye(3) - np.einsum("ni,nj->nij", coms, coms)
    )
    c = m.with_inertias(masses, coms, I_o, about="origin")
    np.testing.assert_allclose(c.inertias["inertias"], I, rtol=0, atol=1e-14)
    assert m.inertias["masses"].tolist() == [
        3.7,
        8.393,
        2.33,
        1.219,
        1.219,
        0.1879,
    ]  # the original is unchanged: UR's published link masses
    assert a.with_tool(np.eye(4)).inertias["masses"].tolist() == masses.tolist()  # copies keep the inertias


def test_bad_inertias_are_rejected_with_clear_messages():
    m = dv.load_model("ur5")
    n = 6
    ok_m, ok_c, ok_i = np.ones(n), np.zeros((n, 3)), np.tile(np.eye(3) * 0.01, (n, 1, 1))
    masses = ok_m.copy()
    masses[2] = -1.0
    with pytest.raises(dv.DenavitError, match=r"invalid mass of link 3: expected a mass >= 0 kg, got -1 kg") as e:
        m.with_inertias(masses, ok_c, ok_i)
    assert (e.value.kind, e.value.joint) == ("InvalidArgument", 3)
    bad = ok_i.copy()
    bad[1, 0, 1] = 0.005
    with pytest.raises(dv.DenavitError, match=r"inertia tensor of link 2: expected a symmetric 3x3 matrix"):
        m.with_inertias(ok_m, ok_c, bad)
    bad = ok_i.copy()
    bad[4] = np.diag([0.1, -0.01, 0.1])
    with pytest.raises(dv.DenavitError, match=r"inertia tensor of link 5: expected a positive semi-definite"):
        m.with_inertias(ok_m, ok_c, bad)
    bad = ok_i.copy()
    bad[5] = np.diag([0.1, 0.1, 0.3])
    with pytest.raises(
        dv.DenavitError,
        match=r"inertia tensor of link 6: expected principal moments satisfying the triangle inequality",
    ) as e:
        m.with_inertias(ok_m, ok_c, bad)
    assert e.value.joint == 6
    with pytest.raises(
        dv.DenavitError,
        match=r"^link 6: invalid inertia tensor: expected principal moments satisfying the triangle inequality",
    ) as e:
        m.with_inertias(ok_m, ok_c, bad, about="origin")
    assert e.value.joint == 6
    with pytest.raises(
        dv.DenavitError, match=r"coms \(centres of mass, m\): expected an array of shape \(N, 3\), got shape \(6,\)"
    ):
        m.with_inertias(ok_m, np.zeros(6), ok_i)
    # each argument's count against the model's joints: the short one is named (five masses had been
    # reported as a wrong size of the centres of mass)
    with pytest.raises(dv.DenavitError, match=r"^wrong size of inertias \(one per joint\): expected 6, got 5$"):
        m.with_inertias(ok_m, ok_c, ok_i[:5])
    with pytest.raises(dv.DenavitError, match=r"^wrong size of masses \(kg, one per joint\): expected 6, got 5$"):
        m.with_inertias(ok_m[:5], ok_c, ok_i)
    with pytest.raises(
        dv.DenavitError, match=r"^wrong size of coms \(centres of mass, one per joint\): expected 6, got 7$"
    ):
        m.with_inertias(ok_m, np.vstack([ok_c, ok_c[:1]]), ok_i)
    with pytest.raises(dv.DenavitError, match=r"frame: expected 'link', 'dh' or 'world', got 'tool'"):
        m.with_inertias(ok_m, ok_c, ok_i, frame="tool")
    with pytest.raises(
        dv.DenavitError,
        match=(
            r"^invalid frame: expected 'dh' only for a model built from a DH table .*, got 'dh' for model"
            r" 'tiansui_edh', which has no DH link frames$"
        ),
    ):
        tiansui_edh().with_inertias(ok_m, ok_c, ok_i, frame="dh")
    with pytest.raises(dv.DenavitError, match=r"mass \(kg\) of link 1 must be finite, got NaN"):
        m.with_inertias(np.full(n, np.nan), ok_c, ok_i)


def test_bad_arguments_are_rejected_with_clear_messages():
    m = tiansui_edh()
    z = np.zeros(6)
    with pytest.raises(dv.DenavitError, match=r"wrong size of q: expected 6, got 5"):
        _core.rnea(m, np.zeros(5), z, z)
    with pytest.raises(dv.DenavitError, match=r"qdd: expected a 1-D array, got shape \(2, 3\)"):
        _core.rnea(m, z, z, np.zeros((2, 3)))
    with pytest.raises(dv.DenavitError, match=r"qd must be finite, got NaN at index 1"):
        _core.rnea(m, z, np.array([0, np.nan, 0, 0, 0, 0]), z)
    with pytest.raises(dv.DenavitError, match=r"wrong size of gravity \(m/s\^2, world\): expected 3, got 2"):
        _core.rnea(m, z, z, z, gravity=[0, -9.81])
    with pytest.raises(dv.DenavitError, match=r"wrong size of f_ext .*: expected 6, got 3"):
        _core.rnea(m, z, z, z, f_ext=np.zeros(3))
    with pytest.raises(dv.DenavitError, match=r"method: expected 'aba' or 'crba', got 'euler'"):
        _core.forward_dynamics(m, z, z, z, method="euler")
    with pytest.raises(
        dv.DenavitError, match=r"wrong size of qd batch \(N\*n values, N = 10, n = 6\): expected 60, got 54"
    ):
        _core.rnea_batch(m, np.zeros((10, 6)), np.zeros((9, 6)), np.zeros((10, 6)))
    with pytest.raises(dv.DenavitError, match=r"qs: expected an array of shape \(N, 6\), got shape \(10,\)"):
        _core.mass_matrix_batch(m, np.zeros(10))
    with pytest.raises(
        dv.DenavitError, match=r"wrong size of external tool wrenches \(6 or N\*6 values, N = 4\): expected 24, got 18"
    ):
        _core.rnea_batch(m, np.zeros((4, 6)), np.zeros((4, 6)), np.zeros((4, 6)), f_ext=np.zeros((3, 6)))
    w = np.zeros((4, 6))
    w[3, 5] = np.nan  # one wrench per row: named by its row, as the joint values are (it had been "index 23")
    with pytest.raises(
        dv.DenavitError, match=r"^external tool wrenches \[f; n\] \(row 3\) must be finite, got NaN at index 5$"
    ):
        _core.rnea_batch(m, np.zeros((4, 6)), np.zeros((4, 6)), np.zeros((4, 6)), f_ext=w)
    qs = np.zeros((4, 6))
    qs[2, 3] = np.inf
    with pytest.raises(dv.DenavitError, match=r"q \(row 2\) must be finite, got inf at index 3"):
        _core.gravity_torques_batch(m, qs)
    with pytest.raises(
        dv.DenavitError, match=r"joint axis 2 of the target model: expected the same joint kind and axis"
    ):
        _core.transfer_inertias(m, dv.load_model("ur5"))
    # a robot without inertias has a singular mass matrix: forward dynamics says so
    with pytest.raises(dv.DegenerateError, match=r"joint 6 \('j6'\) moves no inertia"):
        _core.forward_dynamics(dv.load_robot("tiansui_edh").table.to_model("bare"), z, z, z)
    with pytest.raises(dv.DegenerateError, match=r"not positive definite"):
        _core.forward_dynamics(dv.load_robot("tiansui_edh").table.to_model("bare"), z, z, z, method="crba")


# --------------------------------------------------------------------------------------------------------------------
# Cross-check against pinocchio (optional): the same chain built from the joint placements
# --------------------------------------------------------------------------------------------------------------------


def to_pinocchio(model):
    pin = pytest.importorskip("pinocchio")
    pm = pin.Model()
    parent = 0
    P, ins = model.placements, model.inertias
    for i, kind in enumerate(model.kinds):
        M = model.T_world_base @ P[0] if i == 0 else P[i]
        joint = pin.JointModelRZ() if kind == "revolute" else pin.JointModelPZ()
        parent = pm.addJoint(parent, joint, pin.SE3(M[:3, :3], M[:3, 3]), model.names[i])
        pm.appendBodyToJoint(
            parent, pin.Inertia(ins["masses"][i], ins["coms"][i], ins["inertias"][i]), pin.SE3.Identity()
        )
    pm.gravity = pin.Motion(G, np.zeros(3))
    return pin, pm


def tool_force_in_last_joint_frame(pin, model, f):
    """A tool wrench [f; n] (tool axes, about the tool origin) as a pinocchio Force in the last joint frame."""
    T = model.T_last_tool
    fl = T[:3, :3] @ f[:3]
    return pin.Force(fl, T[:3, :3] @ f[3:] + np.cross(T[:3, 3], fl))


@pytest.mark.parametrize("name", ["kr5", "puma560", "tiansui_edh", "tiansui_mdh", "ur5"])
def test_matches_pinocchio_on_builtin_robots(name, rng):
    model = with_random_inertias(dv.load_model(name), rng) if name != "tiansui_edh" else tiansui_edh()
    pin, pm = to_pinocchio(model)
    pd = pm.createData()
    off = np.array(model.offsets)
    f = np.array([3.0, -2.0, 5.0, 0.4, -0.3, 0.2])
    fext = [pin.Force.Zero() for _ in range(pm.njoints)]
    fext[-1] = tool_force_in_last_joint_frame(pin, model, f)
    for q, qd, qdd in zip(*states(model.nq, 20, rng)):
        qp = q + off
        tau = _core.rnea(model, q, qd, qdd, f_ext=f)
        np.testing.assert_allclose(tau, pin.rnea(pm, pd, qp, qd, qdd, fext), rtol=0, atol=1e-10)
        M = pin.crba(pm, pd, qp)
        M = np.triu(M) + np.triu(M, 1).T
        np.testing.assert_allclose(_core.mass_matrix(model, q), M, rtol=0, atol=1e-10)
        np.testing.assert_allclose(
            _core.forward_dynamics(model, q, qd, tau, f_ext=f), pin.aba(pm, pd, qp, qd, tau, fext), rtol=0, atol=1e-9
        )
        np.testing.assert_allclose(
            _core.gravity_torques(model, q), pin.computeGeneralizedGravity(pm, pd, qp), rtol=0, atol=1e-10
        )
        C = pin.computeCoriolisMatrix(pm, pd, qp, qd)
        np.testing.assert_allclose(_core.coriolis_matrix(model, q, qd) @ qd, C @ qd, rtol=0, atol=1e-10)


def dh_frame(d, a, alpha):
    """Standard-DH frame i in joint frame i: translate d along z and a along x, then rotate alpha about x
    (Denavit & Hartenberg 1955; the factor order is written in docs/conventions.md only)."""
    c, s = np.cos(alpha), np.sin(alpha)
    T = np.eye(4)
    T[:3, :3] = [[1, 0, 0], [0, c, -s], [0, s, c]]
    T[0, 3], T[2, 3] = a, d
    return T


@pytest.mark.parametrize("name", ["puma560", "kr5", "ur5"])
def test_dh_frame_inertias_match_an_independent_pinocchio_model(name, rng):
    """Regression (issue 18): inertias given in the DH link frames (as published DH inertia tables are), passed as
    frame="link", gave torques off by newtons with no warning; frame="dh" re-expresses them in the joint frames.
    Reference: pinocchio with each body placed at the DH frame (dh_frame), computed here from the table's rows."""
    pin = pytest.importorskip("pinocchio")
    robot = dv.load_robot(name)
    assert robot.table.convention == "dh"
    m = robot.model()
    masses, coms, inertias = random_inertias(m.nq, rng)
    coms = coms + rng.uniform(-0.1, 0.1, coms.shape)  # centres of mass away from the frame origins
    dh, wrong = m.with_inertias(masses, coms, inertias, frame="dh"), m.with_inertias(masses, coms, inertias)
    pm, parent = pin.Model(), 0
    for i, (P, (d, _, a, alpha)) in enumerate(zip(m.placements, robot.table.params)):
        M = m.T_world_base @ P if i == 0 else P
        parent = pm.addJoint(parent, pin.JointModelRZ(), pin.SE3(M[:3, :3], M[:3, 3]), m.names[i])
        B = dh_frame(d, a, alpha)
        pm.appendBodyToJoint(parent, pin.Inertia(masses[i], coms[i], inertias[i]), pin.SE3(B[:3, :3], B[:3, 3]))
    pm.gravity = pin.Motion(G, np.zeros(3))
    pd = pm.createData()
    worst_wrong = 0.0
    for q, qd, qdd in zip(*states(m.nq, 10, rng)):
        ref = pin.rnea(pm, pd, q + m.offsets, qd, qdd)
        np.testing.assert_allclose(dv.rnea(dh, q, qd, qdd), ref, rtol=0, atol=1e-10)
        worst_wrong = max(worst_wrong, np.abs(dv.rnea(wrong, q, qd, qdd) - ref).max())
    assert worst_wrong > 1.0  # N m: the joint frame is not the DH frame
    back = pickle.loads(pickle.dumps(dh))
    np.testing.assert_array_equal(back.dh_link_frames, m.dh_link_frames)
    np.testing.assert_array_equal(dv.rnea(back, q, qd, qdd), dv.rnea(dh, q, qd, qdd))


# --------------------------------------------------------------------------------------------------------------------
# Robot files with inertials, and the command line
# --------------------------------------------------------------------------------------------------------------------


def test_builtin_tiansui_files_carry_one_illustrative_set(rng):
    edh, mdh = dv.load_robot("tiansui_edh"), dv.load_robot("tiansui_mdh")
    np.testing.assert_array_equal(edh.inertials["masses"], TIANSUI_EDH_MASSES)
    np.testing.assert_allclose(edh.inertials["coms"], TIANSUI_EDH_COMS, rtol=0, atol=1e-15)
    np.testing.assert_allclose(edh.inertials["inertias"], TIANSUI_EDH_INERTIAS, rtol=0, atol=1e-15)
    for r in (edh, mdh):
        assert "ILLUSTRATIVE" in Path(r.path).read_text(encoding="utf-8")
    qs, qds, qdds = states(6, 200, rng)
    a = _core.rnea_batch(edh.model(), qs, qds, qdds)
    b = _core.rnea_batch(mdh.model(), qs, qds, qdds)
    assert np.abs(a - b).max() < 1e-10


FILE = """
name = "one"
convention = "{conv}"
[units]
length = "mm"
angle = "deg"
mass = "g"
inertia = "{iunit}"
[[joints]]
name = "j1"
{params}
[joints.inertia]
mass = {mass}
com = [0, 0, 0]
ixx = {ixx}
iyy = 2000
izz = 2000
"""


def test_robot_file_inertia_units_frames_and_round_trip(tmp_path):
    # standard DH: the inertia is given in DH frame 1, at the end of the 500 mm link: a 2 kg point-like mass
    p = tmp_path / "one.toml"
    p.write_text(
        FILE.format(
            conv="dh", params="d = 0\ntheta = 0\na = 500\nalpha = 0", mass=2000, ixx=2000, iyy=2000, iunit="g mm^2"
        )
    )
    robot = dv.load_robot(p)
    assert robot.inertials["masses"][0] == pytest.approx(2.0)
    np.testing.assert_allclose(robot.inertials["inertias"][0], np.eye(3) * 2e-6, rtol=1e-12)
    m = robot.model()
    np.testing.assert_allclose(m.inertias["coms"][0], [0.5, 0, 0], atol=1e-15)  # re-expressed in the joint frame
    g = np.array([0.0, -9.81, 0.0])
    assert _core.gravity_torques(m, [0.0], gravity=g)[0] == pytest.approx(2.0 * 9.81 * 0.5, rel=1e-12)
    # written back (SI units for the inertials) and read again: the same model
    out = tmp_path / "out.toml"
    robotfile.save(robot, out, "mm", "deg")
    again = dv.load_robot(out)
    for k in ("masses", "coms", "inertias"):
        np.testing.assert_allclose(again.inertials[k], robot.inertials[k], rtol=1e-12, atol=1e-18)


@pytest.mark.parametrize(
    ("mass", "ixx", "iunit", "drop_units", "match"),
    [
        (-5, 2000, "g mm^2", False, r"joint 1 \(line 9\): inertia: invalid mass of link 1: expected a mass >= 0 kg"),
        (
            5,
            9000,
            "g mm^2",
            False,
            (
                r"joint 1 \(line 9\): inertia: invalid inertia tensor of link 1: expected principal moments satisfying"
                r" the triangle inequality"
            ),
        ),
        (5, 2000, "kg furlong^2", False, r"unknown length unit 'furlong'"),
        (5, 2000, "stone", False, r"unknown inertia unit 'stone'"),
        (5, 2000, "g mm^2", True, r"\[units\] must declare 'mass' and 'inertia'"),
    ],
)
def test_robot_file_inertia_errors(tmp_path, mass, ixx, iunit, drop_units, match):
    text = FILE.format(conv="mdh", params="alpha = 0\na = 0\ntheta = 0\nd = 0", mass=mass, ixx=ixx, iunit=iunit)
    if drop_units:
        text = text.replace('mass = "g"\n', "")
    p = tmp_path / "bad.toml"
    p.write_text(text)
    with pytest.raises(dv.DenavitError, match=match):
        dv.load_robot(p)


def test_robot_file_unknown_inertia_key(tmp_path):
    p = tmp_path / "bad.toml"
    p.write_text(
        FILE.format(conv="mdh", params="alpha = 0\na = 0\ntheta = 0\nd = 0", mass=1, ixx=2000, iunit="g mm^2")
        + "izy = 3\n"
    )
    with pytest.raises(dv.DenavitError, match=r"joint 1 \(line 9\): inertia: unknown keys \['izy'\]"):
        dv.load_robot(p)


def cli(*args, ok=True):
    import subprocess  # noqa: PLC0415
    import sys  # noqa: PLC0415

    p = subprocess.run([sys.executable, "-m", "denavit.cli", *args], capture_output=True, text=True, env=cli_env())
    if ok:
        assert p.returncode == 0, p.stderr
    return p


def test_cli_dynamics_json_matches_the_library():
    import json  # noqa: PLC0415

    doc = json.loads(
        cli(
            "dynamics",
            "tiansui_edh",
            "--q",
            "10,-80,70,5,60,0",
            "--qd",
            "20,0,-10,0,5,0",
            "--qdd",
            "0,30,0,0,0,10",
            "--f-ext",
            "0,0,-20,0,0,0",
            "--json",
        ).stdout
    )
    r = np.radians
    tau = _core.rnea(
        dv.load_model("tiansui_edh"),
        r([10, -80, 70, 5, 60, 0]),
        r([20, 0, -10, 0, 5, 0]),
        r([0, 30, 0, 0, 0, 10]),
        f_ext=[0, 0, -20, 0, 0, 0],
    )
    np.testing.assert_allclose(doc["tau"], tau, rtol=0, atol=1e-12)
    assert doc["tau_units"] == ["N m"] * 6 and "warning" not in doc
    assert doc["q"] == pytest.approx(np.radians([10, -80, 70, 5, 60, 0]))  # typed in deg (the default), JSON in SI
    table = cli("dynamics", "tiansui_mdh", "--q", "10,-80,70,5,60,0").stdout
    assert "Joint efforts" in table and "of which gravity" in table


def test_cli_dynamics_warns_without_inertials_and_rejects_bad_input():
    import json  # noqa: PLC0415

    doc = json.loads(cli("dynamics", "kr5", "--json").stdout)
    assert "carries no inertial parameters" in doc["warning"] and doc["tau"] == [0.0] * 6
    for args, match in [
        (("dynamics", "kr5", "--qd", "1,2"), "--qd: expected 6 joint values for kr5, got 2"),
        (("dynamics", "kr5", "--gravity", "0,9.81"), "--gravity: expected 3 values"),
        (("dynamics", "kr5", "--f-ext", "1,2,3"), "--f-ext: expected 6 values"),
    ]:
        p = cli(*args, ok=False)
        assert p.returncode == 2 and match in " ".join(p.stderr.split()) and "Traceback" not in p.stderr


@pytest.mark.parametrize("to", ["dh", "mdh", "edh", "poe"])
def test_cli_convert_carries_the_inertials(tmp_path, to, rng):
    out = tmp_path / f"tiansui_{to}.toml"
    cli("convert", "tiansui_edh", "--to", to, "-o", str(out), "--length", "mm")
    qs, qds, qdds = states(6, 100, rng)
    a = _core.rnea_batch(dv.load_model(out), qs, qds, qdds)
    b = _core.rnea_batch(dv.load_model("tiansui_edh"), qs, qds, qdds)
    assert np.abs(a - b).max() < 1e-10


def test_dynamics_batches_fill_out_and_follow_threads(rng):
    """out= (filled and returned, checked) and threads= on every dynamics batch; the same values as a fresh result."""
    m = tiansui_edh()
    qs, qds, qdds = states(6, 300, rng)
    calls = {
        "rnea_batch": (lambda **k: _core.rnea_batch(m, qs, qds, qdds, **k), (300, 6)),
        "bias_forces_batch": (lambda **k: _core.bias_forces_batch(m, qs, qds, **k), (300, 6)),
        "gravity_torques_batch": (lambda **k: _core.gravity_torques_batch(m, qs, **k), (300, 6)),
        "mass_matrix_batch": (lambda **k: _core.mass_matrix_batch(m, qs, **k), (300, 6, 6)),
        "coriolis_matrix_batch": (lambda **k: _core.coriolis_matrix_batch(m, qs, qds, **k), (300, 6, 6)),
        "forward_dynamics_batch": (lambda **k: _core.forward_dynamics_batch(m, qs, qds, qdds, **k), (300, 6)),
    }
    for name, (call, shape) in calls.items():
        ref = call()
        out = np.full(shape, np.nan)
        assert call(out=out, threads=1) is out, name
        np.testing.assert_array_equal(out, ref, err_msg=name)
        np.testing.assert_array_equal(call(threads=2), ref, err_msg=name)
        with pytest.raises(
            dv.DenavitError,
            match=r"^invalid out: expected a C-contiguous, writeable float64 numpy array of shape \(300, ",
        ):
            call(out=np.zeros(shape[:-1] + (shape[-1] + 1,)))


def test_rates_and_results_beyond_double_precision_are_refused_not_nan():
    """qd = 1e160 (its square 1e320) had given NaN torques from every dynamics function, caught only by the CLI
    (issue 16). The core refuses it in every entry point, single and batch, with the argument, row and joint; a
    result that overflows all the same (masses of 1e300) is an error naming the result (kind Overflow)."""
    import denavit as dv
    from denavit import _core

    m = dv.load_model("puma560")
    q, qd, z = np.zeros(6), np.array([0.0, 1e160, 0, 0, 0, 0]), np.zeros(6)
    single = {
        "rnea": lambda: _core.rnea(m, q, qd, z),
        "bias_forces": lambda: _core.bias_forces(m, q, qd),
        "forward_dynamics": lambda: _core.forward_dynamics(m, q, qd, z),
        "coriolis_matrix": lambda: _core.coriolis_matrix(m, q, qd),
        "kinetic_energy": lambda: _core.kinetic_energy(m, q, qd),
    }
    for name, f in single.items():
        with pytest.raises(
            dv.DenavitError,
            match=(
                r"^invalid qd at joint 2: expected joint rates whose squares are finite \(\|qd\| <= 1.3408e154 rad/s or"
                r" m/s\), got 1e160$"
            ),
        ) as e:
            f()
        assert e.value.kind == "InvalidArgument" and e.value.what == "qd at joint 2", name
    qs, qds = np.zeros((5, 6)), np.zeros((5, 6))
    qds[3] = qd
    batch = {
        "rnea_batch": lambda: _core.rnea_batch(m, qs, qds, qs),
        "bias_forces_batch": lambda: _core.bias_forces_batch(m, qs, qds),
        "forward_dynamics_batch": lambda: _core.forward_dynamics_batch(m, qs, qds, qs),
        "coriolis_matrix_batch": lambda: _core.coriolis_matrix_batch(m, qs, qds),
    }
    for f in batch.values():
        with pytest.raises(
            dv.DenavitError, match=r"^invalid qd \(row 3\) at joint 2: expected joint rates whose squares are finite"
        ):
            f()
    assert np.isfinite(_core.rnea(m, q, np.array([0.0, 1e100, 0, 0, 0, 0]), z)).all()  # large but representable
    huge = m.with_inertias(np.full(6, 1e300), np.tile([1e10, 0.0, 0.0], (6, 1)), np.zeros((6, 3, 3)))
    for name, f in {
        "gravity_torques": lambda: _core.gravity_torques(huge, q),
        "mass_matrix": lambda: _core.mass_matrix(huge, q),
        "rnea": lambda: _core.rnea(huge, q, z, z),
        "gravity_torques_batch": lambda: _core.gravity_torques_batch(huge, qs),
        "mass_matrix_batch": lambda: _core.mass_matrix_batch(huge, qs),
    }.items():
        with pytest.raises(
            dv.DenavitError,
            match=(
                r"is not finite \(.* at (joint \d|entry \(\d, \d\)|the chain)\): the inputs are moderate: the model's"
                r" parameters"
            ),
        ) as e:
            f()
        assert e.value.kind == "Overflow" and e.value.cause.startswith("the inputs are moderate"), name
