"""Every command, every bad input of issue 16: exit code 2 and exactly one error line on stderr, the last (also on a
narrow terminal, COLUMNS=40: rich must not wrap it; a slow step's progress line may come before it), never a
traceback.

Each case names the command line and a piece of the expected message; the files are made once per module from
valid ones with one defect each."""

import json
import re
from pathlib import Path

import numpy as np
import pytest

import denavit as dv
from cli import error_line, run

DATA = Path(__file__).parent / "data"
KR5 = (Path(dv.__file__).parent / "models" / "kr5.toml").read_text()
UR_URDF = (DATA / "urdf" / "ur_style.urdf").read_text()


def _readonly_dir(root: Path) -> Path | None:
    """A directory nobody may create files in: a chmod 555 one, or (as root, whom chmod does not stop) sysfs."""
    d = root / "readonly"
    d.mkdir()
    d.chmod(0o555)
    for cand in (d, Path("/sys/kernel")):
        try:
            (cand / ".probe").touch()
        except OSError:
            return cand
        (cand / ".probe").unlink()
    return None


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    from denavit import calibration as cal
    from denavit import sweeps as sw
    from denavit.io import sweeps as swio
    from denavit.io.measurements import to_csv

    d = tmp_path_factory.mktemp("bad")
    kr5 = dv.load_robot("kr5")
    s = sw.simulate(
        kr5.model(),
        home=np.radians(sw.PAPER_HOME_DEG),
        ranges=np.radians(sw.PAPER_RANGES_DEG[90]),
        points_per_sweep=8,
        noise=2e-5,
    )
    sweeps = swio.to_long_csv(s, "mm", "deg")
    (d / "s.csv").write_text(sweeps)
    meas = to_csv(cal.simulate(kr5, cal.configurations(kr5, 30), tool=(0.05, 0.03, 0.1)), "mm", "deg")
    (d / "m.csv").write_text(meas)
    lines = sweeps.splitlines()
    first = lines.index(next(ln for ln in lines if ln.startswith("1,")))

    def sweep_cell(name: str, cell: str) -> None:
        out = list(lines)
        out[first] = out[first].rsplit(",", 1)[0] + "," + cell
        (d / name).write_text("\n".join(out) + "\n")

    (d / "poe_w2.toml").write_text(
        'name = "p"\nconvention = "poe"\n[units]\nlength = "mm"\nangle = "deg"\n'
        '[[joints]]\nname = "j1"\nw = [0, 0, 2]\nv = [0, 0, 0]\nlimits = [-90, 90]\n'
    )
    (d / "twins.toml").write_text(KR5.replace('name = "A2"', 'name = "A1"', 1))
    sweep_cell("s_1e308.csv", "1e308")
    sweep_cell("s_underscore.csv", "1_000")
    sweep_cell("s_fullwidth.csv", "\uff11\uff12")
    sweep_cell("s_arabic.csv", "\u0661\u0662")
    sweep_cell("s_nan.csv", " nan ")
    (d / "s_units.csv").write_text(sweeps + "# units: length=m\n")
    (d / "s_latin1.csv").write_bytes("# home 90\xb0\n".encode("latin-1") + sweeps.encode())
    (d / "s_utf16.csv").write_bytes(sweeps.encode("utf-16"))
    (d / "s_header.csv").write_text(sweeps.replace("joint,q1,q2,q3,q4,q5,q6,x,y,z", "joint,q1,q2,q3,q4,q5,q6,x,y,x"))
    (d / "s_long.csv").write_text(
        sweeps.replace("joint,q1,q2,q3,q4,q5,q6,x,y,z", "joint,q1,q2,q3,q4,q5,q6,x,y," + "z" * 250_000)
    )
    mlines = meas.splitlines()
    mlines[3] = mlines[3].rsplit(",", 1)[0] + ",1e308"
    (d / "m_1e308.csv").write_text("\n".join(mlines) + "\n")
    (d / "m_rot.csv").write_text(
        meas.replace("q1,q2,q3,q4,q5,q6,x,y,z", "q1,q2,q3,q4,q5,q6,x,y,z,rx,rz")
        .replace("\n0", "\n0,0,0")
        .replace("\n1", "\n1,0,0")
    )
    doc = {
        "units": {"length": "m", "angle": "rad"},
        "home": s.home.tolist(),
        "sweeps": [{"joint": x.joint, "points": x.points.tolist(), "q": x.q.tolist()} for x in s.sweeps],
    }
    doc["sweeps"][2]["Q"] = doc["sweeps"][2].pop("q")
    (d / "misspelt_q.json").write_text(json.dumps(doc))
    (d / "deep.json").write_text('{"home": ' + "[" * 100_000 + "]" * 100_000 + "}")
    (d / "digits.json").write_text('{"units": {"length": "mm", "angle": "deg"}, "home": [' + "9" * 5000 + "]}")
    (d / "true.json").write_text('{"units": {"length": "mm", "angle": "deg"}, "home": [true, 0, 0, 0, 0, 0]}')
    # plausibility (the list): a unit slip, a mirrored frame, j2/j3 exchanged, a copied sweep, the wrong nominal
    rec = sw.simulate(
        kr5.model(),
        home=np.radians(sw.PAPER_HOME_DEG),
        ranges=np.radians(sw.PAPER_RANGES_DEG[90]),
        points_per_sweep=20,
        noise=2e-5,
        noise_q=1e-4,
        seed=2,
    )

    def altered(name: str, f) -> None:
        (d / name).write_text(
            swio.to_long_csv(
                sw.SweepSet([f(x) for x in rec.sweeps], 6, rec.home, rec.kinds, "", rec.units), "mm", "deg"
            )
        )

    altered("p_x1000.csv", lambda x: sw.Sweep(x.joint, x.points * 1000, x.q, x.where))
    altered("p_xy.csv", lambda x: sw.Sweep(x.joint, x.points[:, [1, 0, 2]], x.q, x.where))
    altered(
        "p_j2j3.csv",
        lambda x: (
            sw.Sweep(x.joint, rec.sweep(5 - x.joint).points, rec.sweep(5 - x.joint).q, x.where)
            if x.joint in (2, 3)
            else x
        ),
    )
    altered("p_copy.csv", lambda x: sw.Sweep(3, rec.sweep(2).points, rec.sweep(2).q, x.where) if x.joint == 3 else x)
    altered("p_good.csv", lambda x: x)
    swapped = d / "joints_j2j3"
    swapped.mkdir()
    for x in rec.sweeps:
        (swapped / f"j{ {2: 3, 3: 2}.get(x.joint, x.joint) }.csv").write_text(
            "x,y,z\n" + "".join(f"{p[0]},{p[1]},{p[2]}\n" for p in x.points * 1e3)
        )
    unit = d / "joints_j4_in_m"  # joint 4's file written in m among files in mm
    unit.mkdir()
    for x in rec.sweeps:
        (unit / f"j{x.joint}.csv").write_text(
            "x,y,z\n" + "".join(f"{p[0]},{p[1]},{p[2]}\n" for p in x.points * (1.0 if x.joint == 4 else 1e3))
        )
    folder = d / "joints"
    folder.mkdir()
    for x in s.sweeps:
        (folder / f"j{x.joint}.csv").write_text(
            "X,Y,Z,RMS\n" + "".join(f"{p[0]},{p[1]},{p[2]},0.01\n" for p in x.points * 1e3)
        )
    limits = "limits = [-155, 155]"
    for name, old, new in [
        ("limits.toml", limits, 'limits = "ab"'),
        ("home.toml", "home = [90,", 'home = ["a",'),
        ("matrix.toml", "[units]", "[base]\nmatrix = [[1, 0, 0, 0], [0, 1, 0], [0, 0, 1, 0], [0, 0, 0, 1]]\n[units]"),
        ("string.toml", "d = 400", 'd = "400"'),
        ("bool.toml", "d = 400", "d = true"),
        ("huge.toml", "d = 400", "d = " + "9" * 5000),
    ]:
        assert old in KR5
        (d / name).write_text(KR5.replace(old, new, 1))
    (d / "robot_latin1.toml").write_bytes("# 90\xb0\n".encode("latin-1") + KR5.encode())
    (d / "damping.urdf").write_text(UR_URDF.replace('damping="0"', 'damping="abc"', 1))
    (d / "axis.urdf").write_text(UR_URDF.replace('<axis xyz="0 0 1"/>', '<axis xzy="0 0 1"/>', 1))
    (d / "limit.urdf").write_text(re.sub(r'upper="[^"]*"', 'upper="1e309"', UR_URDF, count=1))
    (d / "latin1.urdf").write_bytes(b'<?xml version="1.0"?>\n<!-- 90\xb0 -->\n' + UR_URDF.split("?>", 1)[1].encode())
    (d / "c_latin1.csv").write_bytes("# 90\xb0\n".encode("latin-1") + b"q1,q2,q3,q4,q5,q6\n0,0,0,0,0,0\n")
    (d / "c_extra.csv").write_text("# units: angle=deg\nq1,q2,q3,q4,q5,q6,note\n0,0,0,0,0,0,1\n")
    (d / "t_underscore.csv").write_text(
        "# units: length=mm angle=deg\nq1,q2,q3,q4,q5,q6\n10,-80,90,0,45,0\n1_000,-70,80,10,40,5\n"
    )
    (d / "rtde_latin1.csv").write_bytes(
        "# 90\xb0\n".encode("latin-1") + (DATA / "recordings" / "rtde.csv").read_bytes()
    )
    (d / "out_dir").mkdir()
    return d


def cases(d: Path, readonly: Path | None):
    """(id, arguments, a piece of the message)."""
    miss = d / "no" / "such" / "dir"
    out = [
        # missing inputs
        ("identify: missing input", ["identify", d / "nosuch.csv"], "nosuch.csv: no such"),
        ("calibrate: missing input", ["calibrate", d / "nosuch.csv", "--nominal", "kr5"], "nosuch.csv: no such"),
        ("show: missing robot", ["show", d / "nosuch.toml"], "unknown model"),
        ("plan: missing candidates", ["plan", "kr5", "--candidates", d / "nosuch.csv"], "nosuch.csv: no such"),
        (
            "compensate: missing positions",
            ["compensate", d / "nosuch.csv", "--nominal", "kr5", "--identified", "kr5"],
            "nosuch.csv",
        ),
        ("inspect: missing recording", ["inspect", d / "nosuch.csv"], "nosuch.csv"),
        # outputs in a missing directory, on a full disk, at a directory
        (
            "convert: output in a missing directory",
            ["convert", "kr5", "--to", "mdh", "-o", miss / "x.toml"],
            "the directory",
        ),
        (
            "identify: --json in a missing directory",
            ["identify", d / "s.csv", "--json", miss / "r.json"],
            "r.json: cannot write",
        ),
        (
            "calibrate: --save in a missing directory",
            ["calibrate", d / "m.csv", "--nominal", "kr5", "--save", miss / "r.toml"],
            "r.toml: cannot write",
        ),
        ("simulate: -o in a missing directory", ["simulate", "kr5", "-o", miss / "s.csv"], "s.csv: cannot write"),
        (
            "export: --ur-kinematics in a missing directory",
            ["export", "ur5", "--ur-kinematics", miss / "k.yaml"],
            "k.yaml: cannot write",
        ),
        (
            "convert: output on a full disk",
            ["convert", "kr5", "--to", "urdf", "-o", "/dev/full"],
            "/dev/full: cannot write: No space left on device",
        ),
        ("convert: output at a directory", ["convert", "kr5", "--to", "mdh", "-o", d / "out_dir"], "it is a directory"),
        # robot files and URDFs of the wrong types
        ("show: limits = 'ab'", ["show", d / "limits.toml"], "limits: expected a list of 2 numbers, got 'ab'"),
        ("fk: home = ['a']", ["fk", d / "home.toml"], "home[0]: expected a number, got 'a' (a string)"),
        (
            "ik: a ragged base matrix",
            ["ik", d / "matrix.toml", "--pose", "1,0,0,0.5,0,1,0,0,0,0,1,0.5"],
            "matrix row 2: expected a list of 4 numbers",
        ),
        (
            "convert: a number as a string",
            ["convert", d / "string.toml", "--to", "mdh"],
            "parameter d: expected a number, got '400' (a string)",
        ),
        ("export: a boolean as a number", ["export", d / "bool.toml"], "parameter d: expected a number, got true"),
        ("dynamics: a 5000-digit integer", ["dynamics", d / "huge.toml"], "an integer of over 4300 digits"),
        ("show: a Latin-1 robot file", ["show", d / "robot_latin1.toml"], "not UTF-8 text: byte 0xb0 at offset 4"),
        ("dynamics: damping='abc'", ["dynamics", d / "damping.urdf"], "dynamics damping='abc': expected 1 number"),
        ("fk: an <axis> without xyz", ["fk", d / "axis.urdf"], "<axis> (line"),
        ("show: a 1e309 limit", ["show", d / "limit.urdf"], "must be finite"),
        ("convert: a Latin-1 URDF", ["convert", d / "latin1.urdf", "--to", "dh"], "not UTF-8 text: byte 0xb0"),
        (
            "identify: nominal with damping='abc'",
            ["identify", d / "s.csv", "--nominal", d / "damping.urdf"],
            "damping='abc'",
        ),
        # sweeps: decoding, numbers, declarations, headers, JSON
        ("identify: Latin-1 degree sign", ["identify", d / "s_latin1.csv"], "not UTF-8 text: byte 0xb0 at offset 9"),
        ("identify: UTF-16", ["identify", d / "s_utf16.csv"], "UTF-16"),
        (
            "identify: a second units line",
            ["identify", d / "s_units.csv"],
            "length=m contradicts length=mm declared at line 1",
        ),
        ("identify: 1_000", ["identify", d / "s_underscore.csv"], "column 'z' must be a number, got '1_000'"),
        ("identify: full-width digits", ["identify", d / "s_fullwidth.csv"], "ASCII digits 0-9 only"),
        ("identify: Arabic-Indic digits", ["identify", d / "s_arabic.csv"], "ASCII digits 0-9 only"),
        ("identify: ' nan '", ["identify", d / "s_nan.csv"], "column 'z' must be finite, got 'nan'"),
        ("identify: 1e308 coordinate", ["identify", d / "s_1e308.csv"], "a coordinate of 1e+305 m is beyond 1e+09 m"),
        ("identify: a column named twice", ["identify", d / "s_header.csv"], "column(s) x named twice"),
        ("identify: a 250 kB header", ["identify", d / "s_long.csv"], "s_long.csv:"),
        (
            "identify: jN.csv header X,Y,Z,RMS",
            ["identify", d / "joints", "--home", "90,-90,90,0,90,0", "--length", "mm"],
            "header must name x, y, z",
        ),
        ("identify: one sweep's misspelt q", ["identify", d / "misspelt_q.json"], "sweeps[2]: unknown key(s) 'Q'"),
        ("identify: JSON nested 100k deep", ["identify", d / "deep.json"], "nested too deeply"),
        ("identify: a 5000-digit JSON number", ["identify", d / "digits.json"], "home[0]: expected a finite number"),
        ("identify: true as a number", ["identify", d / "true.json"], "home[0]: expected a number, got true"),
        # calibration
        (
            "calibrate: 1e308 coordinate",
            ["calibrate", d / "m_1e308.csv", "--nominal", "kr5"],
            "a coordinate of 1e+305 m is beyond 1e+09 m",
        ),
        ("calibrate: rx,rz without ry", ["calibrate", d / "m_rot.csv", "--nominal", "kr5"], "missing ry"),
        *[
            (
                f"calibrate: --noise {n}",
                ["calibrate", d / "m.csv", "--nominal", "kr5", "--noise", n],
                "--noise: expected the known one-sigma point noise",
            )
            for n in ("0", "nan", "-1")
        ],
        # plan, compensate, inspect, dynamics
        ("plan: Latin-1 candidates", ["plan", "kr5", "--candidates", d / "c_latin1.csv"], "not UTF-8 text"),
        (
            "plan: an unknown candidates column",
            ["plan", "kr5", "--candidates", d / "c_extra.csv"],
            "unknown column(s) note",
        ),
        (
            "compensate: 1_000 in a position",
            ["compensate", d / "t_underscore.csv", "--nominal", "kr5", "--identified", "kr5"],
            "column 'q1' must be a number, got '1_000'",
        ),
        ("inspect: a Latin-1 recording", ["inspect", d / "rtde_latin1.csv"], "not UTF-8 text"),
        (
            "dynamics: qd = 1e160",
            ["dynamics", DATA / "urdf" / "ur_style.urdf", "--qd", "1e160,0,0,0,0,0"],
            "= 1e+160 deg/s: expected |qd| <= 7.6821e+155 deg/s (rates whose squares are finite)",
        ),
        # plausibility against the nominal (identify) and of the fit (calibrate)
        (
            "identify: points x1000",
            ["identify", d / "p_x1000.csv", "--nominal", "kr5"],
            "consecutive) differ from the nominal kr5's",
        ),
        (
            "identify: x and y swapped",
            ["identify", d / "p_xy.csv", "--nominal", "kr5"],
            "mirror image of the nominal kr5's",
        ),
        (
            "identify: j2/j3 exchanged (readings)",
            ["identify", d / "p_j2j3.csv", "--nominal", "kr5"],
            "the readings move joint 3",
        ),
        (
            "identify: j2/j3 files exchanged",
            ["identify", d / "joints_j2j3", "--home", "90,-90,90,0,90,0", "--length", "mm", "--nominal", "kr5"],
            "joints A2 and A3 exchanged",
        ),
        (
            "identify: joint 4's file in m among files in mm (it had been a note and a4 = 1119 mm)",
            ["identify", d / "joints_j4_in_m", "--home", "90,-90,90,0,90,0", "--length", "mm", "--nominal", "kr5"],
            "the axis of joint A4 is ",
        ),
        (
            "identify: sweep 3 a copy of sweep 2",
            ["identify", d / "p_copy.csv", "--nominal", "kr5"],
            "the sweep repeats the 20 points of",
        ),
        (
            "identify: KR5 data, Puma nominal",
            ["identify", d / "p_good.csv", "--nominal", "puma560"],
            "differ from the nominal puma560's",
        ),
        ("models: --json in a missing directory", ["models", "--json", miss / "m.json"], "m.json: cannot write"),
        ("export: a 1e309 URDF limit", ["export", d / "limit.urdf"], "must be finite"),
        (
            "fk: 1_0 on the command line (float() had read it)",
            ["fk", "kr5", "--q", "1_0,0,0,0,0,0"],
            "--q: expected numbers (ASCII decimal",
        ),
        (
            "fk: a full-width digit on the command line",
            ["fk", "kr5", "--q", "\uff11,0,0,0,0,0"],
            "--q: expected numbers (ASCII decimal",
        ),
        (
            "simulate: nan in --tool",
            ["simulate", "kr5", "-o", d / "never.csv", "--tool", "nan,0,0"],
            "--tool: expected numbers (ASCII decimal",
        ),
        (
            "convert: --to urdf --json (it had been ignored)",
            ["convert", "kr5", "--to", "urdf", "--json", d / "never.json"],
            "--json: --to urdf writes URDF (XML), which has no JSON form",
        ),
        (
            "fk: --angle grad without --q (it had printed its tables, exit 0)",
            ["fk", "kr5", "--angle", "grad"],
            "unknown angle unit 'grad': expected one of rad, deg",
        ),
        (
            "identify: --loss foo (it had run as another loss)",
            ["identify", d / "s.csv", "--loss", "foo"],
            "identify: loss must be one of linear, soft_l1, huber, got 'foo'",
        ),
        (
            "identify: --max-sigma -1",
            ["identify", d / "s.csv", "--max-sigma", "-1"],
            "--max-sigma: expected the required axis-position sigma, a finite value > 0 in mm, got -1.0",
        ),
        # options that had been ignored without a word
        (
            "identify: --save-convention without --save",
            ["identify", d / "s.csv", "--save-convention", "dh"],
            "--save-convention dh: it sets the table --save writes; give --save FILE too",
        ),
        (
            "identify: --save-convention foo",
            ["identify", d / "s.csv", "--save", d / "never.toml", "--save-convention", "foo"],
            "foo",
        ),
        (
            "identify: --home with a sweep CSV",
            ["identify", d / "s.csv", "--home", "0,0,0,0,0,0"],
            "--home 0,0,0,0,0,0: ",
        ),
        ("identify: --direction with a sweep CSV", ["identify", d / "s.csv", "--direction", "-1"], "--direction -1: "),
        (
            "show: --compare without --report or --plot",
            ["show", "kr5", "--compare", "mdh"],
            "--compare mdh: it sets what --report or --plot draws",
        ),
        (
            "convert: --parallel-tol 2 (a sine above 1: every pair parallel)",
            ["convert", "kr5", "--to", "dh", "--parallel-tol", "2"],
            "--parallel-tol 2.0: expected the sine of an angle",
        ),
        # two outputs on standard output had been written one after the other; one file named twice, the second
        # write had replaced the first
        (
            "identify: --save - --json -",
            ["identify", d / "s.csv", "--save", "-", "--json", "-"],
            "--save and --json: both write to standard output ('-')",
        ),
        (
            "identify: --save and --urdf one file",
            ["identify", d / "s.csv", "--save", d / "same.toml", "--urdf", d / "same.toml"],
            "--save and --urdf both write",
        ),
        (
            "compensate: -o - --json -",
            ["compensate", d / "m.csv", "--nominal", "kr5", "--identified", "kr5", "-o", "-", "--json", "-"],
            "-o and --json: both write to standard output",
        ),
        # an empty list of joint values had been taken as zeros
        ("fk: --q ''", ["fk", "kr5", "--q", ""], "--q: expected 6 joint values for kr5, got none"),
        ("fk: --q ',,,'", ["fk", "kr5", "--q", ",,,,,"], "--q: expected 6 joint values for kr5, got none"),
        # core errors about a robot file's table, said at their place; a non-rigid target said to be --pose
        ("fk: a POE screw with |w| = 2", ["fk", d / "poe_w2.toml"], "poe_w2.toml, joint 1 (line"),
        (
            "fk: two joints named alike",
            ["fk", d / "twins.toml"],
            "name 'A1' is joint 1's already: expected names unique within the robot",
        ),
        (
            "ik: a scaled --pose",
            ["ik", "kr5", "--pose", "2,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,0,1"],
            "--pose: T_goal is not a rigid transform",
        ),
        # a negative seed had reached numpy (an internal error, exit 3)
        (
            "simulate: --seed -1",
            ["simulate", "kr5", "-o", d / "never.csv", "--seed", "-1"],
            "invalid seed: expected an integer >= 0, got -1",
        ),
        (
            "calibrate: --seed -1",
            ["calibrate", d / "m.csv", "--nominal", "kr5", "--seed", "-1"],
            "invalid seed: expected an integer >= 0, got -1",
        ),
    ]
    if readonly is not None:
        out += [
            (
                "convert: output in a read-only directory",
                ["convert", "kr5", "--to", "mdh", "-o", readonly / "x.toml"],
                "x.toml: cannot write",
            ),
            (
                "identify: --json in a read-only directory",
                ["identify", d / "s.csv", "--json", readonly / "r.json"],
                "r.json: cannot write",
            ),
        ]
    return out


def test_every_bad_input_is_exit_2_and_one_line(files, tmp_path):
    readonly = _readonly_dir(tmp_path)
    failures = []
    for name, args, expected in cases(files, readonly):
        p = run(*args, ok=False, columns=40)
        line = error_line(p.stderr)  # progress lines of slow steps ("fitting 6 sweeps...") may come before it
        ok = p.returncode == 2 and line is not None and expected in line
        ok = ok and len(line) <= 510  # the error type caps messages at 500 characters
        if not ok:
            failures.append(f"{name}: exit {p.returncode}, stderr {p.stderr[-400:]!r}")
    assert not failures, "\n".join(failures)


def test_calibrate_from_another_robots_nominal_explains_the_data_and_says_how_far_it_moved(files):
    """KR5 sweeps calibrated from the Puma 560's table: on the standing KR5 the fit reaches the data (held-out error
    0.15 mm at 0.02 mm and 20 arcsec of noise: the Puma's table has the KR5's structure), so it is no error; but the
    parameters that moved by more than a tenth of the robot's size are named in one note."""
    r = run("calibrate", files / "p_good.csv", "--nominal", "puma560", columns=250)
    assert "more than 0.1 of the robot's size" in r.stdout and "a_2 moves" in r.stdout, r.stdout[-2000:]


def test_inputs_are_left_as_they_were(files):
    before = {f: f.read_bytes() for f in files.iterdir() if f.is_file()}
    run("identify", files / "s_units.csv", ok=False)
    run("calibrate", files / "m_1e308.csv", "--nominal", "kr5", ok=False)
    assert {f: f.read_bytes() for f in before} == before


def test_plan_with_two_candidates_answers_with_a_note(files, tmp_path):
    """Two candidate rows had raised LinAlgError in the measuring-volume box (a flat set of two points): now the
    plan is made and says the poses are too few."""
    c = tmp_path / "c2.csv"
    c.write_text("# units: angle=deg\nq1,q2,q3,q4,q5,q6\n0,0,0,0,0,0\n10,20,30,40,50,60\n")
    p = run("plan", "kr5", "--candidates", c, ok=False)
    assert p.returncode == 0 and "Traceback" not in p.stderr, p.stderr
    assert "2 poses give fewer equations than the" in " ".join(p.stdout.split() + p.stderr.split())
    from denavit import fitting

    box = fitting.oriented_bounding_box([[0.0, 0, 0], [1, 2, 2]])
    assert box.lengths[0] == pytest.approx(3.0) and box.volume == pytest.approx(0.0, abs=1e-12)


def test_messages_do_not_wrap_when_not_on_a_terminal(files):
    """A long message stays one line whatever COLUMNS says (stderr is a pipe here)."""
    p = run("identify", files / "s_long.csv", ok=False, columns=20)
    assert p.returncode == 2 and len(p.stderr.strip().splitlines()) == 1 and len(p.stderr.strip()) <= 510, p.stderr[
        :600
    ]


def test_an_output_never_replaces_an_input(files, tmp_path):
    """An output that is one of the command's input files, by its own path or through a link, is refused before any
    work (the audit's tracker sweeps had been replaced by the JSON result, a program by its compensation), and a
    --plot folder that is an existing file is a one-line error (it had been a traceback after --save was written)."""
    data = tmp_path / "sweeps.csv"
    data.write_bytes((files / "s.csv").read_bytes())
    alias = tmp_path / "alias.toml"
    alias.symlink_to(data)
    robot = tmp_path / "robot.toml"
    robot.write_text(KR5)
    afile = tmp_path / "afile"
    afile.write_text("x")
    before = {f: f.read_bytes() for f in (data, robot, afile)}
    cases = [
        (
            ["identify", data, "--json", data],
            f"--json {data}: is the input file {data} (DATA): an output never replaces an input",
        ),
        (["identify", data, "--save", alias], f"--save {alias}: is the input file {data} (DATA)"),
        (["convert", robot, "--to", "mdh", "-o", robot], f"--output {robot}: is the input file {robot}"),
        (
            ["identify", data, "--save", tmp_path / "new.toml", "--plot", afile],
            f"--plot {afile}: expected a folder (made when missing), got an existing file",
        ),
    ]
    for args, expected in cases:
        p = run(*args, ok=False)
        line = error_line(p.stderr)
        assert p.returncode == 2 and line is not None and expected in line, (args, p.stderr[-600:])
    assert {f: f.read_bytes() for f in before} == before
    assert alias.is_symlink() and not (tmp_path / "new.toml").exists()


def test_an_unexpected_error_is_one_line_and_exit_3(monkeypatch, capfd):
    """The last resort: an exception that is no DenavitError nor an OS error (a defect) reaches the user as one line
    and exit code 3, not a traceback; an OS error as one line naming its file and exit code 2."""
    import denavit.cli as cli

    for exc, code, expected in (
        (RuntimeError("boom"), 3, "error: internal error, please report it with the command line: RuntimeError: boom"),
        (FileExistsError(17, "File exists", "afile"), 2, "error: afile: File exists"),
    ):

        def fail(exc=exc, **kw):
            raise exc

        monkeypatch.setattr(cli, "app", fail)
        with pytest.raises(SystemExit) as e:
            cli.main()
        err = capfd.readouterr().err
        assert e.value.code == code and "Traceback" not in err and err.strip().startswith(expected), err
