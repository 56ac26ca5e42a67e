"""What a newcomer meets in the first hour (issue 40): inspect and identify agree on units and on what they read.

In-process (typer's CliRunner on denavit.cli's app)."""

import importlib.util
import re
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

import denavit as dv
from denavit.cli import app
from denavit.errors import DenavitError


def invoke(*args):
    r = CliRunner().invoke(app, [str(a) for a in args])
    if r.exception is not None and not isinstance(r.exception, SystemExit):
        raise r.exception
    return r


@pytest.fixture(scope="module")
def recording(tmp_path_factory):
    """A delimited recording with no '# units:' line: time (s), six joint readings (deg), a point (mm); joint 1
    sweeps 30 deg."""
    t = np.arange(200) * 0.01
    q = np.zeros((200, 6))
    q[:, 0] = np.linspace(0.0, 30.0, 200)
    x = np.c_[1000 * np.cos(np.radians(q[:, 0])), 1000 * np.sin(np.radians(q[:, 0])), np.full(200, 500.0)]
    p = tmp_path_factory.mktemp("rec") / "rec.csv"
    np.savetxt(p, np.c_[t, q, x], delimiter=",", fmt="%.6f")
    return p


def test_inspect_takes_the_angle_unit_help_and_docs_promise(recording):
    """`inspect rec.csv --columns ... --length mm` had failed with 'units not declared (angle)' although --help
    says --angle defaults to deg and docs/cli.md that only the length is required: the 30 deg sweep is found."""
    r = invoke("inspect", recording, "--columns", "t,q1..q6,x,y,z", "--length", "mm")
    assert r.exit_code == 0, r.output
    row = next(ln for ln in r.output.splitlines() if ln.strip().startswith("1 ") and "sweep" in ln)
    assert "30.000" in row and "200" in row
    # radians asked for: the same file read as radians (a 30 rad sweep), said in the table's unit
    r = invoke("inspect", recording, "--columns", "t,q1..q6,x,y,z", "--length", "mm", "--angle", "rad")
    assert r.exit_code == 0 and "(joint values in rad" in r.output


def test_inspect_names_a_sweep_file_and_an_empty_file(tmp_path):
    """The CSV that `simulate` writes and an empty file had both been 'unknown recording format'."""
    sweeps = tmp_path / "s.csv"
    assert invoke("simulate", "kr5", "-o", sweeps, "--points", "20").exit_code == 0
    with pytest.raises(
        DenavitError,
        match=r"s\.csv: a sweep file \(denavit's long-form CSV with a 'joint' column.*"
        r"`denavit identify .*s\.csv --nominal MODEL` reads it as it is$",
    ):
        invoke("inspect", sweeps)
    empty = tmp_path / "empty.csv"
    empty.write_text("# nothing recorded\n\n")
    with pytest.raises(DenavitError, match=r"empty\.csv: an empty file \(no data lines\): expected a recording"):
        invoke("inspect", empty)
    # identify reads the sweep file as it is
    assert invoke("identify", sweeps, "--nominal", "kr5").exit_code == 0


def test_dwell_detection_does_not_fire_on_constant_speed_at_controller_rates():
    """`simulate kr5 --points 3000` then `identify` had printed three dwell notes (six and 307 rows of A6 dropped at
    100,000 points), the docs' own 100 Hz-1 kHz scenario (issue 40): a dense sweep at constant speed has no dwell,
    while a real stop of 60 rows at the same density is still found and left out."""
    import denavit as dv
    from denavit import sweeps as sw
    from denavit.io.robots import load

    kr5 = load("kr5")
    home, ranges = np.radians([0, -90, 90, 0, 45, 0]), np.radians(sw.PAPER_RANGES_DEG[30])
    s = sw.simulate(kr5.model(), home=home, ranges=ranges, points_per_sweep=3000, noise=2e-5, seed=1)
    assert not [n for n in dv.identify(s, nominal=kr5).notes if "dwell" in n]
    # joint 6 waits 60 rows at the start of its sweep (the first point repeated with the tracker's noise)
    rng = np.random.default_rng(2)
    last = s.sweeps[-1]
    wait = last.points[0] + rng.normal(0, 2e-5, (60, 3))
    stopped = last.take(np.r_[np.zeros(60, dtype=int), np.arange(len(last.points))])
    stopped = type(last)(**{**stopped.__dict__, "points": np.vstack([wait, last.points])})
    s2 = type(s)(**{**s.__dict__, "sweeps": [*s.sweeps[:-1], stopped]})
    notes = [n for n in dv.identify(s2, nominal=kr5).notes if "dwell" in n]
    assert len(notes) == 1 and "joint 6" in notes[0] and "at the start" in notes[0], notes
    found = int(notes[0].split("joint 6: ")[1].split(" dwell rows")[0])
    # 61 rows stand still (the wait and the sweep's own first point); the run may reach into the motion by the rows
    # the pace needs to leave the tolerance (5 sigma of the 0.02 mm noise): up to 2 tol / pace
    pace = np.linalg.norm(last.points[-1] - last.points[0]) / (len(last.points) - 1)
    assert 61 - 5 <= found <= 61 + int(np.ceil(2 * 5 * 2e-5 / pace)), (found, notes)


def test_robot_files_write_arrays_inline_and_read_back_the_same():
    """Exported TOML had put each number of `limits` and `home` on its own line (issue 40): arrays of values are one
    line, a matrix one row a line, and the file reads back to the same robot."""
    import tomllib

    from denavit.io import robotfile
    from denavit.io.robots import as_robot

    r = as_robot("kr5")
    text = robotfile.dumps(r, "mm", "deg")
    assert "home = [90.0, -90.0, 90.0, 0.0, 90.0, 0.0]\n" in text and "limits = [-155.0, 155.0]\n" in text
    doc = tomllib.loads(text)
    assert doc["home"] == [90.0, -90.0, 90.0, 0.0, 90.0, 0.0] and doc["joints"][0]["limits"] == [-155.0, 155.0]
    cov = np.diag(np.arange(1.0, 1.0 + 4 * 6 + 3)) * 1e-8  # a table's parameters, then the tool's x, y, z
    with_cov = type(r)(**{**r.__dict__, "covariance": cov})
    text = robotfile.dumps(with_cov, "mm", "deg")
    rows = [ln for ln in text.splitlines() if ln.startswith("    [") and ln.endswith("],")]
    assert len(rows) == 27 and all(ln.count(",") == 27 for ln in rows)
    np.testing.assert_allclose(
        tomllib.loads(text)["covariance"]["matrix"],
        cov / np.outer(*[robotfile._covariance_scales(r.table, "mm", "deg", False)] * 2),
        rtol=1e-15,
    )


# The README's main job, `denavit identify --example kr5`, on sweeps simulated from a "true" KR5 (issue 40, item 1)

DATA = Path(dv.__file__).parent / "data"
#: The design tool point of the example (README, examples/make_kr5_example.py), m in the flange frame.
DESIGN_TOOL = np.array([0.05, 0.03, 0.10])


def load_script():
    """examples/make_kr5_example.py as a module."""
    path = Path(__file__).resolve().parents[1] / "examples" / "make_kr5_example.py"
    spec = importlib.util.spec_from_file_location("make_kr5_example", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_the_shipped_example_is_what_its_script_makes():
    """The true robot file is the script's, byte for byte; each sweep file has the script's comments and columns and
    its numbers (to the last bits the CPU's floating point may change: 1e-9 mm, 1e-12 deg)."""
    made = load_script().make()
    assert sorted(made) == ["kr5_30deg.csv", "kr5_90deg.csv", "kr5_true.toml"]
    assert (DATA / "kr5_true.toml").read_text(encoding="utf-8") == made["kr5_true.toml"]
    for name in ("kr5_90deg.csv", "kr5_30deg.csv"):
        shipped = (DATA / name).read_text(encoding="utf-8").splitlines()
        ours = made[name].splitlines()
        assert [ln for ln in shipped if ln.startswith("#") or ln[:1].isalpha()] == [
            ln for ln in ours if ln.startswith("#") or ln[:1].isalpha()
        ]
        a, b = (np.loadtxt([ln for ln in t if ln[:1].isdigit()], delimiter=",", ndmin=2) for t in (shipped, ours))
        assert a.shape == b.shape == (240, 10)
        np.testing.assert_allclose(a[:, 1:7], b[:, 1:7], rtol=0, atol=1e-12)  # deg
        np.testing.assert_allclose(a[:, 7:], b[:, 7:], rtol=0, atol=1e-9)  # mm


def test_the_true_robot_differs_from_the_nominal_by_the_errors_stated():
    """kr5_true.toml is the built-in kr5 with every DH length off by 0.3-1 mm and every angle by 0.02-0.1 deg, the tool
    point 0.2-0.6 mm off its design 50, 30, 100 mm per coordinate (as the README and the file's comment say)."""
    true, nominal = dv.load_robot(DATA / "kr5_true.toml"), dv.load_robot("kr5")
    assert true.convention == nominal.convention == "dh" and true.table.columns == ["d", "theta", "a", "alpha"]
    diff = np.abs(true.table.params - nominal.table.params)
    lengths, angles = diff[:, [0, 2]] * 1e3, np.degrees(diff[:, [1, 3]])
    assert np.all((lengths >= 0.3 - 1e-9) & (lengths <= 1.0 + 1e-9)), lengths
    assert np.all((angles >= 0.02 - 1e-9) & (angles <= 0.1 + 1e-9)), angles
    tool = np.abs(true.table.T_last_tool[:3, 3] - DESIGN_TOOL) * 1e3
    assert np.all((tool >= 0.2 - 1e-9) & (tool <= 0.6 + 1e-9)), tool
    assert true.extra["simulation"]["nominal_tool_mm"] == list(DESIGN_TOOL * 1e3)
    np.testing.assert_array_equal(true.lower, nominal.lower)


def accuracy(output: str) -> dict:
    """The accuracy lines of identify's first screen: {'nominal' / 'identified' / 'predicted': (rms, max) in mm}."""
    found = {}
    for key, pattern in (
        ("nominal", r"nominal model \(kr5, tool as designed\) against the true robot:"),
        ("identified", r"identified model \(EDH table\) against the true robot:"),
        ("predicted", r"identified model, predicted \(1 sigma\):"),
    ):
        m = re.search(pattern + r"\s+([0-9.e+-]+) mm \(max ([0-9.e+-]+)\)", output)
        assert m is not None, (key, output)
        found[key] = (float(m.group(1)), float(m.group(2)))
    return found


def true_errors(identified) -> dict:
    """The position errors (rms, max, mm) of the nominal kr5 with its design tool and of the ``identified`` robot
    against the true robot file, at 1000 configurations spread within the joint limits (a Halton sequence, A4 and
    A6 within +-180 deg), computed here from the files alone."""
    from scipy.stats import qmc

    true, nominal = dv.load_robot(DATA / "kr5_true.toml"), dv.load_robot("kr5")
    lo, hi = np.maximum(nominal.lower, -np.pi), np.minimum(nominal.upper, np.pi)
    q = qmc.scale(qmc.Halton(d=6, scramble=False).random(1001)[1:], lo, hi)
    tool = np.eye(4)
    tool[:3, 3] = DESIGN_TOOL
    p_true = np.array([dv.fk(true.model(), x)[:3, 3] for x in q])
    p_nom = np.array([dv.fk(nominal.model().with_tool(tool), x)[:3, 3] for x in q])
    q_id = identified.joint_values(q) if identified.has_reading_model else q
    p_id = np.array([dv.fk(identified.model(), x)[:3, 3] for x in q_id])
    out = {}
    for key, p in (("nominal", p_nom), ("identified", p_id)):
        e = np.linalg.norm(p - p_true, axis=1) * 1e3
        out[key] = (np.sqrt(np.mean(e**2)), e.max())
    return out


def test_the_main_job_says_what_was_measured_found_how_accurate_and_what_next(tmp_path):
    """`denavit identify --example kr5` (the README's main job): its first screen says what was measured (simulated
    from the true robot, the protocol and the noise), the parameters found, each model's true error beside the
    predicted one, and one next step, without the fit's statistics (BIC, Hayati beta, ppm): those come with
    --verbose. The errors it prints are the ones computed here from the true robot file and the model it saves:
    the identified model misses the true robot by far less than the nominal (a gain over 20x), and by about what
    was predicted."""
    r = invoke("identify", "--example", "kr5")
    assert r.exit_code == 0, r.output
    out = r.output
    for word in ("BIC", "Hayati", "ppm", "marginal likelihood", "auto:"):
        assert word not in out, word
    heads = [
        "Measured: 6 sweeps",
        "simulated, not measured: Hayat et al.'s 90 deg protocol",
        "Identified EDH parameters",
        "Accuracy at the tool point",
        "Next: denavit identify --example kr5 --save kr5_identified.toml",
    ]
    at = [out.find(h) for h in heads]
    assert all(k >= 0 for k in at) and at == sorted(at), list(zip(heads, at))
    assert "40 points each (240 in all)" in out and "tracker noise 0.02 mm, joint-reading noise 0.001 deg" in out
    assert len(out.splitlines()) <= 60  # one screen
    printed = accuracy(out)

    saved = tmp_path / "kr5_identified.toml"
    r = invoke("identify", "--example", "kr5", "--save", saved, "--verbose")
    assert r.exit_code == 0, r.output
    assert "BIC" in r.output and "Joint axes" in r.output  # moved behind --verbose, not dropped
    assert accuracy(r.output) == printed
    assert f"Next: denavit compensate kr5 PROGRAM --identified {saved}" in " ".join(r.output.split())
    computed = true_errors(dv.load_robot(saved))
    for key in ("nominal", "identified"):
        np.testing.assert_allclose(printed[key], computed[key], rtol=6e-3, err_msg=key)  # 3 significant figures
    nominal, identified, predicted = printed["nominal"][0], printed["identified"][0], printed["predicted"][0]
    assert 1.0 < nominal < 6.0  # the stated errors (0.3-1 mm, 0.02-0.1 deg on a 1.2 m arm) miss by millimetres
    assert identified < nominal / 20
    assert 0.5 < identified / predicted < 2.0, (identified, predicted)


def test_the_first_workflow_simulate_identify_save_compensate_report_makes_the_true_robot_accurate(tmp_path):
    """The docs' first workflow (README: simulate, identify, save, compensate, report) on a robot that is not its
    nominal (the shipped "true" KR5): the compensated commands, run on the true robot, reach the positions at least
    10x better than the positions sent as they are; judged by forward kinematics of the true robot file, which the
    workflow never reads."""
    true = Path(dv.__file__).parent / "data" / "kr5_true.toml"
    sweeps, saved, report = tmp_path / "s.csv", tmp_path / "kr5_identified.toml", tmp_path / "r.html"
    invoke("simulate", true, "-o", sweeps, "--ranges", "paper90", "--points", "40", "--noise", "0.02", "--seed", "7")
    r = invoke("identify", "kr5", sweeps, "--save", saved)
    assert r.exit_code == 0 and saved.exists(), r.output
    nominal, real = dv.load_robot("kr5"), dv.load_robot(true)
    rng = np.random.default_rng(11)
    q = rng.uniform(nominal.lower * 0.6, nominal.upper * 0.6, (25, 6))
    positions = tmp_path / "positions.csv"
    positions.write_text(
        "# units: length=mm angle=deg\nq1,q2,q3,q4,q5,q6\n"
        + "".join(",".join(f"{v:.12g}" for v in np.degrees(row)) + "\n" for row in q)
    )
    # the nominal with the point simulate measured as its tool (50, 30, 100 mm in the flange frame, simulate's
    # default): the positions are that point's, as a program's positions are its tool's
    from dataclasses import replace

    from denavit.io import robotfile

    point = np.eye(4)
    point[:3, 3] = (0.05, 0.03, 0.10)
    t = nominal.table
    with_tool = tmp_path / "kr5_tool.toml"
    robotfile.save(
        replace(nominal, table=dv.Table(t.convention, t.params, list(t.kinds), t.T_world_base, point)), with_tool
    )
    out, doc = tmp_path / "commands.csv", tmp_path / "c.json"
    args = ("compensate", with_tool, positions, "--identified", saved, "-o", out, "--json", doc)
    r = invoke(*args, "--report", report) if importlib.util.find_spec("plotly") else invoke(*args)
    assert r.exit_code in (0, 1) and out.exists(), r.output  # 1: a row flagged (e.g. its branch changed)
    import json

    rows = json.loads(doc.read_text())["rows"]
    ok = np.array([row["ok"] for row in rows])
    assert ok.sum() >= 20, ok
    # the point on the nominal at the program's joint values, and on the true robot at the values sent
    goal = dv.fk_batch(nominal.model().with_tool(point), q)[:, :3, 3]
    true_model = real.model().with_tool(point)
    sent_as_is = dv.fk_batch(true_model, q)[:, :3, 3]
    commands = np.array([row["q"] for row in rows])
    compensated = dv.fk_batch(true_model, commands)[:, :3, 3]
    before = np.linalg.norm(sent_as_is - goal, axis=1)[ok]
    after = np.linalg.norm(compensated - goal, axis=1)[ok]
    assert np.sqrt(np.mean(after**2)) < 0.1 * np.sqrt(np.mean(before**2)), (before, after)
    if importlib.util.find_spec("plotly"):
        assert report.exists() and report.stat().st_size > 10_000
