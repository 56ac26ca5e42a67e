"""Robot files: declared units, round trips, errors that name the file and line."""

import os
import stat

import numpy as np
import pytest

import denavit as dv
from denavit.io import output, robotfile, robots
from denavit.io.urdf import save_urdf


@pytest.mark.parametrize("name", ["kr5", "puma560", "ur5", "tiansui_mdh", "tiansui_edh"])
def test_builtins_cite_source_and_units(name):
    path = robots.resolve(name)
    text = path.read_text()
    assert "Source" in text or "source" in text
    r = dv.load_robot(name)
    assert r.source and r.table.params.shape == (6, len(r.table.columns))


def test_kr5_values_in_si():
    r = dv.load_robot("kr5")
    assert r.table.params[0, 0] == pytest.approx(0.400)  # d1 = 400 mm (Hayat Table III)
    assert abs(r.table.params[0, 3]) == pytest.approx(
        np.pi / 2
    )  # |alpha1| = 90 deg (Table III; the sign, -90, is KUKA's axis sense)
    assert r.table.params[0, 3] == pytest.approx(-np.pi / 2) and r.table.params[2, 1] == pytest.approx(
        -np.pi / 2
    )  # kr5.toml's convention (theta3 too)
    np.testing.assert_allclose(np.degrees(r.home), [90, -90, 90, 0, 90, 0])


@pytest.mark.parametrize("name", ["kr5", "ur5", "tiansui_edh"])
@pytest.mark.parametrize("units", [("m", "rad"), ("mm", "deg")])
def test_save_load_round_trip(tmp_path, name, units):
    r = dv.load_robot(name)
    f = tmp_path / "r.toml"
    robotfile.save(r, f, *units)
    back = dv.load_robot(f)
    np.testing.assert_allclose(back.table.params, r.table.params, atol=1e-15)
    np.testing.assert_allclose(back.lower, r.lower, atol=1e-15)
    assert back.names == r.names


def test_an_inertia_without_mass_survives_export_and_urdf(tmp_path):
    """The Puma 560's link 1 has no mass but the inertia of its rotor (Corke's table, Izz = 0.35 kg m^2): the
    robot file keeps it, so the dynamics come back unchanged; the URDF writes it too (URDF allows it), and
    denavit's URDF reader, which leaves a massless link's inertia out, says so."""
    r = dv.load_robot("puma560")
    q = np.array([0.1, -0.4, 0.3, 0.2, -0.5, 0.6])
    M = dv.mass_matrix(r.model(), q)
    f = tmp_path / "p.toml"
    robotfile.save(r, f, "mm", "deg")
    np.testing.assert_allclose(dv.mass_matrix(dv.load_model(f), q), M, rtol=1e-12, atol=1e-12)
    u = tmp_path / "p.urdf"
    save_urdf(r.model(), u, r)
    with pytest.warns(dv.DenavitWarning, match=r"link 'link_1' gives an <inertia> but <mass value=\"0\"/>"):
        dv.load_robot(u)


def test_base_and_tool_poses(tmp_path):
    f = tmp_path / "r.toml"
    f.write_text(
        'convention = "dh"\n[units]\nlength = "mm"\nangle = "deg"\n[[joints]]\nd = 0\ntheta = 0\na = 100\nalpha = 0\n'
        "[base]\nxyz = [10, 0, 0]\nrpy = [0, 0, 90]\n[tool]\nxyz = [0, 0, 50]\n"
    )
    m = dv.load_model(f)
    T = dv.fk(m, [0.0])
    np.testing.assert_allclose(T[:3, 3], [0.010, 0.100, 0.050], atol=1e-15)


@pytest.mark.parametrize(
    "text, match",
    [
        (
            'convention = "dh"\n[[joints]]\nd=0\ntheta=0\na=0\nalpha=0\n',
            r"a \[units\] table with 'length' and 'angle' is required",
        ),
        (
            'convention = "xx"\n[units]\nlength="m"\nangle="rad"\n',
            r"'convention' must be one of dh, mdh, edh, poe, got 'xx'",
        ),
        (
            'convention = "dh"\n[units]\nlength="m"\nangle="rad"\n[[joints]]\nd=0\ntheta=0\na=0\n',
            r"joint 1 \(line 5\): missing parameter\(s\) alpha of a dh table",
        ),
        (
            (
                "convention ="
                ' "dh"\n[units]\nlength="m"\nangle="rad"\n[[joints]]\nd=0\ntheta=0\na=0\nalpha=0\n\n'
                '[[joints]]\nd="x"\ntheta=0\na=0\nalpha=0\n'
            ),
            r"joint 2 \(line 11\): parameter d: expected a number, got 'x'",
        ),
        ('convention = "dh"\n[units]\nlength="parsec"\nangle="rad"\n', r"unknown length unit 'parsec'"),
        (
            'convention = "dh"\n[units]\nlength="m"\nangle="rad"\n[[joints]]\ntype="ball"\n',
            r"type must be 'revolute' or 'prismatic', got 'ball'",
        ),
        (
            (
                "convention ="
                ' "dh"\n[units]\nlength="m"\nangle="rad"\n[[joints]]\nd=0\ntheta=0\na=0\nalpha=0\nlimits=[1, -1]\n'
            ),
            r"limits must be \[lower, upper\] with lower <= upper",
        ),
        ('convention = "dh"\n[units\n', r"not a valid TOML robot file"),
    ],
)
def test_bad_robot_files(tmp_path, text, match):
    f = tmp_path / "bad.toml"
    f.write_text(text)
    with pytest.raises(dv.DenavitError, match=match):
        dv.load_robot(f)
    assert f.read_text() == text


UNITS = '[units]\nlength = "mm"\nangle = "deg"\n'
JOINT = "[[joints]]\nd = 0\ntheta = 0\na = 100\nalpha = 0\n"


@pytest.mark.parametrize(
    "text, match",
    [
        # 'kind' is not the reader's 'type': it had loaded as revolute, its limits [-100, 100] as +-1.745 rad
        (
            f'convention = "dh"\n{UNITS}\n{JOINT}\n{JOINT}kind = "prismatic"\nlimits = [-100, 100]\n',
            (
                r"bad.toml, joint 2 \(line 12\): unknown keys \['kind'\]: expected name, type, d, theta, a, alpha,"
                r" limits, inertia$"
            ),
        ),
        (
            f'convention = "dh"\n{UNITS}\n{JOINT}limit = [-10, 10]\n',
            r"bad.toml, joint 1 \(line 6\): unknown keys \['limit'\]: expected .*, limits, inertia$",
        ),
        (
            f'convention = "poe"\n{UNITS}\n[[joints]]\nw = [0, 0, 1]\nv = [0, 0, 0]\nd = 5\n',
            r"joint 1 \(line 6\): unknown keys \['d'\]: expected name, type, w, v, limits, inertia$",
        ),
        (
            f'convention = "dh"\n{UNITS}time = "s"\n\n{JOINT}',
            r"bad.toml, \[units\]: unknown keys \['time'\]: expected length, angle, mass, inertia$",
        ),
        (
            f'convention = "dh"\n{UNITS}\n{JOINT}\n[tool]\nxyz = [0, 0, 1]\nrpz = [0, 0, 0]\n',
            r"bad.toml, \[tool\]: unknown keys \['rpz'\]: expected xyz, rpy, matrix$",
        ),
        (f'convention = "dh"\njoints = [1]\n{UNITS}', r"bad.toml, joint 1: expected a \[\[joints\]\] table, got 1"),
    ],
)
def test_unknown_keys_are_errors(tmp_path, text, match):
    """A misspelt key must not silently fall back to a default: every table of a robot file names its keys."""
    f = tmp_path / "bad.toml"
    f.write_text(text)
    with pytest.raises(dv.DenavitError, match=match):
        dv.load_robot(f)
    f.write_text(f'convention = "dh"\n{UNITS}\n{JOINT}\n{JOINT}type = "prismatic"\nlimits = [-100, 100]\n')
    r = dv.load_robot(f)
    assert r.table.kinds[1] == "prismatic" and r.upper[1] == pytest.approx(0.1)


def test_failed_write_leaves_nothing(tmp_path, monkeypatch):
    r = dv.load_robot("kr5")
    f = tmp_path / "out.toml"
    f.write_text("old")

    def boom(*a, **k):
        raise RuntimeError("disk full")

    monkeypatch.setattr(robotfile, "dumps", boom)
    with pytest.raises(RuntimeError):
        robotfile.save(r, f)
    assert f.read_text() == "old" and len(list(tmp_path.iterdir())) == 1


def test_outputs_are_whole_with_ordinary_permissions(tmp_path):
    """Outputs are replaced atomically, readable like any new file (0666 less the umask, not a temporary
    file's 0600), keep the mode of a file they replace, and a failed write leaves the old file and no debris."""
    robot = dv.load_robot("kr5")
    old = os.umask(0o022)
    try:
        new = tmp_path / "kr5.toml"
        robotfile.save(robot, new)
        assert stat.S_IMODE(new.stat().st_mode) == 0o644
        kept = tmp_path / "private.toml"
        kept.write_text("old")
        kept.chmod(0o640)
        robotfile.save(robot, kept)
        assert stat.S_IMODE(kept.stat().st_mode) == 0o640 and "convention" in kept.read_text()
        with pytest.raises(RuntimeError), output.atomic_path(kept) as tmp:
            tmp.write_text("half")
            raise RuntimeError("interrupted")
        assert "convention" in kept.read_text()
        assert sorted(p.name for p in tmp_path.iterdir()) == ["kr5.toml", "private.toml"]
    finally:
        os.umask(old)


def test_a_stray_top_level_key_is_an_error_and_extension_tables_are_kept(tmp_path):
    text = robots.resolve("kr5").read_text()
    f = tmp_path / "typo.toml"
    f.write_text(text.replace("home = ", "hom = ", 1))
    assert "hom = " in f.read_text()
    with pytest.raises(dv.DenavitError, match=r"typo.toml \(top level\): unknown keys \['hom'\]: expected .*home"):
        dv.load_robot(f)
    g = tmp_path / "ext.toml"
    g.write_text(text + '\n[vendor]\nserial = "A123"\n')
    assert dv.load_robot(g).extra == {"vendor": {"serial": "A123"}}


def test_numbers_are_numbers(tmp_path):
    """A string that looks like a number, a boolean or a 400-digit integer is not a parameter (found by the fuzz
    suite: OverflowError; "1" and true had been read as 1)."""
    text = robotfile_text = (__import__("pathlib").Path(dv.__file__).parent / "models" / "kr5.toml").read_text()
    for bad in ('"400"', "true", "9" * 400):
        f = tmp_path / "bad.toml"
        f.write_text(robotfile_text.replace("d = 400", f"d = {bad}", 1))
        assert f.read_text() != text
        with pytest.raises(dv.DenavitError, match=r"joint 1 \(line \d+\): parameter d: expected a number"):
            dv.load_robot(f)


KR5 = (__import__("pathlib").Path(dv.__file__).parent / "models" / "kr5.toml").read_text()
LIMITS = "limits = [-155, 155]"


@pytest.mark.parametrize(
    "old, new, match",
    [
        # issue 16: each had been a traceback (a ValueError from numpy, an OverflowError, a RecursionError)
        (LIMITS, 'limits = "ab"', r"joint 1 \(line \d+\): limits: expected a list of 2 numbers, got 'ab'$"),
        ("home = [90,", 'home = ["a",', r"kr5.toml: home\[0\]: expected a number, got 'a' \(a string\)$"),
        (
            "[units]",
            "[base]\nmatrix = [[1, 0, 0, 0], [0, 1, 0], [0, 0, 1, 0], [0, 0, 0, 1]]\n[units]",
            r"\[base\]: matrix row 2: expected a list of 4 numbers, got \[0, 1, 0\]$",
        ),
        ("[units]", "[tool]\nxyz = [0, 0, true]\n[units]", r"\[tool\]: xyz\[2\]: expected a number, got true$"),
        ("d = 400", "d = " + "9" * 5000, r"kr5.toml: not a readable TOML robot file: an integer of over 4300 digits$"),
        (
            "d = 400",
            "d = " + "[" * 100_000 + "]" * 100_000,
            r"kr5.toml: not a readable TOML robot file: arrays or tables nested too deeply$",
        ),
        ("d = 400", "d = nan", r"joint 1 \(line \d+\): parameter d: expected a finite number, got NaN$"),
        (LIMITS, "limits = [nan, 1]", r"joint 1 \(line \d+\): limits\[0\]: expected a finite number, got NaN$"),
        ('name = "A1"', "name = 5", r"joint 1 \(line \d+\): name: expected a string, got 5$"),
        ('name = "kr5"', "name = [1, 2]", r"kr5.toml: name: expected a string, got \[1, 2\]$"),
    ],
)
def test_wrong_types_are_one_line_errors(tmp_path, old, new, match):
    f = tmp_path / "kr5.toml"
    f.write_text(KR5.replace(old, new, 1))
    assert f.read_text() != KR5
    with pytest.raises(dv.DenavitError, match=match):
        dv.load_robot(f)


def test_infinite_limits_are_the_one_place_a_robot_file_takes_infinity(tmp_path):
    f = tmp_path / "kr5.toml"
    f.write_text(KR5.replace(LIMITS, "limits = [-inf, inf]", 1))
    r = dv.load_robot(f)
    assert r.lower[0] == -np.inf and r.upper[0] == np.inf


@pytest.mark.parametrize("name", ["kr5", "ur5", "puma560", "tiansui_edh"])
def test_a_written_file_holds_the_shortest_numbers_that_read_back_exactly(name, tmp_path):
    """Each value is written in the file's units as the shortest decimal the reader turns back into the same SI
    double (a KR5 limit of -15 deg had been written -14.999999999999998): the files of the built-ins in mm / deg
    read back bit for bit, and their limits are the data sheet's whole degrees."""
    r = dv.load_robot(name)
    doc = robotfile.to_dict(r, "mm", "deg")
    robotfile.save(r, tmp_path / "r.toml", "mm", "deg")
    back = robotfile.read(tmp_path / "r.toml")
    assert (
        np.array_equal(back.table.params, r.table.params)
        and np.array_equal(back.lower, r.lower)
        and np.array_equal(back.upper, r.upper)
    )
    if name == "kr5":
        assert [j["limits"] for j in doc["joints"]][2] == [-15.0, 158.0]


def test_a_core_error_about_one_joint_is_said_at_that_joint_from_its_structured_field(tmp_path):
    """Issue 35: the core's error carries the joint it is about (``e.joint``), and the reader places it at that
    joint's table in the file without reading the message back: a POE screw that is not a pure rotation at A3."""
    res = dv.identify(dv.simulate("kr5", points_per_sweep=8), nominal="kr5")
    good = tmp_path / "poe.toml"
    dv.save(res, good, convention="poe", length="mm")
    text = good.read_text()
    at = text.index('name = "A3"')
    w_line = text.index("w = [", at)
    bad = tmp_path / "bad.toml"
    bad.write_text(text[:w_line] + "w = [0.0, 0.0, 0.0]" + text[text.index("\n", w_line) :])
    with pytest.raises(dv.DenavitError) as e:
        robotfile.read(bad)
    msg = str(e.value)
    place = msg.split(": invalid poe screw")[0]
    line = int(place.split("(line ")[1].rstrip(")"))
    assert place.startswith(f"{bad}, joint 3 (line "), msg
    assert text[:at].count("\n") - 1 <= line <= text[:w_line].count("\n") + 1, (line, msg)  # A3's table
    assert "poe screw of revolute joint 3" in msg
    with pytest.raises(dv.DenavitError) as core:
        table = dv.load_robot(good).table
        params = np.array(table.params)
        params[2, :3] = 0.0
        dv.Table("poe", params, list(table.kinds)).to_model("bad")
    assert core.value.joint == 3 and core.value.kind == "InvalidArgument"


@pytest.mark.parametrize("convention", ["edh", "poe", "dh"])
def test_an_identification_of_exact_data_saves_and_reads_back(tmp_path, convention):
    """Regression: the covariance of an identification from noise-free sweeps (every entry at round-off) was written
    and then refused on reading as not symmetric (an element-wise relative test on entries near zero)."""
    res = dv.identify(dv.simulate("kr5", points_per_sweep=8), nominal="kr5")
    f = tmp_path / f"exact_{convention}.toml"
    dv.save(res, f, convention=convention, length="mm")
    robot = dv.load_robot(f)
    assert robot.covariance is not None and np.all(np.isfinite(robot.covariance))
    C = np.asarray(res.robot(convention=convention).covariance)
    np.testing.assert_allclose(robot.covariance, C, rtol=1e-12, atol=1e-15 * np.abs(np.diag(C)).max())
