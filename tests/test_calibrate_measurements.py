"""Calibration measurements and their files (denavit.calibration.measurements, denavit.io.measurements,
denavit.io.results): declared units, JSON, prismatic readings, both CSV readers, bad values named by row and place."""

import json

import numpy as np
import pytest
from calibrate_cases import HOME, NOISE, TOOL

import denavit as dv
from denavit import calibration as cal
from denavit import sweeps as sw
from denavit.io import results
from denavit.io import sweeps as swio
from denavit.io.measurements import read_measurements, to_csv
from denavit.io.robots import as_robot


def test_nan_and_mismatched_joint_counts(kr5, tmp_path):
    q = cal.configurations(kr5, 20)
    p = cal.simulate(kr5, q).points
    q_bad = q.copy()
    q_bad[7, 2] = np.nan
    with pytest.raises(
        dv.DenavitError, match=r"measurements, row 8: q \(joint readings\) must be finite, got nan \(joint 3\)"
    ):
        cal.Measurements(q_bad, p)
    p_bad = p.copy()
    p_bad[2, 1] = np.inf
    with pytest.raises(dv.DenavitError, match=r"measurements, row 3: points must be finite, got inf \(column y\)"):
        cal.Measurements(q, p_bad)
    with pytest.raises(dv.DenavitError, match=r"points must have shape \(20, 3\)"):
        cal.Measurements(q, p[:19])
    with pytest.raises(
        dv.DenavitError, match=r"the data has 5 joint readings per pose but the nominal model kr5 has 6 joints \(A1, A2"
    ):
        cal.calibrate(cal.Measurements(q[:, :5], p), kr5)
    f = tmp_path / "m.csv"
    text = to_csv(cal.Measurements(q, p), "mm", "deg").splitlines()
    cells = text[5].split(",")
    cells[7] = "nan"
    text[5] = ",".join(cells)
    f.write_text("\n".join(text) + "\n")
    with pytest.raises(dv.DenavitError, match=r"m.csv:6: column 'y' must be finite, got 'nan'"):
        read_measurements(f)
    f.write_text("q1,q2,x,y,z\n1,2,3,4,5\n")
    with pytest.raises(dv.DenavitError, match="units not declared"):
        read_measurements(f)


def test_declared_units_win_over_the_callers(kr5, tmp_path):
    """Regression: a file's own '#units:' line (no space after '#') was ignored and the caller's length/angle
    used instead (the CLI's default mm/deg), so metres were read as millimetres; what the file declares wins,
    the caller's units only fill in, and a second, conflicting declaration is an error naming both lines."""
    q = cal.configurations(kr5, 12)
    meas = cal.simulate(kr5, q, tool=TOOL)
    text = to_csv(meas, "m", "rad").replace("# units: length=m angle=rad", "#units: length=m angle=rad")
    f = tmp_path / "m.csv"
    f.write_text(text)
    back = read_measurements(f, length="mm", angle="deg")
    np.testing.assert_allclose(back.points, meas.points, atol=1e-12)
    np.testing.assert_allclose(back.q, meas.q, atol=1e-12)
    f.write_text(text.replace("#units: length=m angle=rad", "#units: length=m"))
    np.testing.assert_allclose(read_measurements(f, length="mm", angle="rad").points, meas.points, atol=1e-12)
    f.write_text("# units: length=mm angle=deg\n" + text)
    with pytest.raises(dv.DenavitError, match=r"m.csv:2: length=m contradicts length=mm declared at line 1"):
        read_measurements(f)
    j = tmp_path / "m.json"
    j.write_text(
        json.dumps({"units": {"length": "m", "angle": "rad"}, "q": meas.q.tolist(), "points": meas.points.tolist()})
    )
    np.testing.assert_allclose(read_measurements(j, length="mm", angle="deg").points, meas.points, atol=1e-12)


def test_files_round_trip_and_json(kr5, tmp_path):
    q = cal.configurations(kr5, 40)
    meas = cal.simulate(kr5, q, tool=TOOL, noise=NOISE)
    f = tmp_path / "m.csv"
    f.write_text(to_csv(meas, "mm", "deg"))
    back = read_measurements(f)
    np.testing.assert_allclose(back.q, meas.q, atol=1e-10)
    np.testing.assert_allclose(back.points, meas.points, atol=1e-12)
    poses = cal.simulate(kr5, q, tool=np.eye(4), measure="pose")
    f.write_text(to_csv(poses, "mm", "deg"))
    np.testing.assert_allclose(read_measurements(f).poses, poses.poses, atol=1e-10)
    s = sw.simulate(
        kr5.model(), home=HOME, ranges=np.radians(sw.PAPER_RANGES_DEG[90]), points_per_sweep=8, tool_point=TOOL
    )
    f.write_text(swio.to_long_csv(s))
    assert read_measurements(f).sweeps is not None
    res = cal.calibrate(meas, kr5, tool=TOOL, holdout=0.25)
    out = tmp_path / "r.json"
    results.write_json(res, out)
    doc = json.loads(out.read_text())  # strict JSON: no NaN
    assert doc["units"] == {"length": "m", "angle": "rad"}  # SI, as every JSON (docs/cli.md)
    rows = {r["name"]: r for r in doc["parameters"]}
    assert (
        rows["a_1"]["unit"] == "m"
        and rows["a_1"]["value"] == pytest.approx(0.180, abs=1e-4)
        and rows["c_5"]["sigma"] is None
        and rows["c_5"]["status"] == "redundant"
    )
    assert doc["identifiability"]["rank"] == 27 and doc["validation"]["n_test"] == 10
    assert {u["name"] for u in doc["identifiability"]["unidentifiable"]} >= {"c_5", "offset_6"}


def test_json_kinds_of_another_length_than_q_is_an_error(kr5, tmp_path):
    """A JSON 'kinds' list must have one entry per column of q; a mismatch had skipped the unit scaling of q."""
    q = np.degrees(cal.configurations(kr5, 12))
    p = cal.simulate(kr5, np.radians(q)).points * 1e3
    f = tmp_path / "m.json"
    f.write_text(
        json.dumps(
            {
                "units": {"length": "mm", "angle": "deg"},
                "kinds": ["revolute"] * 5,
                "q": q.tolist(),
                "points": p.tolist(),
            }
        )
    )
    with pytest.raises(
        dv.DenavitError, match=r"m.json: 'kinds': expected 6 joint kinds \(one per joint reading\), got 5"
    ):
        read_measurements(f)
    f.write_text(
        json.dumps(
            {
                "units": {"length": "mm", "angle": "deg"},
                "kinds": ["revolute"] * 5 + ["rotary"],
                "q": q.tolist(),
                "points": p.tolist(),
            }
        )
    )
    with pytest.raises(
        dv.DenavitError, match=r"m.json: 'kinds': joint 6: expected 'revolute' or 'prismatic', got 'rotary'"
    ):
        read_measurements(f)
    f.write_text(
        json.dumps(
            {
                "units": {"length": "mm", "angle": "deg"},
                "kinds": ["revolute"] * 6,
                "q": q.tolist(),
                "points": p.tolist(),
            }
        )
    )
    np.testing.assert_allclose(read_measurements(f).q, np.radians(q), atol=1e-12)


def test_prismatic_readings_take_the_length_unit(tmp_path):
    """Readings of a prismatic joint are in the file's length unit (they had been scaled by the angle unit:
    100 mm became 1.745 m); without the joint kinds, calibrate refuses a robot with a prismatic joint."""
    params = np.array(
        [[0.3, 0.0, 0.1, np.pi / 2], [0.2, 0.3, 0.0, -np.pi / 2], [0.0, 0.2, 0.25, np.pi / 3], [0.1, 0.0, 0.0, 0.0]]
    )
    kinds = ["revolute", "prismatic", "revolute", "revolute"]
    model = dv.Table("dh", params, kinds=kinds).to_model("rprr", lower=[-3, -0.1, -3, -3], upper=[3, 0.4, 3, 3])
    robot = as_robot(model)
    meas = cal.simulate(model, cal.configurations(robot, 40), tool=TOOL, noise=NOISE)
    f = tmp_path / "m.csv"
    f.write_text(to_csv(meas, "mm", "deg"))
    back = read_measurements(f, kinds=kinds)
    np.testing.assert_allclose(back.q, meas.q, atol=1e-10)
    assert back.kinds == tuple(kinds)
    res = cal.calibrate(back, robot, tool=TOOL)
    assert res.rms < 2 * NOISE
    with pytest.raises(
        dv.DenavitError,
        match=(
            r"m.csv: joint 2 \(j2\) of rprr is prismatic, but its readings were read as revolute \(in deg\): pass"
            r" kinds="
        ),
    ):
        cal.calibrate(read_measurements(f), robot, tool=TOOL)
    with pytest.raises(
        dv.DenavitError, match=r"m.csv: kinds given: expected 4 joint kinds \(one per joint reading\), got 3"
    ):
        read_measurements(f, kinds=kinds[:3])
    j = tmp_path / "m.json"
    j.write_text(
        json.dumps(
            {"units": {"length": "mm", "angle": "deg"}, "kinds": kinds, "q": [[0, 100, 0, 0]], "points": [[1, 2, 3]]}
        )
    )
    np.testing.assert_allclose(read_measurements(j).q, [[0, 0.1, 0, 0]])
    with pytest.raises(
        dv.DenavitError,
        match=r"m.json: 'kinds' \['revolute', 'prismatic', 'revolute', 'revolute'\] differ from the kinds given",
    ):
        read_measurements(j, kinds=["revolute"] * 4)


def test_a_measurement_csv_reads_the_same_on_the_c_reader_and_row_by_row(kr5, tmp_path):
    """A comment line at the end sends the file row by row: the same readings, points, poses and places; a bad
    cell deep in the file is still named by its line and column."""
    T_ft = np.eye(4)
    T_ft[:3, 3] = TOOL
    for measure, tool in (("point", TOOL), ("pose", T_ft)):
        meas = cal.simulate(
            kr5,
            cal.configurations(kr5, 300, skip=9),
            tool=tool,
            noise=NOISE,
            noise_rot=1e-5 if measure == "pose" else 0.0,
            measure=measure,
            seed=1,
        )
        fast, slow = tmp_path / f"{measure}.csv", tmp_path / f"{measure}_slow.csv"
        fast.write_text(to_csv(meas))
        slow.write_text(to_csv(meas) + "# end\n")
        a, b = read_measurements(fast), read_measurements(slow)
        assert (
            np.array_equal(a.q, b.q)
            and [w.replace("_slow", "") for w in b.where] == list(a.where)
            and a.where[0].endswith(":3")
        )
        assert np.array_equal(a.points, b.points) if measure == "point" else np.array_equal(a.poses, b.poses)
    lines = fast.read_text().splitlines()
    lines[200] = lines[200].rsplit(",", 1)[0] + ",abc"
    fast.write_text("\n".join(lines) + "\n")
    with pytest.raises(dv.DenavitError, match=r"pose.csv:201: column 'rz' must be a number, got 'abc'"):
        read_measurements(fast)
