"""The calibrate and plan commands: outputs, prismatic readings in the length unit, bad --noise, a jump refused and a
coupling honoured, the HTML report."""

import json
import subprocess
import sys

import numpy as np
import pytest
from calibrate_cases import NOISE, TOOL

import denavit as dv
from cli import env as cli_env
from cli import run as run_cli
from denavit import calibration as cal
from denavit.io.measurements import to_csv


def test_cli_calibrate_and_plan(kr5, tmp_path):
    q = cal.configurations(kr5, 60)
    f = tmp_path / "m.csv"
    f.write_text(to_csv(cal.simulate(kr5, q, tool=TOOL, noise=NOISE), "mm", "deg"))
    env = cli_env(160)
    out = tmp_path / "r.json"
    p = subprocess.run(
        [
            sys.executable,
            "-m",
            "denavit.cli",
            "calibrate",
            str(f),
            "--nominal",
            "kr5",
            "--tool",
            "50,30,100",
            "--json",
            str(out),
            "--save",
            str(tmp_path / "cal.toml"),
        ],
        capture_output=True,
        text=True,
        env=env,
    )
    assert p.returncode == 0, p.stderr
    assert "Held-out validation" in p.stdout and "c_5" in p.stdout
    assert json.loads(out.read_text())["convention"] == "edh"
    assert dv.load_robot(tmp_path / "cal.toml").convention == "edh"
    p = subprocess.run(
        [sys.executable, "-m", "denavit.cli", "plan", "kr5", "--ranges", "paper30", "--json"],
        capture_output=True,
        text=True,
        env=env,
    )
    assert p.returncode == 0, p.stderr
    doc = json.loads(p.stdout)
    assert doc["axis_sigma"][0]["per_circle_position_m"] / doc["axis_sigma"][0]["position_m"] > 5
    p = subprocess.run(
        [sys.executable, "-m", "denavit.cli", "calibrate", str(f), "--nominal", "kr5", "--convention", "dh"],
        capture_output=True,
        text=True,
        env=env,
    )
    assert p.returncode == 2 and "standard DH cannot calibrate kr5" in p.stderr


def test_cli_calibrate_reads_prismatic_readings_in_the_length_unit(tmp_path):
    """A robot file with a prismatic joint: the CLI reads that joint's readings in mm (not deg) and the fit
    finds the simulated truth."""
    f = tmp_path / "rprr.toml"
    f.write_text(
        'name = "rprr"\nconvention = "dh"\n[units]\nlength = "mm"\nangle = "deg"\n'
        '[[joints]]\nname = "j1"\nd = 300\ntheta = 0\na = 100\nalpha = 90\nlimits = [-170, 170]\n'
        '[[joints]]\nname = "j2"\ntype = "prismatic"\nd = 200\ntheta = 90\na = 0\nalpha = -90\nlimits = [0, 300]\n'
        '[[joints]]\nname = "j3"\nd = 0\ntheta = 0\na = 250\nalpha = 60\nlimits = [-170, 170]\n'
        '[[joints]]\nname = "j4"\nd = 100\ntheta = 0\na = 0\nalpha = 0\nlimits = [-170, 170]\n'
    )
    robot = dv.load_robot(f)
    m = tmp_path / "m.csv"
    m.write_text(
        to_csv(cal.simulate(robot, cal.configurations(robot, 60), tool=(0.03, 0.02, 0.05), noise=NOISE), "mm", "deg")
    )
    assert float(m.read_text().splitlines()[-1].split(",")[1]) > 5  # the prismatic reading is in mm, not metres
    out = tmp_path / "r.json"
    p = subprocess.run(
        [
            sys.executable,
            "-m",
            "denavit.cli",
            "calibrate",
            str(m),
            "--nominal",
            str(f),
            "--tool",
            "30,20,50",
            "--json",
            str(out),
        ],
        capture_output=True,
        text=True,
        env=cli_env(160),
    )
    assert p.returncode == 0, p.stderr
    doc = json.loads(out.read_text())
    assert doc["validation"]["after_rms_m"] < 3 * NOISE * np.sqrt(3), doc[
        "validation"
    ]  # m: the noise, not a unit error (it had compared m with mm)


def test_bad_noise_and_a_fit_that_explains_nothing(kr5, tmp_path):
    """--noise 0 had raised ZeroDivisionError, nan 'converged' with 'noise estimate nan', a negative noise was
    taken; degrees read as radians gave rms 814 mm with no word. Now: one-line errors, and a note."""
    q = cal.configurations(kr5, 40)
    meas = cal.simulate(kr5, q, tool=TOOL, noise=NOISE)
    f = tmp_path / "m.csv"
    f.write_text(to_csv(meas, "mm", "deg"))
    for bad in ("0", "nan", "-1", "inf"):
        p = subprocess.run(
            [
                sys.executable,
                "-m",
                "denavit.cli",
                "calibrate",
                str(f),
                "--nominal",
                "kr5",
                "--tool",
                "50,30,100",
                "--noise",
                bad,
            ],
            capture_output=True,
            text=True,
            env=cli_env(160),
        )
        assert (
            p.returncode == 2
            and "--noise: expected the known one-sigma point noise, a finite value > 0 in mm" in p.stderr
        ), p.stderr
    with pytest.raises(dv.DenavitError, match="noise: expected the known one-sigma noise"):
        cal.calibrate(meas, kr5, tool=TOOL, noise=float("nan"))
    wrong = cal.Measurements(np.degrees(meas.q), meas.points, None, "degrees read as radians")
    res = cal.calibrate(wrong, kr5, tool=TOOL, holdout=0)
    assert res.notes[0].startswith("the fit explains little of the data: rms")
    res = cal.calibrate(meas, kr5, tool=TOOL, noise=NOISE / 100, holdout=0)
    assert "x what the declared noise" in res.notes[0]
    assert not any("explains" in n for n in cal.calibrate(meas, kr5, tool=TOOL, noise=NOISE, holdout=0).notes)


def test_cli_calibrate_refuses_a_jump_and_honours_a_coupling(tmp_path):
    """Readings of a Fanuc (J3 read relative to the horizontal) calibrated against the plain nominal: the fit moved
    b_2 by 1.1 m and exited 0 with no note; now it is refused (exit 2) naming the parameter and the coupling to
    declare, and with --coupling "q3=r3+r2" it fits to the noise."""
    kr5 = dv.load_robot("kr5")
    q = cal.configurations(kr5, 60)
    meas = cal.simulate(kr5.model(), q, tool=np.array([0.05, 0.03, 0.1]), noise=2e-5, seed=1)
    r = q.copy()
    r[:, 2] -= q[:, 1]
    lines = ["# units: length=mm angle=deg", "q1,q2,q3,q4,q5,q6,x,y,z"]
    lines += [
        ",".join([*(f"{v:.8f}" for v in np.degrees(a)), *(f"{v:.6f}" for v in p * 1e3)])
        for a, p in zip(r, meas.points, strict=True)
    ]
    f = tmp_path / "fanuc.csv"
    f.write_text("\n".join(lines) + "\n")
    bad = run_cli("calibrate", f, "--nominal", "kr5", "--tool", "50,30,100", ok=False)
    assert (
        bad.returncode == 2
        and "by more than the robot's size" in bad.stderr + bad.stdout
        and "--coupling" in bad.stderr + bad.stdout
    )
    good = run_cli(
        "calibrate",
        f,
        "--nominal",
        "kr5",
        "--tool",
        "50,30,100",
        "--coupling",
        "q3=r3+r2",
        "--json",
        tmp_path / "c.json",
    )
    assert good.returncode == 0
    assert (
        json.loads((tmp_path / "c.json").read_text())["residuals"]["rms_m"] < 5e-5
    )  # m (0.02 mm noise; it had compared m with 0.05 "mm")


def test_cli_calibrate_writes_a_report(tmp_path):
    """`calibrate --report`: the calibration's self-contained HTML report (what it draws: test_report's browser
    test)."""
    kr5 = dv.load_robot("kr5")
    q = cal.configurations(kr5, 30)
    meas = cal.simulate(kr5.model(), q, tool=np.array([0.05, 0.03, 0.1]), noise=2e-5, seed=2)
    lines = ["# units: length=mm angle=deg", "q1,q2,q3,q4,q5,q6,x,y,z"]
    lines += [
        ",".join([*(f"{v:.8f}" for v in np.degrees(a)), *(f"{v:.6f}" for v in p * 1e3)])
        for a, p in zip(q, meas.points, strict=True)
    ]
    f = tmp_path / "m.csv"
    f.write_text("\n".join(lines) + "\n")
    page = tmp_path / "cal.html"
    run_cli("calibrate", f, "--nominal", "kr5", "--tool", "50,30,100", "--report", page)
    html = page.read_text()
    assert html.startswith("<!DOCTYPE html>") and "kr5" in html and len(html) < 2e6
