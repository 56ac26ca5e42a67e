"""Every command in mm/deg (the defaults) and in m/rad on the same data: the numbers agree through the unit
factors (the JSON is SI either way, the tables and files are scaled), and every default keeps its physical
size whatever the unit asked (docs/cli.md, "Units")."""

import json
import math
import re

import numpy as np
import pytest

import denavit as dv
from cli import run

SI = ("--length", "m", "--angle", "rad")
Q_DEG = [10.0, -80.0, 70.0, 5.0, 60.0, 20.0]
Q_RAD = [math.radians(v) for v in Q_DEG]


def csv(values) -> str:
    return ",".join(repr(float(v)) for v in values)


def doc(*args) -> dict:
    """The JSON a command prints with a bare --json (standard output)."""
    p = run(*args, "--json")
    return json.loads(p.stdout)


def close(a, b, rtol=1e-9, atol=1e-12, path="") -> None:
    """Two JSON documents equal, numbers within the tolerances (strings, keys and lengths exactly)."""
    if isinstance(a, dict):
        assert a.keys() == b.keys(), path
        for k in a:
            close(a[k], b[k], rtol, atol, f"{path}.{k}")
    elif isinstance(a, list):
        assert len(a) == len(b), path
        for i, (x, y) in enumerate(zip(a, b)):
            close(x, y, rtol, atol, f"{path}[{i}]")
    elif isinstance(a, float) or isinstance(b, float):
        assert a == pytest.approx(b, rel=rtol, abs=atol), path
    else:
        assert a == b, path


def column(out: str, header: str) -> list[float]:
    """The numbers of a rich table's column (by its header cell) in printed order."""
    lines = out.splitlines()
    head = next(
        i
        for i, ln in enumerate(lines)
        if "┃" in ln and header in ln.split("┃")[1:] or f" {header} " in ln and "┃" in ln
    )
    k = [c.strip() for c in lines[head].split("┃")].index(header)
    vals = []
    for ln in lines[head + 1 :]:
        if ln.startswith("└"):
            break
        if ln.startswith("│"):
            vals.append(float(ln.split("│")[k]))
    return vals


def test_fk_reads_q_in_the_angle_unit_and_prints_lengths_in_the_length_unit():
    a, b = doc("fk", "kr5", "--q", csv(Q_DEG)), doc("fk", "kr5", "--q", csv(Q_RAD), *SI)
    close(a, b)
    np.testing.assert_allclose(a["q"], Q_RAD, atol=1e-15)  # typed in degrees (the default), not radians
    np.testing.assert_allclose(a["T_world_tool"], dv.fk(dv.load_model("kr5"), Q_RAD), atol=1e-12)
    mm, m = run("fk", "kr5", "--q", csv(Q_DEG)).stdout, run("fk", "kr5", "--q", csv(Q_RAD), *SI).stdout
    for c in ("x", "y", "z"):
        np.testing.assert_allclose(np.array(column(mm, f"{c} [mm]")) * 1e-3, column(m, f"{c} [m]"), atol=1e-6)


def test_fk_warns_of_values_beyond_the_limits_in_the_unit_typed():
    """The issue's `fk --q "90,-90,90,0,90,0"` read as radians went far beyond the limits with no word."""
    p = run("fk", "kr5", "--q", "90,-90,90,0,90,0", *SI)
    assert "warning: --q: joint A1 = 90 rad is beyond its limits" in p.stderr and "were degrees meant?" in p.stderr
    assert "warning" not in run("fk", "kr5", "--q", "90,-90,90,0,90,0").stderr


def test_ik_pose_and_q0_in_the_units_asked_and_default_tolerances_keep_their_size():
    T = dv.fk(dv.load_model("kr5"), Q_RAD)
    from denavit.geometry import matrix_rpy

    rpy = matrix_rpy(T[:3, :3])
    pose_mm = csv([*(T[:3, 3] * 1e3), *np.degrees(rpy)])
    pose_m = csv([*T[:3, 3], *rpy])
    start = [v + 5 for v in Q_DEG]
    a = doc("ik", "kr5", "--pose", pose_mm, "--q0", csv(start))
    b = doc("ik", "kr5", "--pose", pose_m, "--q0", csv(np.radians(start)), *SI)
    assert a["success"] and b["success"]
    np.testing.assert_allclose(a["q"], b["q"], atol=1e-8)
    np.testing.assert_allclose(dv.fk(dv.load_model("kr5"), a["q"]), T, atol=1e-9)
    # the default tolerances are 1e-10 m and 1e-10 rad in both: the same physical requirement
    assert a["position_error_m"] <= 1e-10 and b["position_error_m"] <= 1e-10
    assert a["rotation_error_rad"] <= 1e-10 and b["rotation_error_rad"] <= 1e-10


def test_dynamics_reads_q_and_rates_in_the_units_asked():
    qd, qdd = [20.0, -10.0, 5.0, 0.0, 30.0, 0.0], [0.0, 30.0, 0.0, 10.0, 0.0, 5.0]
    a = doc("dynamics", "tiansui_edh", "--q", csv(Q_DEG), "--qd", csv(qd), "--qdd", csv(qdd))
    b = doc(
        "dynamics", "tiansui_edh", "--q", csv(Q_RAD), "--qd", csv(np.radians(qd)), "--qdd", csv(np.radians(qdd)), *SI
    )
    close(a, b)
    tau = dv.rnea(dv.load_model("tiansui_edh"), Q_RAD, np.radians(qd), np.radians(qdd), gravity=[0, 0, -9.81])
    np.testing.assert_allclose(a["tau"], tau, rtol=1e-12, atol=1e-12)


def test_convert_show_and_export_scale_tables_and_files_and_keep_json_si(tmp_path):
    close(doc("convert", "kr5", "--to", "mdh"), doc("convert", "kr5", "--to", "mdh", *SI))
    close(doc("show", "ur5"), doc("show", "ur5", *SI))
    close(doc("export", "ur5"), doc("export", "ur5", *SI))
    mm, m = run("show", "ur5").stdout, run("show", "ur5", *SI).stdout
    np.testing.assert_allclose(np.array(column(mm, "d [mm]")) * 1e-3, column(m, "d [m]"), atol=1e-6)
    np.testing.assert_allclose(np.radians(column(mm, "alpha [deg]")), column(m, "alpha [rad]"), atol=1e-5)
    for cmd in (["convert", "kr5", "--to", "edh", "-o"], ["export", "kr5", ">"]):
        files = []
        for units in ((), SI):
            f = tmp_path / f"{cmd[0]}{len(units)}.toml"
            if cmd[-1] == ">":
                f.write_text(run(*cmd[:-1], *units).stdout)
            else:
                run(*cmd, f, *units)
            files.append(dv.load_robot(f))
        assert 'length = "m"' in (tmp_path / f"{cmd[0]}4.toml").read_text()
        np.testing.assert_allclose(files[0].table.params, files[1].table.params, atol=1e-12)


def test_simulate_defaults_keep_their_physical_size(tmp_path):
    """--noise 0.02 mm and --tool (50, 30, 100) mm by default: with --length m they had become 0.02 m and a tool
    100 m away."""
    from denavit.io import sweeps as swio

    a, b = tmp_path / "a.csv", tmp_path / "b.csv"
    run("simulate", "kr5", "-o", a, "--points", "6")
    run("simulate", "kr5", "-o", b, "--points", "6", *SI)
    sa, sb = swio.read_long_csv(a), swio.read_long_csv(b)
    assert sa.units["length"] == "mm" and sb.units["length"] == "m"
    np.testing.assert_allclose(sa.all_points, sb.all_points, atol=1e-9)  # the same noise draw, the same size
    noise_free = dv.load_model("kr5")
    tool = dv.fk(noise_free, sb.sweeps[0].q[0]) @ [0.05, 0.03, 0.1, 1.0]
    assert np.linalg.norm(sb.sweeps[0].points[0] - tool[:3]) < 2e-4  # the default tool, within the default noise
    # typed values in the unit asked
    c = tmp_path / "c.csv"
    run(
        "simulate",
        "kr5",
        "-o",
        c,
        "--points",
        "6",
        "--noise",
        "2e-5",
        "--tool",
        "0.05,0.03,0.1",
        "--home",
        csv(np.radians([0, -90, 90, 0, 90, 0])),
        *SI,
    )
    d = tmp_path / "d.csv"
    run(
        "simulate",
        "kr5",
        "-o",
        d,
        "--points",
        "6",
        "--noise",
        "0.02",
        "--tool",
        "50,30,100",
        "--home",
        "0,-90,90,0,90,0",
    )
    np.testing.assert_allclose(swio.read_long_csv(c).all_points, swio.read_long_csv(d).all_points, atol=1e-9)


def test_plan_defaults_keep_their_physical_size(tmp_path):
    """'noise 0.02 m' and a 183 x 43 x 37 m measuring volume with --length m: the defaults are 0.02 mm and a
    tool 50, 30, 100 mm from the flange whatever the unit."""
    a, b = doc("plan", "kr5", "--points", "8"), doc("plan", "kr5", "--points", "8", *SI)
    close(a, b, rtol=1e-7, atol=1e-15)
    assert a["noise_m"] == b["noise_m"] == pytest.approx(2e-5)
    assert max(a["bounding_box"]["lengths_m"]) < 2.0  # a KR5's reach, not 183 m
    text = run("plan", "kr5", "--points", "8", *SI).stdout
    assert "noise 2e-05 m per coordinate" in text
    c = doc("plan", "kr5", "--points", "8", "--noise", "0.05", "--tool", "20,10,80")
    d = doc("plan", "kr5", "--points", "8", "--noise", "5e-5", "--tool", "0.02,0.01,0.08", *SI)
    close(c, d, rtol=1e-7, atol=1e-15)
    f, g = tmp_path / "c_deg.csv", tmp_path / "c_rad.csv"
    from denavit import calibration as cal

    q = cal.configurations(dv.load_robot("kr5"), 25)
    f.write_text("q1,q2,q3,q4,q5,q6\n" + "".join(csv(np.degrees(r)) + "\n" for r in q))  # no units line: --angle
    g.write_text("q1,q2,q3,q4,q5,q6\n" + "".join(csv(r) + "\n" for r in q))
    close(doc("plan", "kr5", "--candidates", f), doc("plan", "kr5", "--candidates", g, *SI), rtol=1e-7, atol=1e-15)


@pytest.fixture(scope="module")
def sweeps_mm(tmp_path_factory):
    f = tmp_path_factory.mktemp("sweeps") / "s.csv"
    run("simulate", "kr5", "-o", f, "--points", "10", "--ranges", "paper30")
    return f


def test_identify_prints_and_saves_in_the_units_asked(sweeps_mm, tmp_path):
    a_toml, b_toml = tmp_path / "a.toml", tmp_path / "b.toml"
    pa = run(
        "identify",
        sweeps_mm,
        "--nominal",
        "kr5",
        "--json",
        "-",
        "--save",
        a_toml,
        "--max-sigma",
        "1",
        "--base",
        "0,0,0,0,0,0",
    )
    pb = run(
        "identify",
        sweeps_mm,
        "--nominal",
        "kr5",
        "--json",
        "-",
        "--save",
        b_toml,
        "--max-sigma",
        "0.001",
        "--base",
        "0,0,0,0,0,0",
        *SI,
    )
    close(json.loads(pa.stdout), json.loads(pb.stdout), rtol=1e-7, atol=1e-12)
    np.testing.assert_allclose(dv.load_robot(a_toml).table.params, dv.load_robot(b_toml).table.params, atol=1e-9)
    assert 'length = "m"' in b_toml.read_text()
    mm, m = (
        run("identify", sweeps_mm, "--nominal", "kr5", "--verbose").stdout,  # the joint axes: with --verbose
        run("identify", sweeps_mm, "--nominal", "kr5", "--verbose", *SI).stdout,
    )
    np.testing.assert_allclose(np.array(column(mm, "radius [mm]")) * 1e-3, column(m, "radius [m]"), atol=1e-6)
    np.testing.assert_allclose(np.radians(column(mm, "arc [deg]")), column(m, "arc [rad]"), rtol=1e-3)
    # a 0.000 sigma never stands for metre data: spreads are shown with significant figures
    assert not re.search(r"│\s+0\.000\s+│", m)
    # --max-sigma is a length in --length: 1e-6 mm is as impossible as 1e-9 m
    for args in (("--max-sigma", "1e-6"), ("--max-sigma", "1e-9", *SI)):
        p = run("identify", sweeps_mm, "--nominal", "kr5", *args, ok=False)
        assert p.returncode == 2 and "exceeds the requested 1e-06 mm" in p.stderr


def test_identify_fills_in_an_undeclared_angle_unit_but_not_a_length(sweeps_mm, tmp_path):
    """docs/cli.md: --angle (default deg) fills in what a sweep file does not declare; an undeclared length is
    refused unless --length is given (it had refused the undeclared angle too)."""
    text = sweeps_mm.read_text()
    assert "# units: length=mm angle=deg\n" in text
    f, g = tmp_path / "len_only.csv", tmp_path / "angle_only.csv"
    f.write_text(text.replace("# units: length=mm angle=deg\n", "# units: length=mm\n"))
    g.write_text(text.replace("# units: length=mm angle=deg\n", "# units: angle=deg\n"))
    full, filled = (json.loads(run("identify", x, "--nominal", "kr5", "--json", "-").stdout) for x in (sweeps_mm, f))
    assert full.pop("source") != filled.pop("source")
    close(filled, full, rtol=1e-12, atol=1e-15)
    p = run("identify", g, "--nominal", "kr5", ok=False)
    assert p.returncode == 2 and "units not declared (length)" in p.stderr


def test_identify_per_joint_home_in_the_angle_unit(sweeps_mm, tmp_path):
    """A folder of per-joint files: --home in --angle (degrees by default); the same geometry from radians
    with --angle rad, and a warning when the values cannot be the unit asked (beyond the nominal's limits)."""
    from denavit.io import sweeps as swio

    s = swio.read_long_csv(sweeps_mm)
    folder = tmp_path / "perjoint"
    folder.mkdir()
    for j, sw in enumerate(s.sweeps, 1):
        (folder / f"j{j}.csv").write_text("x,y,z\n" + "".join(csv(p * 1e3) + "\n" for p in sw.points))
    home_deg = np.degrees(s.home)
    a = doc("identify", folder, "--nominal", "kr5", "--home", csv(home_deg), "--length", "mm")
    b = doc("identify", folder, "--nominal", "kr5", "--home", csv(s.home), "--length", "mm", "--angle", "rad")
    close(a, b, rtol=1e-7, atol=1e-10)
    p = run("identify", folder, "--nominal", "kr5", "--home", csv(home_deg), "--length", "mm", "--angle", "rad")
    assert "warning: --home: joint" in p.stderr and "beyond its limits" in p.stderr


def test_calibrate_reads_data_and_tool_in_the_units_asked(tmp_path):
    from denavit import calibration as cal

    kr5 = dv.load_robot("kr5")
    meas = cal.simulate(kr5, cal.configurations(kr5, 40), tool=(0.05, 0.03, 0.1), noise=2e-5, seed=3)
    a, b = tmp_path / "mm.csv", tmp_path / "m.csv"  # no units line: read in --length / --angle
    a.write_text(
        "q1,q2,q3,q4,q5,q6,x,y,z\n"
        + "".join(csv([*np.degrees(q), *(p * 1e3)]) + "\n" for q, p in zip(meas.q, meas.points))
    )
    b.write_text("q1,q2,q3,q4,q5,q6,x,y,z\n" + "".join(csv([*q, *p]) + "\n" for q, p in zip(meas.q, meas.points)))
    da = doc("calibrate", a, "--nominal", "kr5", "--tool", "50,30,100", "--noise", "0.02", "--holdout", "0")
    db = doc("calibrate", b, "--nominal", "kr5", "--tool", "0.05,0.03,0.1", "--noise", "2e-5", "--holdout", "0", *SI)
    for d in (da, db):
        d.pop("elapsed_s", None), d.pop("elapsed", None), d.pop("source", None)
        d.get("measurements", {}).pop("source", None)
    va = {p["name"]: p["value"] for p in da["parameters"]}
    vb = {p["name"]: p["value"] for p in db["parameters"]}
    assert va.keys() == vb.keys()
    for k in va:
        assert va[k] == pytest.approx(vb[k], abs=1e-9), k
    assert (
        da["residuals"]["rms_m"] == pytest.approx(db["residuals"]["rms_m"], rel=1e-6)
        and da["residuals"]["rms_m"] < 5e-5
    )
    mm, m = (
        run("calibrate", f, "--nominal", "kr5", "--tool", t, "--holdout", "0", *u).stdout
        for f, t, u in ((a, "50,30,100", ()), (b, "0.05,0.03,0.1", SI))
    )
    np.testing.assert_allclose(
        column(mm, "calibrated")[-3:], [v * 1e3 for v in column(m, "calibrated")[-3:]], atol=2e-3
    )  # tool_x..z


def test_compensate_reads_rows_and_writes_in_the_units_asked(tmp_path):
    from denavit import calibration as cal

    q = cal.configurations(dv.load_robot("kr5"), 6) * 0.5
    a, b = tmp_path / "a.csv", tmp_path / "b.csv"  # no units line: read in --length / --angle
    a.write_text("q1,q2,q3,q4,q5,q6\n" + "".join(csv(np.degrees(r)) + "\n" for r in q))
    b.write_text("q1,q2,q3,q4,q5,q6\n" + "".join(csv(r) + "\n" for r in q))
    oa, ob = tmp_path / "oa.csv", tmp_path / "ob.csv"
    ja = doc("compensate", a, "--nominal", "kr5", "--identified", "kr5", "-o", oa)
    jb = doc("compensate", b, "--nominal", "kr5", "--identified", "kr5", "-o", ob, *SI)
    assert [r.pop("where") for r in ja["rows"]] == [f"{a}:{k}" for k in range(2, 8)]  # (the rows name their file)
    assert [r.pop("where") for r in jb["rows"]] == [f"{b}:{k}" for k in range(2, 8)]
    close(ja, jb, atol=1e-12)
    assert ja["flagged"] == 0  # the default --branch-tol is 5 deg in both (it had been 5 rad with --angle rad)
    from denavit.io.units import declared_units

    assert declared_units(oa)["length"] == "mm" and declared_units(ob)["length"] == "m"


def test_inspect_prints_joint_values_in_the_angle_unit():
    from pathlib import Path

    rec = Path(__file__).parent / "data" / "recordings" / "rtde.csv"
    rows = []
    for units in ((), ("--angle", "rad")):
        out = run("inspect", rec, *units).stdout
        rows.append(
            [
                [float(c) for c in ln.split()[5:7]]
                for ln in out.splitlines()
                if re.match(r"\s+\d+\s+\d+\s+\w+\s+\d+-\d+", ln)
            ]
        )
    np.testing.assert_allclose(np.radians(rows[0]), rows[1], atol=2e-3)


def test_models_has_no_units_and_json_everywhere_goes_where_asked(tmp_path):
    """`--json` bare or `-` is standard output, a path is a file (identify had written a file named '-')."""
    bare, dash = run("models", "--json").stdout, run("models", "--json", "-").stdout
    assert json.loads(bare) == json.loads(dash)
    f = tmp_path / "m.json"
    p = run("models", "--json", f)
    assert json.loads(f.read_text()) == json.loads(bare) and f"wrote {f}" in p.stdout
    p = run("identify", "--example", "kr5", "--json")
    assert json.loads(p.stdout)["units"] == {"length": "m", "angle": "rad"}
    assert not (tmp_path / "-").exists()


# -- a file's units declaration: one form, one parser; a comment that looks like one is refused, not ignored -------

KR5 = ["revolute"] * 6
LOOKALIKE = "# length: mm\n# angle: rad\n"  # the issue's positions file: these had been ignored, rad read as deg
LOOKALIKE_SAYS = "looks like a units declaration but is not in its form: expected '# units: length=mm angle=rad'"


def _rows(values) -> str:
    return "".join(csv(r) + "\n" for r in values)


def _poses_mm_rad(n=20) -> np.ndarray:
    """kr5's tool poses at n configurations as x,y,z (mm), rx,ry,rz (rad), from the forward kinematics."""
    from denavit import calibration as cal
    from denavit.geometry import matrix_rotvec

    kr5 = dv.load_robot("kr5")
    T = [dv.fk(kr5.model(), q) for q in cal.configurations(kr5, n) * 0.5]
    return np.array([[*(t[:3, 3] * 1e3), *matrix_rotvec(t[:3, :3])] for t in T])


def _reader_files(tmp_path) -> dict:
    """One file per reader kind that takes a '# units:' declaration, each with the look-alike lines; the CLI
    command that reads it and the Python call."""
    from denavit.io.configurations import read_configurations
    from denavit.io.measurements import read_measurements
    from denavit.io.positions import read_positions
    from denavit.io.recordings import read_recording
    from denavit.io.sweeps import read_joint_files, read_long_csv

    q = np.zeros((3, 6)) + [10, -80, 70, 5, 60, 20]
    files = {
        "positions": ("pos.csv", "x,y,z,rx,ry,rz\n" + _rows(_poses_mm_rad(3))),
        "measurements": ("m.csv", "q1,q2,q3,q4,q5,q6,x,y,z\n" + _rows(np.c_[q, np.ones((3, 3))])),
        "sweeps": ("s.csv", "joint,q1,q2,q3,q4,q5,q6,x,y,z\n" + _rows(np.c_[np.ones(3), q, np.ones((3, 3))])),
        "joint files": ("j/j1.csv", "x,y,z\n" + _rows(np.eye(3))),
        "candidates": ("c.csv", "q1,q2,q3,q4,q5,q6\n" + _rows(q)),
        "columns": ("r.txt", _rows(np.c_[np.arange(3), q])),
        "tracker": ("t.csv", "Collection,Group,Point,X,Y,Z\nS,J1,J1_001,1,2,3\nS,J1,J1_002,1,2,4\n"),
    }
    out = {}
    for kind, (name, body) in files.items():
        f = tmp_path / name
        f.parent.mkdir(exist_ok=True)
        f.write_text(LOOKALIKE + body)
        cli = {
            "positions": ("compensate", "kr5", f, "--identified", "kr5", "-o", tmp_path / "o.csv"),
            "measurements": ("calibrate", "kr5", f),
            "sweeps": ("identify", f),
            "joint files": ("identify", f.parent, "--home", "0,0,0,0,0,0", "--length", "mm"),
            "candidates": ("plan", "kr5", "--candidates", f),
            "columns": ("inspect", f, "--columns", "t,q1..q6"),
            "tracker": ("inspect", f),
        }[kind]
        py = {
            "positions": lambda f=f: read_positions(f, KR5),
            "measurements": lambda f=f: read_measurements(f, kinds=KR5),
            "sweeps": lambda f=f: read_long_csv(f),
            "joint files": lambda f=f: read_joint_files(f.parent, home=np.zeros(6), length="mm"),
            "candidates": lambda f=f: read_configurations(f, KR5),
            "columns": lambda f=f: read_recording(f, columns="t,q1..q6"),
            "tracker": lambda f=f: read_recording(f),
        }[kind]
        out[kind] = (f, cli, py)
    return out


def test_every_reader_refuses_a_comment_that_looks_like_a_units_declaration(tmp_path):
    """The issue: '# length: mm' and '# angle: rad' were comments to every reader; compensate read the rotation
    vectors (rad) as degrees (6 of 20 rows 'unreachable', the rest wrong), read_positions said 'units not
    declared'. Now each reader, by the command line and in Python, names the file, the line, what came and the
    form it accepts."""
    files = _reader_files(tmp_path)
    assert len(files) == 7
    for kind, (f, cli, py) in files.items():
        p = run(*cli, ok=False)
        said = " ".join(p.stderr.split())
        assert p.returncode == 2 and f"{f}:1: '# length: mm' {LOOKALIKE_SAYS}" in said, (kind, p.stderr)
        with pytest.raises(dv.DenavitError, match=re.escape(f"{f}:1: '# length: mm' {LOOKALIKE_SAYS}")):
            py()


def test_the_json_units_object_refuses_a_misspelt_key(tmp_path):
    """A JSON file's "units" is the same declaration: {"lengths": "m"} had been ignored and the caller's mm used."""
    from denavit.io.measurements import read_measurements

    f = tmp_path / "m.json"
    f.write_text(json.dumps({"units": {"lengths": "m", "angle": "rad"}, "q": [[0] * 6] * 3, "points": [[1, 2, 3]] * 3}))
    said = f"{f}: unknown key 'lengths' in the units declaration: expected length, angle, mass, inertia, time"
    with pytest.raises(dv.DenavitError, match=re.escape(said)):
        read_measurements(f, kinds=KR5, length="mm", angle="deg")
    p = run("calibrate", "kr5", f, ok=False)
    assert p.returncode == 2 and said in " ".join(p.stderr.split())


@pytest.mark.parametrize(
    "line, expected",
    [
        ("# units: length=mm angle=rad", {"length": "mm", "angle": "rad"}),  # the one form
        ("#UNITS:length=M,angle=RAD", {"length": "m", "angle": "rad"}),
        ("# angle of the tool: 30 deg", {}),  # prose: a quantity, but no unit right after its name
        ("# Time: 12:00:05", {}),  # a tracker export's clock
        ("# unit test data, 3 m cable", {}),
        ("# length: mm", "'# units: length=mm'"),
        ("# angle = rad", "'# units: angle=rad'"),
        ("# angles: deg", "'# units: angle=deg'"),
        ("# unit: m", "'# units: length=m'"),
        ("#units length=mm", "'# units: length=mm'"),
        ("## units: length=mm", "'# units: length=mm'"),
        ("# Lengths in MM, angles in DEG", "'# units: length=mm angle=deg'"),
        ("# length_unit = mm", "'# units: length=mm'"),
        ("# Length [mm]", "'# units: length=mm'"),
        ("# units: mm, rad", "'# units: length=mm angle=rad'"),  # the form, but without keys
        ("# length: millimetres", "'# units: length=mm angle=deg'"),  # a name it does not take: the example
    ],
)
def test_the_declaration_rule(line, expected):
    from denavit.io.units import parse_declaration

    if isinstance(expected, dict):
        assert parse_declaration([line, "x,y,z"], "f.csv") == expected
    else:
        with pytest.raises(dv.DenavitError, match=r"^f\.csv:1: .*expected " + re.escape(expected)):
            parse_declaration([line, "x,y,z"], "f.csv")


def test_the_issues_positions_file_declared_right_reads_the_rotations_in_radians(tmp_path):
    """With the form the error gives, the issue's file compensates every row (kr5 against itself: the positions
    come back unchanged; read as degrees, 0.5 rad rotations had been 0.5 deg ones)."""
    poses = _poses_mm_rad()
    f, o = tmp_path / "pos.csv", tmp_path / "out.csv"
    f.write_text("# units: length=mm angle=rad\nx,y,z,rx,ry,rz\n" + _rows(poses))
    d = doc("compensate", "kr5", f, "--identified", "kr5", "-o", o)
    assert d["flagged"] == 0 and len(d["rows"]) == 20
    lines = [ln.split(",") for ln in o.read_text().splitlines() if not ln.startswith("#")]
    back = np.array([[float(c) for c in r[:6]] for r in lines[1:]])
    assert lines[0][:6] == ["x", "y", "z", "rx", "ry", "rz"]
    np.testing.assert_allclose(back[:, :3], poses[:, :3], atol=1e-6)  # mm
    np.testing.assert_allclose(np.radians(back[:, 3:]), poses[:, 3:], atol=1e-8)  # written in --angle deg


def test_a_typed_unit_that_disagrees_with_the_files_is_a_warning_and_the_file_wins(tmp_path):
    """docs/cli.md: what a file declares wins for reading it; --length / --angle set what is printed and written.
    Typed and different, it is said (a default is not: the user asked nothing)."""
    poses = _poses_mm_rad(6)
    f = tmp_path / "pos.csv"
    f.write_text("# units: length=mm angle=rad\nx,y,z,rx,ry,rz\n" + _rows(poses))
    args = ("compensate", "kr5", f, "--identified", "kr5", "--json")
    base = run(*args)
    typed = run(*args, "--angle", "deg", "--length", "m")
    assert "warning" not in base.stderr and "warning" not in run(*args, "--angle", "rad").stderr
    said = " ".join(typed.stderr.split())
    assert f"warning: {f}: declares angle=rad: read in rad, not in --angle deg (which sets what is printed" in said
    assert f"warning: {f}: declares length=mm: read in mm, not in --length m (which sets what is printed" in said
    a, b = json.loads(base.stdout), json.loads(typed.stdout)
    np.testing.assert_allclose([r["T_command"] for r in a["rows"]], [r["T_command"] for r in b["rows"]], atol=1e-12)
