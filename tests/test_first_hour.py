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
