"""Sweep files read and identification results written (denavit.io.sweeps, denavit.io.results): the long CSV, joint
files and JSON, and bad input named by file and place."""

import json

import numpy as np
import pytest
from identify_cases import HOME, simulate

import denavit as dv
from cli import run
from denavit import sweeps as sw
from denavit.io import sweeps as swio
from denavit.io.results import to_json, write_json


def test_json_output_has_units_rows_and_sigmas(kr5, tmp_path):
    res = dv.identify(simulate(kr5, 90, points_per_sweep=12, noise=2e-5), nominal=kr5)
    out = tmp_path / "r.json"
    write_json(res, out)
    doc = json.loads(out.read_text())
    assert doc["units"] == {"length": "m", "angle": "rad"}  # SI, the unit in each scalar key (docs/cli.md)
    assert [r["joint"] for r in doc["parameters"]] == kr5.names
    assert set(doc["parameters"][0]) >= {"d", "theta", "a", "alpha", "d_sigma", "a_sigma"}
    assert doc["parameters"][0]["d"] == pytest.approx(0.400, abs=5e-4)  # Hayat Table III: d1 = 400 mm
    assert len(doc["joints"]) == 6 and "direction" in doc["joints"][0]["axis"]
    assert len(doc["bounding_box"]["lengths_m"]) == 3
    # every point's residual (m), in the file's order: 0.02 mm per coordinate gives about 0.02 * sqrt(3) mm
    per_point = np.array([j["residuals"]["per_point_m"] for j in doc["joints"]])
    assert per_point.shape == (6, 12) and 1e-5 < np.sqrt(np.mean(per_point**2)) < 6e-5
    assert doc["joints"][0]["residuals"]["rms_m"] == pytest.approx(np.sqrt(np.mean(per_point[0] ** 2)), rel=1e-9)


def test_long_csv_round_trip_and_units(kr5, tmp_path):
    s = simulate(kr5, 30, points_per_sweep=8, noise=1e-5, seed=1)
    f = tmp_path / "s.csv"
    f.write_text(swio.to_long_csv(s, "mm", "deg"))
    before = f.read_bytes()
    r = swio.read_long_csv(f)
    assert f.read_bytes() == before  # input files are never modified
    for a, b in zip(s.sweeps, r.sweeps, strict=True):
        np.testing.assert_allclose(a.points, b.points, atol=1e-12)
        np.testing.assert_allclose(a.q, b.q, atol=1e-10)
    np.testing.assert_allclose(r.home, HOME, atol=1e-10)


def test_joint_files_and_json_readers(kr5, tmp_path):
    s = simulate(kr5, 90, points_per_sweep=10)
    d = tmp_path / "files"
    d.mkdir()
    for sweep in s.sweeps:
        rows = [f"{k * 0.1:.1f};{p[0] * 1e3:.9f};{p[1] * 1e3:.9f};{p[2] * 1e3:.9f}" for k, p in enumerate(sweep.points)]
        (d / f"j{sweep.joint}.csv").write_text("time;x;y;z\n" + "\n".join(rows) + "\n")
    dirs = [np.sign(r[1] - r[0]) for r in sw.PAPER_RANGES_DEG[90]]
    fs = swio.read_joint_files(d, home=sw.PAPER_HOME_DEG, length="mm", angle="deg", direction=dirs)
    res = dv.identify(fs, nominal=kr5)
    assert res.method == "geometric"
    np.testing.assert_allclose(res.table.params, kr5.table.params, atol=1e-7)
    doc = {
        "units": {"length": "m", "angle": "rad"},
        "home": HOME.tolist(),
        "sweeps": [{"joint": x.joint, "points": x.points.tolist(), "q": x.q.tolist()} for x in s.sweeps],
    }
    (tmp_path / "s.json").write_text(json.dumps(doc))
    js = swio.read_json(tmp_path / "s.json")
    np.testing.assert_allclose(dv.identify(js, nominal=kr5).table.params, kr5.table.params, atol=1e-9)


def test_exact_data_written_to_csv_gives_the_nominal_edh(kr5, tmp_path):
    """`denavit simulate kr5 --noise 0` then `identify --convention edh`: the CSV's 10 digits leave axes 2-3
    parallel to ~1e-10, where the common normal follows round-off (theta2 = 45.6 deg); the x axes of near-parallel
    pairs must follow the nominal's."""
    f = tmp_path / "k.csv"
    run("simulate", "kr5", "-o", f, "--noise", "0")
    res = dv.identify(swio.read(f), nominal=kr5, convention="edh")
    d = res.table.params - res.nominal_table.params
    d[:, [0, 4]] = (d[:, [0, 4]] + np.pi) % (2 * np.pi) - np.pi
    assert np.abs(d).max() < 1e-8, d
    # and the ED-H sigmas stay bounded by the axes' own (the common normal of a noisy parallel pair swings)
    noisy = dv.identify(simulate(kr5, 90, points_per_sweep=30, noise=2e-5, seed=8), nominal=kr5, convention="edh")
    bound = max(f.sigma_point_perp for f in noisy.fits)
    assert noisy.sigma[:, 1:4].max() < 20 * bound, (noisy.sigma, bound)


def test_json_of_a_prismatic_poe_row_keeps_its_direction_unitless():
    """Regression: to_json scaled a prismatic POE row's v (a unit direction) as a length (1000x in mm); home
    values follow the per-joint-kind rule (revolute: rad, prismatic: m), as does a joint's reading sigma key."""
    params = np.array(
        [[0.3, 0.0, 0.1, np.pi / 2], [0.2, 0.3, 0.0, -np.pi / 2], [0.0, 0.2, 0.25, np.pi / 3], [0.1, 0.0, 0.0, 0.0]]
    )
    truth = dv.Table("dh", params, kinds=["revolute", "prismatic", "revolute", "revolute"]).to_model(
        "rprr", lower=[-3, -0.1, -3, -3], upper=[3, 0.4, 3, 3]
    )
    home = np.array([0.2, 0.1, -0.3, 0.5])
    ranges = np.array([[-0.3, 0.6], [0.0, 0.3], [-0.8, 0.2], [0.0, 1.2]])
    res = dv.identify(
        sw.simulate(truth, home=home, ranges=ranges, points_per_sweep=12, tool_point=(0.03, 0.02, 0.05)),
        convention="poe",
    )
    doc = to_json(res, box=False)
    v = [doc["parameters"][1][c] for c in ("vx", "vy", "vz")]
    assert np.linalg.norm(v) == pytest.approx(1.0, abs=1e-9)
    np.testing.assert_allclose(v, res.table.params[1, 3:6], atol=1e-12)
    w = [doc["parameters"][0][c] for c in ("wx", "wy", "wz")]
    np.testing.assert_allclose(w, res.table.params[0, :3], atol=1e-12)  # w is unitless in every row
    np.testing.assert_allclose(
        [doc["parameters"][0][c] for c in ("vx", "vy", "vz")], res.table.params[0, 3:6], atol=1e-12
    )  # a revolute v is a length (m)
    np.testing.assert_allclose(doc["home"], home, atol=1e-15)
    assert [("reading_sigma_rad" in j, "reading_sigma_m" in j) for j in doc["joints"]] == [
        (True, False),
        (False, True),
        (True, False),
        (True, False),
    ]


# --------------------------------------------------------------------------------------------------
# bad input: errors that name the file and the place


def write_csv(tmp_path, body, units="# units: length=mm angle=deg\n"):
    f = tmp_path / "bad.csv"
    f.write_text(units + "joint,q1,q2,x,y,z\n" + body)
    return f


@pytest.mark.parametrize(
    "body, units, match",
    [
        (
            "1,0,0,1,0,0\n1,10,0,0.9,0.1,0\n2,0,0,1,0,0\n2,0,5,1,0.1,0\n2,0,10,1,0.2,0\n",
            None,
            r"bad.csv lines 3-4, joint 1: .*at least 3 points, got 2",
        ),
        (
            "1,0,0,1,0,0\n1,5,0,1,0,0\n1,10,0,1,0,0\n2,0,0,1,0,0\n2,0,5,1,0.1,0\n2,0,10,1,0.2,0.1\n",
            None,
            r"joint 1: circle fit needs distinct points, got all 3 points within",
        ),
        (
            "1,0,0,0,0,0\n1,5,0,1,0,0\n1,10,0,2,0,0\n2,0,0,1,0,0\n2,0,5,1,0.1,0\n2,0,10,1,0.2,0.1\n",
            None,
            (
                r"joint 1: .*collinear points \(RMS spread about their centroid 0.816 mm along the line, 0 and 0 mm"
                r" across it"
            ),
        ),
        ("1,0,0,1,0,nan\n", None, r"bad.csv:3: column 'z' must be finite"),
        ("3,0,0,1,0,0\n", None, r"bad.csv:3: joint index out of range: expected 1..2, got 3"),
        ("1,0,0,1,0,0\n1,5,0,1,0,0\n1,10,0,1,0,0\n", None, r"missing sweeps of joint\(s\) 2"),
        ("1,0,0,1,0,0\n", "# units: length=furlong angle=deg\n", r"unknown length unit 'furlong'"),
        ("1,0,0,1,0,0\n", "", r"units not declared"),
        ("1,0,0,1,0\n", None, r"bad.csv:3: expected 6 values, got 5"),
    ],
)
def test_bad_sweep_files(tmp_path, body, units, match):
    f = write_csv(tmp_path, body, units if units is not None else "# units: length=mm angle=deg\n")
    before = f.read_bytes()
    with pytest.raises(dv.DenavitError, match=match):
        dv.identify(swio.read_long_csv(f), method="geometric")
    assert f.read_bytes() == before


def test_out_and_back_sweep_without_readings_is_an_error(kr5, tmp_path):
    """Without readings only the point order gives the direction: a sweep that returns to its start names itself."""
    s = simulate(kr5, 90, points_per_sweep=10)
    d = tmp_path / "files"
    d.mkdir()
    for sweep in s.sweeps:
        pts = sweep.points if sweep.joint != 3 else np.vstack([sweep.points, sweep.points[-2::-1]])
        (d / f"j{sweep.joint}.csv").write_text("\n".join(f"{p[0]},{p[1]},{p[2]}" for p in pts * 1e3) + "\n")
    fs = swio.read_joint_files(d, home=sw.PAPER_HOME_DEG, length="mm", angle="deg")
    with pytest.raises(dv.DenavitError, match=r"j3.csv lines 1-19, joint 3: .*net turn .* over an arc of 90.0 deg"):
        dv.identify(fs, nominal=kr5)


def json_doc(s, **change):
    """The JSON sweep document of a simulated sweep set (m, rad), with top-level entries changed."""
    doc = {
        "units": {"length": "m", "angle": "rad"},
        "home": s.home.tolist(),
        "sweeps": [{"joint": x.joint, "points": x.points.tolist(), "q": x.q.tolist()} for x in s.sweeps],
    }
    doc.update(change)
    return doc


@pytest.mark.parametrize(
    "edit, match",
    [
        (lambda d: [1, 2], r"s.json: expected a JSON object"),
        (
            lambda d: {**d, "home": d["home"][:2] + [float("nan")] + d["home"][3:]},
            r"s.json: home\[2\]: expected a finite number, got NaN",
        ),
        (lambda d: {**d, "home": "90,-90"}, r"s.json: home: expected a list of one or more numbers"),
        (lambda d: {**d, "kinds": ["revolute"] * 5}, r"s.json: kinds: expected 6 of 'revolute' / 'prismatic'"),
        (lambda d: {**d, "units": "mm"}, r"s.json: units: expected an object"),
        (lambda d: {**d, "sweeps": None}, r"s.json: sweeps: expected a list of sweeps"),
        (lambda d: {**d, "sweeps": [d["sweeps"][0], 7]}, r"s.json: sweeps\[1\]: expected an object"),
        (
            lambda d: {
                **d,
                "sweeps": [
                    {
                        **d["sweeps"][0],
                        "points": d["sweeps"][0]["points"][:2] + [[1, 2]] + d["sweeps"][0]["points"][3:],
                    }
                ]
                + d["sweeps"][1:],
            },
            r"s.json: sweeps\[0\].points\[2\]: expected a list of 3 numbers, got \[1, 2\]",
        ),
        (
            lambda d: {**d, "sweeps": [{**d["sweeps"][0], "joint": True}] + d["sweeps"][1:]},
            r"s.json: sweeps\[0\]: joint index out of range: expected an integer 1..6, got true",
        ),
        (
            lambda d: {**d, "sweeps": d["sweeps"] + [d["sweeps"][2]]},
            r"s.json: sweeps\[6\]: a second sweep of joint 3 \(the first is sweeps\[2\]\)",
        ),
        (
            lambda d: {
                **d,
                "sweeps": (
                    d["sweeps"][:1] + [{**d["sweeps"][1], "q": [r[:] for r in d["sweeps"][1]["q"]]}] + d["sweeps"][2:]
                ),
            },
            None,
        ),
        (
            lambda d: {**d, "sweeps": [{**d["sweeps"][0], "q": d["sweeps"][0]["q"][:4]}] + d["sweeps"][1:]},
            r"s.json: sweeps\[0\]: q must have one row per point: expected 8 rows, got 4",
        ),
    ],
)
def test_bad_json_sweeps_name_file_and_place(kr5, tmp_path, edit, match):
    doc = edit(json_doc(simulate(kr5, 30, points_per_sweep=8)))
    if match is None:  # NaN in a locked joint's reading (sweep 2, point 3, joint 1)
        doc["sweeps"][1]["q"][3][0] = float("nan")
        match = r"s.json: sweeps\[1\].q\[3\]\[0\]: expected a finite number, got NaN"
    f = tmp_path / "s.json"
    f.write_text(json.dumps(doc))
    with pytest.raises(dv.DenavitError, match=match):
        swio.read_json(f)


def write_joint_files(s, folder, header="time;x;y;z\n", scale=1e3):
    folder.mkdir(exist_ok=True)
    for x in s.sweeps:
        rows = [f"{k * 0.1:.1f};{p[0]:.9f};{p[1]:.9f};{p[2]:.9f}" for k, p in enumerate(x.points * scale)]
        (folder / f"j{x.joint}.csv").write_text(header + "\n".join(rows) + "\n")
    return folder


def test_joint_files_comments_headers_and_names(kr5, tmp_path):
    """A comment before the header is skipped; only files named exactly jN.csv are sweeps."""
    s = simulate(kr5, 90, points_per_sweep=10)
    d = write_joint_files(s, tmp_path / "files", header="# tracker export, 2024-05-02\ntime;x;y;z\n")
    (d / "j1_old.csv").write_text("0;1;2;3\n0.1;1;2;3\n0.2;1;2;3\n")  # an old recording lying beside j1.csv
    (d / "notes.csv").write_text("x;y;z\n")
    fs = swio.read_joint_files(d, home=sw.PAPER_HOME_DEG, length="mm")
    for a, b in zip(s.sweeps, fs.sweeps, strict=True):
        np.testing.assert_allclose(b.points, a.points, atol=1e-11)
    assert fs.sweeps[0].where[0].endswith("j1.csv:3")
    (d / "j01.csv").write_text((d / "j1.csv").read_text())
    with pytest.raises(dv.DenavitError, match=r"files: two files for joint 1: j01.csv and j1.csv"):
        swio.read_joint_files(d, home=sw.PAPER_HOME_DEG, length="mm")


@pytest.mark.parametrize(
    "first_line, kw, match",
    [
        ("0.0;nan;1;2\n", {}, r"j2.csv:1: column 'x' must be finite, got 'nan'"),
        ("0.0;1;inf;2\n", {}, r"j2.csv:1: column 'y' must be finite, got 'inf'"),
        ("0.0;1,5;1;2\n", {}, r"j2.csv:1: column 'x' must be a number, got '1,5' \(a decimal comma"),
        (
            "",
            {"direction": [1, -1]},
            (
                r"--direction: expected \+1 or -1, one for all joints or 6 \(one per joint, from --home\), got \[1.0,"
                r" -1.0\]"
            ),
        ),
        ("", {"direction": "up"}, r"--direction: expected \+1 or -1"),
        ("", {"home": [90, -90, float("nan"), 0, 90, 0]}, r"--home: expected one finite number per joint"),
        ("", {"kinds": ["revolute"] * 5}, r"6 joints in --home but 5 joint kinds"),
    ],
)
def test_bad_joint_files(kr5, tmp_path, first_line, kw, match):
    """A data line with NaN is an error naming file:line (not a header: a header is a line of names)."""
    d = write_joint_files(simulate(kr5, 90, points_per_sweep=10), tmp_path / "files", header="")
    (d / "j2.csv").write_text(first_line + (d / "j2.csv").read_text())
    with pytest.raises(dv.DenavitError, match=match):
        swio.read_joint_files(d, **{"home": sw.PAPER_HOME_DEG, "length": "mm", **kw})


@pytest.mark.parametrize("cell, got", [("inf", "inf"), ("nan", "nan"), ("1e400", "1e400"), ("1.5", "1.5")])
def test_long_csv_joint_index_not_an_integer(tmp_path, cell, got):
    f = write_csv(tmp_path, f"{cell},0,0,1,0,0\n")
    with pytest.raises(dv.DenavitError, match=rf"bad.csv:3: joint index out of range: expected 1..2, got {got}"):
        swio.read_long_csv(f)
