"""Whole-model calibration: statistics against the Cramér-Rao bound, the joint fit against per-circle fits,
planning, near-parallel axes, identifiability reports and bad input (denavit.calibration; the measurement files in
test_calibrate_measurements.py, the commands in test_calibrate_cli.py)."""

import ast

import numpy as np
import pytest
from calibrate_cases import HOME, NOISE, TOOL
from scipy.spatial.transform import Rotation

import denavit as dv
from denavit import calibration as cal
from denavit import fitting
from denavit import sweeps as sw
from denavit.calibration.least_squares import covariance, residuals, weights
from denavit.io.robots import as_robot


def perturbed(robot, names, seed, convention="edh", length=5e-4, angle=1e-3, extra=None):
    """A 'true' robot: the nominal chain with the parameters `names` moved by Gaussian amounts (m / rad)."""
    pz = cal.parametrize(robot, convention, tool=TOOL)
    rng = np.random.default_rng(seed)
    x = pz.x0.copy()
    for nm in names:
        c = pz.index(nm)
        x[c] += rng.normal(0.0, length if pz.units[c] == "length" else angle)
    for nm, v in (extra or {}).items():
        x[pz.index(nm)] = v
    return pz, x, pz.model(x, "truth"), x[[pz.index(n) for n in ("tool_x", "tool_y", "tool_z")]]


def crb(pz, x, q, free_names):
    """Cramér-Rao bound of the free parameters at the truth x for points at configurations q."""
    w = weights("point", NOISE, NOISE)
    _, J, _ = residuals(pz, x, cal.Measurements(q, np.zeros((len(q), 3))), w)
    idx = [pz.index(n) for n in free_names]
    return covariance(J[:, idx], 1.0)


# ------------------------------------------------------------------------------------------ the chain


@pytest.mark.parametrize(
    "name, convention",
    [("kr5", "edh"), ("kr5", "mdh"), ("ur5", "edh"), ("ur5", "mdh"), ("tiansui_mdh", "edh"), ("puma560", "mdh")],
)
def test_chain_reproduces_the_nominal_model(name, convention, rng):
    robot = dv.load_robot(name)
    pz = cal.parametrize(robot, convention, tool=TOOL)
    q = rng.uniform(-2.5, 2.5, (50, robot.table.params.shape[0]))
    T = np.eye(4)
    T[:3, 3] = TOOL
    truth = dv.fk_batch(robot.model().with_tool(T), q)[:, :3, 3]
    np.testing.assert_allclose(pz.evaluate(pz.x0, q, False)[0][:, :3, 3], truth, atol=1e-10)
    m = pz.model(pz.x0)
    np.testing.assert_allclose(dv.fk_batch(m, q)[:, :3, 3], truth, atol=1e-10)


def test_identification_jacobian_matches_finite_differences(kr5, rng):
    """Through the binding, with joint scales and a tool frame: central differences, step 1e-6."""
    pz = cal.parametrize(kr5, "edh", measure="pose", scale=True)
    x = pz.x0 + rng.normal(0, 1e-2, pz.n_params)
    q = rng.uniform(-2, 2, (5, 6))
    T, J = pz.evaluate(x, q)
    h = 1e-6
    for c in range(pz.n_params):
        xp, xm = x.copy(), x.copy()
        xp[c] += h
        xm[c] -= h
        Tp, Tm = pz.evaluate(xp, q, False)[0], pz.evaluate(xm, q, False)[0]
        dp = (Tp[:, :3, 3] - Tm[:, :3, 3]) / (2 * h)
        Rd = np.einsum("nij,nkj->nik", Tp[:, :3, :3], Tm[:, :3, :3])
        dw = (
            np.stack([Rd[:, 2, 1] - Rd[:, 1, 2], Rd[:, 0, 2] - Rd[:, 2, 0], Rd[:, 1, 0] - Rd[:, 0, 1]], axis=1)
            / 2
            / (2 * h)
        )
        np.testing.assert_allclose(J[:, :3, c], dp, atol=1e-8, err_msg=pz.names[c])
        np.testing.assert_allclose(J[:, 3:, c], dw, atol=1e-8, err_msg=pz.names[c])


# ------------------------------------------------------------------------------------------ statistics


def monte_carlo(kr5, data, runs, seed=11):
    """Seeded Monte Carlo on a perturbed KR5: returns the plan, the truth, estimates and reported sigmas of
    the free parameters, and the CRB at the truth."""
    protocol = {"sweeps": 90, "sweeps30": 30}.get(data)
    if data == "random":
        q = cal.configurations(kr5, 100, skip=50)
        pl = cal.plan(kr5, q=q, noise=NOISE, tool=TOOL)
    else:
        prot = cal.Protocol.paper(protocol, points_per_sweep=30, tool_point=TOOL)
        q = prot.configurations()
        pl = cal.plan(kr5, prot, noise=NOISE)
    pz, x, truth, tool = perturbed(kr5, pl.free_names, seed)
    est, sig = [], []
    for run in range(runs):
        if data == "random":
            meas = cal.simulate(truth, q, tool=tool, noise=NOISE, seed=run)
        else:
            meas = sw.simulate(
                truth,
                home=HOME,
                ranges=np.radians(sw.PAPER_RANGES_DEG[protocol]),
                points_per_sweep=30,
                tool_point=tool,
                noise=NOISE,
                seed=run,
            )
        res = cal.calibrate(
            meas, kr5, tool=TOOL, model="full"
        )  # the least-squares estimator the bound is of (the default's priors beat it)
        assert res.free_names == pl.free_names and res.converged
        est.append(res.values[[pz.index(n) for n in pl.free_names]])
        sig.append(res.sigma[[pz.index(n) for n in pl.free_names]])
    idx = [pz.index(n) for n in pl.free_names]
    return pl, x[idx], np.array(est), np.array(sig), crb(pz, x, q, pl.free_names)


@pytest.mark.parametrize("data", ["random", "sweeps", "sweeps30"])
def test_monte_carlo_reaches_the_cramer_rao_bound_and_sigmas_are_honest(kr5, data):
    """200 seeded runs, 0.02 mm noise (random poses: 100 Halton configurations; sweeps: the paper's 90 degree
    protocol, sweeps30 its 30 degree one, 30 points per sweep), 27 free parameters each.

    * Efficiency: the Mahalanobis error ``e^T CRB^-1 e / p`` averages 1 for an efficient estimator; its mean over
      200 x 27 chi-square terms has a standard error of sqrt(2 / 5400) = 2 %, so sqrt(mean) <= 1.1 is 5 standard
      errors. Per parameter, RMS error / CRB sigma <= 1.1 + 3 standard errors of a 200-run RMS (1/sqrt(400) = 5 %).
    * Honest sigmas: every reported sigma (mean over runs) and every planned sigma (before any data) within 20 %
      of the Monte Carlo spread; the spread of 200 runs has a 5 % standard error, so 20 % is 4 of them.

    The 30 degree protocol does not reach the bound jointly (sqrt of the mean Mahalanobis error 1.15, measured
    once the KR5 stood on its base; 1.07 with the hanging table): one combination of wrist parameters (alpha_5,
    offset_4, offset_5, alpha_4) spreads 2.9x its bound, from a few runs (kurtosis 8.6) whose least-squares
    minimum lies far along it, with a lower cost than the minimum near the truth (checked by starting there): the
    estimator is not efficient on 30 degree wrist arcs of a 100 mm tool, not the solver short of its minimum.
    Every parameter alone still meets the per-parameter and honest-sigma checks, which are asserted for it.
    """
    runs = 200
    pl, x_true, est, sig, C = monte_carlo(kr5, data, runs)
    err = est - x_true
    maha = np.einsum("ri,ij,rj->r", err, np.linalg.inv(C), err) / len(x_true)
    if data != "sweeps30":
        assert np.sqrt(maha.mean()) <= 1.1, np.sqrt(maha.mean())
    rmse_ratio = np.sqrt(np.mean(err**2, axis=0)) / np.sqrt(np.diag(C))
    assert np.all(rmse_ratio <= 1.1 + 3 / np.sqrt(2 * runs)), dict(zip(pl.free_names, rmse_ratio.round(3), strict=True))
    spread = est.std(axis=0, ddof=1)
    reported = sig.mean(axis=0) / spread
    planned = pl.sigma[[pl.parametrization.index(n) for n in pl.free_names]] / spread
    assert np.all(np.abs(reported - 1) < 0.2), dict(zip(pl.free_names, reported.round(3), strict=True))
    assert np.all(np.abs(planned - 1) < 0.2), dict(zip(pl.free_names, planned.round(3), strict=True))


def line_error(c_true, z_fit, c_fit):
    """Distance of the true circle centre from a fitted axis line."""
    r = c_true - c_fit
    return np.linalg.norm(r - z_fit * (r @ z_fit))


def test_joint_fit_beats_every_per_circle_fit_on_the_30_degree_protocol(kr5):
    """Hayat et al.'s 30 degree protocol (Table II), 30 points per sweep, 0.02 mm noise, 40 seeded runs: the
    whole-model fit of all sweeps locates every joint axis better than each per-circle fit of the
    circle-point method (the fits denavit.identify runs per sweep: kasa, hyper, geometric, readings). The bound
    (plan) says joints 1 and 4 by more than 5x over the best per-circle fit (readings); Monte Carlo agrees
    within its 11 % (1/sqrt(80)) standard error."""
    prot = cal.Protocol.paper(30, points_per_sweep=30, tool_point=TOOL)
    pl = cal.plan(kr5, prot, noise=NOISE)
    bound_ratio = pl.per_circle_sigma[:, 0] / pl.axis_sigma[:, 0]
    assert bound_ratio[0] > 5 and bound_ratio[3] > 5, bound_ratio
    assert np.all(bound_ratio > 1.3), bound_ratio
    truth = kr5.model()
    p_home = pl.parametrization.evaluate(pl.parametrization.x0, HOME[None], False)[0][0, :3, 3]
    c_true, _ = cal.axis_lines(truth, HOME, p_home)
    methods = {
        "kasa": fitting.fit_circle_kasa,
        "hyper": fitting.fit_circle_hyper,
        "geometric": fitting.fit_circle_geometric,
    }
    err = {m: [] for m in [*methods, "readings", "joint fit"]}
    for run in range(40):
        s = sw.simulate(
            truth, home=HOME, ranges=prot.ranges, points_per_sweep=30, tool_point=TOOL, noise=NOISE, seed=100 + run
        )
        for m, f in methods.items():
            err[m].append(
                [line_error(c_true[j], f(s.sweeps[j].points).direction, f(s.sweeps[j].points).point) for j in range(6)]
            )
        fits = [fitting.fit_axis_with_readings(x.points, x.moving) for x in s.sweeps]
        err["readings"].append([line_error(c_true[j], fits[j].direction, fits[j].point) for j in range(6)])
        res = cal.calibrate(
            s, kr5, tool=TOOL, model="full"
        )  # the least-squares fit the plan's bound is of (the default's priors beat it)
        c, z = cal.axis_lines(res.model(), HOME, p_home)
        err["joint fit"].append([line_error(c_true[j], z[j], c[j]) for j in range(6)])
    rms = {m: np.sqrt(np.mean(np.square(v), axis=0)) for m, v in err.items()}
    for m in ("kasa", "hyper", "geometric", "readings"):
        assert np.all(rms["joint fit"] < rms[m]), (m, rms[m], rms["joint fit"])
    mc_ratio = rms["readings"] / rms["joint fit"]
    assert mc_ratio[0] > 4 and mc_ratio[3] > 4, mc_ratio
    np.testing.assert_allclose(rms["joint fit"], pl.axis_sigma[:, 0], rtol=0.35)


def test_plan_puts_the_papers_claim_into_numbers(kr5):
    """Smaller ranges (30 vs 90 degrees) need a smaller measuring volume; the plan says by how much, and what it
    costs in parameter uncertainty, before anything is measured."""
    p30 = cal.plan(kr5, cal.Protocol.paper(30), noise=NOISE)
    p90 = cal.plan(kr5, cal.Protocol.paper(90), noise=NOISE)
    assert p30.box.volume < 0.3 * p90.box.volume
    assert p30.free_names == p90.free_names and len(p30.free_names) == 27
    i = [p30.parametrization.index(n) for n in p30.free_names]
    ratio = p30.sigma[i] / p90.sigma[i]
    assert np.all(np.isfinite(ratio)) and np.median(ratio) > 1
    # the points of the plan lie in its box
    local = (p30.points - p30.box.center) @ p30.box.axes
    assert np.all(np.abs(local) <= p30.box.lengths / 2 + 1e-9)


def test_d_optimal_selection_beats_the_first_poses(kr5):
    cand = cal.configurations(kr5, 400)
    best = cal.plan(kr5, q=cand, select=30, noise=NOISE, tool=TOOL)
    first = cal.plan(kr5, q=cand[:30], noise=NOISE, tool=TOOL)
    assert len(set(best.selected.tolist())) == 30 and best.q.shape == (30, 6)
    assert best.free_names == first.free_names
    i = [best.parametrization.index(n) for n in best.free_names]
    assert np.linalg.slogdet(np.linalg.inv(best.covariance))[1] > np.linalg.slogdet(np.linalg.inv(first.covariance))[1]
    assert np.mean(best.sigma[i] / first.sigma[i]) < 0.9


@pytest.mark.parametrize("measure", ["point", "pose"])
def test_d_optimal_selection_is_the_greedy_log_det_gain(kr5, measure):
    """The rank-one (Woodbury) updates pick what the definition picks: at each step the candidate whose rows
    J_c (column-normalised Jacobian of the identifiable parameters) raise log det M the most, M = ridge I + the
    chosen rows' J^T J, computed here from scratch per candidate."""
    from denavit.calibration.identifiability import rank_reveal
    from denavit.calibration.plan import select_poses

    T_ft = np.eye(4)
    T_ft[:3, 3] = TOOL
    pz = cal.parametrize(kr5, "edh", tool=TOOL if measure == "point" else T_ft, measure=measure)
    q = cal.configurations(kr5, 120, skip=5)
    rows = 6 if measure == "pose" else 3
    _, jac = pz.evaluate(pz.x0, q, True)
    J = jac[:, :rows] * weights(pz.measure, 1.0, 1.0)[:rows, None]
    kept, _, _, norms, _, _ = rank_reveal(J.reshape(-1, pz.n_params), list(pz.order))
    J = J[:, :, kept] / norms[kept]
    M = np.eye(len(kept)) * 1e-6 * len(q) * rows / len(kept)
    expected = []
    for _ in range(12):
        gain = [np.linalg.slogdet(M + J[c].T @ J[c])[1] if c not in expected else -np.inf for c in range(len(q))]
        expected.append(int(np.argmax(gain)))
        M = M + J[expected[-1]].T @ J[expected[-1]]
    assert select_poses(pz, q, 12).tolist() == expected


# ------------------------------------------------------------------------------------------ geometry


def test_near_parallel_axes_calibrate_in_edh_and_mdh_and_dh_says_it_cannot():
    """UR5 (axes 2, 3, 4 parallel) whose axes 3 and 4 are tilted about y by 0.1 degree (what a DH table cannot
    represent): ED-H and MDH with Hayati's angle converge to the noise level; no parameter diverges."""
    ur5 = dv.load_robot("ur5")
    pz = cal.parametrize(ur5, "edh", tool=TOOL)
    assert "beta_2" in pz.names and "beta_3" in pz.names
    names = [n for n in pz.names if not n.startswith(("c_", "offset_6", "alpha_0", "a_0", "b_0"))]
    _, _, truth, tool = perturbed(ur5, names, 3, extra={"beta_2": np.radians(0.1), "beta_3": np.radians(-0.1)})
    q = cal.configurations(ur5, 120, skip=20)
    meas = cal.simulate(truth, q, tool=tool, noise=NOISE, seed=5)
    check = cal.configurations(ur5, 300, skip=5000)
    p_true = cal.simulate(truth, check, tool=tool).points
    for conv in ("edh", "mdh"):
        res = cal.calibrate(meas, ur5, convention=conv, tool=TOOL, holdout=0.2)
        assert res.converged and not [n for n in res.notes if "diverged" in n]
        m = res.model()
        p_hat = cal.simulate(m, check, tool=np.asarray(m.T_flange_tool)[:3, 3]).points
        assert np.sqrt(np.mean(np.sum((p_hat - p_true) ** 2, axis=1))) < 2 * NOISE, conv
        assert res.validation.after_rms < 3 * NOISE < res.validation.before_rms
        lengths = [v for v, u in zip(res.values, res.parametrization.units, strict=True) if u == "length"]
        assert np.max(np.abs(lengths)) < 1.0
    mdh = cal.parametrize(ur5, "mdh")
    assert {"beta_2", "beta_3"} <= set(mdh.names) and set(mdh.rules) == {"d_2", "d_3"}
    with pytest.raises(
        dv.DegenerateError,
        match=r"standard DH cannot calibrate ur5: axes 2-3 \(0 deg\), 3-4 \(0 deg\) are parallel.*use convention 'mdh'",
    ):
        cal.calibrate(meas, ur5, convention="dh")


def skew_arm():
    """A 4R arm in standard DH with no two consecutive axes parallel (DH is fine there)."""
    p = np.array(
        [[0.3, 0.0, 0.1, np.pi / 2], [0.05, 0.2, 0.4, -np.pi / 3], [0.1, -0.3, 0.3, np.pi / 2], [0.08, 0.0, 0.0, 0.0]]
    )
    return dv.Robot("skew4", dv.Table("dh", p), ["j1", "j2", "j3", "j4"], np.full(4, -2.8), np.full(4, 2.8))


@pytest.mark.parametrize("convention, along", [("edh", "c_3"), ("mdh", "d_4"), ("dh", "d_4")])
def test_tool_offset_along_the_last_axis_is_reported_unidentifiable(convention, along):
    """The tool point's offset along the last axis and the last joint's offset along that axis (c / d) move
    every measurement alike: one is named, with the other as the reason, and gets no sigma; likewise the last
    joint's zero offset against the tool point's angle about the last axis."""
    robot = skew_arm()
    meas = cal.simulate(robot, cal.configurations(robot, 60), tool=TOOL, noise=NOISE)
    res = cal.calibrate(meas, robot, convention=convention, tool=TOOL)
    un = {u.name: u for u in res.identifiability.unidentifiable}
    assert along in un and "tool_z" in un[along].combination and un[along].structural
    assert un[along].combination["tool_z"] == pytest.approx(1.0, abs=1e-6)
    assert "the tool absorbs" in un[along].reason
    k = res.parametrization.index(along)
    assert np.isnan(res.sigma[k]) and res.status[k] == "redundant" and res.values[k] == res.start[k]
    assert "offset_4" in un and {"tool_x", "tool_y"} & set(un["offset_4"].combination)
    assert res.rms < 2 * NOISE


def test_pose_measurements_identify_the_tool_frame(kr5, rng):
    T_tool = np.eye(4)
    T_tool[:3, :3] = Rotation.from_euler("xyz", [0.3, -0.2, 0.6]).as_matrix()
    T_tool[:3, 3] = TOOL
    q = cal.configurations(kr5, 60)
    meas = cal.simulate(kr5, q, tool=T_tool, noise=NOISE, noise_rot=2e-5, measure="pose", seed=2)
    assert meas.kind == "pose"
    res = cal.calibrate(meas, kr5, tool=T_tool)
    assert {"tool_rx", "tool_ry", "tool_rz"} <= set(res.free_names)
    assert "offset_6" in {u.name for u in res.identifiability.unidentifiable}
    assert res.rms < 3 * NOISE and res.rms_rotation < 1e-4
    np.testing.assert_allclose(np.asarray(res.model().T_flange_tool), T_tool, atol=1e-4)


def test_robust_loss_flags_outliers_and_keeps_the_fit(kr5):
    """Three gross outliers (5 mm) among 80 points: the linear fit moves the parameters by tens of sigmas;
    soft_l1 cuts that more than tenfold, cauchy (redescending) to the noise; the outliers are flagged."""
    q = cal.configurations(kr5, 80)
    clean = cal.simulate(kr5, q, tool=TOOL, noise=NOISE, seed=4)
    pts = clean.points.copy()
    pts[[3, 40, 41]] += [0.005, -0.004, 0.006]
    dirty = cal.Measurements(q, pts)
    ref = cal.calibrate(clean, kr5, tool=TOOL)
    i = [ref.parametrization.index(n) for n in ref.free_names]

    def shift(res):
        return np.abs(res.values - ref.values)[i] / ref.sigma[i]

    lin = shift(cal.calibrate(dirty, kr5, tool=TOOL))
    soft = cal.calibrate(dirty, kr5, tool=TOOL, loss="soft_l1")
    cauchy = cal.calibrate(dirty, kr5, tool=TOOL, loss="cauchy")
    assert set(soft.outliers.tolist()) == {3, 40, 41} == set(cauchy.outliers.tolist())
    assert lin.max() > 20 and shift(soft).max() < 0.1 * lin.max() and shift(cauchy).max() < 2
    assert cauchy.noise == pytest.approx(NOISE, rel=0.2)
    assert any("robust sigmas" in n for n in soft.notes)


def test_start_from_the_circle_point_identification(kr5):
    s = sw.simulate(
        kr5.model(),
        home=HOME,
        ranges=np.radians(sw.PAPER_RANGES_DEG[90]),
        points_per_sweep=20,
        tool_point=TOOL,
        noise=NOISE,
        seed=8,
    )
    a = cal.calibrate(s, kr5, tool=TOOL)
    b = cal.calibrate(s, kr5, tool=TOOL, start="circles")
    assert any("circle-point identification" in n for n in b.notes)
    np.testing.assert_allclose(a.values, b.values, atol=1e-9)
    with pytest.raises(dv.DenavitError, match="start='circles' needs sweep data"):
        cal.calibrate(cal.simulate(kr5, cal.configurations(kr5, 30)), kr5, start="circles")


def test_measurements_in_another_frame_and_validation(kr5):
    """A laser tracker 3 m away, turned 120 degrees: the base is registered, then calibrated."""
    T = np.eye(4)
    T[:3, :3] = Rotation.from_euler("zyx", [120, 8, -5], degrees=True).as_matrix()
    T[:3, 3] = [3.0, -1.0, 0.4]
    q = cal.configurations(kr5, 100, skip=3)
    meas = cal.simulate(kr5, q, tool=TOOL, noise=NOISE, T_world_base=T, seed=9)
    res = cal.calibrate(meas, kr5, tool=TOOL, holdout=0.2)
    np.testing.assert_allclose(np.asarray(res.model().T_world_base), T, atol=2e-4)
    v = res.validation
    assert v.n_test == 20 and v.n_train == 80 and v.after_rms < 2 * NOISE
    assert res.identifiability.rank == 27 and res.identifiability.condition_number > 1
    assert set(res.identifiability.observability) == {"O1", "O2", "O3", "O4", "O5"}


def test_joint_scale_is_estimated(kr5):
    pz = cal.parametrize(kr5, "edh", tool=TOOL, scale=True)
    x = pz.x0.copy()
    x[pz.index("scale_2")] = 1e-3
    poses = pz.evaluate(x, cal.configurations(kr5, 150), False)[0]
    q = cal.configurations(kr5, 150)
    meas = cal.Measurements(q, poses[:, :3, 3] + np.random.default_rng(1).normal(0, NOISE, (150, 3)))
    res = cal.calibrate(meas, kr5, tool=TOOL, scale=True)
    v, s = res.value("scale_2")
    assert abs(v - 1e-3) < 4 * s and s < 1e-4
    assert res.scales["scale_2"] == v


def test_fix_by_name_pattern_and_value(kr5):
    meas = cal.simulate(kr5, cal.configurations(kr5, 50), tool=TOOL, noise=NOISE)
    res = cal.calibrate(meas, kr5, tool=TOOL, fix=["base_*", "tool_z"])
    for n in ("base_tx", "base_rz", "tool_z"):
        k = res.parametrization.index(n)
        assert res.status[k] == "fixed" and np.isnan(res.sigma[k]) and res.values[k] == res.nominal[k]
    res = cal.calibrate(meas, kr5, tool=TOOL, fix={"tool_x": 0.051})
    assert res.value("tool_x")[0] == 0.051
    with pytest.raises(
        dv.DenavitError,
        match=r"fix: 'tool_w' matches no parameter of the edh model of kr5: expected names or patterns of base_tx",
    ):
        cal.calibrate(meas, kr5, fix=["tool_w"])


# ------------------------------------------------------------------------------------------ bad input


def test_too_few_poses_for_the_free_parameters(kr5):
    meas = cal.simulate(kr5, cal.configurations(kr5, 8), tool=TOOL)
    with pytest.raises(
        dv.DenavitError,
        match=(
            r"too few measurements: 8 points give 24 equations for the 27 parameters this model can identify"
            r" \(base_tx.*need at least 10 points"
        ),
    ):
        cal.calibrate(meas, kr5, tool=TOOL)


def test_a_joint_that_never_moves_is_named(kr5):
    """All poses with joint 4 at one value: an error naming the joint, its value and the parameters the data
    cannot see; holding exactly those fixed, the calibration runs."""
    q = cal.configurations(kr5, 60)
    q[:, 3] = 0.25
    meas = cal.simulate(kr5, q, tool=TOOL)
    with pytest.raises(
        dv.DenavitError,
        match=(
            r"joint\(s\) 4 \(A4\) never move in the data \(q4 = 0.25 rad in all 60 poses\): the data cannot identify"
            r" (\w+, )*\w+ .*hold these fixed: fix=\["
        ),
    ) as e:
        cal.calibrate(meas, kr5, tool=TOOL)
    names = ast.literal_eval(str(e.value).split("fix=")[1])
    res = cal.calibrate(meas, kr5, tool=TOOL, fix=names)
    assert all(res.status[res.parametrization.index(n)] == "fixed" for n in names) and res.rms < 1e-9


def test_calibration_convention_aliases_are_the_cores(kr5):
    """Regression: calibrate(..., convention="craig") / "ED-H" were unknown calibration conventions; every
    convention name (here and in Calibration.table) goes through the core's parser (_core.convention_info).
    POE is still refused, with the reason."""
    meas = cal.simulate(kr5, cal.configurations(kr5, 40), tool=TOOL, noise=NOISE)
    res = cal.calibrate(meas, kr5, convention="ED-H", tool=TOOL)
    assert res.convention == "edh" and res.table("Craig").convention == "mdh"
    assert cal.parametrize(kr5, "craig").convention == "mdh"
    with pytest.raises(dv.DenavitError, match="product-of-exponentials calibration is not available yet"):
        cal.parametrize(kr5, "POE")


def test_configurations_are_the_unscrambled_halton_sequence(kr5):
    """configurations() is the Halton sequence from index 1 (bases 2, 3, 5, ...; scipy.stats.qmc), point for
    point the radical inverses the hand-written generator it replaced gave, so seeded outcomes stay put."""

    def radical_inverse(k, b):
        f, r = 1.0, 0.0
        while k > 0:
            f /= b
            r += f * (k % b)
            k //= b
        return r

    robot = as_robot(kr5)
    lo = np.maximum(robot.lower, -np.pi)
    hi = np.minimum(robot.upper, np.pi)
    Q = cal.configurations(kr5, 50, skip=3)
    expected = [
        [lo[j] + (hi[j] - lo[j]) * radical_inverse(k, b) for j, b in enumerate((2, 3, 5, 7, 11, 13))]
        for k in range(3, 53)
    ]
    np.testing.assert_array_equal(Q, np.array(expected))


def test_an_unknown_tool_point_is_found_from_a_zero_start(kr5):
    """No tool given: the nominal tool is the flange origin (the KR5's wrist centre); the tool point is fitted."""
    meas = cal.simulate(kr5, cal.configurations(kr5, 60), tool=TOOL, noise=NOISE, seed=6)
    res = cal.calibrate(meas, kr5)
    np.testing.assert_allclose([res.value(n)[0] for n in ("tool_x", "tool_y", "tool_z")], TOOL, atol=2e-5)
    assert res.rms < 2 * NOISE


@pytest.mark.parametrize("convention", ["edh", "mdh"])
def test_tool_is_given_in_the_flange(convention, rng):
    """``--tool 50,30,100`` on the UR5 used to come out as tool_z = 182.3 mm (the tool in joint frame 6): the
    tool is in the flange (DH frame 6, docs/conventions.md "Frames"), and the calibrated model keeps the flange."""
    ur5 = dv.load_robot("ur5")
    pz = cal.parametrize(ur5, convention, tool=[0.05, 0.03, 0.1])
    x = dict(zip(pz.names, pz.x0))
    np.testing.assert_allclose([x["tool_x"], x["tool_y"], x["tool_z"]], [0.05, 0.03, 0.1], atol=1e-9)
    m = pz.model(pz.x0)
    np.testing.assert_allclose(m.T_flange_tool[:3, 3], [0.05, 0.03, 0.1], atol=1e-9)
    for q in rng.uniform(-np.pi, np.pi, (10, 6)):
        np.testing.assert_allclose(dv.fk(m.with_tool(np.eye(4)), q), ur5.table.frames(q)[-1], atol=1e-9)


def test_the_solver_builds_jacobians_only_where_it_asks_for_them(kr5, monkeypatch):
    """Trial points get residuals only: the poses evaluated with a Jacobian are the solver's Jacobian
    evaluations (njev) times the poses, fewer than its residual evaluations (every one of which built a Jacobian),
    and the weighted rows of the free columns, which the core writes alone, equal the full Jacobian's entries
    times the weights, bit for bit."""
    from denavit.calibration import least_squares as ls
    from denavit.calibration.parametrization import Parametrization

    pz = cal.parametrize(kr5, "edh", tool=TOOL)
    meas = cal.simulate(kr5, cal.configurations(kr5, 250, skip=3), tool=TOOL, noise=NOISE, seed=2)
    free = [c for c in range(pz.n_params) if pz.names[c] not in pz.rules][:20]
    free = free[::-1]  # in any order
    _, jac = pz.evaluate(pz.x0, meas.q, True)
    w = weights("point", NOISE, 1.0)
    assert np.array_equal(
        ls.jacobian_rows(pz, pz.x0, meas.q, w, free)[1], (jac[:, :3][:, :, free] * w[:3, None]).reshape(-1, len(free))
    )
    jac_poses = []
    evaluate = Parametrization.evaluate

    def counted(self, x, q, jacobian=True, **kw):
        if jacobian:
            jac_poses.append(len(q))
        return evaluate(self, x, q, jacobian, **kw)

    monkeypatch.setattr(Parametrization, "evaluate", counted)
    x0 = pz.x0.copy()
    x0[free] += 1e-4
    _, sol = ls.fit_parameters(pz, x0, free, meas, w, "linear", None)
    # (scipy evaluates the Jacobian once more at the solution, for its result's ``jac``)
    assert sum(jac_poses) <= (sol.njev + 1) * meas.n < sol.nfev * meas.n


def test_a_calibration_remembers_what_it_has_evaluated_and_gets_the_same_result(kr5, monkeypatch):
    """calibrate asks again for evaluations it has made (the analysis' Jacobian at the start of a fit, the last
    residuals and Jacobian at the solution): within ``remembered`` they come from memory, a Jacobian's columns
    from one with more. The core builds fewer Jacobians and the result is the same to the last bit; a memory
    hit gives the caller its own Jacobian array."""
    from denavit.calibration import parametrization as P
    from denavit.calibration import solve

    meas = cal.simulate(kr5, cal.configurations(kr5, 300, skip=5), tool=TOOL, noise=NOISE, seed=4)
    with P.remembered() as memo:
        a = cal.calibrate(meas, kr5, tool=TOOL)
    built_with = memo.built
    built_without = []
    evaluate = P.Parametrization.evaluate

    def counted(self, x, q, jacobian=True, **kw):
        built_without.append(jacobian)
        return evaluate(self, x, q, jacobian, **kw)

    monkeypatch.setattr(P.Parametrization, "evaluate", counted)
    b = solve.calibrate.__wrapped__(meas, kr5, tool=TOOL)  # without the memory
    monkeypatch.undo()
    assert (
        np.array_equal(a.values, b.values)
        and np.array_equal(a.covariance, b.covariance)
        and a.evaluations == b.evaluations
    )
    assert 0 < built_with < sum(built_without), (built_with, sum(built_without))

    pz = cal.parametrize(kr5, "edh", tool=TOOL)
    x, q = pz.x0, meas.q
    with P.remembered() as memo:
        _, J1 = pz.evaluate(x, q, True, rows=3, columns=[4, 1, 7])
        J1[:] = 0.0  # the caller's own array: the memory is not touched
        _, J2 = pz.evaluate(x, q, True, rows=3, columns=[7, 4])
        assert memo.built == 1
    _, J0 = pz.evaluate(x, q, True, rows=3, columns=[7, 4])
    assert np.array_equal(J2, J0) and J2.flags.writeable


def test_a_non_finite_joint_value_is_named_by_row_and_index():
    pz = cal.parametrize(dv.load_robot("kr5"), "edh")
    q = np.zeros((5, 6))
    q[3, 4] = np.nan
    with pytest.raises(dv.DenavitError, match=r"^q \(row 3\) must be finite, got NaN at index 4$"):
        pz.evaluate(pz.x0, q, False)
