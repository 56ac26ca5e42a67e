"""Every reader and every command with a prismatic joint, in mm and m, deg and rad (issue 11).

An RPR arm (DH, mm/deg, with link inertias) and its POE form: a revolute joint's value is an angle, a prismatic
joint's a length, and a prismatic POE direction v is unitless, on the way in and on the way out of every
reader and command. The values are compared with the robot's own numbers (the file below), not with our
output.
"""

import json
import math

import numpy as np
import pytest
import tomllib

import denavit as dv
from cli import run

RPR = """name = "rpr"
convention = "dh"
home = [10, 100, 20]
[units]
length = "mm"
angle = "deg"
mass = "kg"
inertia = "kg m^2"
[[joints]]
name = "j1"
d = 300
theta = 0
a = 50
alpha = -90
limits = [-170, 170]
[[joints]]
name = "j2"
type = "prismatic"
d = 200
theta = 90
a = 0
alpha = 90
limits = [0, 300]
[joints.inertia]
mass = 4.0
com = [0, 0, -50]
ixx = 0.02
iyy = 0.02
izz = 0.01
[[joints]]
name = "j3"
d = 80
theta = 0
a = 120
alpha = 0
limits = [-170, 170]
[joints.inertia]
mass = 2.0
com = [-60, 0, 0]
ixx = 0.002
iyy = 0.01
izz = 0.01
"""
HOME = [10.0, 100.0, 20.0]  # deg, mm, deg
HOME_SI = [math.radians(10), 0.1, math.radians(20)]
RANGES_MM_DEG = "-40,40,50,250,-60,60"
RANGES_M_RAD = ",".join(
    f"{v!r}" for v in (math.radians(-40), math.radians(40), 0.05, 0.25, math.radians(-60), math.radians(60))
)


def _display(values_si, length):
    """An RPR joint vector from the JSON (rad, m, rad) in (deg, ``length``, deg)."""
    return np.asarray(values_si) / [math.pi / 180, 1e-3 if length == "mm" else 1.0, math.pi / 180]


def _si(values_mm_deg):
    """(deg, mm, deg) -> (rad, m, rad) as the CLI text of --q etc."""
    a, l, b = values_mm_deg
    return f"{math.radians(a)!r},{l / 1e3!r},{math.radians(b)!r}"


@pytest.fixture
def rpr(tmp_path):
    f = tmp_path / "rpr.toml"
    f.write_text(RPR)
    return f


@pytest.fixture
def rpr_poe(rpr, tmp_path):
    f = tmp_path / "rpr_poe.toml"
    run("convert", rpr, "--to", "poe", "-o", f, "--length", "m", "--angle", "rad")
    return f


def test_robot_file_reads_prismatic_values_as_lengths_and_writes_them_back(rpr, tmp_path):
    r = dv.load_robot(rpr)
    np.testing.assert_allclose(r.home, HOME_SI, atol=1e-15)
    np.testing.assert_allclose([r.lower[1], r.upper[1]], [0.0, 0.3], atol=1e-15)
    np.testing.assert_allclose(r.table.params[1], [0.2, math.pi / 2, 0.0, math.pi / 2], atol=1e-15)
    np.testing.assert_allclose(r.inertials["coms"][1], [0, 0, -0.05], atol=1e-15)
    for length, angle, k in (("m", "rad", 1e-3), ("mm", "deg", 1.0)):
        text = run("export", rpr, "--length", length, "--angle", angle).stdout
        doc = tomllib.loads(text)
        assert doc["units"]["length"] == length and doc["units"]["angle"] == angle
        ak = 1.0 if angle == "deg" else math.pi / 180
        np.testing.assert_allclose(doc["home"], [10 * ak, 100 * k, 20 * ak], rtol=1e-12)
        np.testing.assert_allclose(doc["joints"][1]["limits"], [0, 300 * k], rtol=1e-12)
        np.testing.assert_allclose(doc["joints"][0]["limits"], [-170 * ak, 170 * ak], rtol=1e-12)
        assert doc["joints"][1]["d"] == pytest.approx(200 * k, rel=1e-12)
        np.testing.assert_allclose(doc["joints"][2]["inertia"]["com"], [-60 * k, 0, 0], rtol=1e-12)
        back = tmp_path / f"back_{length}.toml"
        back.write_text(text)
        b = dv.load_robot(back)
        np.testing.assert_allclose(b.table.params, r.table.params, atol=1e-14)
        np.testing.assert_allclose(b.home, r.home, atol=1e-14)
        np.testing.assert_allclose(b.upper, r.upper, atol=1e-14)


def test_poe_prismatic_direction_is_unitless_in_files_tables_and_json(rpr, rpr_poe, tmp_path):
    poe = dv.load_robot(rpr_poe)
    np.testing.assert_allclose(dv.fk(poe.model(), HOME_SI), dv.fk(dv.load_model(rpr), HOME_SI), atol=1e-12)
    v_si = poe.table.params[1, 3:]
    assert np.linalg.norm(v_si) == pytest.approx(1.0)  # a prismatic screw's v is its unit direction
    w1 = poe.table.params[0, :3]
    v1 = poe.table.params[0, 3:]  # revolute: -w x p, a length
    for length in ("m", "mm"):
        k = 1e3 if length == "mm" else 1.0
        mm = tmp_path / f"p_{length}.toml"
        run("convert", rpr, "--to", "poe", "-o", mm, "--length", length)
        j = tomllib.loads(mm.read_text())["joints"]
        np.testing.assert_allclose(j[1]["v"], v_si, atol=1e-12)  # unitless, whatever the length unit
        np.testing.assert_allclose(j[0]["v"], v1 * k, atol=1e-9)
        np.testing.assert_allclose(j[0]["w"], w1, atol=1e-12)
        assert np.allclose(dv.load_robot(mm).table.params, poe.table.params, atol=1e-12)
        rows = json.loads(run("convert", rpr, "--to", "poe", "--json", "--length", length).stdout)[
            "rows"
        ]  # JSON: SI whatever --length
        np.testing.assert_allclose([rows[1][c] for c in ("vx", "vy", "vz")], v_si, atol=1e-12)
        np.testing.assert_allclose([rows[0][c] for c in ("vx", "vy", "vz")], v1, atol=1e-12)
        np.testing.assert_allclose([rows[0][c] for c in ("wx", "wy", "wz")], w1, atol=1e-12)
        shown = run("show", rpr_poe, "--length", length).stdout
        line = next(ln for ln in shown.splitlines() if ln.strip("│ ").startswith("j2"))
        cells = [float(c) for c in line.replace("│", " ").split()[1:]]
        np.testing.assert_allclose(cells[3:], v_si, atol=1e-4)  # printed with 4 decimals, unitless
        np.testing.assert_allclose(cells[:3], poe.table.params[1, :3], atol=1e-4)
        line = next(ln for ln in shown.splitlines() if ln.strip("│ ").startswith("j1"))
        cells = [float(c) for c in line.replace("│", " ").split()[1:]]
        np.testing.assert_allclose(cells[:3], w1, atol=1e-4)  # the POE w is unitless: never scaled by the length unit


def test_show_and_export_tables_give_the_prismatic_offset_as_a_length(rpr):
    for length, k in (("mm", 1.0), ("m", 1e-3)):
        shown = run("show", rpr, "--length", length, "--angle", "deg").stdout
        shown = shown[shown.index("┏") :]  # the table (the model's title and source come first)
        assert f"d [{length}]" in shown
        line = next(ln for ln in shown.splitlines() if ln.strip("│ ").startswith("j2"))
        cells = [float(c) for c in line.replace("│", " ").split()[1:]]
        np.testing.assert_allclose(cells, [200 * k, 90, 0, 90], atol=1e-4)


def test_fk_reads_and_echoes_prismatic_values_in_the_length_unit(rpr):
    T = dv.fk(dv.load_model(rpr), HOME_SI)
    a = json.loads(run("fk", rpr, "--q", "10,100,20", "--json").stdout)  # deg, mm: the defaults; JSON SI
    b = json.loads(run("fk", rpr, "--q", _si(HOME), "--length", "m", "--angle", "rad", "--json").stdout)
    np.testing.assert_allclose(_display(a["q"], "mm"), HOME, atol=1e-12)
    np.testing.assert_allclose(b["q"], HOME_SI, atol=1e-15)
    np.testing.assert_allclose(np.array(a["T_world_tool"])[:3, 3], T[:3, 3], atol=1e-12)
    np.testing.assert_allclose(np.array(b["T_world_tool"])[:3, 3], T[:3, 3], atol=1e-12)


def test_ik_answers_prismatic_values_in_the_length_unit(rpr):
    T = dv.fk(dv.load_model(rpr), HOME_SI)
    T_mm = T.copy()
    T_mm[:3, 3] *= 1e3
    pose_mm = ",".join(repr(float(v)) for v in T_mm.ravel())
    pose_m = ",".join(repr(float(v)) for v in T.ravel())
    # an RPR arm reaches a 3-D point, not a 6-D pose: start next to the answer, judge the position alone
    a = json.loads(
        run(
            "ik",
            rpr,
            "--pose",
            pose_mm,
            "--q0",
            "12,90,25",
            "--json",
            "--restarts",
            "0",
            "--tol-rotation",
            str(math.degrees(10)),
            "--tol-position",
            "1e-6",
            ok=False,
        ).stdout
    )
    b = json.loads(
        run(
            "ik",
            rpr,
            "--pose",
            pose_m,
            "--q0",
            _si((12, 90, 25)),
            "--length",
            "m",
            "--angle",
            "rad",
            "--json",
            "--restarts",
            "0",
            "--tol-rotation",
            "10",
            "--tol-position",
            "1e-9",
            ok=False,
        ).stdout
    )
    np.testing.assert_allclose(_display(a["q"], "mm"), HOME, atol=1e-5)
    np.testing.assert_allclose(b["q"], HOME_SI, atol=1e-7)


def test_dynamics_reads_and_echoes_prismatic_values_and_rates_in_the_length_unit(rpr):
    m = dv.load_model(rpr)
    qd_si, qdd_si = [0.2, 0.05, -0.1], [0.1, 0.3, 0.2]
    tau = dv.rnea(m, HOME_SI, qd_si, qdd_si, gravity=[0, 0, -9.81])
    a = json.loads(
        run(
            "dynamics",
            rpr,
            "--q",
            "10,100,20",
            "--qd",
            ",".join(repr(v) for v in (math.degrees(0.2), 50.0, math.degrees(-0.1))),
            "--qdd",
            ",".join(repr(v) for v in (math.degrees(0.1), 300.0, math.degrees(0.2))),
            "--json",
        ).stdout
    )
    b = json.loads(
        run(
            "dynamics",
            rpr,
            "--q",
            _si(HOME),
            "--qd",
            ",".join(map(repr, qd_si)),
            "--qdd",
            ",".join(map(repr, qdd_si)),
            "--length",
            "m",
            "--angle",
            "rad",
            "--json",
        ).stdout
    )
    np.testing.assert_allclose(a["tau"], tau, rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(b["tau"], tau, rtol=1e-10, atol=1e-12)
    assert a["tau_units"] == ["N m", "N", "N m"]
    np.testing.assert_allclose(_display(a["q"], "mm"), HOME, atol=1e-12)
    np.testing.assert_allclose(_display(a["qd"], "mm"), [math.degrees(0.2), 50.0, math.degrees(-0.1)], atol=1e-12)
    np.testing.assert_allclose(b["qdd"], qdd_si, atol=1e-15)


def _long_csv_rows(path):
    lines = [ln for ln in path.read_text().splitlines() if ln and not ln.startswith("#")]
    cols = lines[0].split(",")
    return cols, np.array([[float(c) for c in ln.split(",")] for ln in lines[1:]])


def test_simulate_then_identify_with_a_prismatic_joint(rpr, tmp_path):
    mm, m = tmp_path / "mm.csv", tmp_path / "m.csv"
    run("simulate", rpr, "-o", mm, "--home", "10,100,20", "--ranges", RANGES_MM_DEG, "--points", "12", "--noise", "0")
    run(
        "simulate",
        rpr,
        "-o",
        m,
        "--home",
        _si(HOME),
        "--ranges",
        RANGES_M_RAD,
        "--points",
        "12",
        "--noise",
        "0",
        "--tool",
        "0.05,0.03,0.1",
        "--length",
        "m",
        "--angle",
        "rad",
    )
    cols, a = _long_csv_rows(mm)
    _, b = _long_csv_rows(m)
    assert cols == ["joint", "q1", "q2", "q3", "x", "y", "z"]
    locked = a[a[:, 0] != 2]
    np.testing.assert_allclose(locked[:, 2], 100.0, atol=1e-9)  # the prismatic home in mm (had been 1745.33)
    sweep2 = a[a[:, 0] == 2]
    np.testing.assert_allclose(sweep2[[0, -1], 2], [50, 250], atol=1e-9)
    np.testing.assert_allclose(b[:, 1:4], a[:, 1:4] * [math.pi / 180, 1e-3, math.pi / 180], rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(b[:, 4:], a[:, 4:] * 1e-3, rtol=1e-9, atol=1e-12)
    T = dv.fk(dv.load_model(rpr).with_tool(np.eye(4)), HOME_SI)
    point = T[:3, :3] @ [0.05, 0.03, 0.1] + T[:3, 3]  # the tool point at home (m), as simulated
    first = None
    for data, length in ((mm, "mm"), (m, "m"), (mm, "m")):
        out = tmp_path / f"{data.stem}_{length}.json"
        run("identify", data, "--nominal", rpr, "--convention", "dh", "--length", length, "--json", out)
        doc = json.loads(out.read_text())
        k = 1e3 if length == "mm" else 1.0
        np.testing.assert_allclose(_display(doc["home"], length), [10, 100 * k / 1e3, 20], atol=1e-6)
        assert doc["units"] == {"length": "m", "angle": "rad"}  # JSON: SI whatever --length
        np.testing.assert_allclose(doc["tool_point_home_m"], point, atol=1e-6)
        params = np.array([[r[c] for c in ("d", "theta", "a", "alpha")] for r in doc["parameters"]]) * [
            1,
            180 / math.pi,
            1,
            180 / math.pi,
        ]  # m, deg
        first = params if first is None else first
        np.testing.assert_allclose(params, first, atol=1e-8)  # the same geometry whatever the units in and out
        np.testing.assert_allclose(params[2, [0, 2]], [0.08, 0.12], atol=1e-8)  # joint 3: d 80 mm, a 120 mm
    # one file per joint: x, y, z only; --home in --angle (revolute) and --length (prismatic) units
    for home, length, angle in (("10,100,20", "mm", "deg"), (_si(HOME), "m", "rad")):
        folder = tmp_path / f"perjoint_{length}"
        folder.mkdir()
        for j in (1, 2, 3):
            rows = (a if length == "mm" else b)[a[:, 0] == j]
            (folder / f"j{j}.csv").write_text(
                "x,y,z\n" + "".join(",".join(repr(float(v)) for v in p) + "\n" for p in rows[:, 4:])
            )
        out = tmp_path / f"folder_{length}.json"
        run(
            "identify",
            folder,
            "--nominal",
            rpr,
            "--convention",
            "dh",
            "--home",
            home,
            "--length",
            length,
            "--angle",
            angle,
            "--json",
            out,
        )
        doc = json.loads(out.read_text())
        k = 1e3 if length == "mm" else 1.0
        np.testing.assert_allclose(_display(doc["home"], length), [10, 100 * k / 1e3, 20], atol=1e-6)
        params = np.array([[r[c] for c in ("d", "theta", "a", "alpha")] for r in doc["parameters"]]) * [
            1,
            180 / math.pi,
            1,
            180 / math.pi,
        ]  # m, deg
        np.testing.assert_allclose(params, first, atol=1e-6)  # (the home point is a measured one: no readings)


def test_calibrate_reads_prismatic_readings_in_the_length_unit_in_mm_and_m(rpr, tmp_path):
    from denavit import calibration as cal

    robot = dv.load_robot(rpr)
    q = cal.configurations(robot, 30)
    meas = cal.simulate(robot, q, tool=(0.03, 0.02, 0.05))
    for length, angle, sep in (("mm", "deg", " "), ("m", "rad", "")):
        f = tmp_path / f"m_{length}.csv"
        ls, as_ = (1e-3, math.pi / 180) if length == "mm" else (1.0, 1.0)
        qs = np.array([as_, ls, as_])
        lines = [f"#{sep}units: length={length} angle={angle}", "q1,q2,q3,x,y,z"]
        lines += [",".join(repr(float(v)) for v in (*qi / qs, *p / ls)) for qi, p in zip(meas.q, meas.points)]
        f.write_text("\n".join(lines) + "\n")
        out = tmp_path / f"r_{length}.json"
        # the file declares its units: --length/--angle (default mm, deg) are the output's (and --tool's) only
        run("calibrate", f, "--nominal", rpr, "--tool", "30,20,50", "--json", out, "--holdout", "0", "--fix", "tool_*")
        doc = json.loads(out.read_text())
        assert doc["units"]["length"] == "m"  # JSON: SI
        assert doc["residuals"]["rms_m"] < 1e-9, doc["residuals"]  # m (1e-6 mm): exact data, read in the right units


def test_plan_reads_home_and_ranges_of_a_prismatic_joint_in_the_length_unit(rpr):
    a = json.loads(
        run(
            "plan",
            rpr,
            "--home",
            "10,100,20",
            "--ranges",
            RANGES_MM_DEG,
            "--points",
            "10",
            "--tool",
            "30,20,50",
            "--json",
        ).stdout
    )
    b = json.loads(
        run(
            "plan",
            rpr,
            "--home",
            _si(HOME),
            "--ranges",
            RANGES_M_RAD,
            "--points",
            "10",
            "--tool",
            "0.03,0.02,0.05",
            "--noise",
            "2e-5",
            "--length",
            "m",
            "--angle",
            "rad",
            "--json",
        ).stdout
    )
    np.testing.assert_allclose(b["bounding_box"]["lengths_m"], a["bounding_box"]["lengths_m"], rtol=1e-9)  # JSON: SI
    m = dv.load_model(rpr)
    from denavit import sweeps as sw

    s = sw.simulate(
        m,
        home=HOME_SI,
        ranges=[[math.radians(-40), math.radians(40)], [0.05, 0.25], [math.radians(-60), math.radians(60)]],
        points_per_sweep=10,
        tool_point=(0.03, 0.02, 0.05),
    )
    P = s.all_points
    diameter = max(np.linalg.norm(P - p, axis=1).max() for p in P)
    diagonal = np.linalg.norm(a["bounding_box"]["lengths_m"])  # the box holds every point: its diagonal spans them
    assert diameter - 1e-9 <= diagonal <= math.sqrt(3) * diameter  # m


def test_convert_carries_prismatic_limits_and_home_in_the_length_unit(rpr, tmp_path):
    for to in ("mdh", "edh"):
        for length, k in (("mm", 1.0), ("m", 1e-3)):
            out = tmp_path / f"{to}_{length}.toml"
            run("convert", rpr, "--to", to, "-o", out, "--length", length)
            doc = tomllib.loads(out.read_text())
            np.testing.assert_allclose(doc["joints"][1]["limits"], [0, 300 * k], rtol=1e-12)
            np.testing.assert_allclose(doc["home"], [10, 100 * k, 20], rtol=1e-12)
            back = dv.load_robot(out)
            np.testing.assert_allclose(dv.fk(back.model(), HOME_SI), dv.fk(dv.load_model(rpr), HOME_SI), atol=1e-12)
