"""Progress of long jobs (issue 40): the Python API's ``progress(message, fraction)`` callback and the command line's
bar with the percentage and the time left."""

import io
import time

import numpy as np
from rich.console import Console

import denavit as dv
from denavit.cli import console as cli_console
from denavit.progress import Stage


def _fractions(calls):
    return [m.fraction for m in calls]


def test_identify_and_calibrate_report_stages_with_growing_fractions():
    """Both workflows call progress(stage) at each stage, a str whose fraction rises from 0 towards 1."""
    calls = []
    dv.identify(dv.simulate("kr5", points_per_sweep=12, noise=2e-5), nominal="kr5", progress=calls.append)
    f = _fractions(calls)
    assert f[0] == 0.0 and 0.8 <= f[-1] < 1.0 and all(b >= a for a, b in zip(f, f[1:])), calls
    assert any("sweep 6 of 6" in m for m in calls) and len(calls) >= 8 and all(isinstance(m, str) for m in calls)
    kr5 = dv.load_robot("kr5")
    meas = dv.simulate("kr5", dv.calibration.configurations(kr5, 40), noise=2e-5)
    calls = []
    dv.calibrate(meas, kr5, progress=calls.append)
    f = _fractions(calls)
    assert f[0] == 0.0 and 0.8 <= f[-1] < 1.0 and all(b >= a for a, b in zip(f, f[1:])), calls
    assert any(m.startswith("model full ") for m in calls), calls  # each candidate model named as it is fitted


def test_the_command_lines_status_shows_a_percentage_on_a_terminal_and_in_a_log(monkeypatch):
    """On a terminal: a bar with the percentage (and the time left); elsewhere: one line with the percentage once
    the step has lasted PATIENCE."""
    buf = io.StringIO()
    term = Console(file=buf, force_terminal=True, width=120)
    monkeypatch.setattr(cli_console, "err_console", term)
    with cli_console.status("fitting") as st:
        st.update(Stage("sweep 3 of 6", 0.42))
        time.sleep(0.3)  # rich refreshes the live display several times a second
    assert "42%" in buf.getvalue() and "sweep 3 of 6" in buf.getvalue()
    log = io.StringIO()
    monkeypatch.setattr(cli_console, "err_console", Console(file=log, force_terminal=False, width=120))
    monkeypatch.setattr(cli_console, "PATIENCE", 0.05)
    with cli_console.status("fitting") as st:
        st.update("sweep 5 of 6", np.float64(0.7))  # (or the fraction given beside a plain message)
        time.sleep(0.3)
    assert "fitting sweep 5 of 6 (70 %)" in log.getvalue(), log.getvalue()


def test_identify_notes_say_their_lengths_in_the_units_asked(tmp_path):
    """Issue 35: a note's lengths follow --length (a denavit.message.Message keeps its quantities in SI); the note
    as a str still reads in mm, as it always has."""
    from cli import run
    from denavit.message import Message

    csv = tmp_path / "s.csv"
    run("simulate", "kr5", "-o", csv, "--points", "12", "--noise", "0.02", "--seed", "3")
    res = dv.identify(str(csv), nominal="kr5", convention="dh")
    carried = [n for n in res.notes if isinstance(n, Message) and "carries a tool-position error" in n]
    assert carried and " mm " in carried[0]
    out = run("identify", "kr5", csv, "--convention", "dh", "--length", "m").stdout
    lines = [ln for ln in out.splitlines() if "carries a tool-position error" in ln]
    assert lines and " m (" in lines[0] and " mm" not in lines[0], lines
    value_m = float(lines[0].split("error up to ")[1].split(" m ")[0])
    value_mm = float(carried[0].split("error up to ")[1].split(" mm ")[0])
    assert abs(value_m * 1e3 - value_mm) <= 1e-4 * max(value_mm, 1e-9) + 5e-4, (value_m, value_mm)
