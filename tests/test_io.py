"""The edge layer (denavit.io): outputs, input decoding, the one units rule, convention names, at every reader
and writer of the package and through the command line."""

import json
import os
import subprocess
import sys
import threading

import numpy as np
import pytest

import denavit as dv
from cli import env, run
from denavit.io import output

# -- outputs (denavit.io.output) -------------------------------------------------------------------------


def test_a_symlink_is_written_through_and_kept(tmp_path):
    target, link = tmp_path / "target.txt", tmp_path / "link.txt"
    target.write_text("old")
    link.symlink_to(target)
    output.write_text(link, "new")
    assert link.is_symlink() and os.readlink(link) == str(target)
    assert target.read_text() == "new"


def test_a_fifo_gets_the_bytes(tmp_path):
    fifo = tmp_path / "pipe"
    os.mkfifo(fifo)
    got = []
    reader = threading.Thread(target=lambda: got.append(fifo.read_bytes()))
    reader.start()
    output.write_text(fifo, "through the pipe\n")
    reader.join(10)
    assert got == [b"through the pipe\n"]
    assert fifo.exists() and not fifo.is_file()  # still the FIFO, not replaced by a file


def test_dev_null_is_not_replaced():
    before = os.stat("/dev/null")
    output.write_text("/dev/null", "nothing")
    after = os.stat("/dev/null")
    assert (after.st_ino, after.st_mode, after.st_rdev) == (before.st_ino, before.st_mode, before.st_rdev)


def test_dash_writes_to_stdout():
    code = "from denavit.io import output; output.write_text('-', 'to stdout\\n')"
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env())
    assert p.returncode == 0, p.stderr
    assert p.stdout == "to stdout\n"


def test_a_directory_is_refused_with_one_line_naming_it(tmp_path):
    with pytest.raises(dv.DenavitError, match=r"cannot write the output: it is a directory") as e:
        output.write_text(tmp_path, "x")
    assert str(e.value).startswith(str(tmp_path)) and "\n" not in str(e.value)


def test_a_missing_directory_names_the_users_path_not_the_temporary_file(tmp_path):
    path = tmp_path / "no" / "such" / "out.toml"
    with pytest.raises(dv.DenavitError) as e:
        output.write_text(path, "x")
    msg = str(e.value)
    assert msg.startswith(str(path)) and "does not exist" in msg and ".out.toml." not in msg


def test_cli_writers_follow_symlinks_and_stream_to_stdout(tmp_path):
    target, link = tmp_path / "t.toml", tmp_path / "l.toml"
    target.write_text("old")
    link.symlink_to(target)
    run("convert", "kr5", "--to", "mdh", "-o", link)
    assert link.is_symlink() and 'convention = "mdh"' in target.read_text()
    p = run("convert", "kr5", "--to", "mdh", "-o", "-")
    assert 'convention = "mdh"' in p.stdout
    p = run("convert", "kr5", "--to", "mdh", "-o", tmp_path, ok=False)
    assert p.returncode == 2 and "it is a directory" in p.stderr and "Traceback" not in p.stderr


# -- input decoding (denavit.io.text), at every text reader ------------------------------------------------

ROBOT = (
    'name = "one"\nconvention = "dh"\n[units]\nlength = "mm"\nangle = "deg"\n[[joints]]\nd = 100\ntheta = 0\na ='
    " 0\nalpha = 0\n"
)


def _sweeps_csv() -> str:
    from denavit import sweeps as sw

    m = dv.load_model("kr5")
    s = sw.simulate(
        m, home=np.radians(sw.PAPER_HOME_DEG), ranges=np.radians(sw.PAPER_RANGES_DEG[30]), points_per_sweep=8
    )
    rows = []
    for sw_ in s.sweeps:
        for q, p in zip(sw_.q, sw_.points):
            rows.append(
                ",".join([str(sw_.joint), *(repr(float(v)) for v in np.degrees(q)), *(repr(float(v)) for v in p * 1e3)])
            )
    return "joint,q1,q2,q3,q4,q5,q6,x,y,z\n" + "\n".join(rows) + "\n"


def test_a_robot_file_with_a_bom_reads(tmp_path):
    f = tmp_path / "bom.toml"
    f.write_bytes(b"\xef\xbb\xbf" + ROBOT.encode())
    assert dv.load_robot(f).table.params[0, 0] == pytest.approx(0.1)


@pytest.mark.parametrize("kind", ["robot", "csv", "json", "folder", "candidates"])
def test_a_latin1_degree_sign_is_one_line_naming_the_byte_offset(tmp_path, kind):
    """Excel on Windows saves "°" as the single Latin-1 byte 0xb0: every reader says where, in one line."""
    comment = "# home 90\xb0\n".encode("latin-1")
    if kind == "robot":
        f = tmp_path / "r.toml"
        f.write_bytes(comment + ROBOT.encode())
        args = ("show", f)
    elif kind == "csv":
        f = tmp_path / "s.csv"
        f.write_bytes(comment + b"# units: length=mm angle=deg\n" + _sweeps_csv().encode())
        args = ("identify", f)
    elif kind == "json":
        f = tmp_path / "s.json"
        f.write_bytes(b'{"units": {"length": "mm", "angle": "deg"}, "home": [0], "sweeps": [], "note": "90\xb0"}')
        args = ("identify", f)
    elif kind == "folder":
        f = tmp_path / "d"
        f.mkdir()
        for j in range(1, 7):
            (f / f"j{j}.csv").write_bytes((comment if j == 3 else b"") + b"1,2,3\n2,3,4\n3,4,6\n")
        f = f / "j3.csv"
        args = ("identify", f.parent, "--home", "0,0,0,0,0,0", "--length", "mm")
    else:
        f = tmp_path / "c.csv"
        f.write_bytes(comment + b"q1,q2,q3,q4,q5,q6\n0,0,0,0,0,0\n")
        args = ("plan", "kr5", "--candidates", f)
    p = run(*args, ok=False)
    err = " ".join(p.stderr.split())
    assert p.returncode == 2 and "Traceback" not in p.stderr and "UnicodeDecodeError" not in p.stderr, p.stderr
    offset = f.read_bytes().index(b"\xb0")
    assert f"not UTF-8 text: byte 0xb0 at offset {offset}" in err and f.name in err, err


def test_utf16_is_one_line_with_a_hint(tmp_path):
    f = tmp_path / "r.toml"
    f.write_bytes(ROBOT.encode("utf-16"))
    p = run("show", f, ok=False)
    assert p.returncode == 2 and "not UTF-8 text" in p.stderr and "UTF-16" in p.stderr and "Traceback" not in p.stderr


def test_a_sweep_csv_with_a_bom_reads(tmp_path):
    f = tmp_path / "s.csv"
    f.write_bytes(b"\xef\xbb\xbf# units: length=mm angle=deg\n" + _sweeps_csv().encode())
    out = tmp_path / "r.json"
    run("identify", f, "--convention", "dh", "--json", out)
    assert json.loads(out.read_text())["parameters"][0]["d"] == pytest.approx(0.4, abs=1e-6)  # m: JSON is SI


# -- the one units rule: what a file declares wins; the command line fills what it does not ---------------


def test_a_units_line_without_a_space_is_honoured_by_identify(tmp_path):
    """'#units: length=mm' and --length m: the data are mm, the output m (d1 had been read as 400 m)."""
    f = tmp_path / "s.csv"
    f.write_text("#units: length=mm angle=deg\n" + _sweeps_csv())
    out = tmp_path / "r.json"
    run("identify", f, "--convention", "dh", "--length", "m", "--json", out)
    doc = json.loads(out.read_text())
    assert doc["units"]["length"] == "m"
    assert doc["parameters"][0]["d"] == pytest.approx(0.4, abs=1e-6)


def test_a_units_line_without_a_space_is_honoured_by_calibrate(tmp_path):
    """A file in metres declaring '#units:length=m,angle=rad': calibrate's default --length mm is the output's
    unit only (a_2 had come out 93 mm against 600)."""
    from denavit import calibration as cal

    kr5 = dv.load_robot("kr5")
    meas = cal.simulate(kr5, cal.configurations(kr5, 40), tool=(0.05, 0.03, 0.1))
    f = tmp_path / "m.csv"
    f.write_text(
        "#units:length=m,angle=rad\nq1,q2,q3,q4,q5,q6,x,y,z\n"
        + "".join(",".join(repr(float(v)) for v in (*q, *p)) + "\n" for q, p in zip(meas.q, meas.points))
    )
    out = tmp_path / "r.json"
    run("calibrate", f, "--nominal", "kr5", "--convention", "mdh", "--tool", "50,30,100", "--json", out)
    doc = json.loads(out.read_text())
    a = {p["name"]: p for p in doc["parameters"]}
    assert doc["units"]["length"] == "m" and a["a_2"]["value"] == pytest.approx(0.6, abs=1e-9)  # JSON: SI


def test_a_second_conflicting_units_line_is_an_error_naming_both_lines(tmp_path):
    f = tmp_path / "s.csv"
    f.write_text("# units: length=mm angle=deg\n" + _sweeps_csv() + "#units: length=m\n")
    p = run("identify", f, ok=False)
    n = len(f.read_text().splitlines())
    assert p.returncode == 2 and f"s.csv:{n}: length=m contradicts length=mm declared at line 1" in " ".join(
        p.stderr.split()
    )


def test_candidates_units_line_is_the_one_parser(tmp_path):
    """plan --candidates: '#units:angle=rad' (no space) is honoured; a second conflicting line is an error."""
    f = tmp_path / "c.csv"
    q = np.radians([[10, -80, 90, 5, 60, 0], [40, -60, 70, -20, 30, 50], [-30, -100, 110, 40, 80, -40]] * 6)
    q = q + np.random.default_rng(0).normal(0, 0.2, q.shape)
    f.write_text(
        "#units:angle=rad\nq1,q2,q3,q4,q5,q6\n" + "".join(",".join(map(repr, map(float, r))) + "\n" for r in q)
    )
    a = json.loads(run("plan", "kr5", "--candidates", f, "--json").stdout)
    g = tmp_path / "d.csv"
    g.write_text(
        "# units: angle=deg\nq1,q2,q3,q4,q5,q6\n"
        + "".join(",".join(map(repr, map(float, r))) + "\n" for r in np.degrees(q))
    )
    b = json.loads(run("plan", "kr5", "--candidates", g, "--json").stdout)
    np.testing.assert_allclose(a["bounding_box"]["lengths_m"], b["bounding_box"]["lengths_m"], rtol=1e-9)
    g.write_text(g.read_text() + "# units: angle=rad\n")
    p = run("plan", "kr5", "--candidates", g, ok=False)
    assert p.returncode == 2 and "angle=rad contradicts angle=deg declared at line 1" in " ".join(p.stderr.split())


# -- convention names: the core's one parser ---------------------------------------------------------------


@pytest.mark.parametrize(
    "name, expected",
    [("craig", "mdh"), ("MDH", "mdh"), ("Modified-DH", "mdh"), ("SDH", "dh"), ("ED-H".replace("-", ""), "edh")],
)
def test_robot_files_accept_every_convention_name_of_the_core(tmp_path, name, expected):
    f = tmp_path / "r.toml"
    cols = {
        "dh": "d = 100\ntheta = 0\na = 0\nalpha = 0\n",
        "mdh": "alpha = 0\na = 0\ntheta = 0\nd = 100\n",
        "edh": "alpha = 0\na = 0\nb = 0\nc = 100\ntheta = 0\n",
    }
    f.write_text(
        f'name = "one"\nconvention = "{name}"\n[units]\nlength = "mm"\nangle = "deg"\n[[joints]]\n{cols[expected]}'
    )
    r = dv.load_robot(f)
    assert r.convention == expected


def test_a_robot_file_with_an_unknown_convention_names_the_core_list(tmp_path):
    f = tmp_path / "r.toml"
    f.write_text(ROBOT.replace('"dh"', '"hayati"'))
    with pytest.raises(
        dv.DenavitError,
        match=(
            r"r.toml: 'convention' must be one of dh, mdh, edh, poe, got 'hayati' \(aliases: sdh, craig, modified-dh,"
            r" in any case\)"
        ),
    ):
        dv.load_robot(f)


@pytest.mark.parametrize("name, expected", [("craig", "mdh"), ("MDH", "mdh")])
def test_cli_identify_accepts_every_convention_name_of_the_core(tmp_path, name, expected):
    out = tmp_path / "r.json"
    run("identify", "--example", "kr5", "--convention", name, "--json", out)
    assert json.loads(out.read_text())["convention"] == expected


# -- headers are honoured ----------------------------------------------------------------------------------


def test_a_joint_file_header_says_which_column_is_which(tmp_path):
    """`z,y,x` had been read as x,y,z and `X,Y,Z,RMS` as time,x,y,z."""
    from denavit.io import sweeps as swio

    a, b = tmp_path / "a", tmp_path / "b"
    for d in (a, b):
        d.mkdir()
    pts = np.array([[1.0, 2.0, 3.0], [2.0, 3.5, 4.0], [3.0, 4.0, 6.5]])
    (a / "j1.csv").write_text("x,y,z\n" + "".join(f"{x},{y},{z}\n" for x, y, z in pts))
    (b / "j1.csv").write_text("z;time;y;x\n" + "".join(f"{z};{k};{y};{x}\n" for k, (x, y, z) in enumerate(pts)))
    ra = swio.read_joint_files(a, home=[0], length="mm")
    rb = swio.read_joint_files(b, home=[0], length="mm")
    np.testing.assert_allclose(rb.sweeps[0].points, ra.sweeps[0].points)
    np.testing.assert_allclose(ra.sweeps[0].points, pts * 1e-3)
    (b / "j1.csv").write_text("X,Y,Z,RMS\n1,2,3,0.1\n")
    with pytest.raises(
        dv.DenavitError, match=r"j1.csv:1: header must name x, y, z \(and optionally time\), got 'X,Y,Z,RMS'"
    ):
        swio.read_joint_files(b, home=[0], length="mm")


def test_a_column_named_twice_is_an_error(tmp_path):
    from denavit.io import sweeps as swio

    f = tmp_path / "s.csv"
    f.write_text("# units: length=mm angle=deg\njoint,q1,x,y,x\n1,0,1,2,3\n")
    with pytest.raises(dv.DenavitError, match=r"s.csv:2: column\(s\) x named twice in the header"):
        swio.read_long_csv(f)


def test_a_urdf_in_latin1_without_an_encoding_declaration_is_one_line(tmp_path):
    f = tmp_path / "r.urdf"
    f.write_bytes(b'<?xml version="1.0"?>\n<!-- 90\xb0 -->\n<robot name="r"><link name="a"/></robot>\n')
    with pytest.raises(dv.DenavitError, match=r"r.urdf:2: not UTF-8 text: byte 0xb0 at offset 29"):
        dv.load_robot(f)


def test_identify_poe_table_prints_the_nominal_w_unitless(tmp_path):
    """The POE terminal table had printed the nominal w scaled by 1000 (wz = 1000.000 beside 1.000)."""
    # the nominal kr5's own sweeps (the example before issue 40; the shipped one is now a "true" KR5's)
    sweeps = tmp_path / "kr5_nominal.csv"
    run("simulate", "kr5", "-o", sweeps, "--ranges", "paper90", "--points", "40", "--noise", "0.02", "--seed", "90")
    out = run("identify", "kr5", sweeps, "--convention", "poe").stdout
    rows = [ln.replace("│", " ").split() for ln in out.splitlines() if ln.strip("│ ").split()[:1] in (["wz"], ["A1"])]
    wz = [r for r in rows if "wz" in r]
    assert len(wz) == 6
    for r in wz:
        nominal, identified = float(r[-4]), float(r[-3])
        assert abs(nominal) <= 1.0 + 1e-9 and abs(nominal - identified) < 1e-3, r


def test_simulate_to_stdout_keeps_the_csv_clean():
    p = run("simulate", "kr5", "-o", "-", "--points", "3", "--noise", "0")
    lines = p.stdout.splitlines()
    assert lines[1] == "# units: length=mm angle=deg" and lines[2].startswith("joint,q1") and len(lines) == 3 + 18
    assert "wrote -" in p.stderr


def test_json_outputs_are_strict_and_tables_show_nan():
    """Bare NaN is not JSON: every JSON output goes through io.output.json_text (NaN, inf -> null, numpy values
    plain); a NaN cell prints as 'nan', not 0.000000."""
    import numpy as np

    from denavit.cli.console import fmt
    from denavit.io.output import json_text

    doc = json.loads(
        json_text(
            {"a": float("nan"), "b": [1.0, float("inf"), np.float64(2.5)], "c": np.array([[np.nan, 1.0]]), "d": "x"}
        )
    )
    assert doc == {"a": None, "b": [1.0, None, 2.5], "c": [[None, 1.0]], "d": "x"}
    assert fmt(float("nan")) == "nan" and fmt(-1e-15) == "0.000000" and fmt(1.5, 2) == "1.50"


# -- error messages: one line, a readable length (denavit.errors) -------------------------------------------


def test_messages_are_one_line_and_capped_keeping_head_and_tail():
    """A message echoing a 250 kB header had been 250 kB long, and lxml's had held line breaks."""
    from denavit.errors import MAX_MESSAGE

    e = dv.DenavitError("f.csv:2: header must be 'x,y,z', got '" + "z" * 250_000 + "' (a hint)")
    msg = str(e)
    assert (
        len(msg) <= MAX_MESSAGE == 500
        and msg.startswith("f.csv:2: header must be 'x,y,z', got 'zzz")
        and msg.endswith("zzz' (a hint)")
    )
    assert " [...] " in msg
    assert str(dv.DegenerateError("line 1\n  line 2\r\nline 3")) == "line 1 line 2 line 3"
    assert str(dv.DenavitError("short")) == "short"


# -- numbers: ASCII decimal or scientific, finite (denavit.io.delimited) -----------------------------------


@pytest.mark.parametrize(
    "cell, match",
    [
        ("1_000", r"column 'z' must be a number, got '1_000' \(no digit separators"),
        ("\uff11\uff12", r"column 'z' must be a number, got '１２' \(ASCII digits 0-9 only\)"),  # full-width 12
        ("\u0661\u0662", r"column 'z' must be a number, got '١٢' \(ASCII digits 0-9 only\)"),  # Arabic-Indic 12
        (" nan ", r"column 'z' must be finite, got 'nan'"),
        ("infinity", r"column 'z' must be finite, got 'infinity'"),
        ("1e309", r"column 'z' must be finite, got '1e309' \(beyond the float range\)"),
        ("0x10", r"column 'z' must be a number, got '0x10'"),
    ],
)
def test_text_cells_are_ascii_decimal_numbers(tmp_path, cell, match):
    """float() reads all of these; a measurement file means none of them (they had been read as numbers)."""
    from denavit.io import sweeps as swio
    from denavit.io.delimited import number

    text = _sweeps_csv().splitlines()
    text[3] = text[3].rsplit(",", 1)[0] + "," + cell
    f = tmp_path / "s.csv"
    f.write_text("# units: length=mm angle=deg\n" + "\n".join(text) + "\n")
    with pytest.raises(dv.DenavitError, match=r"s.csv:5: " + match):
        swio.read_long_csv(f)
    for good in ("12", "-0.5", ".5", "1e-3", "+2.E+4", "7."):
        assert number(good, "here", "x") == float(good)


def test_parsed_values_are_numbers_not_booleans_or_strings():
    from denavit.io.delimited import as_number

    assert as_number(3, "w") == 3.0 and as_number(float("-inf"), "w", finite=False) == float("-inf")
    for bad, match in [
        (True, "w: expected a number, got true"),
        ("1", r"w: expected a number, got '1' \(a string\)"),
        (None, "got nothing"),
        ([1], "got a list"),
        (10**400, "w: expected a number in the float range, got an integer of about 401 digits"),
        (float("nan"), "w: expected a finite number, got NaN"),
        (float("inf"), "w: expected a finite number, got inf"),
    ]:
        with pytest.raises(dv.DenavitError, match=match):
            as_number(bad, "w")
    with pytest.raises(dv.DenavitError, match="got NaN"):
        as_number(float("nan"), "w", finite=False)


# -- JSON inputs: strict (sweeps and measurements) ----------------------------------------------------------


def _sweeps_json_doc() -> dict:
    from denavit import sweeps as sw

    s = sw.simulate(
        dv.load_model("kr5"),
        home=np.radians(sw.PAPER_HOME_DEG),
        ranges=np.radians(sw.PAPER_RANGES_DEG[30]),
        points_per_sweep=5,
    )
    return {
        "units": {"length": "m", "angle": "rad"},
        "home": s.home.tolist(),
        "sweeps": [{"joint": x.joint, "points": x.points.tolist(), "q": x.q.tolist()} for x in s.sweeps],
    }


@pytest.mark.parametrize(
    "text, match",
    [
        # issue 16: a RecursionError and a ValueError (Python's 4300-digit limit) had reached the user
        (
            '{"home": ' + "[" * 100_000 + "]" * 100_000 + "}",
            r"s.json: not readable JSON: lists or objects nested too deeply$",
        ),
        (
            '{"units": {"length": "m", "angle": "rad"}, "home": [' + "9" * 5000 + "]}",
            r"s.json: home\[0\]: expected a finite number, got inf$",
        ),
        (
            '{"units": {"length": "m", "angle": "rad"}, "home": [Infinity]}',
            r"s.json: home\[0\]: expected a finite number, got inf$",
        ),
        (
            '{"units": {"length": "m", "angle": "rad"}, "home": ["1"]}',
            r"s.json: home\[0\]: expected a number, got '1' \(a string\)$",
        ),
        (
            '{"units": {"length": "m", "angle": "rad"}, "home": [true]}',
            r"s.json: home\[0\]: expected a number, got true$",
        ),
        (
            '{"units": {"length": "m", "angle": "rad"}, "home": [0], "home": [1]}',
            r"s.json: key\(s\) 'home' given twice in one object",
        ),
        (
            '{"units": {"length": "m", "angle": "rad"}, "hom": [0]}',
            r"s.json: unknown key\(s\) 'hom': expected units, home, kinds, nest, sweeps$",
        ),
        ('{"home": [0,', r"s.json:1: not valid JSON: Expecting value \(column 13\)$"),
    ],
)
def test_bad_json_sweeps_are_one_line(tmp_path, text, match):
    from denavit.io import sweeps as swio

    f = tmp_path / "s.json"
    f.write_text(text)
    with pytest.raises(dv.DenavitError, match=match):
        swio.read_json(f)


def test_a_misspelt_q_in_one_sweep_is_an_error_not_a_set_without_readings(tmp_path):
    """One sweep's "Q" for "q" had dropped every sweep's readings (has_readings is all-or-nothing)."""
    from denavit.io import sweeps as swio

    doc = _sweeps_json_doc()
    f = tmp_path / "s.json"
    f.write_text(json.dumps(doc))
    assert swio.read_json(f).has_readings
    doc["sweeps"][2]["Q"] = doc["sweeps"][2].pop("q")
    f.write_text(json.dumps(doc))
    with pytest.raises(
        dv.DenavitError,
        match=r"s.json: sweeps\[2\]: unknown key\(s\) 'Q': expected joint, points, targets, q, quaternions$",
    ):
        swio.read_json(f)


def test_hand_built_sweep_sets_need_one_sweep_per_joint():
    """A missing sweep had raised IndexError in identify, a duplicated one had been identified silently."""
    from denavit import sweeps as sw

    s = sw.simulate(
        dv.load_model("kr5"),
        home=np.radians(sw.PAPER_HOME_DEG),
        ranges=np.radians(sw.PAPER_RANGES_DEG[30]),
        points_per_sweep=5,
    )
    with pytest.raises(dv.DenavitError, match=r"missing sweeps of joint\(s\) 6: every joint 1..6 needs one sweep"):
        sw.SweepSet(s.sweeps[:5], 6, s.home, s.kinds, "mine")
    with pytest.raises(dv.DenavitError, match=r"mine: missing sweeps of joint\(s\) 2; a second sweep of joint\(s\) 1"):
        sw.SweepSet([s.sweeps[0], *s.sweeps[::-1][:4], s.sweeps[0]], 6, s.home, s.kinds, "mine")
    # in joint order whatever the order given: the fits go by position (reversed, joint 1 had got joint 6's sweep)
    assert [x.joint for x in sw.SweepSet(s.sweeps[::-1], 6, s.home, s.kinds).sweeps] == [1, 2, 3, 4, 5, 6]


@pytest.mark.parametrize(
    "doc, match",
    [
        (
            {"units": {"length": "mm", "angle": "deg"}, "q": [[0, "1"]], "points": [[0, 0, 0]]},
            r"m.json: q\[0\]\[1\]: expected a number, got '1' \(a string\)$",
        ),
        (
            {"units": {"length": "mm", "angle": "deg"}, "q": [[0, True]], "points": [[0, 0, 0]]},
            r"m.json: q\[0\]\[1\]: expected a number, got true$",
        ),
        (
            {"units": {"length": "mm", "angle": "deg"}, "q": [[0, 1], [0]], "points": [[0, 0, 0]]},
            r"m.json: q\[1\]: rows of different lengths \(1 here, 2 in the first row\): expected a rectangular array$",
        ),
        (
            {"units": {"length": "mm", "angle": "deg"}, "q": [[0, 1]], "point": [[0, 0, 0]]},
            r"m.json: unknown key\(s\) 'point'",
        ),
        (
            {"units": {"length": "mm", "angle": "deg"}, "q": [[0, 1]], "poses": [[[1, 0, 0, 0]] * 3]},
            r"m.json: poses must have shape \(1, 4, 4\) \(one per row of q\), got shape \(1, 3, 4\)",
        ),
    ],
)
def test_bad_json_measurements_are_one_line(tmp_path, doc, match):
    from denavit.io.measurements import read_measurements

    f = tmp_path / "m.json"
    f.write_text(json.dumps(doc))
    with pytest.raises(dv.DenavitError, match=match):
        read_measurements(f)


@pytest.mark.parametrize(
    "head, match",
    [
        # issue 16: 'rx,y,rz' had silently dropped the rotation; unknown columns had been ignored
        (
            "q1,q2,q3,q4,q5,q6,x,y,z,rx,rz",
            r"m.csv:2: header must be .*; missing ry, got 'q1,q2,q3,q4,q5,q6,x,y,z,rx,rz'$",
        ),
        ("q1,q2,q3,q4,q5,q6,x,y,z,rms", r"m.csv:2: header must be .*; unknown column\(s\) rms, got"),
        ("q1,q2,q3,q4,q5,q6,x,y,x", r"m.csv:2: column\(s\) x named twice in the header"),
    ],
)
def test_measurement_headers_are_honoured(tmp_path, head, match):
    from denavit.io.measurements import read_measurements

    f = tmp_path / "m.csv"
    f.write_text(f"# units: length=mm angle=deg\n{head}\n" + ",".join(["1"] * len(head.split(","))) + "\n")
    with pytest.raises(dv.DenavitError, match=match):
        read_measurements(f)


def test_candidates_headers_are_honoured(tmp_path):
    from denavit.io.configurations import read_configurations

    f = tmp_path / "c.csv"
    f.write_text("# units: angle=deg\nq1,q2,q3,q4,q5,q6,note\n0,0,0,0,0,0,1\n")
    with pytest.raises(
        dv.DenavitError, match=r"c.csv:2: header must name q1..q6 \(6 joints\); unknown column\(s\) note"
    ):
        read_configurations(f, ["revolute"] * 6)
    f.write_text('# units: angle=deg\nq1,q2,q3,q4,q5,q6\n0,0,0,0,0,0\n0,0,"1\n')
    with pytest.raises(dv.DenavitError, match=r"c.csv:4: "):
        read_configurations(f, ["revolute"] * 6)


# -- URDF attributes and UR kinematics YAML: the same number rule ------------------------------------------

UR_URDF = __import__("pathlib").Path(__file__).parent / "data" / "urdf" / "ur_style.urdf"


@pytest.mark.parametrize(
    "old, new, match",
    [
        (
            'damping="0"',
            'damping="abc"',
            r"joint 'shoulder_pan_joint' \(line \d+\): dynamics damping='abc': expected 1 number",
        ),  # had been a ValueError traceback
        ('damping="0"', 'damping="nan"', r"dynamics damping='nan': expected 1 finite number"),
        ('effort="150"', 'effort="1e999"', r"limit effort='1e999': expected 1 finite number"),
        (
            'xyz="0 0 0.089159"',
            'xyz="0 0 \uff11"',
            r"origin xyz='0 0 １': expected 3 numbers \(ASCII decimal\)",
        ),  # full-width 1 had been read
        ('xyz="0 0 0.089159"', 'xyz="0 0 1_0"', r"origin xyz='0 0 1_0': expected 3 numbers"),
        (
            '<mass value="4.0"/>',
            '<mass value="4_0"/>',
            r"link 'base_link' \(line \d+\): mass value='4_0': expected 1 number",
        ),
        ('ixx="0.00443333156"', 'ixx="abc"', r"link 'base_link' \(line \d+\): inertia ixx='abc': expected 1 number"),
        (
            '<axis xyz="0 0 1"/>',
            '<axis xzy="0 0 1"/>',
            r"joint 'shoulder_pan_joint' \(line \d+\): <axis> \(line \d+\) without xyz",
        ),  # had been the default x axis
    ],
)
def test_urdf_numbers_follow_the_one_rule(tmp_path, old, new, match):
    text = UR_URDF.read_text()
    assert old in text
    f = tmp_path / "ur.urdf"
    f.write_text(text.replace(old, new, 1))
    with pytest.raises(dv.DenavitError, match=match):
        dv.load_robot(f)


@pytest.mark.parametrize(
    "new, match",
    [
        ("x: 1_000", r"kinematics.shoulder.x: expected a number, got '1_000' \(a string\)"),
        ("x: 1:30", r"kinematics.shoulder.x: expected a number, got '1:30' \(a string\)"),  # YAML 1.1 sexagesimal: 90
        ("x: .inf", r"kinematics.shoulder.x: expected a number, got '.inf' \(a string\)"),
        ("x: '0.0'", r"kinematics.shoulder.x: expected a number, got '0.0' \(a string\)"),
        ("x: true", r"kinematics.shoulder.x: expected a number, got true"),
        ("x: 1e999", r"kinematics.shoulder.x: expected a finite number, got inf"),
        ("x: 0.0\n    x: 1.0", r"k.yaml:3: key\(s\) x given twice in one mapping"),  # PyYAML keeps the last
        ("x: " + "[" * 5000, r"k.yaml: not readable YAML: mappings or lists nested too deeply"),
        ("x: " + "[" * 100_000 + "]" * 100_000, r"k.yaml: not readable YAML: mappings or lists nested too deeply"),
    ],
)
def test_ur_kinematics_numbers_follow_the_one_rule(new, match):
    from denavit.io import ur_calibration as urc

    r = dv.load_robot("ur5")
    text = urc.dumps(r.model(), r.table)
    assert "    x: 0.0\n" in text
    assert np.allclose(urc.loads(text.replace("x: 0.0", "x: 0", 1), "k.yaml"), urc.loads(text, "k.yaml"))
    with pytest.raises(dv.DenavitError, match=match):
        urc.loads(text.replace("x: 0.0", new, 1), "k.yaml")


def test_coordinates_beyond_a_billion_metres_are_not_measurements(tmp_path):
    """A 1e308 mm coordinate had overflowed calibrate's residuals to a traceback (and identify's to RuntimeWarnings)."""
    from denavit.io import sweeps as swio
    from denavit.io.delimited import MAX_LENGTH
    from denavit.io.positions import read_positions

    doc = _sweeps_json_doc()
    doc["sweeps"][1]["points"][4][2] = 1e300
    f = tmp_path / "s.json"
    f.write_text(json.dumps(doc))
    with pytest.raises(
        dv.DenavitError, match=r"s.json: sweeps\[1\].points\[4\]\[2\]: a coordinate of 1e\+300 m is beyond 1e\+09 m"
    ):
        swio.read_json(f)
    t = tmp_path / "t.csv"
    t.write_text("# units: length=mm angle=deg\nx,y,z,rx,ry,rz\n100,0,2e12,0,0,0\n")
    with pytest.raises(dv.DenavitError, match=r"t.csv:3: column 'z': a coordinate of 2e\+09 m"):
        read_positions(t, ["revolute"] * 6)
    t.write_text("# units: length=mm angle=deg\nx,y,z,rx,ry,rz\n100,0,1e7,0,0,0\n")  # 10 km: a survey frame
    assert read_positions(t, ["revolute"] * 6).poses[0, 2, 3] == pytest.approx(1e4) and MAX_LENGTH == 1e9


@pytest.mark.parametrize(
    "ipoc, match",
    [
        ("--1", r"<IPOC> \(time stamp, ms\)' must be a number, got '--1'"),  # a ValueError, found by the fuzz run
        ("\u0661\u0662", r"<IPOC> \(time stamp, ms\)' must be a number, got '١٢' \(ASCII digits 0-9 only\)"),
    ],
)
def test_rsi_numbers_follow_the_one_rule(tmp_path, ipoc, match):
    from denavit.io.recordings import read_recording

    text = (__import__("pathlib").Path(__file__).parent / "data" / "recordings" / "rsi.xml").read_text()
    first = text.index("<IPOC>") + len("<IPOC>")
    f = tmp_path / "r.xml"
    f.write_text(text[:first] + ipoc + text[text.index("</IPOC>", first) :])
    with pytest.raises(dv.DenavitError, match=r"r.xml:\d+: column '" + match):
        read_recording(f, "rsi")
