"""The command line, run as a user would (in-process, as the entry point runs it; a few as a subprocess)."""

import json
import subprocess
import sys
import time

import numpy as np
import pytest

import denavit as dv
from cli import env as cli_env
from cli import run


def test_models_lists_builtins():
    out = json.loads(run("models", "--json").stdout)
    assert {"kr5", "puma560", "ur5", "tiansui_mdh", "tiansui_edh"} <= {m["name"] for m in out}


def test_fk_json_degrees():
    doc = json.loads(run("fk", "tiansui_edh", "--q", "0,0,0,0,0,0", "--json").stdout)
    np.testing.assert_allclose(np.array(doc["T_world_tool"])[:3, 3], [0, -0.1505, 0.92], atol=1e-12)
    assert len(doc["T_world_joint"]) == 6


def test_convert_json_and_file(tmp_path):
    doc = json.loads(run("convert", "tiansui_edh", "--to", "mdh", "--json").stdout)
    assert doc["max_tool_position_error_m"] < 1e-12 and len(doc["rows"]) == 6
    out = tmp_path / "t.toml"
    run("convert", "kr5", "--to", "edh", "-o", str(out))
    assert 'convention = "edh"' in out.read_text()


def test_tables_and_messages_print_their_units_and_brackets_as_written(tmp_path):
    """Column headers carry their units ("a [mm]") and messages print bracketed text verbatim: nothing the
    tables or errors say is taken for terminal markup."""
    out = run("convert", "kr5", "--to", "mdh", "--length", "m", "--angle", "rad").stdout
    for head in ("alpha [rad]", "a [m]", "theta [rad]", "d [m]", "distance [m]", "Hayati beta [rad]", "angle [rad]"):
        assert head in out, head
    poe = run("convert", "ur5", "--to", "poe").stdout
    assert "wx [1]" in poe and "vx [mm]" in poe  # screw directions are unitless
    axes = run("identify", "--example", "kr5", "--verbose").stdout  # the joint axes: with --verbose (issue 40)
    assert "radius [mm]" in axes and "sigma dir [deg]" in axes
    bad = tmp_path / "odd [v2].toml"
    p = run("show", str(bad), ok=False)
    assert p.returncode == 2 and "odd [v2].toml" in p.stderr


def test_identify_length_flag_sets_the_output_unit_of_a_file_that_declares_its_own(tmp_path):
    """The example declares mm: --length m changes only the printed unit, not how the data are read; the
    JSON is SI either way."""
    mm, m = tmp_path / "mm.json", tmp_path / "m.json"
    a_out = run("identify", "--example", "kr5", "--convention", "dh", "--json", str(mm), "--verbose").stdout
    b_out = run(
        "identify", "--example", "kr5", "--convention", "dh", "--length", "m", "--json", str(m), "--verbose"
    ).stdout
    a, b = json.loads(mm.read_text()), json.loads(m.read_text())
    assert a["units"] == b["units"] == {"length": "m", "angle": "rad"}
    d_mm, d_m = [r["d"] for r in a["parameters"]], [r["d"] for r in b["parameters"]]
    np.testing.assert_allclose(d_m, d_mm, rtol=1e-9, atol=1e-12)
    assert abs(d_m[0] - 0.4) < 1e-3  # KR5 d1 = 400 mm (Hayat Table III)
    assert "radius [mm]" in a_out and "radius [m]" in b_out


def test_identify_in_a_tracker_frame_with_the_base_given(tmp_path):
    """Noise-free sweeps measured in a tracker frame; with --base (that frame's pose of the robot base) the DH
    table is Hayat's Table III and the JSON's base is the one given; without it the table is expressed from
    the tracker frame (d1 is then no longer 400 mm)."""
    from scipy.spatial.transform import Rotation

    from denavit import sweeps as sw
    from denavit.io import sweeps as swio

    B = np.eye(4)
    B[:3, :3] = Rotation.from_euler("xyz", [2, -3, 35], degrees=True).as_matrix()
    B[:3, 3] = [1.2, -0.4, 0.3]
    truth = dv.load_model("kr5").with_base(B)
    csv = tmp_path / "s.csv"
    csv.write_text(
        swio.to_long_csv(
            sw.simulate(
                truth,
                home=np.radians(sw.PAPER_HOME_DEG),
                ranges=np.radians(sw.PAPER_RANGES_DEG[30]),
                points_per_sweep=12,
            ),
            "mm",
            "deg",
        )
    )
    out = tmp_path / "r.json"
    run("identify", "kr5", str(csv), "--convention", "dh", "--base", "1200,-400,300,2,-3,35", "--json", str(out))
    doc = json.loads(out.read_text())
    table_iii = {
        "d": [400, 0, 0, 620, 0, 0],
        "a": [180, 600, 120, 0, 0, 0],
        "alpha": [90, 0, 90, 90, 90, 0],
        "theta": [0] * 6,
    }
    # the twists in magnitude (Table III prints no sign) and with kr5.toml's signs and A3 offset (KUKA's convention)
    signed = {
        "alpha": np.multiply([-1, 1, -1, 1, -1, 1], table_iii["alpha"]),
        "theta": np.add(table_iii["theta"], [0, 0, -90, 0, 0, 0]),
    }
    for k, v in table_iii.items():  # the JSON is SI: m, rad
        # the CSV holds 10 significant digits (1e-6 mm at 1.2 m from the tracker): 1e-4 (mm, deg) is that rounding,
        # amplified
        si = np.radians(v) if k in ("alpha", "theta") else np.array(v) * 1e-3
        got = np.array([r[k] for r in doc["parameters"]])
        tol = np.radians(1e-4) if k in ("alpha", "theta") else 1e-7
        np.testing.assert_allclose(
            np.abs(got) if k == "alpha" else got,
            si if k != "theta" else np.radians(signed["theta"]),
            atol=tol,
            err_msg=k,
        )
        if k in signed:
            np.testing.assert_allclose(got, np.radians(signed[k]), atol=tol, err_msg=k)
    T = np.array(doc["T_world_base"])
    np.testing.assert_allclose(T[:3, :3], B[:3, :3], atol=1e-12)
    np.testing.assert_allclose(T[:3, 3], B[:3, 3], atol=1e-12)
    run("identify", str(csv), "--nominal", "kr5", "--convention", "dh", "--json", str(out))
    assert abs(json.loads(out.read_text())["parameters"][0]["d"] - 0.4) > 1e-3
    p = run("identify", str(csv), "--base", "1,2,3", ok=False)
    assert p.returncode == 2 and "--base: expected 16 or 12 numbers" in p.stderr


def test_identify_example_and_json(tmp_path):
    out, nominal = tmp_path / "r.json", tmp_path / "kr5_nominal.csv"
    # the example before issue 40: the nominal kr5's own sweeps (the shipped example is now a "true" KR5's)
    run("simulate", "kr5", "-o", nominal, "--ranges", "paper90", "--points", "40", "--noise", "0.02", "--seed", "90")
    p = run("identify", "kr5", nominal, "--convention", "dh", "--json", str(out), "--verbose")
    assert "Identified DH parameters" in p.stdout and "Measuring volume" in p.stdout
    doc = json.loads(out.read_text())
    assert doc["units"] == {"length": "m", "angle": "rad"}
    assert doc["parameters"][0]["d"] == pytest.approx(0.4, abs=1e-4)


def test_simulate_then_identify(tmp_path):
    f = tmp_path / "s.csv"
    run("simulate", "kr5", "-o", str(f), "--ranges", "paper30", "--points", "12", "--noise", "0.0")
    doc = json.loads(
        run("identify", str(f), "--nominal", "kr5", "--convention", "mdh", "--json", str(tmp_path / "o.json")).stdout
        and (tmp_path / "o.json").read_text()
    )
    assert doc["convention"] == "mdh"


@pytest.mark.parametrize(
    "args, match",
    [
        (("fk", "nosuch"), "unknown model 'nosuch'"),
        (("fk", "kr5", "--q", "1,2"), "--q: expected 6 joint values for kr5, got 2"),
        (("convert", "kr5", "--to", "hayati"), "unknown convention 'hayati'"),
        (("identify", "--example", "nope"), "unknown example 'nope'"),
    ],
)
def test_errors_are_one_line_and_exit_2(args, match):
    p = run(*args, ok=False)
    assert p.returncode == 2
    assert match in " ".join(p.stderr.split())
    assert "Traceback" not in p.stderr


@pytest.mark.parametrize("args", [["--help"], ["fk", "--help"], ["identify", "--help"], ["--version"]])
def test_help_imports_neither_scipy_nor_numpy(args):
    """`denavit --help` pays for typer and rich only (issue 18: <= 0.3 s CPU, benchmarks/bench_startup.py): scipy
    (88 % of the old import time), numpy and the Python layers behind the commands (api, robot, identify,
    calibration) load when a command runs, not for its help; a command's help loads that command's module
    only, and neither the pydantic typer coerces values with nor the markdown and syntax highlighting (markdown-it,
    pygments) of typer's help formatter."""
    from denavit.cli.common import COMMANDS

    p = subprocess.run(
        [sys.executable, "-X", "importtime", "-m", "denavit.cli", *args], capture_output=True, text=True, env=cli_env()
    )
    assert p.returncode == 0, p.stderr
    mods = [ln.split("|")[-1].strip() for ln in p.stderr.splitlines() if ln.startswith("import time:")]
    heavy = [
        m
        for m in mods
        if m.split(".")[0]
        in ("scipy", "numpy", "matplotlib", "plotly", "yourdfpy", "pydantic", "markdown_it", "pygments")
        or m in ("denavit.api", "denavit.robot", "denavit.identification", "denavit.calibration", "denavit.sweeps")
    ]
    assert "denavit.cli" in mods and heavy == []
    own = [f"denavit.cli.{COMMANDS[args[0]][0]}"] if args[0] in COMMANDS else []
    shared = {f"denavit.cli.{m}" for m in ("common", "options", "console", "outputs", "values")}  # common, by concern
    assert [m for m in mods if m.startswith("denavit.cli.") and m not in shared] == own
    p = subprocess.run(
        [sys.executable, "-X", "importtime", "-c", "import denavit"], capture_output=True, text=True, env=cli_env()
    )
    assert "numpy" not in [
        ln.split("|")[-1].strip() for ln in p.stderr.splitlines() if ln.startswith("import time:")
    ]  # `import denavit`: the core only


def test_the_command_list_is_each_commands_own_summary():
    """`denavit --help` lists every command with its summary without importing the command modules
    (:data:`denavit.cli.common.COMMANDS`): the list holds every command registered, in its module, and each
    summary is the first paragraph of the command's own help; a mistyped command is still answered with the
    nearest names."""
    from typer.main import get_command

    from denavit.cli import app
    from denavit.cli.common import COMMANDS, commands

    group = get_command(app)
    built = {name: group.get_command(None, name) for name in COMMANDS}  # imports every command module
    assert sorted(COMMANDS) == sorted(i.name or i.callback.__name__ for i in commands.registered_commands)
    for name, (module, summary) in COMMANDS.items():
        assert built[name].callback.__module__ == f"denavit.cli.{module}", name
        assert built[name].help.split("\n\n")[0] == summary, name
    p = subprocess.run(
        [sys.executable, "-m", "denavit.cli", "--help"],
        capture_output=True,
        text=True,
        env={**cli_env(), "COLUMNS": "1000"},
    )
    listed = " ".join(p.stdout.split())
    assert all(f"{name} {summary}" in listed for name, (_, summary) in COMMANDS.items())
    p = run("fik", ok=False)
    assert p.returncode == 2 and "No such command 'fik'. Did you mean 'ik', 'fk'?" in p.stderr


def test_the_help_formatter_loads_markdown_and_tracebacks_on_first_use():
    """typer's help formatter is imported without rich.markdown and rich.traceback (which help in rich markup
    never uses); its Markdown and Traceback still make the real ones, imported then."""
    code = (
        "import sys; from denavit.cli.common import import_rich_utils; import_rich_utils(); import typer.rich_utils as"
        " ru; before = [m for m in ('rich.markdown', 'rich.traceback', 'pygments') if m in sys.modules]; import"
        " rich.markdown, rich.traceback; md = ru.Markdown('**x**'); print(before, type(md) is rich.markdown.Markdown,"
        " ru.Traceback.from_exception == rich.traceback.Traceback.from_exception)"
    )
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=cli_env())
    assert p.stdout.split() == ["[]", "True", "True"], p.stdout + p.stderr


def test_recordings_through_the_cli(tmp_path):
    """`denavit inspect` and `denavit identify` read instrument recordings (format from the content) and say
    what they found: the reader, the segmentation table; the identified axes land on the robot's."""
    rec = __import__("pathlib").Path(__file__).parent / "data" / "recordings"
    p = run("inspect", rec / "rtde.csv")
    assert "format rtde (detected" in p.stdout and "segmentation of" in p.stdout and "6 sweeps" in p.stdout
    out = tmp_path / "r.json"
    for f in ("rtde.csv", "rsi.xml", "ros2_mcap"):
        p = run("identify", rec / f, "--nominal", "kr5", "--json", out)
        assert "segmentation of" in p.stdout
        doc = json.loads(out.read_text())
        assert len(doc["joints"]) == 6
    p = run("identify", rec / "columns.txt", "--nominal", "kr5", "--columns", "t,q1..q6,x,y,z", ok=False)
    assert (
        p.returncode == 2
        and "columns.txt:2: expected 10 values" in p.stderr
        and len(p.stderr.strip().splitlines()) == 1
    )


def test_import_denavit_loads_no_scipy():
    """`import denavit` stays light (scipy had been 88 % of it): scipy, matplotlib, plotly, yourdfpy, lxml and
    trimesh load only in the functions that need them."""
    code = (
        "import sys, denavit; heavy = [m for m in ('scipy', 'matplotlib', 'plotly', 'yourdfpy', 'lxml', 'trimesh',"
        " 'typer', 'rich') if m in sys.modules]; print(','.join(heavy))"
    )
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=cli_env())
    assert p.returncode == 0 and p.stdout.strip() == "", p.stdout + p.stderr


def test_calibrate_from_a_log_of_poses_with_pauses(tmp_path):
    """`denavit calibrate LOG --columns ...`: a controller/tracker log of 40 random poses, 1 s pauses and 1 s
    moves at 50 Hz (0.02 mm noise): one pose per pause (median), and the calibration explains the data."""
    from denavit import calibration as cal

    kr5 = dv.load_robot("kr5")
    tool = np.eye(4)
    tool[:3, 3] = [0.05, 0.03, 0.1]
    m = kr5.model().with_tool(tool)
    poses = cal.configurations(kr5, 40) * 0.8
    rng = np.random.default_rng(4)
    rows, t = [], 0.0
    for a, b in zip(poses[:-1], poses[1:], strict=True):
        for s in np.linspace(0, 1, 50, endpoint=False):  # a pause at a, then a smooth move to b
            q = a if s < 0.5 else a + (b - a) * (1 - np.cos(np.pi * (s - 0.5) * 2)) / 2
            rows.append((t, q))
            t += 0.02
    Q = np.array([q for _, q in rows])
    P = dv.fk_batch(m, Q)[:, :3, 3] + rng.normal(0, 2e-5, (len(Q), 3))
    f = tmp_path / "log.txt"
    f.write_text(
        "# units: length=m angle=rad time=s\n"
        + "".join(
            f"{ti!r} " + " ".join(repr(float(v)) for v in (*q, *p)) + "\n" for (ti, q), p in zip(rows, P, strict=True)
        )
    )
    out = tmp_path / "c.json"
    p = run(
        "calibrate",
        f,
        "--nominal",
        "kr5",
        "--columns",
        "t,q1..q6,x,y,z",
        "--tool",
        "50,30,100",
        "--json",
        out,
        "--holdout",
        "0",
    )
    assert "poses where the robot stood still" in p.stdout
    doc = json.loads(out.read_text())
    assert doc["n_poses"] == 39  # the last pose has no pause after it: 39 pauses of 25 rows
    assert doc["residuals"]["rms_m"] < 5e-5, doc["residuals"]  # m (0.05 mm): the noise, not the motion


def test_version():
    from denavit import __version__

    assert run("--version").stdout.strip() == f"denavit {__version__}"


def test_help_keeps_the_robot_files_table_names():
    """A robot file's table named in a help text ([covariance], [couplings]) is printed, not taken for rich markup
    (the help had read "with its : compensate predicts" and "default: the robot file's .")."""
    for cmd, name in (
        ("calibrate", "[covariance]"),
        ("calibrate", "[couplings]"),
        ("identify", "[couplings]"),
        ("simulate", "[couplings]"),
    ):
        out = " ".join(run(cmd, "--help").stdout.split())
        assert name in out, (cmd, name)


def test_convert_writes_the_json_beside_the_robot_file(tmp_path):
    """`convert -o FILE --json J` writes both (the JSON had been skipped when -o was given); the JSON's rows are the
    written table's, in SI."""
    out, js = tmp_path / "k.toml", tmp_path / "k.json"
    run("convert", "kr5", "--to", "mdh", "-o", out, "--json", js)
    doc = json.loads(js.read_text())
    back = dv.load_robot(out)
    assert doc["convention"] == "mdh" and len(doc["rows"]) == 6
    np.testing.assert_allclose([r["a"] for r in doc["rows"]], np.asarray(back.table.params)[:, 1], atol=1e-9)


def test_a_missing_plot_extra_is_refused_before_any_work_with_a_command_that_works(tmp_path):
    """`identify --example kr5 --report x.html` without plotly had run the whole fit, then exited 2 advising
    `pip install 'denavit[plot]'`, which fails for a source install (issue 40): now it stops before reading anything,
    naming the option, the module and the pip command for this installation (a local folder: that folder)."""
    from denavit.plotting import install_hint

    code = (
        "import sys, importlib.abc\nclass Hide(importlib.abc.MetaPathFinder):\n    def find_spec(self, name,"
        " path=None, target=None):\n        if name.split('.')[0] in ('plotly', 'matplotlib'):\n            raise"
        " ModuleNotFoundError(name)\nsys.meta_path.insert(0, Hide())\nfrom denavit.cli import main\nsys.argv ="
        f" ['denavit', 'identify', '--example', 'kr5', '--report', {str(tmp_path / 'x.html')!r}, '--plot',"
        f" {str(tmp_path)!r}]\nmain()\n"
    )
    t0 = time.monotonic()
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=cli_env())
    assert p.returncode == 2, p.stderr
    assert time.monotonic() - t0 < 10 and "fitting" not in p.stderr and not (tmp_path / "x.html").exists()
    line = p.stderr.strip().splitlines()[-1]
    assert line == f"error: --report needs plotly, --plot needs matplotlib, which is not installed: {install_hint()}", (
        line
    )
    assert "pip install" in line and "[plot]" in line


def test_the_entry_point_end_to_end_exit_codes_and_streams():
    """`python -m denavit.cli` as a user's shell runs it (the other tests run the same entry point in-process): exit
    0 with the result on standard output and nothing on stderr, 1 for a goal not met, 2 for bad input with one
    error line on stderr and nothing on standard output."""
    from cli import run_process

    p = run_process("fk", "kr5", "--json")
    assert p.returncode == 0 and json.loads(p.stdout)["model"] == "kr5" and p.stderr == ""
    p = run_process("ik", "kr5", "--pose", "5000,0,0,0,0,0", "--restarts", "0", ok=False)
    assert p.returncode == 1 and "not solved" in p.stdout
    p = run_process("fk", "kr5", "--q", "1,2", ok=False)
    assert p.returncode == 2 and p.stdout == "" and p.stderr.startswith("error: --q: expected 6 joint values")


def test_fk_prints_the_pose_that_ik_reads_round_trip():
    """One pose format (issue 40): fk prints x,y,z and the rotation vector, ik --goal reads that line as printed,
    in mm/deg and in m/rad, and lands on the same tool pose; fk --json gives the matrix and the vector."""
    m = dv.load_model("kr5")
    q = np.radians([10, -30, 40, 20, 35, -15])
    for units, q_text, q0 in (
        ([], "10,-30,40,20,35,-15", "5,-25,35,15,30,-10"),
        (["--length", "m", "--angle", "rad"], ",".join(map(str, q.tolist())), ",".join(map(str, (q - 0.08).tolist()))),
    ):
        out = run("fk", "kr5", "--q", q_text, *units).stdout
        goal = next(ln for ln in out.splitlines() if ln.startswith("pose")).split(": ", 1)[1]
        doc = json.loads(run("ik", "kr5", "--goal", goal, "--q0", q0, "--json", *units).stdout)
        assert doc["success"]
        np.testing.assert_allclose(dv.fk(m, doc["q"]), dv.fk(m, q), atol=1e-8)
    doc = json.loads(run("fk", "kr5", "--q", "10,-30,40,20,35,-15", "--json").stdout)
    T, v = np.array(doc["T_world_tool"]), np.array(doc["pose"]["rotvec_rad"])
    theta = np.linalg.norm(v)
    k = v / theta
    K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    np.testing.assert_allclose(np.eye(3) + np.sin(theta) * K + (1 - np.cos(theta)) * K @ K, T[:3, :3], atol=1e-12)
    np.testing.assert_allclose(doc["pose"]["xyz_m"], T[:3, 3], atol=1e-15)


def test_ik_pose_is_a_deprecated_alias_read_as_roll_pitch_yaw():
    """--pose (x,y,z,roll,pitch,yaw) keeps working, with one warning line; --goal 'rpy: ...' names the convention."""
    m = dv.load_model("kr5")
    T = dv.fk(m, np.radians([10, -30, 40, 20, 35, -15]))
    from denavit.geometry import matrix_rpy

    text = ",".join(repr(float(v)) for v in [*(T[:3, 3] * 1e3), *np.degrees(matrix_rpy(T[:3, :3]))])
    old = run("ik", "kr5", "--pose", text, "--q0", "5,-25,35,15,30,-10", "--json")
    new = run("ik", "kr5", "--goal", f"rpy: {text}", "--q0", "5,-25,35,15,30,-10", "--json")
    assert old.stderr.count("warning: --pose x,y,z,roll,pitch,yaw is deprecated") == 1 and new.stderr == ""
    np.testing.assert_allclose(json.loads(old.stdout)["q"], json.loads(new.stdout)["q"], atol=1e-12)
    np.testing.assert_allclose(dv.fk(m, json.loads(new.stdout)["q"]), T, atol=1e-9)
