"""Compensation (denavit.compensation, core compensate.rs): targets in, commands for a nominal controller out."""

import numpy as np
import pytest

import denavit as dv
from denavit import calibration as cal
from denavit import compensation as cp

TOOL = np.array([0.05, 0.03, 0.10])


DEG_005 = np.radians(0.05)


def kr5_pair(seed=3, length=0.5e-3, angle=DEG_005):
    kr5 = dv.load_robot("kr5")
    t = kr5.table
    E = np.random.default_rng(seed).uniform(-1, 1, t.params.shape) * np.where(np.array(t.angle_columns), angle, length)
    tool = np.eye(4)
    tool[:3, 3] = TOOL
    true = dv.Table(t.convention, t.params + E, t.kinds, t.T_world_base, t.T_last_tool).to_model("true", kr5.names, kr5.lower, kr5.upper)
    return kr5, kr5.model().with_tool(tool), true.with_tool(tool)


def program(kr5, count, seed=5):
    """``count`` configurations over 0.8 of the joint limits, kept 10 deg clear of the KR5's singularities as a
    program is: the wrist (A5 = 0) and the stretched arm (the wrist centre in line with A2 and A3, at
    A3 = atan(a3 / d4) = 10.95 deg, KUKA's zero being the forearm in line with the upper arm). Near them the
    identified robot reaches a target only on the other branch (a row 2.3 deg from both had been flagged)."""
    rng = np.random.default_rng(seed)
    out = []
    while len(out) < count:
        q = rng.uniform(kr5.lower, kr5.upper) * 0.8
        if abs(q[4]) > np.radians(10) and abs(q[2] - np.arctan2(0.12, 0.62)) > np.radians(10):
            out.append(q)
    return np.array(out)


def test_exact_models_return_the_targets():
    kr5, nominal, _ = kr5_pair()
    Q = program(kr5, 200)
    T = dv.fk_batch(nominal, Q)
    c = cp.compensate(nominal, nominal, T, q_nominal=Q)
    assert c.ok.all()
    np.testing.assert_allclose(c.commands, T, atol=1e-12)
    np.testing.assert_allclose(c.q, Q, atol=1e-12)
    assert c.before.max() < 1e-12


def test_a_known_error_model_is_undone_through_a_nominal_controller():
    kr5, nominal, true = kr5_pair()
    Q = program(kr5, 300)
    T = dv.fk_batch(nominal, Q)
    c = cp.compensate(nominal, true, T, q_nominal=Q)
    ok = c.ok
    assert ok.mean() > 0.9 and np.median(c.before) > 5e-4
    ctrl = dv.ik_batch(nominal, c.commands[ok], Q[ok], restarts=0)
    assert ctrl.success.all()
    reached = dv.fk_batch(true, ctrl.q)
    np.testing.assert_allclose(reached[:, :3, 3], T[ok, :3, 3], atol=1e-9)
    np.testing.assert_allclose(reached[:, :3, :3], T[ok, :3, :3], atol=1e-9)


def test_flags_and_the_path_mode():
    kr5, nominal, true = kr5_pair()
    T = dv.fk_batch(nominal, program(kr5, 3))
    T[1, :3, 3] += [5.0, 0.0, 0.0]  # 5 m away: unreachable
    c = cp.compensate(nominal, true, T, q0=program(kr5, 1)[0], restarts=3)
    assert list(c.reached) == [True, False, True] and not c.ok[1]
    # a path that flips its shoulder half way: the jump is flagged
    q = np.tile(np.radians([30, -90, 90, 0, 60, 0]), (4, 1))
    q[2:, 0] += 2.0
    c = cp.compensate(nominal, true, dv.fk_batch(nominal, q), q_nominal=q, path=True)
    assert list(c.path_jump) == [False, False, True, False]


def test_predicted_error_after_matches_the_real_one():
    """Calibrate from 100 simulated poses (0.02 mm noise), compensate, run on the true robot: the RMS
    position error after is within 1.5x of what the calibration covariance predicts (fixed seed)."""
    kr5, nominal, true = kr5_pair()
    q = cal.configurations(kr5, 100)
    c = cal.calibrate(cal.simulate(true, q, tool=TOOL, noise=2e-5, seed=2), kr5, tool=TOOL)
    Q = program(kr5, 300)
    T = dv.fk_batch(nominal, Q)
    res = cp.compensate(nominal, c, T, q_nominal=Q, result=c)
    ok = res.ok
    ctrl = dv.ik_batch(nominal, res.commands[ok], Q[ok], restarts=0)
    after = np.linalg.norm(dv.fk_batch(true, ctrl.q)[:, :3, 3] - T[ok, :3, 3], axis=1)
    ratio = np.sqrt(np.mean(after**2)) / np.sqrt(np.mean(res.predicted_after[ok] ** 2))
    assert 1 / 1.5 < ratio < 1.5, ratio
    am = cp.accuracy_map(nominal, c, c, count=200)
    s = am.summary()
    assert s["nominal"]["rms"] > 20 * s["identified"]["rms"]


def test_bad_input():
    kr5, nominal, _ = kr5_pair()
    T = dv.fk_batch(nominal, program(kr5, 2))
    with pytest.raises(dv.DenavitError, match="expected 6, got 2"):
        cp.compensate(nominal, dv.Table("dh", np.array([[0, 0, 1.0, 0], [0, 0, 1.0, 0]])).to_model(), T)
    bad = T.copy()
    bad[1, :3, :3] *= 1.1
    with pytest.raises(dv.DenavitError, match=r"targets\[1\]"):
        cp.compensate(nominal, nominal, bad)
    with pytest.raises(dv.DenavitError, match="q_nominal"):
        cp.compensate(nominal, nominal, T, q_nominal=np.zeros((2, 5)))
    with pytest.raises(dv.DenavitError, match="expected an identification or a calibration"):
        cp.predicted_sigma(nominal, np.zeros((1, 6)))


def write_program(path, rows, header, units="length=mm angle=deg"):
    path.write_text(f"# units: {units}\n{header}\n" + "".join(",".join(repr(float(v)) for v in r) + "\n" for r in rows))


def test_cli_compensates_joint_rows_and_poses(tmp_path):
    """`denavit compensate` on joint rows (deg) and on poses (m, rotation vector): every written row reaches its
    target on the identified robot, and the joint rows keep the program's branch."""
    from cli import run
    from denavit.geometry import matrix_rotvec
    from denavit.io import robotfile
    from denavit.robot import Robot

    kr5, nominal, true = kr5_pair()
    t = dv.extract(dv.axes(true.with_tool(np.eye(4)), np.zeros(6)), "dh", nominal=kr5.table).table
    ident = tmp_path / "kr5_id.toml"
    robotfile.save(Robot("kr5_id", t, kr5.names, kr5.lower, kr5.upper), ident, "mm", "deg")
    Q = program(kr5, 25)
    write_program(tmp_path / "q.csv", np.degrees(Q), "q1,q2,q3,q4,q5,q6")
    T = dv.fk_batch(kr5.model(), Q)
    write_program(tmp_path / "p.csv", [[*Ti[:3, 3], *matrix_rotvec(Ti[:3, :3])] for Ti in T], "x,y,z,rx,ry,rz", "length=m angle=rad")
    for f in ("q.csv", "p.csv"):
        out = tmp_path / f"out_{f}"
        run("compensate", tmp_path / f, "--nominal", "kr5", "--identified", ident, "-o", out)
        rows = np.array([[float(v) for v in line.split(",")] for line in out.read_text().splitlines()[3:]])
        assert rows.shape == (25, 18) and (rows[:, 12] == 1).all()
        q_id = np.radians(rows[:, 6:12])
        reached = dv.fk_batch(dv.load_model(ident), q_id)
        np.testing.assert_allclose(reached[:, :3, 3], T[:, :3, 3], atol=1e-9)
        np.testing.assert_allclose(reached[:, :3, :3], T[:, :3, :3], atol=1e-9)
        if f == "q.csv":
            assert np.abs(q_id - Q).max() < 0.05
    # --report: the compensation's HTML report (the browser test in test_report checks what it draws)
    page = tmp_path / "comp.html"
    run("compensate", tmp_path / "q.csv", "--nominal", "kr5", "--identified", ident, "--report", page)
    html = page.read_text()
    assert html.startswith("<!DOCTYPE html>") and "kr5_id" in html and len(html) < 2e6


def test_cli_compensate_bad_input(tmp_path):
    from cli import run

    Q = program(dv.load_robot("kr5"), 3)
    write_program(tmp_path / "q.csv", np.degrees(Q), "q1,q2,q3,q4,q5,q6")
    p = run("compensate", tmp_path / "q.csv", "--nominal", "kr5", "--identified", "puma560x", ok=False)
    assert p.returncode == 2 and "unknown model 'puma560x'" in p.stderr and len(p.stderr.strip().splitlines()) == 1
    p = run("compensate", tmp_path / "q.csv", "--nominal", "kr5", "--identified", "ur5", ok=False)
    assert p.returncode == 1 and "no target can be sent" in p.stdout
    T = dv.fk_batch(dv.load_model("kr5"), Q)
    # positions in mm under a file that says metres
    write_program(tmp_path / "p.csv", [[*(Ti[:3, 3] * 1e3), 0, 0, 0] for Ti in T], "x,y,z,rx,ry,rz", "length=m angle=rad")
    p = run("compensate", tmp_path / "p.csv", "--nominal", "kr5", "--identified", "kr5", ok=False)
    assert p.returncode == 2 and "p.csv:3: the target is" in p.stderr and "is the file's length unit right?" in p.stderr
    write_program(tmp_path / "bad.csv", [[1, 2, 3]], "q1,q2,q3")
    p = run("compensate", tmp_path / "bad.csv", "--nominal", "kr5", "--identified", "kr5", ok=False)
    assert p.returncode == 2 and "bad.csv:2: header must be 'x,y,z,rx,ry,rz' and/or 'q1,...,q6' (6 joints)" in p.stderr
    write_program(tmp_path / "nan.csv", [[1, 2, 3, 4, 5, float("nan")]], "q1,q2,q3,q4,q5,q6")
    p = run("compensate", tmp_path / "nan.csv", "--nominal", "kr5", "--identified", "kr5", ok=False)
    assert p.returncode == 2 and "nan.csv:3: column 'q6' must be finite" in p.stderr


def test_identification_report_has_the_accuracy_section():
    """The HTML report of an identification with a nominal says how accurate each model is (a table and a chart)."""
    pytest.importorskip("plotly")
    from denavit import report
    from denavit.cli.identify import example_path
    from denavit.io import sweeps as swio

    res = dv.identify(swio.read_long_csv(example_path("kr5")), nominal=dv.load_robot("kr5"))
    page = report.report_html(res)
    assert 'id="accuracy"' in page and "accuracy-chart" in page and "nominal (what the robot misses)" in page


def test_cli_exports_the_ur_kinematics_file(tmp_path):
    """`denavit export ROBOT --ur-kinematics OUT`: the identified UR5 as ur_description reads it; another robot is
    refused in one line."""
    from cli import run
    from denavit.io import robotfile, ur_calibration
    from denavit.robot import Robot

    r = dv.load_robot("ur5")
    t = r.table
    E = np.random.default_rng(2).normal(0, 1, t.params.shape) * np.where(np.array(t.angle_columns), np.radians(0.05), 0.5e-3)
    E[5, 2:] = 0
    ident = tmp_path / "ur5_id.toml"
    robotfile.save(Robot("ur5_id", dv.Table("dh", t.params + E, t.kinds, t.T_world_base, t.T_last_tool), r.names, r.lower, r.upper), ident, "mm", "deg")
    out = tmp_path / "cal.yaml"
    run("export", ident, "--ur-kinematics", out)
    origins = ur_calibration.loads(out.read_text())
    q = np.array([0.3, -1.2, 1.0, 0.4, -0.7, 2.0])
    T = np.eye(4)
    for o, qi in zip(origins, q):
        c, s = np.cos(qi), np.sin(qi)
        T = T @ o @ np.array([[c, -s, 0, 0], [s, c, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1.0]])
    np.testing.assert_allclose(T, dv.fk(dv.load_model(ident), q), atol=1e-9)  # mm-rounded file: 17 digits
    p = run("export", "kr5", "--ur-kinematics", out, ok=False)
    assert p.returncode == 2 and "expected a calibration of the nominal UR arm" in p.stderr


def test_identify_save_persists_the_covariance_and_compensate_predicts_per_row(tmp_path):
    """`identify --save` writes the parameters' covariance ([covariance], in the file's units); reading it back
    gives the identification's (SI); `compensate` with that robot prints and writes (JSON, per row) the predicted
    error after compensation, from it: the values of compensation.table_sigma at the rows' joint values, within
    20 % of the identification's own prediction (the exact ED-H model of its axes). Before, compensate could not
    predict anything from a robot file."""
    import json

    from cli import run
    from denavit.cli.identify import example_path
    from denavit.io import robotfile
    from denavit.io import sweeps as swio

    saved = tmp_path / "kr5_id.toml"
    run("identify", "--example", "kr5", "--convention", "edh", "--save", saved)
    robot = robotfile.read(saved)
    res = dv.identify(swio.read(example_path("kr5")), nominal=dv.load_robot("kr5"), convention="edh")
    np.testing.assert_allclose(robot.covariance, res.param_cov, rtol=1e-4, atol=1e-16)
    again = tmp_path / "again.toml"
    robotfile.save(robot, again, "m", "rad")
    np.testing.assert_allclose(robotfile.read(again).covariance, robot.covariance, rtol=1e-9, atol=1e-24)
    Q = program(dv.load_robot("kr5"), 5)
    write_program(tmp_path / "q.csv", np.degrees(Q), "q1,q2,q3,q4,q5,q6")
    out = run("compensate", tmp_path / "q.csv", "--nominal", saved, "--identified", saved, "--json", tmp_path / "c.json", columns=200).stdout
    assert "Predicted error after compensation" in out
    rows = json.loads((tmp_path / "c.json").read_text())["predicted_after"]
    sig = cp.table_sigma(robot, Q) * 1e3
    np.testing.assert_allclose([r["sigma_m"] * 1e3 for r in rows], sig, rtol=1e-6)
    np.testing.assert_allclose(sig, cp.predicted_sigma(res, Q) * 1e3, rtol=0.2)


def test_bad_covariance_in_a_robot_file(tmp_path):
    from denavit.io import robotfile

    kr5 = dv.load_robot("kr5")
    text = robotfile.dumps(kr5, "mm", "deg")
    f = tmp_path / "r.toml"
    f.write_text(text + "\n[covariance]\nmatrix = [[1.0, 0.0], [0.0, 1.0]]\n")
    with pytest.raises(dv.DenavitError, match=r"\[covariance\]: matrix: expected 27 rows \(the joints' parameters, then the tool's x, y, z\), got 2"):
        robotfile.read(f)
    bad = np.eye(27)
    bad[0, 1] = 1.0
    f.write_text(text + "\n[covariance]\nmatrix = [" + ", ".join("[" + ", ".join(str(v) for v in r) + "]" for r in bad) + "]\n")
    with pytest.raises(dv.DenavitError, match="symmetric positive semi-definite"):
        robotfile.read(f)
