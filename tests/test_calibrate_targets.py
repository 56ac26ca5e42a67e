"""Several targets per pose in calibrate (denavit.calibration.targets): marker clusters and SMR nests in one fit,
every target's point in the flange frame a parameter, the tracker anywhere.

* 4 markers per pose, 30 poses, the tracker 7 m away and turned: the kinematic parameters and the targets' points
  come out within their sigmas (Mahalanobis), their sigmas are smaller than target 1's alone, and the held-out
  prediction of a target's point beats the calibration from that target alone;
* a sweep file with three targets and its nest (as `denavit simulate --targets` writes it) through the command
  line: exit 0, the targets' parameters in the JSON, the tool frame the nest's.
"""

import json

import numpy as np
from scipy.spatial.transform import Rotation
from typer.testing import CliRunner

import denavit as dv
from denavit import calibration as cal
from denavit import sweeps as sw
from denavit.calibration.targets import TargetMeasurements, several_targets
from denavit.cli import app
from denavit.geometry import pose
from denavit.io import sweeps as swio

NOISE = 2e-5
NEST = np.array([[0.05, 0.03, 0.10], [-0.04, 0.06, 0.08], [0.03, -0.07, 0.13], [0.0, 0.0, 0.16]])  # m, flange frame
BASE = pose(Rotation.from_euler("xyz", [5, 10, 100], degrees=True).as_matrix(), [4.0, -6.0, 1.0])
MOVED = [
    "a_1",
    "alpha_1",
    "offset_2",
    "a_2",
    "alpha_2",
    "b_2",
    "beta_2",
    "a_3",
    "alpha_3",
    "b_3",
    "offset_4",
    "alpha_4",
    "a_4",
    "b_4",
    "offset_5",
    "alpha_5",
    "a_5",
    "b_5",
]


def _truth(kr5, seed=7):
    pz = cal.parametrize(kr5, "edh", measure="pose", tool=np.eye(4))
    rng = np.random.default_rng(seed)
    x = pz.x0.copy()
    for nm in MOVED:
        c = pz.index(nm)
        x[c] += rng.normal(0, 5e-4 if pz.units[c] == "length" else 1e-3)
    return pz, x, pz.model(x, "truth").with_tool(np.eye(4)).with_base(BASE)


def _targets(model, q, seed):
    F = dv.fk_batch(model, q)
    t = np.einsum("nij,kj->nki", F[:, :3, :3], NEST) + F[:, None, :3, 3]
    return t + np.random.default_rng(seed).normal(0, NOISE, t.shape)


def test_four_markers_per_pose_recover_the_model_and_predict_better_than_one(kr5):
    pz, x_true, truth = _truth(kr5)
    q = cal.configurations(kr5, 30)
    tm = TargetMeasurements(q, _targets(truth, q, 1), kinds=tuple(kr5.table.kinds))
    assert several_targets(tm) and not several_targets(cal.Measurements(q, tm.targets[:, 0]))
    c = cal.calibrate(tm, kr5)
    assert c.converged and c.measurements.n == 120 and c.rms < 3 * NOISE * np.sqrt(3)
    assert any("base registered in closed form" in n for n in c.notes)
    assert [c.status[c.names.index(n)] for n in MOVED] == ["free"] * len(MOVED)
    # the moved parameters and the targets' points within their sigmas, jointly (chi-square of 30 terms: mean 1, sd
    # 0.26)
    kin = [c.names.index(n) for n in MOVED]
    tgt = [c.names.index(f"target{k + 1}_{a}") for k in range(4) for a in "xyz"]
    idx = kin + tgt
    truth_x = np.concatenate([x_true[[pz.index(n) for n in MOVED]], NEST.ravel()])
    sel = [c.free_names.index(c.names[i]) for i in idx]
    e = c.values[idx] - truth_x
    maha = e @ np.linalg.solve(c.covariance[np.ix_(sel, sel)], e) / len(idx)
    assert maha < 2.0, maha
    assert np.all(np.abs(e) < 4 * c.sigma[idx]), dict(
        zip([c.names[i] for i in idx], (e / c.sigma[idx]).round(2), strict=True)
    )
    # one target alone: larger sigmas, a worse prediction of that target's point at 200 new poses
    one = cal.calibrate(
        cal.Measurements(q, tm.targets[:, 0], None, "target 1", kinds=tuple(kr5.table.kinds)), kr5, tool=NEST[0]
    )
    s_one = np.array([one.sigma[one.names.index(n)] for n in MOVED if one.status[one.names.index(n)] == "free"])
    s_all = np.array([c.sigma[c.names.index(n)] for n in MOVED if one.status[one.names.index(n)] == "free"])
    assert len(s_one) >= 12 and np.all(s_all < s_one)
    qt = cal.configurations(kr5, 200, skip=1000)
    exact = dv.fk_batch(truth, qt)
    true_p = exact[:, :3, :3] @ NEST[0] + exact[:, :3, 3]
    err_all = np.linalg.norm(
        dv.fk_batch(c.model(), qt)[:, :3, 3] - true_p, axis=1
    )  # the tool frame's origin is target 1
    err_one = np.linalg.norm(dv.fk_batch(one.model(), qt)[:, :3, 3] - true_p, axis=1)
    assert np.sqrt(np.mean(err_all**2)) < 0.8 * np.sqrt(np.mean(err_one**2)), (
        np.sqrt(np.mean(err_all**2)),
        np.sqrt(np.mean(err_one**2)),
    )
    # the result saves and predicts as a single-target calibration does
    assert c.robot().covariance is not None and np.all(
        np.isfinite(dv.validate(c, cal.Measurements(qt[:5], true_p[:5])).sigma)
    )


def test_held_out_poses_leave_all_their_targets_out(kr5):
    _, _, truth = _truth(kr5)
    q = cal.configurations(kr5, 40)
    c = cal.calibrate(TargetMeasurements(q, _targets(truth, q, 2)), kr5, holdout=0.25, seed=3)
    v = c.validation
    assert v.n_test == 10 * 4 and v.n_train == 30 * 4 and v.after_rms < 3 * NOISE * np.sqrt(3) < v.before_rms
    rows = np.asarray(v.test_indices)
    assert np.array_equal(rows.reshape(-1, 4) % 4, np.tile(np.arange(4), (10, 1)))  # whole poses


def test_cli_calibrate_a_sweep_file_with_three_targets_and_a_nest(kr5, tmp_path):
    s = sw.simulate(
        kr5.model(),
        home=np.radians(sw.PAPER_HOME_DEG),
        ranges=np.radians(sw.PAPER_RANGES_DEG[90]),
        points_per_sweep=8,
        noise=NOISE,
        targets=NEST[:3],
        seed=5,
    )
    f = tmp_path / "nest.csv"
    f.write_text(swio.to_long_csv(s, "mm", "deg"))
    out = tmp_path / "c.json"
    r = CliRunner().invoke(
        app, ["calibrate", str(f), "--nominal", "kr5", "--holdout", "0", "--json", str(out)], env={"COLUMNS": "200"}
    )
    assert r.exit_code == 0, r.output
    assert "target1_x" in r.output and "tool frame: the nest's" in r.output
    doc = json.loads(out.read_text())
    p = {row["name"]: row for row in doc["parameters"]}
    for k in range(3):
        for a, v in zip("xyz", NEST[k], strict=True):
            assert abs(p[f"target{k + 1}_{a}"]["value"] - v) < 5 * p[f"target{k + 1}_{a}"]["sigma"] + 1e-9
    T = np.array(doc["model"]["T_flange_tool"])
    np.testing.assert_allclose(
        T, np.eye(4), atol=2e-4
    )  # the nest is the targets in the flange frame: the tool frame is the flange
    assert doc["residuals"]["rms_m"] < 3 * NOISE * np.sqrt(3)


def _targets_csv(q, targets, nest=None) -> str:
    """A measurement CSV with several targets per pose (mm, deg), and its nest line."""
    K = targets.shape[1]
    head = ["q1", "q2", "q3", "q4", "q5", "q6", "x", "y", "z"] + [f"{a}{k}" for k in range(2, K + 1) for a in "xyz"]
    lines = ["# units: length=mm angle=deg"] + (
        ["# nest: " + "; ".join(",".join(f"{v * 1e3:.9g}" for v in p) for p in nest)] if nest is not None else []
    )
    lines.append(",".join(head))
    lines += [
        ",".join([*(f"{v:.12g}" for v in np.degrees(a)), *(f"{v * 1e3:.12g}" for v in t.ravel())])
        for a, t in zip(q, targets, strict=True)
    ]
    return "\n".join(lines) + "\n"


def test_cli_calibrate_and_validate_a_measurement_csv_with_four_markers(kr5, tmp_path):
    """`q1..q6,x,y,z,x2,y2,z2,...` with a `# nest:` line: calibrate fits every marker (exit 0, the tracker 7 m
    away), saves the robot, and validate scores every marker of a new session at its nest point (the tool frame is
    the nest's): the noise, sqrt(3) x 0.02 mm within 15 %."""
    from denavit.io.measurements import read_measurements

    _, _, truth = _truth(kr5)
    q = cal.configurations(kr5, 40)
    train = tmp_path / "train.csv"
    train.write_text(_targets_csv(q, _targets(truth, q, 1), NEST))
    m = read_measurements(train, kinds=list(kr5.table.kinds))
    assert isinstance(m, TargetMeasurements) and m.n_targets == 4 and np.allclose(m.nest, NEST)
    r = CliRunner().invoke(
        app,
        ["calibrate", str(train), "--nominal", "kr5", "--save", str(tmp_path / "cal.toml"), "--holdout", "0"],
        env={"COLUMNS": "200"},
    )
    assert r.exit_code == 0, r.output
    assert "40 poses x 4 targets" in r.output and "robot's size" not in r.output
    qt = cal.configurations(kr5, 60, skip=2000)
    test = tmp_path / "test.csv"
    test.write_text(_targets_csv(qt, _targets(truth, qt, 9), NEST))
    out = CliRunner().invoke(app, ["validate", str(tmp_path / "cal.toml"), str(test), "--json", "-"])
    assert out.exit_code == 0, out.output
    doc = json.loads(out.stdout)
    assert doc["n_poses"] == 240 and any("every target scored" in n for n in doc["notes"])
    assert abs(doc["rms_m"] / (np.sqrt(3) * NOISE) - 1) < 0.15, doc["rms_m"]


def test_cli_calibrate_a_recording_with_three_targets_per_row(kr5, tmp_path):
    """A delimited recording (column map `q1..q6,x1,y1,z1,x2,...`, every row a static pose): every target in one fit
    by default, `--target 2` that target alone (its tool point then found as the single target's)."""
    _, _, truth = _truth(kr5)
    q = cal.configurations(kr5, 30)
    t = _targets(truth, q, 4)[:, :3]
    text = "# units: length=mm angle=deg\n" + "".join(
        ",".join([*(f"{v:.12g}" for v in np.degrees(a)), *(f"{v * 1e3:.12g}" for v in p.ravel())]) + "\n"
        for a, p in zip(q, t, strict=True)
    )
    f = tmp_path / "log.txt"
    f.write_text(text)
    cols = "q1..q6,x1,y1,z1,x2,y2,z2,x3,y3,z3"
    out = tmp_path / "all.json"
    r = CliRunner().invoke(
        app,
        [
            "calibrate",
            str(f),
            "--nominal",
            "kr5",
            "--format",
            "columns",
            "--columns",
            cols,
            "--holdout",
            "0",
            "--json",
            str(out),
        ],
    )
    assert r.exit_code == 0, r.output
    names = [p["name"] for p in json.loads(out.read_text())["parameters"]]
    assert "target3_z" in names
    one = tmp_path / "one.json"
    r = CliRunner().invoke(
        app,
        [
            "calibrate",
            str(f),
            "--nominal",
            "kr5",
            "--format",
            "columns",
            "--columns",
            cols,
            "--target",
            "2",
            "--holdout",
            "0",
            "--json",
            str(one),
        ],
    )
    assert r.exit_code == 0, r.output
    doc = json.loads(one.read_text())
    p = {row["name"]: row["value"] for row in doc["parameters"]}
    assert "target1_x" not in p and np.allclose([p["tool_x"], p["tool_y"], p["tool_z"]], NEST[1], atol=2e-4)


def test_validate_groups_repeated_poses_not_the_targets_of_one_pose(kr5):
    """Several targets scored at their nest points: a pose's targets share its readings but are no repeated visits
    (ISO 9283 groups only poses visited again: here 3 poses visited 10 times each)."""
    _, _, truth = _truth(kr5)
    q = np.vstack([np.repeat(cal.configurations(kr5, 3, skip=50), 10, axis=0), cal.configurations(kr5, 10, skip=80)])
    tm = TargetMeasurements(q, _targets(truth, q, 6), NEST)
    model = truth.with_tool(np.eye(4))
    v = dv.validate(model, tm)
    assert v.n == 40 * 4 and len(v.groups) == 3 and sorted(g.n for g in v.groups) == [10, 10, 10]
    assert abs(v.rms / (np.sqrt(3) * NOISE) - 1) < 0.25


def test_six_dof_sweeps_are_calibrated_as_poses(kr5):
    """Sweeps of a 6-DoF probe (orientations recorded, one target): calibrate uses the orientations (pose
    measurements) and finds the probe's frame, (50, 30, 100) mm from the flange, not turned."""
    s = sw.simulate(
        kr5.model(),
        home=np.radians(sw.PAPER_HOME_DEG),
        ranges=np.radians(sw.PAPER_RANGES_DEG[90]),
        points_per_sweep=8,
        poses=True,
        noise=NOISE,
        noise_rot=2e-5,
        seed=2,
    )
    c = cal.calibrate(s, kr5)
    assert c.measurements.kind == "pose" and c.rms_rotation < 1e-4 and c.rms < 3 * NOISE * np.sqrt(3)
    T = np.asarray(c.model().T_flange_tool)
    np.testing.assert_allclose(T[:3, 3], (0.05, 0.03, 0.10), atol=1e-4)
    assert np.linalg.norm(Rotation.from_matrix(T[:3, :3]).as_rotvec()) < 1e-3
