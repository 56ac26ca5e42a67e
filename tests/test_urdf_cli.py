"""Every command of the CLI on URDFs in the shape of real ones (issue #15), with --tip-link and with the default tip.

The files (tests/data/urdf): ur5_ros.urdf (ur_description's layout: a `world` root, base/flange/tool0 frames, a
wrist camera), irb_rosi.urdf (a ROS-Industrial description with a `base` leaf), humanoid.urdf (a torso with two
arms and a head), gripper.urdf (an arm with a mimic-finger gripper). Commands had failed on most of them (several
tips, no --tip-link); each one here must run (exit code 0), say the default tip in one line when it chose it, and
its output is checked where it is cheap to: the URDF written keeps every link of the original, fk equals the
model's forward kinematics, ik reaches the pose, identify and calibrate on noise-free data recover the robot.
"""

import json
from pathlib import Path

import numpy as np
import pytest
import yourdfpy

import denavit as dv
from cli import run

DATA = Path(__file__).parent / "data" / "urdf"
# (file, --tip-link or None for the default, the tip the default chooses)
CASES = [
    ("ur5_ros.urdf", None, "tool0"),
    ("ur5_ros.urdf", "wrist_3_link", None),
    ("irb_rosi.urdf", None, "tool0"),
    ("irb_rosi.urdf", "link_6", None),
    ("humanoid.urdf", None, "arm_right_tool_link"),
    ("humanoid.urdf", "xtion_rgb_optical_frame", None),
    ("gripper.urdf", None, "leftfinger"),
    ("gripper.urdf", "hand_tcp", None),
]


def numbers(values) -> str:
    return ",".join(repr(float(v)) for v in values)


@pytest.mark.parametrize("name, tip, default", CASES, ids=[f"{c[0][:-5]}-{c[1] or 'default'}" for c in CASES])
def test_every_command_runs_on_the_urdf(name, tip, default, tmp_path):
    from denavit import calibration as cal  # noqa: PLC0415
    from denavit.io.measurements import to_csv  # noqa: PLC0415

    f = DATA / name
    chain = ["--tip-link", tip] if tip else []
    robot = dv.load_robot(f, tip_link=tip)
    n = len(robot.names)
    prismatic = [k == "prismatic" for k in robot.table.kinds]
    lo, hi = np.maximum(robot.lower, -np.pi), np.minimum(robot.upper, np.pi)
    mid, half = (lo + hi) / 2, np.minimum((hi - lo) / 2, np.where(prismatic, 0.02, 0.6)) * 0.9
    q = mid + 0.3 * half  # SI, within the limits

    def ok(*args):
        p = run(*args)
        if default:
            assert f"tip link {default!r}" in p.stderr, args
        else:
            assert "tip link" not in p.stderr, args
        return p

    # convert: the URDF written keeps every link of the original; a convention's table
    out = tmp_path / "out.urdf"
    ok("convert", f, "--to", "urdf", "-o", out, *chain)
    assert set(yourdfpy.URDF.load(str(out), load_meshes=False).link_map) == set(
        yourdfpy.URDF.load(str(f), load_meshes=False).link_map
    )
    ok("show", f, *chain)
    assert "[joints" in ok("export", f, *chain).stdout
    # fk, ik, dynamics
    T = dv.fk(robot.model(), q)
    np.testing.assert_allclose(
        json.loads(ok("fk", f, "--q", numbers(q), "--length", "m", "--angle", "rad", "--json", *chain).stdout)[
            "T_world_tool"
        ],
        T,
        atol=1e-12,
    )
    ok("ik", f, "--pose", numbers(T.ravel()), "--length", "m", "--angle", "rad", *chain)
    ok(
        "dynamics",
        f,
        "--q",
        numbers(q),
        "--qd",
        numbers(np.zeros(n)),
        "--qdd",
        numbers(np.zeros(n)),
        "--length",
        "m",
        "--angle",
        "rad",
        *chain,
    )
    # simulate -> inspect, identify --nominal; plan
    ranges = np.stack([mid - half, mid + half], axis=1) * np.where(prismatic, 1000.0, np.degrees(1.0))[:, None]
    home = mid * np.where(prismatic, 1000.0, np.degrees(1.0))
    sweeps = tmp_path / "s.csv"
    ok(
        "simulate",
        f,
        "-o",
        sweeps,
        "--noise",
        "0",
        "--points",
        "8",
        "--ranges",
        numbers(ranges.ravel()),
        "--home",
        numbers(home),
        *chain,
    )
    run("inspect", sweeps, "--format", "columns", "--columns", f"-,q1..q{n},x,y,z")  # a recording, no MODEL
    ok("plan", f, "--ranges", numbers(ranges.ravel()), "--home", numbers(home), "--points", "8", *chain)
    ident = tmp_path / "identified.urdf"
    ok("identify", sweeps, "--nominal", f, "--urdf", ident, *chain)
    # calibrate --nominal (noise-free poses): the calibrated URDF reproduces the measured points
    qs = cal.configurations(robot, 40)
    meas = tmp_path / "m.csv"
    meas.write_text(to_csv(cal.simulate(robot, qs, tool=(0.02, 0.01, 0.05), noise=0.0), "mm", "deg"))
    calibrated = tmp_path / "cal.urdf"
    ok(
        "calibrate",
        meas,
        "--nominal",
        f,
        "--tool",
        "20,10,50",
        "--urdf",
        calibrated,
        "--save",
        tmp_path / "cal.toml",
        *chain,
    )
    m_cal = dv.load_model(calibrated, tip_link="tcp")
    T_ft = np.eye(4)
    T_ft[:3, 3] = (0.02, 0.01, 0.05)
    truth = robot.model().with_tool(T_ft)
    for qq in qs[:5]:
        np.testing.assert_allclose(dv.fk(m_cal, qq)[:3, 3], dv.fk(truth, qq)[:3, 3], atol=1e-6)
    # compensate a joint program with the calibrated robot
    positions = tmp_path / "positions.csv"
    positions.write_text(
        "# units: length=mm angle=deg\n"
        + ",".join(f"q{k + 1}" for k in range(n))
        + "\n"
        + "\n".join(numbers(row * np.where(prismatic, 1000.0, np.degrees(1.0))) for row in qs[:3])
        + "\n"
    )
    # the calibrated URDF's own default tip is its `tcp` where the file has no tool0: name the nominal's tip for both
    run("compensate", positions, "--nominal", f, "--identified", calibrated, "--tip-link", tip or default)


def test_a_library_warning_is_one_warning_line(tmp_path):
    """A warning raised while a command loads a URDF (here the Puma 560's massless link 1 with its rotor's
    inertia) reads like the commands' own: one ``warning:`` line, without Python's file, line and source."""
    u = tmp_path / "p560.urdf"
    run("convert", "puma560", "--to", "urdf", "-o", u)
    p = run("dynamics", u)
    lines = [ln for ln in p.stderr.splitlines() if ln.strip()]
    assert lines == [
        "warning: "
        + f"{u}: link 'link_1' gives an <inertia> but <mass value=\"0\"/>: the inertia of a massless link is left out"
    ], p.stderr
