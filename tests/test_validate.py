"""`denavit validate MODEL DATA` and `denavit.validate` (denavit.calibration.validate): known answers.

* a model scored on data simulated from itself with known noise gives the RMS of that noise (sqrt(3) sigma per
  point, within the chi-square spread of 3N coordinates);
* a model whose link is off by a known 1 mm translation gives 1 mm at every pose (a translation factor of the
  chain moves everything after it rigidly), as the forward kinematics of both say;
* data from a moved tracker: frozen registration gives the tracker's move at every pose, re-fitted registration
  the noise (with 9 of the 3N residuals absorbed);
* ISO 9283 AP and RP of repeated poses against the clause's formulas computed here;
* extrapolation flags against the training ranges computed here; the command line's table, JSON (keys, units) and
  report (in-process, typer's CliRunner).
"""

import json
from dataclasses import replace

import numpy as np
import pytest
from scipy.spatial.transform import Rotation
from typer.testing import CliRunner

import denavit as dv
from denavit import calibration as cal
from denavit.calibration import validate as va
from denavit.cli import app
from denavit.geometry import pose
from denavit.io.measurements import to_csv
from denavit.io.robotfile import save

NOISE = 2e-5  # m per coordinate
TOOL = np.array([0.05, 0.03, 0.10])
MOVE = pose(Rotation.from_euler("xyz", [10, -30, 50], degrees=True).as_matrix(), [3.0, -1.0, 0.5])
LO, HI = np.radians([-60, -100, 20, -60, 20, -90]), np.radians([60, -40, 120, 60, 110, 90])  # the training ranges


def _with_tool(model, tool=TOOL):
    T = np.eye(4)
    T[:3, 3] = tool
    return model.with_tool(T)


def _shifted(robot, joint: int, column: str, by: float):
    """``robot`` with one table entry moved (a DH translation: everything after it moves rigidly)."""
    t = robot.table
    P = np.array(t.params)
    P[joint - 1, list(t.columns).index(column)] += by
    return replace(robot, table=dv.Table(t.convention, P, t.kinds, t.T_world_base, t.T_last_tool))


def test_a_model_on_data_simulated_from_itself_gives_the_noise(kr5):
    """300 poses, 0.02 mm per coordinate: the RMS error is sqrt(3) x 0.02 mm within 4 standard deviations of its
    chi-square spread (sd of rms / (sqrt(3) sigma) = 1 / sqrt(2 x 900) ~ 0.024), the median that of a 3-D Gaussian
    misfit (1.538 sigma, within 10 %); nothing is flagged."""
    m = _with_tool(kr5.model())
    meas = cal.simulate(m, cal.configurations(kr5, 300, skip=300), tool=TOOL, noise=NOISE, seed=11)
    v = dv.validate(m, meas)
    assert v.registration == "frozen" and v.n == 300 and v.n_flagged == 0
    ratio = v.rms / (np.sqrt(3) * NOISE)
    assert abs(ratio - 1) < 4 / np.sqrt(2 * 900), ratio
    assert abs(v.percentiles[50] / (1.5382 * NOISE) - 1) < 0.1, v.percentiles
    assert v.max == pytest.approx(v.errors.max()) and v.sigma is None and not v.groups


def test_a_link_1_mm_off_gives_1_mm_everywhere(kr5):
    """The truth's a_2 is 1 mm longer than the model's: every pose errs by exactly 1 mm (the forward kinematics of
    both, computed here, agree), so RMS, max and every percentile are 1 mm."""
    truth = _shifted(kr5, 2, "a", 1e-3)
    q = cal.configurations(kr5, 50, skip=7)
    meas = cal.simulate(_with_tool(truth.model()), q, tool=TOOL)
    v = dv.validate(_with_tool(kr5.model()), meas)
    independent = np.linalg.norm(
        dv.fk_batch(_with_tool(truth.model()), q)[:, :3, 3] - dv.fk_batch(_with_tool(kr5.model()), q)[:, :3, 3], axis=1
    )
    np.testing.assert_allclose(v.errors, independent, rtol=0, atol=1e-12)
    np.testing.assert_allclose(v.errors, 1e-3, rtol=0, atol=1e-12)
    assert v.rms == pytest.approx(1e-3, abs=1e-12) and v.max == pytest.approx(1e-3, abs=1e-12)
    assert all(p == pytest.approx(1e-3, abs=1e-12) for p in v.percentiles.values())


def test_frozen_and_refitted_registration_on_data_from_a_moved_tracker(kr5):
    """The tracker moved by 3.2 m and 60 deg after the model was calibrated. Frozen, each pose errs by exactly how
    far the move carries its point; re-fitted (base and tool, the kinematics frozen), the noise-free data fit to
    1e-9 m with the move and the tool recovered, and noisy data give rms^2 = (3N - 9) / N sigma^2 within 4 sd."""
    m = _with_tool(kr5.model())
    q = cal.configurations(kr5, 200, skip=50)
    exact = cal.simulate(m, q, tool=TOOL)
    moved = replace(exact, points=exact.points @ MOVE[:3, :3].T + MOVE[:3, 3])
    frozen = dv.validate(m, moved)
    np.testing.assert_allclose(
        frozen.errors, np.linalg.norm(moved.points - exact.points, axis=1), rtol=1e-12, atol=1e-12
    )
    refit = dv.validate(m, moved, registration="refit")
    assert refit.registration == "refit" and refit.max < 1e-9
    np.testing.assert_allclose(refit.T_world_base, MOVE, atol=1e-9)
    np.testing.assert_allclose(refit.T_flange_tool[:3, 3], TOOL, atol=1e-9)
    noisy = cal.simulate(m.with_base(MOVE), q, tool=TOOL, noise=NOISE, seed=3)
    v = dv.validate(m, noisy, registration="refit")
    expected = NOISE * np.sqrt((3 * 200 - 9) / 200)
    assert abs(v.rms / expected - 1) < 4 / np.sqrt(2 * 591), v.rms / expected
    assert any("re-fitted" in n for n in v.notes)
    # a tool guessed 100 mm off and turned: the re-fit finds it
    v2 = dv.validate(kr5.model(), moved, registration="refit", tool=np.array([0.1, -0.05, 0.0]))
    assert v2.max < 1e-9


def test_refit_recovers_a_tools_orientation_from_poses(kr5):
    """6-DoF poses of a tool turned 88 deg about y, from a moved tracker: the re-fitted registration finds the
    tool's orientation (rotation errors at the noise, 2e-5 rad)."""
    T_tool = pose(Rotation.from_euler("xyz", [20, -88, 40], degrees=True).as_matrix(), TOOL)
    meas = cal.simulate(
        kr5.model().with_base(MOVE),
        cal.configurations(kr5, 60),
        tool=T_tool,
        noise=NOISE,
        noise_rot=2e-5,
        measure="pose",
        seed=4,
    )
    v = dv.validate(kr5.model(), meas, registration="refit")
    assert v.measure == "pose" and v.rms_rotation < 1e-4 and v.rms < 3 * NOISE * np.sqrt(3)
    assert np.linalg.norm(Rotation.from_matrix(v.T_flange_tool[:3, :3].T @ T_tool[:3, :3]).as_rotvec()) < 2e-5


def test_iso_9283_accuracy_and_repeatability_of_repeated_poses(kr5):
    """5 commanded poses visited 30 times each (readings repeated within 1e-5 rad) plus 20 single poses, the model
    1 mm off: 5 groups; AP and RP are the clause's formulas computed here, AP about 1 mm, RP about the noise."""
    truth = _shifted(kr5, 2, "a", 1e-3)
    base_q = cal.configurations(kr5, 5, skip=40)
    q = np.vstack(
        [
            np.repeat(base_q, 30, axis=0) + np.random.default_rng(0).uniform(-1e-5, 1e-5, (150, 6)),
            cal.configurations(kr5, 20, skip=400),
        ]
    )
    meas = cal.simulate(_with_tool(truth.model()), q, tool=TOOL, noise=NOISE, seed=8)
    v = dv.validate(_with_tool(kr5.model()), meas)
    assert len(v.groups) == 5 and sorted(g.n for g in v.groups) == [30] * 5
    pred = dv.fk_batch(_with_tool(kr5.model()), q)[:, :3, 3]
    for g in v.groups:
        assert np.array_equal(np.sort(g.indices), np.arange(g.indices.min(), g.indices.min() + 30))
        x = meas.points[g.indices]
        bary = x.mean(axis=0)
        ap = np.sqrt(np.sum((bary - pred[g.indices].mean(axis=0)) ** 2))
        lj = np.sqrt(np.sum((x - bary) ** 2, axis=1))
        rp = lj.mean() + 3 * np.sqrt(np.sum((lj - lj.mean()) ** 2) / 29)
        assert g.ap == pytest.approx(ap, rel=1e-12) and g.rp == pytest.approx(rp, rel=1e-12)
        assert abs(g.ap - 1e-3) < 5 * NOISE and 2 * NOISE < g.rp < 8 * NOISE
    assert not any("30 times" in n for n in v.notes)
    assert va.repeat_groups(np.zeros((1, 6))) == []


def test_extrapolation_is_flagged_outside_the_training_ranges_and_where_sigma_is_large(kr5):
    """A calibration on 50 poses within 30-90 deg ranges, scored on 40 poses inside and 40 over the whole range: the
    poses flagged outside_training_range are those with a joint outside the training min / max (computed here), and
    their predicted sigma and errors are larger."""
    truth = _shifted(_shifted(kr5, 3, "a", 4e-4), 5, "d", -3e-4)
    lo, hi = np.radians([-30, -90, 40, -30, 40, -45]), np.radians([30, -60, 90, 30, 90, 45])
    qtr = lo + (hi - lo) * np.random.default_rng(1).random((50, 6))
    c = cal.calibrate(cal.simulate(_with_tool(truth.model()), qtr, tool=TOOL, noise=NOISE, seed=1), kr5, tool=TOOL)
    lo, hi = qtr.min(axis=0), qtr.max(axis=0)
    q = np.vstack([lo + (hi - lo) * np.random.default_rng(2).random((40, 6)), cal.configurations(kr5, 40, skip=900)])
    v = dv.validate(c, cal.simulate(_with_tool(truth.model()), q, tool=TOOL, noise=NOISE, seed=5))
    outside = np.any((q < qtr.min(axis=0)) | (q > qtr.max(axis=0)), axis=1)
    assert outside[40:].sum() >= 35 and not outside[:40].any()
    np.testing.assert_array_equal(np.isin(np.arange(80), v.flagged("outside_training_range")), outside)
    assert v.sigma is not None and np.median(v.sigma[outside]) > 1.5 * np.median(v.sigma[~outside])
    assert np.sqrt(np.mean(v.errors[outside] ** 2)) > np.sqrt(np.mean(v.errors[~outside] ** 2))
    # large predicted sigma: above 3 x the training poses' median (computed here), or above max_sigma when given
    from denavit.compensation import predicted_sigma

    limit = 3 * np.median(predicted_sigma(c, qtr))
    assert v.sigma_limit == pytest.approx(limit, rel=1e-9)
    np.testing.assert_array_equal(v.flagged("large_predicted_sigma"), np.flatnonzero(v.sigma > limit))
    v2 = dv.validate(c, cal.simulate(_with_tool(truth.model()), q, tool=TOOL, noise=NOISE, seed=5), max_sigma=limit / 2)
    big = v2.flagged("large_predicted_sigma")
    assert len(big) >= 3 and np.array_equal(big, np.flatnonzero(v2.sigma > limit / 2)) and outside[big].all()
    np.testing.assert_allclose(v.training_lower, qtr.min(axis=0))


def test_bad_arguments_are_one_line_errors(kr5):
    meas = cal.simulate(kr5.model(), cal.configurations(kr5, 10), tool=TOOL)
    with pytest.raises(dv.DenavitError, match="registration: expected 'frozen' or 'refit', got 'moved'"):
        dv.validate(kr5, meas, registration="moved")
    with pytest.raises(dv.DenavitError, match="max_sigma: expected a finite value > 0"):
        dv.validate(kr5, meas, max_sigma=-1.0)
    with pytest.raises(dv.DenavitError, match="the data has 5 joint readings per pose but the model"):
        dv.validate(kr5, cal.Measurements(np.zeros((5, 5)), np.zeros((5, 3))))


@pytest.fixture(scope="module")
def session(tmp_path_factory):
    """A calibration saved as a robot file (mm, deg) and a test session (CSV) from the same robot 1 m away."""
    kr5 = dv.load_robot("kr5")
    tmp = tmp_path_factory.mktemp("validate")
    truth = _shifted(kr5, 3, "a", 4e-4)
    far = pose(None, [1.0, 0.2, 0.0])
    qtr = LO + (HI - LO) * np.random.default_rng(1).random((50, 6))
    c = cal.calibrate(
        cal.simulate(_with_tool(truth.model()).with_base(far), qtr, tool=TOOL, noise=NOISE, seed=1), kr5, tool=TOOL
    )
    save(c.robot(), tmp / "cal.toml", "mm", "deg")
    q = np.vstack([LO + (HI - LO) * np.random.default_rng(2).random((20, 6)), cal.configurations(kr5, 20, skip=900)])
    test = cal.simulate(_with_tool(truth.model()).with_base(far), q, tool=TOOL, noise=NOISE, seed=5)
    (tmp / "test.csv").write_text(to_csv(test))
    moved = replace(test, points=test.points @ MOVE[:3, :3].T + MOVE[:3, 3])
    (tmp / "moved.csv").write_text(to_csv(moved))
    return tmp


def test_cli_validate_prints_a_table_and_writes_json_and_a_report(session):
    """`denavit validate cal.toml test.csv`: exit 0, the table and the summary; `--json` with the documented keys
    (every number's unit known from its key, as test_cli_json requires); `--report` and `--plot` write their files."""
    from test_cli_json import offenders

    r = CliRunner().invoke(
        app,
        [
            "validate",
            str(session / "cal.toml"),
            str(session / "test.csv"),
            "--json",
            str(session / "v.json"),
            "--report",
            str(session / "v.html"),
            "--plot",
            str(session / "figs"),
        ],
        env={"COLUMNS": "200"},
    )
    assert r.exit_code == 0, r.output
    assert (
        "Validation of kr5_calibrated on 40 points (registration frozen)" in r.output
        and "error [mm]" in r.output
        and "predicted sigma [mm]" in r.output
    )
    doc = json.loads((session / "v.json").read_text())
    assert {"n_poses", "rms_m", "max_m", "percentiles_m", "registration", "per_pose", "iso9283", "units"} <= set(doc)
    assert doc["n_poses"] == 40 and doc["registration"] == "frozen" and len(doc["per_pose"]) == 40
    assert doc["rms_m"] < 1e-4 and set(doc["percentiles_m"]) == {"p50_m", "p90_m", "p95_m", "p99_m"}
    assert {"where", "error_m", "sigma_predicted_m", "flags", "q"} <= set(doc["per_pose"][0])
    assert offenders(doc) == []
    html = (session / "v.html").read_text()
    assert 'id="errors-chart"' in html and 'id="poses"' in html and "registration" in html
    assert (session / "figs" / "validation.png").stat().st_size > 1000


def test_cli_validate_refits_the_registration_when_asked(session):
    """The session seen from a moved tracker: frozen, metres of error; --refit-registration, the noise again, and
    the output says which."""
    frozen = CliRunner().invoke(app, ["validate", str(session / "cal.toml"), str(session / "moved.csv"), "--json", "-"])
    refit = CliRunner().invoke(
        app, ["validate", str(session / "cal.toml"), str(session / "moved.csv"), "--refit-registration", "--json", "-"]
    )
    assert frozen.exit_code == 0 and refit.exit_code == 0, frozen.output + refit.output
    a, b = json.loads(frozen.stdout), json.loads(refit.stdout)
    assert a["registration"] == "frozen" and a["rms_m"] > 1.0
    assert b["registration"] == "refit" and b["rms_m"] < 1e-4
    text = CliRunner().invoke(
        app, ["validate", str(session / "cal.toml"), str(session / "moved.csv"), "--refit-registration"]
    )
    assert "(registration refit)" in text.output and "registration re-fitted with the kinematics frozen" in text.output


def test_a_robot_file_from_calibrate_save_carries_its_training_ranges(kr5, tmp_path):
    """`calibrate --save` writes the training poses' joint ranges ([training], the file's units); `validate` on that
    file flags exactly the poses with a joint outside them (computed here) and names the joints."""
    truth = _shifted(kr5, 3, "a", 4e-4)
    lo, hi = np.radians([-30, -90, 40, -30, 40, -45]), np.radians([30, -60, 90, 30, 90, 45])
    qtr = lo + (hi - lo) * np.random.default_rng(1).random((50, 6))
    (tmp_path / "train.csv").write_text(
        to_csv(cal.simulate(_with_tool(truth.model()), qtr, tool=TOOL, noise=NOISE, seed=1))
    )
    r = CliRunner().invoke(
        app,
        [
            "calibrate",
            str(tmp_path / "train.csv"),
            "--nominal",
            "kr5",
            "--tool",
            "50,30,100",
            "--save",
            str(tmp_path / "cal.toml"),
        ],
    )
    assert r.exit_code == 0, r.output
    saved = dv.load_robot(tmp_path / "cal.toml")
    np.testing.assert_allclose(
        np.radians(saved.extra["training"]["lower"]), qtr.min(axis=0), atol=1e-9
    )  # degrees in a mm/deg file
    q = np.vstack(
        [
            qtr.min(axis=0) + (qtr.max(axis=0) - qtr.min(axis=0)) * np.random.default_rng(2).random((20, 6)),
            cal.configurations(kr5, 20, skip=900),
        ]
    )
    (tmp_path / "test.csv").write_text(
        to_csv(cal.simulate(_with_tool(truth.model()), q, tool=TOOL, noise=NOISE, seed=5))
    )
    out = CliRunner().invoke(app, ["validate", str(tmp_path / "cal.toml"), str(tmp_path / "test.csv"), "--json", "-"])
    assert out.exit_code == 0, out.output
    doc = json.loads(out.stdout)
    flagged = np.array(["outside_training_range" in p["flags"] for p in doc["per_pose"]])
    outside = np.any((q < qtr.min(axis=0) - 1e-9) | (q > qtr.max(axis=0) + 1e-9), axis=1)
    np.testing.assert_array_equal(flagged, outside)
    assert outside[20:].sum() >= 15 and all(
        p["outside_joints"] for p, o in zip(doc["per_pose"], outside, strict=True) if o
    )
    np.testing.assert_allclose(doc["training_range"]["upper"], qtr.max(axis=0), atol=1e-9)
