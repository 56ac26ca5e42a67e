"""Joint compliance, payload and gravity (issue 37): the robot file's [compliance], the one-line errors, the
elastostatic calibration (compliances recovered within their sigmas, left out where the data show none) and the
compensation at a payload the calibration never saw."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

import denavit as dv
from denavit import _core
from denavit.calibration import Measurements, calibrate, parametrize
from denavit.calibration.compliance import elastic, gravity_torques
from denavit.calibration.least_squares import residuals
from denavit.calibration.selection import COMPLIANCE
from denavit.compensation import compensate
from denavit.geometry import pose
from denavit.io import robotfile as rf
from denavit.io.payload import parse_payload

NOISE = 2e-5
TOOL = np.array([0.04, 0.03, 0.10])
COM = np.array([0.02, 0.0, 0.06])
RATED = 5.0  # kg, the UR5's
#: joint compliances of a UR5-like cobot (rad/(N m)): about 1 mm at the tool under 5 kg
K_TRUE = np.array([0.0, 1.2e-5, 2.5e-5, 1.0e-4, 1.2e-4, 0.0])


def ur5() -> dv.Robot:
    return dv.load_robot("ur5")


def draw(robot, n, rng):
    lo, hi = np.maximum(robot.lower, -math.pi), np.minimum(robot.upper, math.pi)
    return lo + (hi - lo) * rng.random((n, len(lo)))


def true_model(robot, rng):
    pz = parametrize(robot, "edh", tool=TOOL)
    x = pz.x0.copy()
    for c, name in enumerate(pz.names):
        if not name.startswith(("base_", "tool_")):
            x[c] += rng.normal(0, 5e-4) if pz.units[c] == "length" else rng.normal(0, math.radians(0.05))
    return pz.model(x)


def measure(m_true, robot, k, q, mass, rng):
    pl = np.tile(np.r_[mass, COM], (len(q), 1))
    tau = gravity_torques(robot.model(), q, pl)
    p = _core.fk_batch(m_true, q - k * tau)[:, :3, 3] + rng.normal(0, NOISE, (len(q), 3))
    return Measurements(q, p, None, "simulated", payload=pl)


def two_payloads(seed: int, k, n: int = 30):
    """The two-payload protocol: n poses measured at no payload and at the rated one."""
    robot = ur5()
    rng = np.random.default_rng(seed)
    m_true = true_model(robot, rng)
    q = draw(robot, n, rng)
    a, b = measure(m_true, robot, k, q, 0.0, rng), measure(m_true, robot, k, q, RATED, rng)
    train = Measurements(
        np.vstack([a.q, b.q]),
        np.vstack([a.points, b.points]),
        None,
        "training",
        payload=np.vstack([a.payload, b.payload]),
    )
    return robot, m_true, train, rng


# --- robot files and units --------------------------------------------------------------------------------------


def test_the_robot_file_round_trips_compliance_with_its_units(tmp_path):
    k = np.array([0.0, 1.5e-6, 2.25e-6, 4e-6, 5e-6, 5e-6])
    cov = np.diag([0.0, 1e-14, 4e-14, 1e-13, 1e-13, 1e-13])
    r = replace(ur5(), compliance=k, compliance_covariance=cov)
    text = rf.dumps(r, "mm", "deg")
    assert '[compliance]\nunit = "urad/(N m)"' in text
    p = tmp_path / "ur5c.toml"
    p.write_text(text)
    back = rf.read(p)
    assert np.allclose(back.compliance, k, rtol=1e-14, atol=0) and np.allclose(
        back.compliance_covariance, cov, rtol=1e-12, atol=0
    )
    # any unit of the grammar, SI inside
    for unit, scale in (("rad/(N m)", 1.0), ("mrad/Nm", 1e-3), ("urad/(N*m)", 1e-6), ("deg/N/m", math.pi / 180)):
        q = tmp_path / "u.toml"
        q.write_text(text.split("[compliance]")[0] + f'[compliance]\nunit = "{unit}"\nvalues = [0, 1, 2, 3, 4, 5]\n')
        assert np.allclose(rf.read(q).compliance, scale * np.arange(6.0), rtol=1e-15, atol=0)
    # a prismatic joint takes a length per force
    from denavit.io.payload import compliance_unit

    assert compliance_unit("um/N", "prismatic", "x") == 1e-6
    # without [compliance]: rigid, nothing written
    assert "[compliance]" not in rf.dumps(ur5(), "mm", "deg") and ur5().compliance is None


def _one_line(exc) -> str:
    msg = str(exc.value)
    assert "\n" not in msg
    return msg


def test_one_line_errors(tmp_path):
    text = rf.dumps(ur5(), "mm", "deg")
    p = tmp_path / "neg.toml"
    p.write_text(text + '\n[compliance]\nunit = "urad/(N m)"\nvalues = [0, 1, -2, 3, 4, 5]\n')
    with pytest.raises(dv.DenavitError) as e:
        rf.read(p)
    assert (
        "joint 3 (elbow)" in _one_line(e)
        and "expected a compliance >= 0" in str(e.value)
        and "-2 urad/(N m)" in str(e.value)
    )
    p.write_text(text + "\n[compliance]\nvalues = [0, 1, 2, 3, 4, 5]\n")
    with pytest.raises(dv.DenavitError) as e:
        rf.read(p)
    assert "missing 'unit'" in _one_line(e)
    p.write_text(text + '\n[compliance]\nunit = "mm/N"\nvalues = [0, 1, 2, 3, 4, 5]\n')
    with pytest.raises(dv.DenavitError) as e:
        rf.read(p)
    assert "unknown compliance unit 'mm/N' for revolute joints" in _one_line(e)
    kr5 = rf.dumps(dv.load_robot("kr5"), "mm", "deg")  # no inertials
    p.write_text(kr5 + '\n[compliance]\nunit = "urad/(N m)"\nvalues = [0, 1, 2, 3, 4, 5]\n')
    with pytest.raises(dv.DenavitError) as e:
        rf.read(p)
    assert "need the links' inertial parameters" in _one_line(e)
    with pytest.raises(dv.DenavitError) as e:
        parse_payload("5 @ 0,0,80 mm")
    assert "has no unit" in _one_line(e)
    with pytest.raises(dv.DenavitError) as e:
        parse_payload("5 kgf")
    assert "unknown mass unit" in _one_line(e)
    assert parse_payload("5 kg @ 0,0,80 mm")[0] == 5.0 and np.allclose(
        parse_payload("500 g @ 0,0,8 cm")[1], [0, 0, 0.08]
    )
    # a pose file's payload columns: kg and the file's length unit; a negative mass names its line
    f = tmp_path / "m.csv"
    f.write_text(
        "# units: length=mm"
        " angle=deg\nq1,q2,q3,q4,q5,q6,x,y,z,payload_mass,payload_z\n0,-90,90,0,90,0,100,200,300,5,80\n"
        "0,-80,90,0,90,0,1,2,3,-1,0\n"
    )
    from denavit.io.measurements import read_measurements

    with pytest.raises(dv.DenavitError) as e:
        read_measurements(f)
    assert f"{f}:4" in _one_line(e) and "payload_mass" in str(e.value)
    f.write_text(
        "# units: length=mm"
        " angle=deg\nq1,q2,q3,q4,q5,q6,x,y,z,payload_mass,payload_z\n0,-90,90,0,90,0,100,200,300,5,80\n"
    )
    assert np.allclose(read_measurements(f).payload, [[5, 0, 0, 0.08]])
    # a sweep file's too: per point, carried into the measurements calibrate reads
    from denavit.io.sweeps import read_long_csv, to_long_csv
    from denavit.sweeps import simulate

    lines = to_long_csv(
        simulate(ur5().model(), home=np.zeros(6), ranges=np.tile([-0.5, 0.5], (6, 1)), points_per_sweep=4)
    ).splitlines()
    rows = [
        (
            ln
            if ln.startswith("#")
            else ln + (",payload_mass,payload_x" if ln.startswith("joint") else f",{2.5 * (i % 2)},{10 * (i % 2)}")
        )
        for i, ln in enumerate(lines)
    ]
    s = tmp_path / "s.csv"
    s.write_text("\n".join(rows) + "\n")
    sw = read_long_csv(s)
    assert sw.sweeps[0].payload.shape == (4, 4) and set(sw.sweeps[0].payload[:, 0]) == {0.0, 2.5}
    assert np.allclose(
        read_measurements(s).payload[:, 1], read_measurements(s).payload[:, 0] * 0.004
    )  # 10 mm per 2.5 kg here
    # calibrate without inertials: no compliance, one note says why
    robot, _, train, _ = two_payloads(0, K_TRUE, 12)
    res = calibrate(replace(train, kinds=None), dv.load_robot("kr5"), tool=TOOL, model="base-tool")
    why = [n for n in res.notes if "compliance not modelled" in n]
    assert len(why) == 1 and "carries no link masses" in why[0] and "\n" not in why[0]


# --- the model ----------------------------------------------------------------------------------------------------


def test_payload_torque_and_compliance_jacobian():
    """The payload's torque equals the point mass's on the last link; the compliances' Jacobian columns match central
    differences of the deflected chain."""
    robot = ur5()
    rng = np.random.default_rng(3)
    q = draw(robot, 5, rng)
    pl = np.tile(np.r_[2.0, COM], (5, 1))
    m = robot.model()
    ins = m.inertias
    masses, coms, inertias = np.array(ins["masses"]), np.array(ins["coms"]), np.array(ins["inertias"])
    flange = np.asarray(m.T_last_flange)
    c6 = flange[:3, :3] @ COM + flange[:3, 3]  # the payload's centre in joint frame 6
    coms[5] = (masses[5] * coms[5] + 2.0 * c6) / (masses[5] + 2.0)
    masses[5] += 2.0
    heavy = m.with_inertias(masses, coms, inertias)
    assert np.allclose(gravity_torques(m, q, pl), _core.gravity_torques_batch(heavy, q), rtol=1e-9, atol=1e-9)
    from denavit.calibration.compliance import with_compliance

    meas = Measurements(q, np.zeros((5, 3)), None, "x", payload=pl)
    pz, _ = with_compliance(parametrize(robot, "edh", tool=TOOL), meas, robot, True)
    x = pz.x0.copy()
    x[pz.n_geometric :] = K_TRUE
    cols = list(pz.compliance_idx)
    J = residuals(pz, x, meas, np.ones(6), columns=cols)[1]
    for i, c in enumerate(cols):
        e = np.zeros_like(x)
        e[c] = 1e-7
        d = (
            residuals(pz, x + e, meas, np.ones(6), jacobian=False)[0]
            - residuals(pz, x - e, meas, np.ones(6), jacobian=False)[0]
        ) / 2e-7
        assert np.allclose(J[:, i], d, rtol=1e-5, atol=1e-6 * np.abs(d).max())


def test_compliances_recovered_within_their_sigmas():
    robot, _, train, _ = two_payloads(1, K_TRUE)
    res = calibrate(train, robot, tool=TOOL)
    assert res.model_choice.chosen.endswith(COMPLIANCE)
    for j in (1, 2, 3, 4):
        v, s = res.value(f"k_{j + 1}")
        assert np.isfinite(s) and abs(v - K_TRUE[j]) < 3 * s, (j, v, s, K_TRUE[j])
    assert res.status[res.names.index("k_1")] != "free"  # a vertical axis holds no gravity torque
    assert np.isclose(res.rms, math.sqrt(3) * NOISE, rtol=0.25)
    # plan predicted these sigmas before measuring (the Cramer-Rao bound at the nominal, the same poses and payloads)
    from denavit.calibration.compliance import plan_compliance

    p = plan_compliance(robot, train.q[:30], (0.0, RATED), com=COM, noise=NOISE, tool=TOOL)
    for j in (1, 2, 3, 4):
        assert 0.7 < res.value(f"k_{j + 1}")[1] / p.sigma[j] < 1.4
    assert np.isnan(p.sigma[0])


@pytest.mark.parametrize("seed", [2, 3])
def test_auto_leaves_compliance_out_of_rigid_data(seed):
    robot, _, train, _ = two_payloads(seed, np.zeros(6))
    res = calibrate(train, robot, tool=TOOL)
    assert not res.model_choice.chosen.endswith(COMPLIANCE)
    assert all(s != "free" for n, s in zip(res.names, res.status, strict=True) if n.startswith("k_"))
    rigid = calibrate(train, robot, tool=TOOL, compliance=False)  # the geometric result is the one without compliance
    assert res.model_choice.chosen == rigid.model_choice.chosen and np.allclose(
        res.values[: len(rigid.values)], rigid.values, rtol=0, atol=1e-12
    )


def test_compensation_at_a_payload_the_calibration_never_saw():
    """Calibrated at 0 and 5 kg, compensated at 2.5 kg: the error after is within 1.5x the prediction (RMS over 150
    positions), and well below the geometry-only calibration's."""
    robot, m_true, train, rng = two_payloads(4, K_TRUE)
    res = calibrate(train, robot, tool=TOOL)
    el = elastic(res)
    assert el is not None
    q = draw(robot, 150, rng)
    half = np.tile(np.r_[RATED / 2, COM], (len(q), 1))
    positions = _core.fk_batch(m_true, q)
    nominal = robot.model().with_tool(pose(p=TOOL))  # the controller knows the tool
    c = compensate(nominal, res, positions, q_nominal=q, payload=(RATED / 2, COM))
    ok = c.ok  # (a row whose identified solution leaves the program's branch is flagged, not compensated)
    assert ok.mean() > 0.95 and c.predicted_after is not None
    reached = _core.fk_batch(m_true, c.q_command - K_TRUE * gravity_torques(robot.model(), c.q_command, half))
    err = np.linalg.norm(reached[:, :3, 3] - positions[:, :3, 3], axis=1)[ok]
    rms, pred = math.sqrt(np.mean(err**2)), math.sqrt(np.mean(c.predicted_after[ok] ** 2))
    assert rms < 1.5 * pred, (rms, pred)
    geo = calibrate(train, robot, tool=TOOL, compliance=False)
    g = compensate(nominal, geo, positions, q_nominal=q)
    reached = _core.fk_batch(m_true, g.q_command - K_TRUE * gravity_torques(robot.model(), g.q_command, half))
    assert rms < 0.5 * math.sqrt(np.mean(np.linalg.norm(reached[:, :3, 3] - positions[:, :3, 3], axis=1)[ok] ** 2))


def test_a_saved_calibration_carries_its_compliances_and_validate_uses_them(tmp_path):
    """calibrate -> robot file ([compliance] with its covariance) -> validate at another payload: the joints deflected
    by the saved compliances (errors at the noise), the rigid reading of the same file far worse."""
    robot, m_true, train, rng = two_payloads(5, K_TRUE)
    res = calibrate(train, robot, tool=TOOL)
    saved = res.robot()
    assert saved.compliance is not None and saved.compliance_covariance is not None
    p = tmp_path / "cal.toml"
    rf.save(saved, p, "mm", "deg")
    back = rf.read(p)
    assert np.allclose(back.compliance, saved.compliance, rtol=1e-12, atol=0)
    q = draw(robot, 40, rng)
    session = measure(m_true, robot, K_TRUE, q, RATED / 2, rng)
    v = dv.validate(res, session)
    assert v.rms < 2 * math.sqrt(3) * NOISE and any("deflected" in n for n in v.notes)
    assert (
        back.compliance_flange is not None and abs(back.compliance_flange[2, 3] - 0.0823) < 5e-3
    )  # the UR5's flange, 82.3 mm past the last frame
    saved_v = dv.validate(back, session)  # the robot file alone: its [compliance], inertials and flange
    assert saved_v.rms < 2 * math.sqrt(3) * NOISE and abs(saved_v.rms - v.rms) < 0.2 * v.rms
    rigid = dv.validate(
        res, replace(session, payload=None), payload=0.0
    )  # the links' weight only: the payload's deflection unexplained
    assert rigid.rms > 3 * v.rms


def test_the_predicted_error_in_the_measurement_frame_and_its_rms_bound_match_sampled_parameter_errors():
    """The prediction propagates the calibration's covariance through its Jacobian: checked against the model itself
    at 1000 parameter vectors drawn from that covariance (the compliant chain at the commands, each row's torques). With
    ``registration=True`` (positions located in the measurement frame) the base registration's draws move the tool
    too; without, they are left out (the robot base frame). Every row's error comes from one draw, so the RMS over the
    rows scatters as a generalised chi-square: ``predicted_rms_bound(0.95)`` is exceeded in about 5 % of the draws."""
    robot, m_true, train, rng = two_payloads(4, K_TRUE)
    res = calibrate(train, robot, tool=TOOL)
    q = draw(robot, 60, rng)
    nominal = robot.model().with_tool(pose(p=TOOL)).with_base(res.model().T_world_base)
    positions = _core.fk_batch(nominal, q)
    pz, free = res.parametrization, [res.parametrization.index(n) for n in res.free_names]
    base = np.array([n.startswith("base_") for n in res.free_names])
    L = np.linalg.cholesky(np.asarray(res.covariance))
    dx = rng.standard_normal((1000, len(free))) @ L.T
    for registration in (True, False):
        c = compensate(nominal, res, positions, q_nominal=q, payload=(RATED / 2, COM), registration=registration)
        ok = c.ok
        assert ok.mean() > 0.8 and math.isclose(c.predicted_rms, math.sqrt(np.mean(c.predicted_after[ok] ** 2)))
        half = np.tile(np.r_[RATED / 2, COM], (ok.sum(), 1))
        inputs = np.hstack([c.q_command[ok], gravity_torques(robot.model(), c.q_command[ok], half)])
        p0 = pz.evaluate(res.values, inputs, False)[0][:, :3, 3]
        e2 = np.empty((len(dx), ok.sum()))
        for i, d in enumerate(dx):
            x = res.values.copy()
            x[free] += d if registration else np.where(base, 0.0, d)
            e2[i] = np.sum((pz.evaluate(x, inputs, False)[0][:, :3, 3] - p0) ** 2, axis=1)
        # each row's mean square error over the draws is its predicted sigma^2 (1000 draws: 5 % on a 3-D error)
        assert np.allclose(e2.mean(axis=0) / c.predicted_after[ok] ** 2, 1.0, atol=0.2)
        rms2 = e2.mean(axis=1)
        assert abs(rms2.mean() / c.predicted_rms**2 - 1) < 0.06
        beyond = np.mean(np.sqrt(rms2) > c.predicted_rms_bound(0.95))
        assert 0.03 < beyond < 0.075, beyond
        assert 5 < c.predicted_dof < len(free)
    # a robot file's [covariance] has no registration to include
    with pytest.raises(dv.DenavitError, match="carries no base registration"):
        compensate(nominal, res.robot(), positions, q_nominal=q, payload=(RATED / 2, COM), registration=True)


def test_a_compliance_fitted_negative_is_held_at_0_with_the_sigma_the_data_give_it():
    """k >= 0 in calibrate as in identify: a rigid wrist joint's compliance fitted below zero is held at its bound 0,
    keeps the sigma the data give it (the covariance with it free at 0: it had been saved with none, as if known to be
    exactly 0), and a note says so; the saved robot file carries that variance into every prediction."""
    from denavit.calibration.solve import AT_BOUND

    k = K_TRUE.copy()
    k[4] = 0.0  # joint 5 rigid: its estimate falls below 0 about half the time (seed 3: it does)
    robot, _, train, _ = two_payloads(3, k)
    res = calibrate(train, robot, tool=TOOL, model=f"full-prior{COMPLIANCE}")
    c = res.names.index("k_5")
    assert res.status[c] == AT_BOUND and res.values[c] == 0.0
    v, s = res.value("k_5")
    assert v == 0.0 and np.isfinite(s) and 1e-5 < s < 1e-3, s  # the free fit's sigma on these poses: 6.6e-5
    assert any(n.startswith("k_5: compliance held at 0") for n in res.notes), res.notes
    saved = res.robot()
    assert saved.compliance[4] == 0.0 and math.isclose(math.sqrt(saved.compliance_covariance[4, 4]), s, rel_tol=1e-9)


# --- one covariance of the geometry and the compliances in the robot file -------------------------------------------


def _saved(res, tmp_path, convention="edh"):
    """``res.robot(convention)`` through a robot file in mm and deg and back."""
    p = tmp_path / f"cal_{convention}.toml"
    rf.save(res.robot(convention=convention), p, "mm", "deg")
    return rf.read(p)


def _ratios(res, back, session, nominal):
    """Per row, the file's predicted sigma over the calibration's: validate's at the session's poses, compensate's
    predicted_after at their positions (the rows both send)."""
    a, b = dv.validate(res, session), dv.validate(back, session)
    T = _core.fk_batch(nominal, session.q)
    ca = compensate(nominal, res, T, q_nominal=session.q, payload=session.payload)
    cb = compensate(nominal, back, T, q_nominal=session.q, payload=session.payload)
    ok = ca.ok & cb.ok
    assert ok.mean() > 0.8
    return b.sigma / a.sigma, cb.predicted_after[ok] / ca.predicted_after[ok]


@pytest.mark.parametrize("case", ["two payloads", "one payload, 20 poses"])
def test_a_saved_calibration_predicts_as_the_calibration(case, tmp_path):
    """calibrate -> robot file ([covariance] and [compliance] with their cross_covariance) -> validate and compensate
    at a payload the calibration never saw: every row's predicted sigma is the calibration's own within 1 % (measured
    0.2 %: the central differences through the table's extraction, and the file's gravity torques from its own table).
    Without the cross-covariance (a file written before it) the geometry and the compliances are taken as uncorrelated:
    -3 % to +4 % on the two-payload protocol, -11 % to +12 % calibrated on 20 poses at one payload (their correlation
    strong). POE (exact for every geometry) predicts the same: its payload had been taken at its home pose's frame
    instead of the flange (0.29 m off)."""
    robot = ur5()
    if case == "two payloads":
        _, m_true, train, rng = two_payloads(4, K_TRUE)
        res, spread = calibrate(train, robot, tool=TOOL), 0.02
    else:
        rng = np.random.default_rng(4)
        m_true = true_model(robot, rng)
        train = measure(m_true, robot, K_TRUE, draw(robot, 40, rng)[:20], RATED, rng)
        res, spread = calibrate(train, robot, tool=TOOL, model=f"full{COMPLIANCE}"), 0.08
    assert res.model_choice.chosen == f"full{COMPLIANCE}"
    session = measure(m_true, robot, K_TRUE, draw(robot, 60, rng), RATED / 2, rng)
    nominal = robot.model().with_tool(pose(p=TOOL))
    back = _saved(res, tmp_path)
    assert back.compliance_cross is not None and back.compliance_cross.shape == (len(back.covariance), 6)
    for r in _ratios(res, back, session, nominal):
        assert np.all(np.abs(r - 1) < 0.01), (r.min(), r.max())
    # the correlation matters: without it the file misses by more than the spread
    v = _ratios(res, replace(back, compliance_cross=None), session, nominal)[0]
    assert np.max(np.abs(v - 1)) > spread, (v.min(), v.max())
    poe = _saved(res, tmp_path, "poe")
    a, b = dv.validate(res, session), dv.validate(poe, session)
    assert np.all(np.abs(b.sigma / a.sigma - 1) < 0.01) and abs(b.rms - a.rms) < 0.01 * a.rms


def test_a_rigid_calibration_s_file_predicts_as_it_does(tmp_path):
    """The robot file's [covariance] is propagated through central differences of a small step (the linearisation at
    the estimate): a step of each parameter's sigma had taken the curvature in, and the saved ED-H table (joint
    offsets with sigmas of 0.05-0.09 rad, their sum well determined) predicted up to 28 % above the calibration at a
    configuration. Now within 1e-5."""
    robot, _, train, rng = two_payloads(4, K_TRUE)
    res = calibrate(train, robot, tool=TOOL, compliance=False)
    back = _saved(res, tmp_path)
    q = draw(robot, 60, rng)
    from denavit.compensation import predicted_sigma, table_sigma

    np.testing.assert_allclose(table_sigma(back, q), predicted_sigma(res, q), rtol=1e-5)


def test_files_without_the_cross_covariance_still_read_and_bad_ones_say_why():
    """A robot file written before the cross-covariance was carried reads as before (the geometry and the compliances
    uncorrelated). The cross-covariance is in the products of its row's [covariance] unit and the compliance unit, and
    a bad one is one line naming the file and the section: without the [covariance] its rows are of, a row missing,
    a correlation beyond 1."""
    import re

    robot, m_true, train, rng = two_payloads(4, K_TRUE)
    res = calibrate(train, robot, tool=TOOL)
    saved = res.robot()
    doc = rf.tomllib.loads(rf.dumps(saved, "mm", "deg"))
    cross = doc["compliance"]["cross_covariance"]
    old = dict(doc, compliance={k: v for k, v in doc["compliance"].items() if k != "cross_covariance"})
    back = rf.from_dict(old, "old.toml")
    assert back.compliance_cross is None and back.compliance_covariance is not None
    session = measure(m_true, robot, K_TRUE, draw(robot, 20, rng), RATED / 2, rng)
    assert dv.validate(back, session).sigma is not None
    # a length row of a file in mm with unit = "urad/(N m)": mm urad/(N m); an angle row's deg urad/(N m)
    P = len(saved.covariance)
    entry = np.array([1e-3 if u == "length" else math.radians(1.0) for u in _entry_units(saved.table)])
    np.testing.assert_allclose(np.array(cross), saved.compliance_cross / np.outer(entry, np.full(6, 1e-6)), rtol=1e-12)
    no_cov = {k: v for k, v in doc.items() if k != "covariance"}
    short = dict(doc, compliance=dict(doc["compliance"], cross_covariance=cross[:-1]))
    big = dict(doc, compliance=dict(doc["compliance"], cross_covariance=[[1e3 * v for v in row] for row in cross]))
    for d, match in (
        (no_cov, "expected it beside the file's [covariance] and this table's covariance"),
        (short, f"expected {P} rows (one per [covariance] entry) of 6 numbers (one per joint), got {P - 1}"),
        (big, "positive semi-definite (a correlation beyond 1)"),
    ):
        with pytest.raises(dv.DenavitError, match=re.escape(match)) as e:
            rf.from_dict(d, "cal.toml")
        assert str(e.value).startswith("cal.toml, [compliance]: cross_covariance: ") and "\n" not in str(e.value)


def _entry_units(table) -> list:
    """Per [covariance] entry of ``table`` (its cells row by row, the tool's x, y, z): "length" or "angle"."""
    angle = np.array(table.angle_columns)
    cells = ["angle" if angle[c] else "length" for _ in range(len(table.params)) for c in range(len(angle))]
    return cells + ["length"] * 3


def test_convert_carries_the_compliances_with_their_flange(tmp_path):
    """`denavit convert` had dropped [compliance] (a converted calibration compensated as a rigid arm), and fleet diff's
    conversion kept the compliances' flange in the old table's last frame: now both carry the compliances, their
    covariance and cross block (through the conversion's Jacobian) and the flange into the new last frame, and the
    converted robot deflects under a payload as the original does."""
    from typer.testing import CliRunner

    from denavit.cli import app
    from denavit.conversion import converted_robot

    robot, _, train, rng = two_payloads(5, K_TRUE)
    saved = calibrate(train, robot, tool=TOOL).robot()
    src = tmp_path / "cal.toml"
    rf.save(saved, src, "mm", "deg")
    q = draw(robot, 20, rng)
    pl = (RATED, COM)
    T = dv.fk_batch(saved.model(), q)
    want = compensate(saved, saved, T, q_nominal=q, payload=pl)
    out = tmp_path / "cal_poe.toml"
    r = CliRunner().invoke(app, ["convert", str(src), "--to", "poe", "-o", str(out)])
    assert r.exit_code == 0, r.output
    back = rf.read(out)
    assert back.compliance is not None and np.allclose(back.compliance, saved.compliance, rtol=1e-9, atol=0)
    assert back.compliance_cross is not None
    got = compensate(saved, back, T, q_nominal=q, payload=pl)  # the same deflection: the same commands
    assert np.abs(got.q_command - want.q_command).max() < 1e-6
    assert np.allclose(got.predicted_after, want.predicted_after, rtol=0.02)
    # a table that cannot hold the axes (MDH: the UR5's parallel shoulder and elbow tilted) carries no inertias, and
    # then no compliances: said, not silently kept in frames they no longer fit
    r = CliRunner().invoke(app, ["convert", str(src), "--to", "mdh", "-o", str(tmp_path / "cal_mdh.toml")])
    assert r.exit_code == 0 and "nor the joints' compliances" in " ".join(r.output.split()), r.output
    # fleet diff's route (Python): the compliances' flange follows the new last frame
    conv = converted_robot(saved, _core.extract(_core.axes(saved.model(), np.zeros(6)), "poe").table)[0]
    F, G = (np.asarray(r.table.frames(np.zeros(6)))[-1] @ r.compliance_flange for r in (conv, saved))
    np.testing.assert_allclose(F, G, atol=1e-9)
    assert not np.allclose(conv.compliance_flange, saved.compliance_flange, atol=1e-3)  # (other last frames)
