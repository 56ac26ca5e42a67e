"""Issues 37 and 38 as a newcomer meets them: identify, then compensate with the result, on every built-in arm (the
kr210's flange is a pure rotation of its DH frame 6, REP-199's tool0), and the command line's words for it."""

from types import SimpleNamespace

import numpy as np
from scipy.spatial.transform import Rotation

import denavit as dv
from cli import run
from denavit import _core
from denavit import compensation as cp
from denavit.sweeps import simulate

HOME = np.radians([0, -90, 90, 0, 30, 0])
TOOL = np.array([0.05, 0.0, 0.25])  # m, the reflector on the flange


def test_identify_then_compensate_on_an_arm_whose_flange_is_a_turned_frame():
    """The kr210's model carries its flange as a half turn about DH frame 6's z (a tool with no offset). identify's
    result of sweeps simulated from that very model, used to compensate joint rows on it, had every row flagged
    'branch changed' (joint 6 half a turn away: the measured point's frame compensated against the nominal's flange)."""
    robot = dv.load_robot("kr210")
    nom = robot.model()
    ranges = [(h - np.radians(50), h + np.radians(50)) for h in HOME]
    ss = simulate(nom, home=HOME, ranges=ranges, points_per_sweep=30, tool_point=TOOL, seed=1, noise=2e-5)
    idf = dv.identify(ss, nominal=robot)
    q = HOME + np.radians(np.random.default_rng(5).uniform(-40, 40, (20, 6)))
    T = _core.fk_batch(nom, q)
    c = cp.compensate(robot, idf, T, q_nominal=q)
    assert c.ok.all(), f"{int((~c.ok).sum())} of {len(q)} rows flagged"
    assert any("kr210 has its flange frame (a rotation) as its only tool" in n for n in c.notes), c.notes  # not "none"
    # the identified robot is the nominal within the noise: the commands stay on the program's arm, a degree at most
    # (near the wrist's singularity), and the nominal run at them is within the flange's identification error
    assert np.degrees(np.abs(c.q_command - q)).max() < 2.0
    after = np.linalg.norm(_core.fk_batch(nom, c.q_command)[:, :3, 3] - T[:, :3, 3], axis=1)
    assert np.sqrt(np.mean(after**2)) < 5e-4


def invoke(*args):
    """``denavit ARGS...`` in this process as a user runs it (the entry point's error handling): ``exit_code`` and
    ``output`` (stdout and stderr)."""
    r = run(*args, ok=False, columns=400)
    return SimpleNamespace(exit_code=r.returncode, output=r.stdout + r.stderr)


def test_the_payload_help_names_the_robot_files_compliance_section():
    """'[compliance]' had been read as console markup and dropped: "(a robot file's ) the commands ..."."""
    for command in ("compensate", "validate"):
        out = " ".join(invoke(command, "--help").output.split())
        assert "a robot file's [compliance])" in out, command
        assert "(kg, g)" in out and "lb" not in out  # the mass units the parser takes


def test_a_positions_file_without_configurations_is_told_in_the_units_asked(tmp_path):
    """The note on the rows without a configuration had given --q0 in rad / m beside the summary's deg."""
    robot = dv.load_robot("kr5")
    q = HOME + np.radians(np.random.default_rng(2).uniform(-30, 30, (4, 6)))
    T = _core.fk_batch(robot.model(), q)
    rows = [np.r_[t[:3, 3] * 1e3, np.degrees(Rotation.from_matrix(t[:3, :3]).as_rotvec())] for t in T]
    path = tmp_path / "pos.csv"
    path.write_text(
        "# units: length=mm angle=deg\nx,y,z,rx,ry,rz\n" + "".join(",".join(map(str, r)) + "\n" for r in rows)
    )
    r = invoke("compensate", "kr5", path, "--identified", "kr5", "--payload", "5 kg @ 0,0,80 mm")
    assert r.exit_code == 0, r.output
    assert "rad / m" not in r.output and "4 of 4 rows had none" in r.output and " deg);" in r.output
    # a payload with a rigid identified robot is said to change nothing, never silently taken
    assert "the payload changes nothing: kr5 has no joint compliances" in " ".join(r.output.split())
    v = invoke("validate", "kr5", _measured(tmp_path, robot), "--payload", "5 kg")
    assert v.exit_code == 0, v.output
    assert "the payload changes nothing: kr5 has no joint compliances" in " ".join(v.output.split())


def _measured(tmp_path, robot):
    q = HOME + np.radians(np.random.default_rng(3).uniform(-30, 30, (5, 6)))
    p = _core.fk_batch(robot.model(), q)[:, :3, 3] * 1e3
    path = tmp_path / "meas.csv"
    path.write_text(
        "# units: length=mm angle=deg\nq1,q2,q3,q4,q5,q6,x,y,z\n"
        + "".join(",".join(map(str, np.r_[np.degrees(a), b])) + "\n" for a, b in zip(q, p, strict=True))
    )
    return path


def test_a_report_or_a_kinematics_file_given_as_the_robot_says_what_it_is(tmp_path):
    """calibrate's --json and export --ur-kinematics had been read as TOML robot files: 'Invalid statement'."""
    for name, text, expected in (
        ("cal.json", '{"units": {"length": "m"}}', "a JSON file is not a robot model"),
        ("cal.yaml", "kinematics:\n  shoulder: {x: 0}\n", "a YAML file is not a robot model here"),
    ):
        path = tmp_path / name
        path.write_text(text)
        r = invoke("compensate", "kr5", _measured(tmp_path, dv.load_robot("kr5")), "--identified", path)
        assert r.exit_code == 2 and expected in r.output and "TOML" not in r.output, r.output


def test_a_urdf_of_compliant_joints_says_it_leaves_them_out(tmp_path):
    """A calibration with free compliances written --urdf: the URDF has no place for them, and compensating with it
    is the rigid arm's (0.30 mm against 0.018 mm from the robot file, on a UR5 at 2.5 kg), said where it is written."""
    from denavit.calibration import parametrize
    from denavit.calibration.compliance import gravity_torques

    robot = dv.load_robot("ur5")
    rng = np.random.default_rng(7)
    pz = parametrize(robot, "edh", tool=TOOL)
    m_true = pz.model(pz.x0 + np.array([0.0 if n.startswith(("base_", "tool_")) else 3e-4 for n in pz.names]))
    k = np.array([0.0, 1.2e-5, 2.5e-5, 1.0e-4, 1.2e-4, 0.0])
    q = np.column_stack([rng.uniform(-3, 3, 40), rng.uniform(-2.8, -0.3, 40), rng.uniform(-3, 3, (40, 4))])
    rows = []
    for mass in (0.0, 5.0):
        pl = np.tile([mass, 0.02, 0.0, 0.06], (len(q), 1))
        p = _core.fk_batch(m_true, q - k * gravity_torques(robot.model(), q, pl))[:, :3, 3]
        p = p + rng.normal(0, 2e-5, p.shape)
        rows += [np.r_[np.degrees(a), b * 1e3, c[0], c[1:] * 1e3] for a, b, c in zip(q, p, pl, strict=True)]
    data = tmp_path / "poses.csv"
    data.write_text(
        "# units: length=mm angle=deg\nq1,q2,q3,q4,q5,q6,x,y,z,payload_mass,payload_x,payload_y,payload_z\n"
        + "".join(",".join(map(str, r)) + "\n" for r in rows)
    )
    r = invoke("calibrate", "ur5", data, "--model", "full+compliance", "--urdf", tmp_path / "cal.urdf")
    assert r.exit_code == 0, r.output
    assert "cal.urdf: a URDF carries no joint compliances" in " ".join(r.output.split())


def test_a_positions_file_carries_its_payload_per_row(tmp_path):
    """Issue 37's 'the same columns in compensate's inputs': payload_mass, payload_x, payload_y, payload_z had been
    refused ('header must be ...'). A row's columns compensate as --payload does for every row."""
    from dataclasses import replace

    from denavit.io import robotfile as rf

    robot = dv.load_robot("ur5")
    stiff = tmp_path / "ur5c.toml"
    stiff.write_text(rf.dumps(replace(robot, compliance=np.array([0, 1e-5, 2e-5, 8e-5, 1e-4, 0])), "mm", "deg"))
    q = np.radians([[10, -80, 70, -60, -90, 20], [-30, -120, 100, -20, 60, 0], [60, -60, 40, -100, -80, 45]])
    T = _core.fk_batch(robot.model(), q)
    rows = [np.r_[t[:3, 3] * 1e3, np.degrees(Rotation.from_matrix(t[:3, :3]).as_rotvec())] for t in T]
    head = "# units: length=mm angle=deg\nx,y,z,rx,ry,rz"
    loads = ([5, 0, 0, 80], [0, 0, 0, 0], [5, 0, 0, 80])
    with_columns = tmp_path / "pl.csv"
    with_columns.write_text(
        head
        + ",payload_mass,payload_x,payload_y,payload_z\n"
        + "".join(",".join(map(str, [*r, *p])) + "\n" for r, p in zip(rows, loads, strict=True))
    )
    plain = tmp_path / "plain.csv"
    plain.write_text(head + "\n" + "".join(",".join(map(str, r)) + "\n" for r in rows))
    outs = {}
    for name, args in (
        ("columns", [with_columns]),
        ("loaded", [plain, "--payload", "5 kg @ 0,0,80 mm"]),
        ("empty", [plain]),
    ):
        r = invoke("compensate", "ur5", *args, "--identified", stiff, "-o", tmp_path / f"{name}.csv")
        assert r.exit_code == 0, r.output
        outs[name] = np.loadtxt(tmp_path / f"{name}.csv", delimiter=",", comments="#", skiprows=4)[:, 6:12]
    assert np.allclose(outs["columns"][[0, 2]], outs["loaded"][[0, 2]], rtol=0, atol=1e-9)
    assert np.allclose(outs["columns"][1], outs["empty"][1], rtol=0, atol=1e-9)
    assert np.abs(outs["loaded"] - outs["empty"]).max() > 1e-3  # deg: the payload does change the commands
    c = dv.compensate("ur5", stiff, with_columns)  # Python reads the same columns
    assert np.allclose(np.degrees(c.q_command), outs["columns"], rtol=0, atol=1e-9)


def test_a_payload_python_cannot_read_is_one_line():
    """payload='5 kg @ 0,0,80 mm' (the command line's text) had raised numpy's 'could not convert string to float';
    a negative or NaN mass had been taken."""
    import pytest

    from denavit.calibration.compliance import as_payload

    for bad, match in (
        ("5 kg @ 0,0,80 mm", "got the text '5 kg @ 0,0,80 mm'"),
        (-5.0, "expected a mass >= 0 kg"),
        ((5.0, (0.0, 0.0, float("nan"))), "finite centre of mass"),
        ({"mass": 5}, "got dict"),
    ):
        with pytest.raises(dv.DenavitError, match=match) as e:
            as_payload(bad, 3)
        assert "\n" not in str(e.value)
    assert np.array_equal(as_payload((5.0, (0.0, 0.0, 0.08)), 2), [[5.0, 0.0, 0.0, 0.08]] * 2)


def test_a_program_is_written_under_its_own_extension(tmp_path):
    """`-o out.csv` for an ABB module had written RAPID text into a .csv without a word, and a KUKA `-o res.txt` had
    become res.txt.src + res.txt.dat: the output's name ends as the program's (the controller reads it by its
    extension), one line naming what came, nothing written; `-o` on the program's own .dat names both files."""
    import shutil

    data = __import__("pathlib").Path(__file__).parent / "data" / "programs"
    for prog, out, want in (
        (data / "abb" / "DemoKR5.mod", tmp_path / "out.csv", "ending in .mod"),
        (data / "kuka" / "kr5_demo.src", tmp_path / "res.txt", "ending in .src"),
    ):
        r = invoke("compensate", "kr5", str(prog), "--identified", "kr5", "-o", str(out))
        assert r.exit_code == 2 and want in r.output and len(r.output.strip().splitlines()) == 1, r.output
        assert not list(tmp_path.iterdir())
    src = tmp_path / "kr5_demo.src"
    for f in ("kr5_demo.src", "kr5_demo.dat"):
        shutil.copy(data / "kuka" / f, tmp_path / f)
    before = {p.name: p.read_bytes() for p in tmp_path.iterdir()}
    r = invoke("compensate", "kr5", str(src), "--identified", "kr5", "-o", str(tmp_path / "kr5_demo.dat"))
    assert r.exit_code == 2 and "kr5_demo.dat: would replace" in r.output and "the program read" in r.output, r.output
    assert {p.name: p.read_bytes() for p in tmp_path.iterdir()} == before
    ok = invoke("compensate", "kr5", str(src), "--identified", "kr5", "-o", str(tmp_path / "out" / "c.src"))
    assert ok.exit_code == 2  # (a folder that does not exist: its own one line)
    (tmp_path / "out").mkdir()
    ok = invoke("compensate", "kr5", str(src), "--identified", "kr5", "-o", str(tmp_path / "out" / "c"))
    assert ok.exit_code == 0 and sorted(p.name for p in (tmp_path / "out").iterdir()) == ["c.dat", "c.src"], ok.output


def test_the_summary_counts_one_row_and_predicts_only_rows_sent(tmp_path):
    """'over the 1 rows' and a predicted sigma printed for a row that is not sent (unreachable): the summary counts in
    the singular and lists a flagged row once, with why, not with a prediction."""
    from denavit import calibration as cal

    kr5 = dv.load_robot("kr5")
    res = cal.calibrate(cal.simulate(kr5.model(), cal.configurations(kr5, 30), noise=2e-5, seed=1), kr5)
    robot_file = tmp_path / "cal.toml"
    dv.save(res, robot_file)
    q = np.radians([[10, -80, 80, 10, 40, 10], [10, -80, 80, 10, 40, 10]])
    T = _core.fk_batch(kr5.model(), q)
    rows = np.hstack([np.degrees(q), T[:, :3, 3] * 1e3, np.degrees(Rotation.from_matrix(T[:, :3, :3]).as_rotvec())])
    rows[1, 6] += 300.0  # 0.3 m farther out: beyond the arm's reach
    path = tmp_path / "pos.csv"
    path.write_text(
        "# units: length=mm angle=deg\nq1,q2,q3,q4,q5,q6,x,y,z,rx,ry,rz\n"
        + "".join(",".join(map(str, row)) + "\n" for row in rows)
    )
    r = invoke("compensate", "kr5", path, "--identified", robot_file, "-o", tmp_path / "out.csv")
    assert r.exit_code == 1 and "over the 1 row that can be sent" in r.output, r.output
    row4 = [line for line in r.output.splitlines() if line.strip().startswith(f"{path}:4")]  # (line 4: the 2nd row)
    assert len(row4) == 1 and "unreachable" in row4[0], r.output
