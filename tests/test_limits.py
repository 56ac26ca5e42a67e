"""Limits by design (issue 34, docs/cli.md "Limits"): every size an input asks for is checked against a documented
limit before anything is allocated, and every number read or typed against what is physically plausible, each
with a one-line error that names the limit (and how to raise it): no MemoryError, OverflowError or LinAlgError
reaching the user as an "internal error" (exit 3), no run without bound, no absurd value written to a file.

The command line runs in-process (typer's CliRunner on denavit.cli's app); the worst cases run once more in a
subprocess under a 4 GiB address-space limit, through ``denavit.cli.main`` (exit code 2 and one ``error:`` line)."""

import re
import resource
import subprocess
import sys
import time
import tracemalloc
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

import denavit as dv
from cli import env
from denavit import calibration
from denavit.cli import app
from denavit.errors import DenavitError
from denavit.io import robotfile
from denavit.io.measurements import to_csv
from denavit.io.sweeps import to_long_csv

KR5 = (Path(dv.__file__).parent / "models" / "kr5.toml").read_text()
SECONDS = 5.0  # each refusal comes at once: before the fix, these ran for minutes or failed after 30-40 s


def refused(*args) -> str:
    """The one-line error of ``denavit ARGS`` run in-process: a DenavitError (main() makes it exit 2) or exit 2
    with an ``error:`` line; quickly."""
    t = time.perf_counter()
    r = CliRunner().invoke(app, [str(a) for a in args])
    took = time.perf_counter() - t
    if r.exception is not None and not isinstance(r.exception, SystemExit):
        assert isinstance(r.exception, DenavitError), f"{type(r.exception).__name__}: {r.exception}"
        message = str(r.exception)
    else:
        assert r.exit_code == 2, (r.exit_code, r.output)
        message = [ln for ln in r.output.splitlines() if ln.strip()][-1]
        assert message.startswith("error: "), r.output
    assert "\n" not in message and len(message) <= 510, message
    assert took < SECONDS, f"{took:.1f} s: {message}"
    return message


def urdf(n_links: int, moving: int = 6, branch: bool = False, origin: str = "0 0 0.1", rpy: str = "0 0 0") -> str:
    """A URDF of ``n_links`` links below l0: the first ``moving`` joints revolute, the rest fixed (hung on l0
    with ``branch``: links off the chain); the first joint's origin ``origin`` / ``rpy``."""
    out = ['<?xml version="1.0"?>', '<robot name="big">', '<link name="l0"/>']
    for i in range(1, n_links + 1):
        kind = "revolute" if i <= moving else "fixed"
        parent = 0 if branch and i > moving else i - 1
        extra = '<axis xyz="0 0 1"/><limit lower="-3" upper="3" effort="1" velocity="1"/>' if kind == "revolute" else ""
        o, r = (origin, rpy) if i == 1 else ("0 0 0.1", "0 0 0")
        out.append(
            f'<link name="l{i}"/><joint name="j{i}" type="{kind}"><parent link="l{parent}"/><child link="l{i}"/>'
            f'<origin xyz="{o}" rpy="{r}"/>{extra}</joint>'
        )
    return "\n".join([*out, "</robot>"])


def robot_file(n_joints: int) -> str:
    head = KR5[: KR5.index("[[joints]]")].replace("home = [90, -90, 90, 0, 90, 0]", "")
    return head + "".join(f'[[joints]]\nname = "j{i}"\nd = 0\ntheta = 0\na = 100\nalpha = 0\n' for i in range(n_joints))


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    d = tmp_path_factory.mktemp("limits")
    (d / "d1e308.toml").write_text(KR5.replace("d = 400", "d = 1e308"))
    (d / "a2km.toml").write_text(KR5.replace("a = 180", "a = 2000000"))
    (d / "rpy.toml").write_text(KR5 + "\n[tool]\nrpy = [1e300, 0, 0]\n")
    (d / "home.toml").write_text(KR5.replace("home = [90, -90, 90, 0, 90, 0]", "home = [1e20, -90, 90, 0, 90, 0]"))
    (d / "rad.toml").write_text(
        KR5.replace('angle = "deg"', 'angle = "rad"').replace("home = [90, -90, 90, 0, 90, 0]", "")
    )
    (d / "rad_alpha.toml").write_text(
        re.sub(
            r"limits = \[.*\]",
            "",
            KR5.replace('angle = "deg"', 'angle = "rad"').replace("home = [90, -90, 90, 0, 90, 0]", ""),
        )
    )
    (d / "joints_1e5.toml").write_text(robot_file(100_000))
    (d / "joints_65.toml").write_text(robot_file(65))
    (d / "origin.urdf").write_text(urdf(3, 2, origin="1e308 0 0"))
    (d / "rpy.urdf").write_text(urdf(3, 2, rpy="1e300 0 0"))
    (d / "links_1e4.urdf").write_text(urdf(10_000, 6, branch=True))
    (d / "chain_100.urdf").write_text(urdf(100, 100))
    header = b"joint,q1,q2,q3,q4,q5,q6,x,y,z\n"
    (d / "line.csv").write_bytes(header + b"1," + b"1," * 2_500_000 + b"\n")  # one line of 5 MB
    with open(d / "huge.csv", "wb") as f:  # 2 GB of one line (sparse: no disk used)
        f.write(header + b"1,0")
        f.truncate(2_000_000_000)
    (d / "columns.csv").write_text("joint," + ",".join(f"c{i}" for i in range(2000)) + "\n")
    kr5 = dv.load_robot("kr5")
    (d / "poses.csv").write_text(
        to_long_csv(dv.simulate(kr5, points_per_sweep=8, noise=2e-5, poses=True, noise_rot=1e-4), "mm", "deg")
    )
    (d / "m.csv").write_text(to_csv(dv.simulate(kr5, calibration.configurations(kr5, 30), noise=2e-5), "mm", "deg"))
    return d


CLI_CASES = [
    # sizes: typed counts
    (
        ["simulate", "kr5", "-o", "{d}/s.csv", "--points", "1000000000"],
        r"--points: 1,000,000,000 points per sweep is beyond the limit of 1,000,000 \(set DENAVIT_MAX_POINTS",
    ),
    (
        ["simulate", "kr5", "-o", "{d}/s.csv", "--points", "999999999999"],
        r"beyond the limit of 1,000,000 \(set DENAVIT_MAX_POINTS",
    ),
    (
        ["plan", "kr5", "--points", "1000000000"],
        r"--points: 1,000,000,000 points per sweep is beyond the limit .*DENAVIT_MAX_POINTS",
    ),
    (["plan", "kr5", "--points", "999999999999"], r"--points: .* is beyond the limit .*DENAVIT_MAX_POINTS"),
    (
        ["plan", "kr5", "--points", "100000"],
        r"--points: 600,000 poses \(6 sweeps x 100,000 points\) is beyond the limit of 100,000 \(set DENAVIT_MAX_POSES",
    ),
    (
        ["plan", "kr5", "--random", "1000000000"],
        r"--random: 1,000,000,000 configurations is beyond the limit of 100,000 \(set DENAVIT_MAX_POSES",
    ),
    # absurd values typed
    (
        ["plan", "kr5", "--noise", "1e300"],
        r"--noise: a noise of 1e\+300 mm \(one sigma\) is not below the robot's size, 1\d{3}\.\d+ mm",
    ),
    (
        ["simulate", "kr5", "-o", "{d}/s.csv", "--noise", "1e300"],
        r"--noise: a noise of 1e\+300 mm .*not below the robot's size",
    ),
    (
        ["simulate", "kr5", "-o", "{d}/s.csv", "--noise", "5", "--length", "m"],
        r"--noise: a noise of 5 m .*not below the robot's size, 1\.\d+ m",
    ),
    (
        ["simulate", "kr5", "-o", "{d}/s.csv", "--noise-q", "1e300"],
        r"--noise-q \(revolute joints\): .*below half a turn \(180 deg.*got 1e\+300 deg",
    ),
    (
        ["simulate", "kr5", "-o", "{d}/s.csv", "--poses", "--noise-rot", "1e300"],
        r"--noise-rot: .*below half a turn .*got 1e\+300 deg",
    ),
    (
        ["simulate", "kr5", "-o", "{d}/s.csv", "--tool", "1e308,0,0"],
        r"--tool: expected a finite length within 1e\+06 mm \(1 km",
    ),
    (
        ["simulate", "kr5", "-o", "{d}/s.csv", "--targets", "0,0,0; 2e6,0,0"],
        r"--targets \(target 2\): expected a finite length within",
    ),
    (
        ["simulate", "kr5", "-o", "{d}/s.csv", "--ranges", "0,1e300,0,1,0,1,0,1,0,1,0,1"],
        r"--ranges: joint 1: expected a finite joint value within ±36000 deg \(100 turns\), got 1e\+300 deg",
    ),
    (
        ["simulate", "kr5", "-o", "{d}/s.csv", "--home", "0,0,0,0,0,1e300"],
        r"--home: joint 6: expected a finite joint value within ±36000 deg",
    ),
    (["plan", "kr5", "--tool", "0,0,1e308"], r"--tool: expected a finite length within"),
    (
        ["ik", "kr5", "--pose", "500,0,500,1e300,0,0"],
        r"--pose: roll, pitch, yaw: expected a finite angle within ±1440 deg \(4 turns\), got 1e\+300 deg",
    ),
    (["ik", "kr5", "--pose", "1e308,0,500,0,0,0"], r"--pose: position: expected a finite length within 1e\+06 mm"),
    (["fk", "kr5", "--q", "1e20,0,0,0,0,0"], r"--q: joint 1: expected a finite joint value within ±36000 deg"),
    (
        ["fk", "kr5", "--q", "0,0,0,0,0,700", "--angle", "rad"],
        r"--q: joint 6: expected a finite joint value within ±628\.319 rad \(100 turns\), got 700 rad",
    ),
    # robot files
    (
        ["show", "{d}/d1e308.toml"],
        r"d1e308\.toml, joint 1 \(line \d+\): parameter d: expected a finite length within 1e\+06 mm .*got 1e\+308 mm",
    ),
    (
        ["show", "{d}/a2km.toml"],
        r"joint 1 \(line \d+\): parameter a: expected a finite length within 1e\+06 mm .*got 2e\+06 mm",
    ),
    (["show", "{d}/rpy.toml"], r"\[tool\]: rpy: expected a finite angle within ±1440 deg"),
    (["show", "{d}/home.toml"], r"home: expected a finite joint value within ±36000 deg"),
    (
        ["show", "{d}/rad.toml"],
        r"joint 1 \(line \d+\): limits: -155 is beyond 2 pi, yet \[units\] angle = \"rad\": degrees written\?",
    ),
    (
        ["show", "{d}/rad_alpha.toml"],
        r"joint 1 \(line \d+\): parameter alpha: -90 is beyond 2 pi, yet \[units\] angle = \"rad\": degrees written\?",
    ),
    (
        ["show", "{d}/joints_1e5.toml"],
        r"joints_1e5\.toml: 100,000 joints is beyond the limit of 64 \(set DENAVIT_MAX_JOINTS",
    ),
    (
        ["convert", "{d}/joints_65.toml", "--to", "mdh", "-o", "{d}/o.toml"],
        r"65 joints is beyond the limit of 64 \(set DENAVIT_MAX_JOINTS",
    ),
    # URDF
    (
        ["show", "{d}/origin.urdf"],
        r"origin\.urdf: joint 'j1' \(line \d+\): <origin> xyz: expected a finite length within 1000 m .*got 1e\+308 m",
    ),
    (
        ["show", "{d}/rpy.urdf"],
        (
            r"joint 'j1' \(line \d+\): <origin> rpy: expected a finite angle within ±25\.1327 rad \(4 turns\), got"
            r" 1e\+300 rad"
        ),
    ),
    (
        ["show", "{d}/links_1e4.urdf"],
        r"links_1e4\.urdf: 10,001 <link> elements is beyond the limit of 4,096 \(set DENAVIT_MAX_URDF_LINKS",
    ),
    (
        ["convert", "{d}/links_1e4.urdf", "--to", "urdf", "-o", "{d}/o.urdf"],
        r"10,001 <link> elements is beyond the limit of 4,096",
    ),
    (
        ["show", "{d}/chain_100.urdf"],
        r"the chain l0 -> l100: 100 moving joints is beyond the limit of 64 \(set DENAVIT_MAX_JOINTS",
    ),
    (
        ["calibrate", "{d}/m.csv", "--nominal", "kr5", "--noise", "1e300"],
        r"--noise: a noise of 1e\+300 mm \(one sigma\) is not below the robot's size",
    ),
    (
        ["identify", "{d}/poses.csv", "--rotation-noise", "1e300"],
        r"--rotation-noise: expected a finite angular noise >= 0 and below half a turn",
    ),
    (
        ["identify", "{d}/poses.csv", "--tracker-noise", "1e300 mm, 1 arcsec"],
        r"--tracker-noise: the range noise: expected a finite length within 1e\+06 mm",
    ),
    (
        ["identify", "{d}/poses.csv", "--tracker-noise", "5 um, 1e300 arcsec"],
        r"--tracker-noise: the angle noise: expected a finite angular noise",
    ),
    # delimited files
    (
        ["identify", "{d}/line.csv"],
        r"line\.csv: line 2 of the sweep file is longer than the limit of 4,194,304 bytes.*DENAVIT_MAX_LINE_BYTES",
    ),
    (["inspect", "{d}/line.csv"], r"line\.csv: line 2 of the recording is longer than the limit of 4,194,304 bytes"),
    (
        ["identify", "{d}/huge.csv"],
        (
            r"huge\.csv: 2,000,000,000 bytes in the sweep file is beyond the limit of 1,073,741,824 \(set"
            r" DENAVIT_MAX_FILE_BYTES"
        ),
    ),
    (["inspect", "{d}/huge.csv"], r"huge\.csv: 2,000,000,000 bytes in the recording is beyond the limit"),
    (
        ["identify", "{d}/columns.csv"],
        r"columns\.csv:1: 2,001 columns is beyond the limit of 1,000 \(set DENAVIT_MAX_COLUMNS",
    ),
]


@pytest.mark.parametrize(
    ("args", "expected"),
    CLI_CASES,
    ids=[" ".join(a.rsplit("/", 1)[-1] for a in args if a != "-o")[:60] for args, _ in CLI_CASES],
)
def test_each_limit_and_absurd_value_is_a_one_line_error(files, args, expected):
    message = refused(*(a.format(d=files) for a in args))
    assert re.search(expected, message), message


def test_limits_are_raised_by_their_environment_variables(files, monkeypatch, tmp_path):
    """Each size limit is the value of its variable when set: lower to see it bite, higher to let an input through."""
    monkeypatch.setenv("DENAVIT_MAX_POINTS", "10")
    assert "11 points per sweep is beyond the limit of 10 (set DENAVIT_MAX_POINTS" in refused(
        "simulate", "kr5", "-o", tmp_path / "s.csv", "--points", "11"
    )
    monkeypatch.setenv("DENAVIT_MAX_LINE_BYTES", "100")
    (tmp_path / "l.csv").write_text(
        "joint,q1,q2,q3,q4,q5,q6,x,y,z\n" + "1,0,0,0,0,0,0,1,2,3\n" * 3 + "1," + "0" * 200 + "\n"
    )
    assert "l.csv: line 5 of the sweep file is longer than the limit of 100 bytes" in refused(
        "identify", tmp_path / "l.csv"
    )
    monkeypatch.setenv("DENAVIT_MAX_JOINTS", "65")
    r = CliRunner().invoke(app, ["show", str(files / "joints_65.toml")])
    assert r.exit_code == 0, r.output
    monkeypatch.setenv("DENAVIT_MAX_JOINTS", "lots")
    assert "DENAVIT_MAX_JOINTS='lots': expected a positive integer" in refused("show", files / "joints_65.toml")
    monkeypatch.delenv("DENAVIT_MAX_JOINTS")


def test_plausible_values_pass(tmp_path):
    """What is plausible is not refused: a 1 mm noise, a 2 m tool, ±720 degree ranges, joint values of many turns."""
    r = CliRunner().invoke(
        app,
        [
            "simulate",
            "kr5",
            "-o",
            str(tmp_path / "s.csv"),
            "--noise",
            "1",
            "--tool",
            "0,0,2000",
            "--points",
            "5",
            "--ranges",
            "-720,720,-90,0,0,90,-720,720,0,90,-720,720",
            "--noise-q",
            "0.01",
        ],
    )
    assert r.exit_code == 0, r.output
    r = CliRunner().invoke(app, ["plan", "kr5", "--random", "200", "--noise", "0.05"])
    assert r.exit_code == 0, r.output
    r = CliRunner().invoke(
        app, ["fk", "kr5", "--q", "0,0,0,0,0,30000"]
    )  # 83 turns of A6: a warning (beyond its limits), no error
    assert r.exit_code == 0, r.output


@pytest.mark.parametrize(
    ("call", "expected"),
    [
        (
            lambda: dv.simulate("kr5", noise=1e300),
            r"simulate: noise: a noise of 1e\+300 m \(one sigma\) is not below the robot's size",
        ),
        (lambda: dv.simulate("kr5", noise_q=1e300), r"simulate: noise_q \(revolute joints\): .*below half a turn"),
        (lambda: dv.simulate("kr5", poses=True, noise_rot=1e300), r"simulate: noise_rot: .*below half a turn"),
        (
            lambda: dv.simulate("kr5", tool_point=(1e308, 0, 0)),
            r"simulate: tool_point: expected a finite length within 1000 m",
        ),
        (
            lambda: dv.simulate("kr5", points_per_sweep=10**9),
            r"points_per_sweep: 1,000,000,000 points per sweep is beyond the limit .*DENAVIT_MAX_POINTS",
        ),
        (
            lambda: dv.simulate("kr5", ranges=np.array([[0, 1e300]] + [[0, 1]] * 5)),
            r"simulate: ranges: expected a finite joint value within ±628\.319 rad",
        ),
        (lambda: dv.simulate("kr5", q=np.zeros((2, 6)), noise=1e300), r"simulate: noise: a noise of 1e\+300 m"),
        (lambda: dv.plan("kr5", noise=1e300), r"plan: noise: a noise of 1e\+300 m .*not below the robot's size"),
        (
            lambda: dv.plan("kr5", points_per_sweep=10**9),
            r"points_per_sweep: 1,000,000,000 points per sweep is beyond the limit",
        ),
        (
            lambda: dv.plan("kr5", q=np.zeros((100_001, 6))),
            r"plan: q: 100,001 configurations is beyond the limit of 100,000 \(set DENAVIT_MAX_POSES",
        ),
        (
            lambda: calibration.configurations("kr5", 10**9),
            r"configurations: count: 1,000,000,000 configurations is beyond the limit",
        ),
        (
            lambda: robotfile.from_dict(
                {
                    "convention": "dh",
                    "units": {"length": "m", "angle": "rad"},
                    "joints": [{"d": 0, "theta": 0, "a": 0, "alpha": -90}],
                }
            ),
            r"robot, joint 1: parameter alpha: -90 is beyond 2 pi, yet \[units\] angle = \"rad\": degrees written\?",
        ),
    ],
    ids=[
        "noise",
        "noise_q",
        "noise_rot",
        "tool",
        "points",
        "ranges",
        "noise at q",
        "plan noise",
        "plan points",
        "plan q",
        "configurations",
        "rad tell",
    ],
)
def test_the_python_api_refuses_them_too(call, expected):
    t = time.perf_counter()
    with pytest.raises(DenavitError, match=expected):
        call()
    assert time.perf_counter() - t < SECONDS


@pytest.mark.parametrize("dtype", ["datetime64[s]", "timedelta64[ms]"])
def test_numpy_dates_and_durations_are_not_joint_values(dtype):
    """numpy casts datetime64 / timedelta64 to float without a word (days or seconds since 1970)."""
    q = np.zeros((4, 6), dtype=dtype)
    name = "dates" if dtype.startswith("datetime") else "durations"
    for call in (
        lambda: dv.simulate("kr5", q=q),
        lambda: dv.plan("kr5", q=q),
        lambda: dv.simulate("kr5", home=q[0]),
        lambda: dv.calibrate(q, "kr5", points=np.zeros((4, 3))),
    ):
        with pytest.raises(DenavitError, match=rf"expected numbers \(rad / m\), got numpy {name}"):
            call()
    with pytest.raises(DenavitError, match=rf"got numpy {name}"):
        dv.simulate("kr5", q=np.array([[q[0, 0], 0.0, 0.0, 0.0, 0.0, 0.0]], dtype=object))


def test_registering_a_long_chain_is_linear_in_memory():
    """`convert` of a 10^4-joint URDF had allocated 60,000 x 60,000 (the full SVD of the 6n x 6 line Jacobian,
    io.urdf._register_lines): a 1,000-joint chain now takes a few MB, not the 288 MB of that U."""
    from denavit.geometry import rotvec_matrix
    from denavit.io.urdf.write import _register_lines

    n = 1000
    rng = np.random.default_rng(3)
    F = np.tile(np.eye(4), (n, 1, 1))
    F[:, :3, :3] = rotvec_matrix(rng.normal(0, 1, (n, 3)))
    F[:, :3, 3] = rng.normal(0, 1, (n, 3))
    tracemalloc.start()
    try:
        X = _register_lines(F, F, ["revolute"] * n, np.eye(4), np.eye(4))
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert np.allclose(X, np.eye(4), atol=1e-9)
    assert peak < 50e6, f"{peak / 1e6:.0f} MB"


DRIVER = """
import sys, time
from denavit.cli import main
for args in {cases!r}:
    sys.argv = ["denavit", *args]
    t = time.perf_counter()
    try:
        main()
        code = 0
    except SystemExit as e:
        code = e.code
    print(f"=== {{code}} {{time.perf_counter() - t:.2f}}", file=sys.stderr, flush=True)
"""


def _limit_memory():
    resource.setrlimit(resource.RLIMIT_AS, (4 << 30, 4 << 30))


def test_the_worst_cases_fail_fast_in_bounded_memory(files):
    """Under a 4 GiB address-space limit (ulimit -v), through main(): each worst case is exit 2 and one error line,
    within seconds (before: MemoryError after 30-40 s as exit 3, or a 44.7 GiB request)."""
    cases = [
        ["identify", f"{files}/huge.csv"],
        ["inspect", f"{files}/line.csv"],
        ["simulate", "kr5", "-o", f"{files}/s.csv", "--points", "1000000000"],
        ["plan", "kr5", "--points", "1000000000"],
        ["plan", "kr5", "--random", "1000000000"],
        ["plan", "kr5", "--points", "999999999999"],
        ["plan", "kr5", "--noise", "1e300"],
        ["simulate", "kr5", "-o", f"{files}/s.csv", "--poses", "--noise-rot", "1e300"],
        ["convert", f"{files}/links_1e4.urdf", "--to", "dh", "-o", f"{files}/o.toml"],
        ["show", f"{files}/joints_1e5.toml"],
    ]
    t = time.perf_counter()
    p = subprocess.run(
        [sys.executable, "-c", DRIVER.format(cases=cases)],
        capture_output=True,
        text=True,
        env=env(),
        preexec_fn=_limit_memory,
        timeout=120,
    )
    took = time.perf_counter() - t
    assert p.returncode == 0, p.stderr[-2000:]
    blocks = p.stderr.split("=== ")
    results = [(b.split("\n", 1)[0], b) for b in blocks[1:]]
    chunks = [blocks[0]] + [b.split("\n", 1)[1] if "\n" in b else "" for b in blocks[1:-1]]
    assert len(results) == len(cases), p.stderr[-2000:]
    for args, (status, _), out in zip(cases, results, chunks):
        code, seconds = status.split()
        lines = [ln for ln in out.splitlines() if ln.strip() and not ln.startswith("note:")]
        assert (
            code == "2" and len(lines) == 1 and lines[0].startswith("error: ") and "internal error" not in lines[0]
        ), (args, status, out)
        assert float(seconds) < SECONDS, (args, seconds)
    assert took < 60, took
