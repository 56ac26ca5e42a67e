"""Robot programs in controller languages (denavit.io.programs): read, compensate on their own configurations, write
back with only the positions changed; the configuration conventions against the arm's geometry; saved-file parity."""

import re
import shutil
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

import denavit as dv
from denavit import calibration as cal
from denavit import compensation as cp
from denavit.io import programs as pg
from denavit.io.programs import abb, fanuc, kuka
from denavit.io.programs.rotations import matrix_zyx, pose_matrix
from denavit.io.robots import load

DATA = Path(__file__).parent / "data" / "programs"
PROGRAMS = [
    ("kuka/kr5_demo.src", "kr5"),
    ("kuka/kr5_tool.src", "kr5"),
    ("abb/DemoKR5.mod", "kr5"),
    ("fanuc/demo_kr5.ls", "kr5"),
    ("ur/demo_ur5.script", "ur5"),
]


def perturbed(robot, seed=3):
    """``robot`` with 0.5 mm / 0.05 deg errors on every parameter of its table (uniform): the "true" robot."""
    t = robot.table
    E = np.random.default_rng(seed).uniform(-1, 1, t.params.shape) * np.where(
        np.array(t.angle_columns), np.radians(0.05), 0.5e-3
    )
    return replace(
        robot,
        table=dv.Table(t.convention, t.params + E, t.kinds, t.T_world_base, t.T_last_tool),
        name=f"{robot.name}_true",
    )


def copy_program(path: Path, to: Path) -> Path:
    """The program (and a KUKA pair's .dat, and its $config.dat) copied into ``to``."""
    for f in path.parent.glob(path.stem + ".*"):
        shutil.copy(f, to)
    if (path.parent / "$config.dat").exists():
        shutil.copy(path.parent / "$config.dat", to)
    return to / path.name


@pytest.mark.parametrize(("name", "model"), PROGRAMS)
def test_round_trip_is_byte_identical(name, model, tmp_path):
    """With the nominal model as the identified one, the written program is the program, byte for byte (the CRLF
    line endings of the KRL and RAPID files included)."""
    r = load(model)
    prog = pg.read_program(DATA / name, r)
    assert len(prog.points) >= 12
    pc = pg.compensate_program(prog, r, r)
    assert not pc.left
    paths = pg.write_program(prog, tmp_path / Path(name).name, pc.new_values)
    for p, src in zip(paths, prog.sources, strict=True):
        assert Path(p).read_bytes() == Path(src.path).read_bytes()


def _without_positions(prog, relabelled=()) -> list[str]:
    """Each file's text with its position fields cut out, and the configuration fields of the points ``relabelled``
    (indices)."""
    out = []
    for i, src in enumerate(prog.sources):
        nums = [n for p in prog.points for n in p.numbers]
        nums += [n for k in relabelled for n in prog.points[k].config_fields]
        spans = sorted((n.start, n.end) for n in nums if n.source == i)
        text, last, parts = src.text, 0, []
        for s, e in spans:
            parts.append(text[last:s])
            last = e
        parts.append(text[last:])
        out.append("\x00".join(parts))
    return out


@pytest.mark.parametrize(("name", "model"), PROGRAMS)
def test_compensation_changes_only_the_positions_and_the_true_robot_reaches_them(name, model, tmp_path):
    """A "true" robot (the model's table with 0.5 mm / 0.05 deg errors) runs the compensated program on a nominal
    controller that honours each position's configuration (its bits; URScript: the solution nearest the previous
    position): its tool reaches the program's positions within 0.1 mm RMS, >= 10x better than the program as written.
    Only the position fields differ, each number in its original form with at least its decimals."""
    r = load(model)
    true = perturbed(r)
    path = copy_program(DATA / name, tmp_path)
    prog = pg.read_program(path, r)
    pc = pg.compensate_program(prog, r, true)
    assert not pc.left and len(pc.new_values) == len(prog.points)
    out_dir = tmp_path / "out"
    out_dir.mkdir()
    if (path.parent / "$config.dat").exists():
        shutil.copy(path.parent / "$config.dat", out_dir)
    paths = pg.write_program(prog, out_dir / path.name, pc.new_values)
    back = pg.read_program(paths[0], r)
    assert _without_positions(back) == _without_positions(prog)
    for p, b in zip(prog.points, back.points, strict=True):
        assert p.config == b.config and p.name == b.name
        for n, m in zip(p.numbers, b.numbers, strict=True):
            dec = lambda t: len(t.split(".")[1].split("e")[0].split("E")[0]) if "." in t else 0  # noqa: E731
            assert dec(m.token) >= dec(n.token)
            assert (
                m.token.lstrip("-+").startswith(".") == n.token.lstrip("-+").startswith(".") or abs(float(m.token)) >= 1
            )
    Q_program = pg.controller_joints(prog, r)
    Q_comp = pg.controller_joints(back, r)
    F = prog.vendor.flange_rotation(r)
    target = pg.tool_poses(prog, r.model().with_tool(np.eye(4)), Q_program, F)
    tm = true.model().with_tool(np.eye(4))
    before = np.linalg.norm(pg.tool_poses(prog, tm, Q_program, F)[:, :3, 3] - target[:, :3, 3], axis=1)
    after = np.linalg.norm(pg.tool_poses(back, tm, Q_comp, F)[:, :3, 3] - target[:, :3, 3], axis=1)
    rms_before, rms_after = np.sqrt(np.mean(before**2)), np.sqrt(np.mean(after**2))
    assert rms_after < 1e-4 and rms_before > 10 * rms_after, (rms_before, rms_after)
    assert np.abs(Q_comp - Q_program).max() < np.radians(5)  # the same branches


def test_the_points_cover_the_workspace():
    """Each example program's positions spread over its arm's workspace: both sides of the base, heights from near
    the floor to overhead, wrists flipped and not, turns beyond +-180 deg."""
    for name, model in PROGRAMS:
        r = load(model)
        prog = pg.read_program(DATA / name, r)
        Q = pg.controller_joints(prog, r)
        P = dv.fk_batch(r.model(), Q)[:, :3, 3]
        assert np.ptp(P[:, 0]) > 0.6 and np.ptp(P[:, 1]) > 0.6 and np.ptp(P[:, 2]) > 0.4, name
        assert (Q[:, 4] > 0).any() and (Q[:, 4] < 0).any(), name
        assert (np.abs(Q[:, [3, 5]]) > np.pi).any(), name


def test_kuka_status_and_turn_follow_the_kr5_geometry():
    """KUKA's S and T on the KR5 (its A1, A4, A6 turned the other way from the model's): the home is the basic area,
    A3 above phi, A5 positive: S 'B010', T 'B000010' (A2 < 0); phi is atan(a3 / d4) = 10.95 deg; the arm over its
    shoulder sets bit 0 (the wrist centre, here the flange, behind A1 in the A1 frame); a negative A5 bit 2; the
    same pose with A6 a turn away changes T bit 5 only; every solution of a pose has its own (S, T)."""
    r = load("kr5")
    m = r.model()
    cache = {"signs": kuka.signs(r)}
    home = np.radians([0, -90, 90, 0, 90, 0])
    assert kuka.configuration(m, home, cache) == (0b010, 0b000010)
    assert np.degrees(kuka._phi(m, cache)) == pytest.approx(np.degrees(np.arctan2(0.12, 0.62)), abs=1e-6)
    below_phi = home.copy()
    below_phi[2] = np.radians(5)
    assert kuka.configuration(m, below_phi, cache)[0] == 0b000
    over = np.radians([0, -150, 20, 0, 60, 0])  # the upper arm tilted back, the wrist behind A1
    p = dv.fk(m, over)[:3, 3]
    assert p[0] < 0 and kuka.configuration(m, over, cache)[0] & 1 == 1
    flipped = home.copy()
    flipped[4] = np.radians(-60)
    assert kuka.configuration(m, flipped, cache)[0] & 4 == 4
    a = np.radians([30, -80, 100, 40, 50, 170])
    b = a.copy()
    b[5] -= 2 * np.pi  # the same pose
    np.testing.assert_allclose(dv.fk(m, a), dv.fk(m, b), atol=1e-12)
    sa, sb = kuka.configuration(m, a, cache), kuka.configuration(m, b, cache)
    assert sa[0] == sb[0] and sa[1] ^ sb[1] == 1 << 5  # model q6 = -A6: A6 -170 vs 190
    sols = pg.candidates(m, dv.fk(m, a))
    configs = [kuka.configuration(m, q, cache) for q in sols]
    assert len(sols) >= 8 and len(set(configs)) == len(configs)


def test_abb_and_fanuc_configurations_follow_the_geometry():
    """ABB's confdata: quadrants floor(angle / 90) (axis 4 at -230 deg: -3), cfx from the wrist's side of axis 1 and of
    the lower arm and axis 5's sign; FANUC's 'N U T' at the KR5's home (J5 positive in the model's sense: F), turn
    numbers beyond +-180 deg; over the shoulder B and, for ABB, cfx 4 and up. Each solution of a pose has its own."""
    r = load("kr5")
    m = r.model()
    cache = {"signs": abb.signs(r)}
    home = np.radians([0, -90, 90, 0, 90, 0])
    assert abb.configuration(m, home, cache) == (0, 0, 0, 0)
    q = np.radians([-100, -90, 90, -230, -40, 200])
    assert abb.configuration(m, q, cache)[:3] == (-2, -3, 2) and abb.configuration(m, q, cache)[3] & 1 == 1
    over = np.radians([0, -150, 20, 0, 60, 0])
    assert abb.configuration(m, over, cache)[3] >= 4
    folded = np.radians([0, -90, -10, 0, 60, 0])  # A3 below phi: the wrist behind the lower arm's line
    assert abb.configuration(m, folded, cache)[3] & 2 == 2
    assert fanuc.configuration(m, home, cache) == ("F", "U", "T", 0, 0, 0)
    assert fanuc.configuration(m, q, cache)[3:] == (0, -1, 1)
    assert fanuc.configuration(m, over, cache)[2] == "B"
    a = np.radians([30, -80, 100, 40, 50, 170])
    for v in (abb, fanuc):
        configs = [v.configuration(m, s, cache) for s in pg.candidates(m, dv.fk(m, a))]
        assert len(set(configs)) == len(configs)


def test_a_pose_only_program_states_the_configuration_it_assumed_and_configurations_keep_the_gain():
    """The issue's case: tool poses the robot reached at configurations spread over its limits. Without their
    configuration each row is compensated on the nominal's solution nearest q0 (the home) and says so (`assumed`,
    a note); a controller that keeps the program's configuration then misses. With the configuration (the joint
    values, or the KRL bits of the same poses) the gain is kept: within 0.1 mm RMS, >= 10x better."""
    r = load("kr5")
    true = perturbed(r)
    m, tm = r.model(), true.model()
    rng = np.random.default_rng(11)
    Q = []
    while len(Q) < 60:
        q = rng.uniform(m.lower, m.upper) * 0.85
        if abs(np.sin(q[4])) > 0.26 and abs(np.sin(q[2] - np.arctan2(0.12, 0.62))) > 0.26:
            Q.append(q)
    Q = np.array(Q)
    T = dv.fk_batch(m, Q)
    blind = cp.compensate(r, true, T)
    assert blind.assumed.all() and any("without a configuration" in n and "nearest q0" in n for n in blind.notes)
    near = cp.nearest_solutions(m, T, np.asarray(r.home))[0]
    np.testing.assert_allclose(blind.q_nominal, near, atol=1e-6)
    off_branch = np.abs(blind.q_nominal - Q).max(axis=1) > 0.5
    assert off_branch.mean() > 0.2

    # the controller keeps the program's configuration: the rows compensated on another branch miss
    def run(c, keep):
        sent = np.where(c.ok[:, None], c.commands.reshape(len(c), 16), T.reshape(len(c), 16)).reshape(-1, 4, 4)
        q = np.array(
            [
                pg.candidates(m, s) and min(pg.candidates(m, s), key=lambda x: np.linalg.norm(x - k))
                for s, k in zip(sent, keep, strict=True)
            ]
        )
        return np.linalg.norm(dv.fk_batch(tm, q)[:, :3, 3] - T[:, :3, 3], axis=1)

    before = np.linalg.norm(dv.fk_batch(tm, Q)[:, :3, 3] - T[:, :3, 3], axis=1)
    kept = cp.compensate(r, true, T, q_nominal=Q)
    assert not kept.assumed.any() and kept.ok.all()
    after = run(kept, Q)
    assert np.sqrt(np.mean(after**2)) < 1e-4 and np.sqrt(np.mean(before**2)) > 10 * np.sqrt(np.mean(after**2))
    after_blind = run(blind, Q)
    assert np.sqrt(np.mean(after_blind**2)) > 10 * np.sqrt(np.mean(after**2))
    # the same poses as KRL E6POS with their S and T: the bits give the program's configuration back
    cache = {"signs": kuka.signs(r)}
    F = np.eye(4)
    F[:3, :3] = kuka.flange_rotation(r)
    for q, t in zip(Q[:12], T[:12], strict=True):
        pt = pg.Point("XP", "x:1", "pose", [], kuka.configuration(m, q, cache))
        np.testing.assert_allclose(pg.configuration_solution(kuka, m, pt, t, np.asarray(r.home), cache), q, atol=1e-6)


def test_cli_compensates_a_krl_pair_and_writes_both_files(tmp_path):
    """`denavit compensate prog.src --nominal kr5 --identified true.toml -o out.src` writes out.src and out.dat; the
    summary counts the positions; an output over the input is refused."""
    from cli import run
    from denavit.io import robotfile

    r = load("kr5")
    robotfile.save(perturbed(r), tmp_path / "true.toml", "mm", "deg")
    src = copy_program(DATA / "kuka" / "kr5_demo.src", tmp_path)
    p = run("compensate", src, "--nominal", "kr5", "--identified", tmp_path / "true.toml", "-o", tmp_path / "out.src")
    assert "16 positions (kuka), 16 compensated, 0 left as they were" in p.stdout, p.stdout
    assert (tmp_path / "out.dat").read_bytes() != src.with_suffix(".dat").read_bytes()
    assert (tmp_path / "out.src").read_bytes() == src.read_bytes()  # the .src holds no position
    p = run("compensate", src, "--nominal", "kr5", "--identified", tmp_path / "true.toml", "-o", src, ok=False)
    assert p.returncode == 2 and "an output never replaces an input" in p.stderr


def _bad(tmp_path, name, edit):
    path = copy_program(DATA / name, tmp_path)
    target = path.with_suffix(".dat") if name.endswith(".src") else path
    text = target.read_bytes().decode()
    target.write_bytes(edit(text).encode())
    return path


@pytest.mark.parametrize(
    ("name", "edit", "message"),
    [
        (
            "kuka/kr5_demo.src",
            lambda t: t.replace("DECL INT SUCCESS", "DECL WIDGET W1={A 1}"),
            r"kr5_demo\.dat:9: unknown declaration type 'WIDGET'",
        ),
        (
            "kuka/kr5_demo.src",
            lambda t: re.sub(r"X [-\d.]+,Y", "X 5000.0,Y", t, count=1),
            r"kr5_demo\.dat:13: XP1: the configuration S \d+ .* is not reachable on the nominal kr5",
        ),
        (
            "kuka/kr5_demo.src",
            lambda t: t.replace("TOOL_NO 0", "TOOL_NO 3", 1),
            r"kr5_demo\.dat:14: TOOL 3 is the controller's TOOL_DATA\[3\].*unsupported",
        ),
        (
            "abb/DemoKR5.mod",
            lambda t: t.replace("tGripper\\WObj", "tOther\\WObj", 1),
            r"DemoKR5\.mod:\d+: tooldata tOther is not declared in the module: unsupported",
        ),
        (
            "abb/DemoKR5.mod",
            lambda t: t.replace("[-1,-3,1,0]", "[-1,-3,1]", 1),
            r"DemoKR5\.mod:10: robtarget p10: expected",
        ),
        (
            "fanuc/demo_kr5.ls",
            lambda t: t.replace("UT : 0", "UT : 2", 1),
            r"demo_kr5\.ls:\d+: P\[1\]: UT : 2 is the controller's tool frame 2",
        ),
        ("fanuc/demo_kr5.ls", lambda t: t.replace("/POS", "/WHAT\n/POS"), r"demo_kr5\.ls:\d+: unknown section /WHAT"),
        (
            "ur/demo_ur5.script",
            lambda t: t.replace("set_tcp(p[0.0, 0.0, 0.12, 0.0, 0.0, 0.0])", "set_tcp(pose_trans(a, b))"),
            r"demo_ur5\.script:3: set_tcp\(pose_trans",
        ),
    ],
)
def test_bad_programs_give_one_line_errors_and_write_nothing(tmp_path, name, edit, message):
    from cli import run

    path = _bad(tmp_path, name, edit)
    out = tmp_path / "out" / path.name
    out.parent.mkdir()
    p = run(
        "compensate",
        path,
        "--nominal",
        "kr5" if "ur5" not in name else "ur5",
        "--identified",
        "kr5" if "ur5" not in name else "ur5",
        "-o",
        out,
        ok=False,
    )
    assert p.returncode == 2 and re.search(message, p.stderr), p.stderr
    assert len(p.stderr.strip().splitlines()) == 1
    assert not any(out.parent.iterdir())


def test_a_missing_dat_is_one_line(tmp_path):
    from cli import run

    shutil.copy(DATA / "kuka" / "kr5_demo.src", tmp_path)
    p = run(
        "compensate",
        tmp_path / "kr5_demo.src",
        "--nominal",
        "kr5",
        "--identified",
        "kr5",
        "-o",
        tmp_path / "o.src",
        ok=False,
    )
    assert (
        p.returncode == 2
        and "kr5_demo.src:1: its data list kr5_demo.dat is missing" in p.stderr
        and not (tmp_path / "o.src").exists()
    )


def test_a_point_the_compensation_cannot_send_is_left_and_listed(tmp_path):
    """A KRL position at the wrist singularity (A5 = 0.01 deg): the identified robot reaches it only by swinging A4 and
    A6, the row is left as it was and listed with its line; the others are compensated."""
    r = load("kr5")
    path = copy_program(DATA / "kuka" / "kr5_demo.src", tmp_path)
    dat = path.with_suffix(".dat")
    text = dat.read_bytes().decode()
    text = re.sub(r"(DECL E6AXIS XP4=\{A1 [-\d.]+,A2 [-\d.]+,A3 [-\d.]+,A4 [-\d.]+,A5 )[-\d.]+", r"\g<1>0.01000", text)
    dat.write_bytes(text.encode())
    prog = pg.read_program(path, r)
    pc = pg.compensate_program(prog, r, perturbed(r))
    k = next(i for i, p in enumerate(prog.points) if p.name == "XP4")
    assert k not in pc.new_values and [w for w, _ in pc.left] == [prog.points[k].where]
    assert len(pc.new_values) == len(prog.points) - 1


SAVES = ["edh", "dh", "mdh", "poe", "urdf"]


@pytest.fixture(scope="module")
def calibration():
    kr5 = load("kr5")
    rng = np.random.default_rng(3)
    t = kr5.table
    E = rng.uniform(-1, 1, t.params.shape) * np.where(np.array(t.angle_columns), np.radians(0.05), 5e-4)
    true = dv.Table(t.convention, t.params + E, t.kinds, t.T_world_base, t.T_last_tool).to_model(
        "true", kr5.names, kr5.lower, kr5.upper
    )
    meas = cal.simulate(true, cal.configurations(kr5, 40), tool=np.array([0.0, 0.0, 0.107]), noise=2e-5, seed=2)
    return kr5, cal.calibrate(meas, kr5, tool=np.array([0.0, 0.0, 0.107]))


@pytest.mark.parametrize("save", SAVES)
def test_a_saved_calibration_compensates_as_the_in_memory_result(calibration, save, tmp_path):
    """The issue's route: calibrate with a 107 mm reflector, save, compensate against the tool-less nominal. The
    saved file (robot file in each convention, URDF) compensates as the result in memory does: commands within 1 um
    (the ED-H file had put 0.107 mm of the last link into [tool] z: 0.1 mm off), the same prediction within 1 %."""
    from denavit.io import robotfile, urdf

    kr5, c = calibration
    rng = np.random.default_rng(5)
    Q = rng.uniform(kr5.lower, kr5.upper, (40, 6)) * 0.8
    T = dv.fk_batch(kr5.model(), Q)
    mem = cp.compensate(kr5, c, T, q_nominal=Q)
    if save == "urdf":
        f = tmp_path / "cal.urdf"
        urdf.save_urdf(c.robot().model(), f, c.robot())
    else:
        f = tmp_path / f"cal_{save}.toml"
        robotfile.save(c.robot(convention=save), f, "mm", "deg")
    saved = dv.compensate(kr5, str(f), T, q_nominal=Q)  # (a path: read by the api)
    ok = mem.ok & saved.ok
    assert ok.sum() >= 36
    assert np.abs(saved.commands[ok, :3, 3] - mem.commands[ok, :3, 3]).max() < 1e-6
    assert np.abs(saved.commands[ok, :3, :3] - mem.commands[ok, :3, :3]).max() < 1e-6
    if saved.predicted_after is not None:
        np.testing.assert_allclose(saved.predicted_after[ok], mem.predicted_after[ok], rtol=0.01)


def test_a_saved_ur_kinematics_file_compensates_as_the_in_memory_result(tmp_path):
    """A UR5 calibrated with a 100 mm reflector, exported as ur_description's kinematics file (its flange the
    compensation's: compensation.flange_model) and read back as a chain on the result's base (the file holds the arm
    from its base): the same commands within 1 um."""
    from denavit.io import ur_calibration as urc

    ur5 = load("ur5")
    rng = np.random.default_rng(4)
    t = ur5.table
    E = rng.uniform(-1, 1, t.params.shape) * np.where(np.array(t.angle_columns), np.radians(0.05), 5e-4)
    E[5, 2:] = 0
    true = dv.Table(t.convention, t.params + E, t.kinds, t.T_world_base, t.T_last_tool).to_model(
        "true", ur5.names, ur5.lower, ur5.upper
    )
    c = cal.calibrate(
        cal.simulate(true, cal.configurations(ur5, 40), tool=np.array([0.0, 0.0, 0.1]), noise=2e-5, seed=2),
        ur5,
        tool=np.array([0.0, 0.0, 0.1]),
    )
    f = tmp_path / "cal.yaml"
    fm = cp.flange_model(ur5, c)
    urc.save(f, fm, t)
    origins = urc.read(f)
    pts, dirs, T = [], [], np.asarray(fm.T_world_base)
    for o in origins:
        T = T @ o
        pts.append(T[:3, 3].copy())
        dirs.append(T[:3, 2].copy())
    screws = np.array([[*d, *np.cross(p, d)] for p, d in zip(pts, dirs, strict=True)])
    yaml_model = dv.Table("poe", screws, ["revolute"] * 6, np.eye(4), T).to_model(
        "from yaml", ur5.names, ur5.lower, ur5.upper
    )
    np.testing.assert_allclose(dv.fk_batch(yaml_model, np.zeros((1, 6))), dv.fk_batch(fm, np.zeros((1, 6))), atol=1e-12)
    Q = np.random.default_rng(6).uniform(-2.5, 2.5, (30, 6))
    Tg = dv.fk_batch(ur5.model(), Q)
    mem = cp.compensate(ur5, c, Tg, q_nominal=Q)
    back = cp.compensate(ur5, yaml_model, Tg, q_nominal=Q)
    ok = mem.ok & back.ok
    assert ok.sum() >= 25
    assert np.abs(back.commands[ok, :3, 3] - mem.commands[ok, :3, 3]).max() < 1e-6


def test_krl_inline_positions_and_a_tool_assigned_in_the_src(tmp_path):
    """A .src that sets $TOOL and $BASE literally and moves to inline aggregates (an E6POS with S and T, an E6AXIS, a
    POS without S and T: nearest the previous position): read with those frames, compensated in place, the rest of
    the line kept; a true robot reaches the positions."""
    r = load("kr5")
    m = r.model().with_tool(np.eye(4))
    cache = {"signs": kuka.signs(r)}
    tool = kuka.pose_matrix(np.array([0.0, 0.0, 0.12]), kuka.zyx_matrix(0.0, np.radians(-90), 0.0))
    base = kuka.pose_matrix(np.array([0.5, 0.1, 0.0]), kuka.zyx_matrix(np.radians(30), 0.0, 0.0))
    F = np.eye(4)
    F[:3, :3] = kuka.flange_rotation(r)
    qs = np.radians([[20, -80, 100, 30, 60, -40], [-30, -100, 110, -200, -50, 100], [-20, -95, 105, -190, -45, 110]])
    lines = [
        "DEF INLINE( )",
        "$TOOL = {X 0.0,Y 0.0,Z 120.0,A 0.0,B -90.0,C 0.0}",
        "$BASE = {X 500.0,Y 100.0,Z 0.0,A 30.0,B 0.0,C 0.0}",
    ]
    for k, q in enumerate(qs):
        T = np.linalg.inv(base) @ dv.fk(m, q) @ F @ tool
        x = np.concatenate([T[:3, 3] * 1e3, np.degrees(matrix_zyx(T[:3, :3]))])
        if k == 1:
            a = np.degrees(q * kuka.signs(r))
            lines.append(
                "PTP {" + ",".join(f"A{i + 1} {v:.4f}" for i, v in enumerate(a)) + "} C_PTP ; a joint position"
            )
        elif k == 0:
            s, t = kuka.configuration(m, q, cache)
            lines.append(
                "PTP {" + ",".join(f"{n} {v:.4f}" for n, v in zip("XYZABC", x, strict=True)) + f",S {s},T {t}}}"
            )
        else:
            lines.append("LIN {" + ",".join(f"{n} {v:.4f}" for n, v in zip("XYZABC", x, strict=True)) + "} C_DIS")
    lines += ["END", ""]
    (tmp_path / "inline.src").write_text("\n".join(lines))
    (tmp_path / "inline.dat").write_text("DEFDAT INLINE\nENDDAT\n")
    prog = pg.read_program(tmp_path / "inline.src", r)
    assert [p.kind for p in prog.points] == ["pose", "joints", "pose"] and prog.points[2].config is None
    np.testing.assert_allclose(prog.points[0].tool, tool, atol=1e-12)
    np.testing.assert_allclose(prog.points[0].base, base, atol=1e-12)
    true = perturbed(r)
    pc = pg.compensate_program(prog, r, true)
    assert not pc.left
    (tmp_path / "out").mkdir()
    out = pg.write_program(prog, tmp_path / "out" / "inline.src", pc.new_values)
    back = pg.read_program(out[0], r)
    assert Path(out[0]).read_text().splitlines()[4].endswith("C_PTP ; a joint position")
    Q0, Qc = pg.controller_joints(prog, r), pg.controller_joints(back, r)
    np.testing.assert_allclose(Q0, qs, atol=1e-6)
    target = pg.tool_poses(prog, m, Q0, F[:3, :3])
    after = pg.tool_poses(back, true.model().with_tool(np.eye(4)), Qc, F[:3, :3])
    assert np.linalg.norm(after[:, :3, 3] - target[:, :3, 3], axis=1).max() < 1e-5


def test_cli_frame_gives_a_numbered_frame_of_the_controller(tmp_path):
    """A TP program taught with UT : 2 (a tool frame of the controller) is refused without it and compensated with
    --frame 'tool 2=...': with the identity, as the same program taught with UT : 0; --frame on a CSV is refused."""
    from cli import run
    from denavit.io import robotfile

    r = load("kr5")
    robotfile.save(perturbed(r), tmp_path / "true.toml", "mm", "deg")
    text = (DATA / "fanuc" / "demo_kr5.ls").read_text()
    (tmp_path / "ut0.ls").write_text(text)
    (tmp_path / "ut2.ls").write_text(text.replace("UT : 0", "UT : 2"))
    p = run(
        "compensate",
        tmp_path / "ut2.ls",
        "--nominal",
        "kr5",
        "--identified",
        tmp_path / "true.toml",
        "-o",
        tmp_path / "o2.ls",
        ok=False,
    )
    assert p.returncode == 2 and "--frame 'tool 2=X,Y,Z,W,P,R'" in p.stderr
    run(
        "compensate",
        tmp_path / "ut2.ls",
        "--nominal",
        "kr5",
        "--identified",
        tmp_path / "true.toml",
        "-o",
        tmp_path / "o2.ls",
        "--frame",
        "tool 2=0,0,0,0,0,0",
    )
    run(
        "compensate",
        tmp_path / "ut0.ls",
        "--nominal",
        "kr5",
        "--identified",
        tmp_path / "true.toml",
        "-o",
        tmp_path / "o0.ls",
    )
    assert (tmp_path / "o2.ls").read_text() == (tmp_path / "o0.ls").read_text().replace("UT : 0", "UT : 2")
    assert (tmp_path / "o0.ls").read_text() != text
    p = run(
        "compensate", tmp_path / "ut0.ls", "--nominal", "kr5", "--identified", "kr5", "--frame", "tool 2=0,0", ok=False
    )
    assert p.returncode == 2 and "--frame 'tool 2=0,0': expected" in p.stderr


def test_the_python_api_takes_a_program():
    """dv.compensate(nominal, identified, PROGRAM) reads, compensates and returns what write_program writes."""
    r = load("kr5")
    pc = dv.compensate(r, perturbed(r), str(DATA / "abb" / "DemoKR5.mod"))
    assert isinstance(pc, pg.ProgramCompensation) and len(pc.new_values) == 16 and not pc.left


# -- real programs from public sources (tests/data/programs/README.md: their repositories, commits and licenses) -----
# Each is mapped onto a built-in robot as the README says: the KRL program's one E6AXIS (A1 -156.9 deg, beyond the
# KR5's +-155) on the kr210 (A1 +-185); the TP program's UF 1 / UT 1 (frames of the controller it was taught on, not in
# the file) given as a user frame 500 mm in front of, 200 mm right of and 200 mm above the KR5's base and a 150 mm
# straight torch, which puts its weld seam in the KR5's workspace.
FANUC_FRAMES = {
    ("base", 1): pose_matrix(np.array([0.5, -0.2, 0.2]), np.eye(3)),
    ("tool", 1): pose_matrix(np.array([0.0, 0.0, 0.15]), np.eye(3)),
}
FANUC_FLAGS = ["--frame", "base 1=500,-200,200,0,0,0", "--frame", "tool 1=0,0,150,0,0,0"]
REAL = [
    ("real/kuka_experimental/ros_krlptp.src", "kr210", {}, []),
    ("real/fanuc_ls_vscode/SCHWEISS1.LS", "kr5", FANUC_FRAMES, ["P[9]"]),  # P[9]: taught, no line of /MN moves to it
]


@pytest.mark.parametrize(("name", "model", "frames", "unused"), REAL)
def test_a_real_program_round_trips_byte_identical(name, model, frames, unused, tmp_path):
    """A program from a public repository, read and written with the nominal model as the identified one: the same
    bytes (its license header, folds, tabs, the spacing of its numbers); only its unused positions are listed."""
    r = load(model)
    prog = pg.read_program(DATA / name, r, frames=frames)
    pc = pg.compensate_program(prog, r, r)
    assert [w for w, _ in pc.left] == [p.where for p in prog.points if p.name in unused]
    paths = pg.write_program(prog, tmp_path / Path(name).name, pc.new_values)
    for p, src in zip(paths, prog.sources, strict=True):
        assert Path(p).read_bytes() == Path(src.path).read_bytes()


@pytest.mark.parametrize(("name", "model", "frames", "unused"), REAL)
def test_a_real_program_compensated_changes_only_its_positions_and_reaches_them(name, model, frames, unused, tmp_path):
    """The true robot (0.5 mm / 0.05 deg errors) runs the compensated real program on a nominal controller that keeps
    each position's configuration: within 0.1 mm RMS of the positions, >= 10x better than the program as written; the
    files differ from the originals in their position fields only."""
    r = load(model)
    true = perturbed(r)
    path = copy_program(DATA / name, tmp_path)
    prog = pg.read_program(path, r, frames=frames)
    pc = pg.compensate_program(prog, r, true)
    moved = [k for k, p in enumerate(prog.points) if p.name not in unused]
    assert sorted(pc.new_values) == moved
    (tmp_path / "out").mkdir()
    paths = pg.write_program(prog, tmp_path / "out" / path.name, pc.new_values)
    back = pg.read_program(paths[0], r, frames=frames)
    assert _without_positions(back) == _without_positions(prog)
    assert any(Path(p).read_bytes() != Path(s.path).read_bytes() for p, s in zip(paths, prog.sources, strict=True))
    F = prog.vendor.flange_rotation(r)
    fm, tm = pg.flange_of(r).model(), pg.flange_of(true).model()
    Q_program, Q_comp = pg.controller_joints(prog, r)[moved], pg.controller_joints(back, r)[moved]
    pts = [prog.points[k] for k in moved]
    target = pg.tool_poses(replace(prog, points=pts), fm, Q_program, F)[:, :3, 3]
    before = np.linalg.norm(pg.tool_poses(replace(prog, points=pts), tm, Q_program, F)[:, :3, 3] - target, axis=1)
    after = np.linalg.norm(pg.tool_poses(replace(back, points=pts), tm, Q_comp, F)[:, :3, 3] - target, axis=1)
    rms_before, rms_after = np.sqrt(np.mean(before**2)), np.sqrt(np.mean(after**2))
    assert rms_after < 1e-4 and rms_before > 10 * rms_after, (rms_before, rms_after)


@pytest.mark.parametrize("save", SAVES)
def test_a_saved_calibration_compensates_a_real_program_as_the_in_memory_result(calibration, save, tmp_path):
    """The TP program from a public repository compensated from each saved format of a calibration (robot file in
    each convention, URDF) and from the result in memory: the same commands within 1 um."""
    from denavit.io import robotfile, urdf

    kr5, c = calibration
    name = DATA / REAL[1][0]
    mem = dv.compensate(kr5, c, str(name), frames=FANUC_FRAMES)
    if save == "urdf":
        f = tmp_path / "cal.urdf"
        urdf.save_urdf(c.robot().model(), f, c.robot())
    else:
        f = tmp_path / f"cal_{save}.toml"
        robotfile.save(c.robot(convention=save), f, "mm", "deg")
    saved = dv.compensate(kr5, str(f), str(name), frames=FANUC_FRAMES)
    assert sorted(mem.new_values) == sorted(saved.new_values) == [0, 1, 2, 3]
    a, b = mem.compensation, saved.compensation
    assert np.abs(a.commands[:, :3, 3] - b.commands[:, :3, 3]).max() < 1e-6
    assert np.abs(a.commands[:, :3, :3] - b.commands[:, :3, :3]).max() < 1e-6
    for k in mem.new_values:
        assert np.abs(mem.new_values[k][:3] - saved.new_values[k][:3]).max() < 1e-3  # mm


@pytest.mark.parametrize(
    ("name", "edit", "flags", "message"),
    [
        (REAL[1][0], None, [], r"SCHWEISS1\.LS:\d+: P\[1\]: UF : 1 is the controller's user frame 1"),
        (
            REAL[1][0],
            lambda t: t.replace("'N U T, 0, 0, 0'", "'N D B, 0, 0, 0'", 1),
            FANUC_FLAGS,
            r"SCHWEISS1\.LS:38: P\[1\]: the configuration 'N D B, 0, 0, 0' is not reachable on the nominal kr5",
        ),
        (
            REAL[0][0],
            lambda t: t.replace("DECL PDAT ROS_Pdat", "DECL PDATA ROS_Pdat"),
            [],
            r"ros_krlptp\.dat:9: unknown declaration type 'PDATA'",
        ),
    ],
)
def test_a_bad_real_program_gives_a_one_line_error_and_writes_nothing(tmp_path, name, edit, flags, message):
    from cli import run

    path = copy_program(DATA / name, tmp_path)
    if edit is not None:
        target = path.with_suffix(".dat") if name.endswith(".src") else path
        target.write_bytes(edit(target.read_bytes().decode()).encode())
    out = tmp_path / "out" / path.name
    out.parent.mkdir()
    model = "kr210" if name.endswith(".src") else "kr5"
    p = run("compensate", path, "--nominal", model, "--identified", model, *flags, "-o", out, ok=False)
    assert p.returncode == 2 and re.search(message, p.stderr), p.stderr
    assert len(p.stderr.strip().splitlines()) == 1
    assert not any(out.parent.iterdir())


def test_a_program_compensated_under_a_payload(tmp_path):
    """Issue 37's payload for programs: a UR5 whose joints give way under gravity (compliances of 2-4e-5 rad/N m: about
    1 mm at the tool with 5 kg) runs the URScript program compensated with the payload (5 kg, 80 mm out of the
    flange) on a nominal controller: within 0.1 mm RMS of the positions, >= 10x better than as written and >= 3x better
    than compensated for the links' own weight alone; `compensate PROGRAM --payload` writes the same program."""
    from cli import run
    from denavit.calibration.compliance import elastic
    from denavit.io import robotfile

    r = load("ur5")
    K = np.array([0.0, 2e-5, 2e-5, 4e-5, 4e-5, 4e-5])
    true = replace(perturbed(r), compliance=K)
    el = elastic(true)
    path = copy_program(DATA / "ur" / "demo_ur5.script", tmp_path)
    prog = pg.read_program(path, r)
    loaded = pg.compensate_program(prog, r, true, payload=(5.0, (0.0, 0.0, 0.08)))
    unloaded = pg.compensate_program(prog, r, true)
    assert not loaded.left and not unloaded.left
    F = prog.vendor.flange_rotation(r)
    Q_program = pg.controller_joints(prog, r)
    target = pg.tool_poses(prog, pg.flange_of(r).model(), Q_program, F)[:, :3, 3]
    pl = np.tile([5.0, 0.0, 0.0, 0.08], (len(prog.points), 1))

    def error(values):  # the readings a nominal controller sends, the true links deflected under gravity and payload
        Q = pg.controller_joints(prog, r, values)
        reached = pg.tool_poses(prog, pg.flange_of(true).model(), el.deflected(Q, pl), F)[:, :3, 3]
        return float(np.sqrt(np.mean(np.linalg.norm(reached - target, axis=1) ** 2)))

    before, after, weight_only = error(None), error(loaded.new_values), error(unloaded.new_values)
    assert after < 1e-4 and before > 10 * after and weight_only > 3 * after, (before, after, weight_only)
    robotfile.save(true, tmp_path / "true.toml", "mm", "deg")
    out = tmp_path / "out.script"
    run(
        "compensate", path, "--nominal", "ur5", "--identified", tmp_path / "true.toml", "--payload",
        "5 kg @ 0,0,80 mm", "-o", out,
    )  # fmt: skip
    back = pg.read_program(out, r)
    for k, p in enumerate(back.points):
        np.testing.assert_allclose(p.values, loaded.new_values[k], rtol=0, atol=2e-6)
