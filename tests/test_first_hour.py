"""What a newcomer meets in the first hour (issue 40): inspect and identify agree on units and on what they read.

In-process (typer's CliRunner on denavit.cli's app)."""

import numpy as np
import pytest
from typer.testing import CliRunner

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
        match=r"s\.csv: a sweep file \(denavit's long-form CSV with a 'joint' column.*`denavit identify .*s\.csv --nominal MODEL` reads it as it is$",
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

    from denavit.io.robots import as_robot
    from denavit.io import robotfile

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
