"""Real ABB RAPID and URScript programs from public repositories (tests/data/programs/README.md: repositories,
commits, licenses), read, compensated and written back as the KRL and TP ones of test_programs.py (its helpers):
a RobotStudio module on the arm it was taught on (the IRB 1200-5/0.9 of ROS-Industrial's description: no built-in
model is an ABB arm) and a PolyScope program on the built-in ur5 in UR's base frame."""

import re
from pathlib import Path

import numpy as np
import pytest
from test_programs import _without_positions, copy_program, perturbed

from denavit.io import programs as pg
from denavit.io.programs import abb
from denavit.io.robots import load
from denavit.io.urdf.read import load_urdf

DATA = Path(__file__).parent / "data" / "programs" / "real"
MODULE = DATA / "abb_robot_client" / "Module1.mod"
IRB1200 = DATA / "abb_experimental" / "irb1200_5_90.urdf"
SCRIPT = DATA / "urscript_examples" / "timing_debug.script"


def irb1200():
    return load_urdf(IRB1200)


# the program, the arm it runs on
REAL = [(MODULE, irb1200), (SCRIPT, lambda: load("ur5"))]


def test_robotstudio_confdata_is_the_irb1200_geometry():
    """The confdata RobotStudio wrote for the seven robtargets of the module (cf1, cf4, cf6 the quadrants of axes
    1, 4, 6; cfx 1 for axis 5 negative, 0 for positive: the arm in front of axis 1 and of the lower arm in all seven)
    is the configuration (denavit.io.programs.abb) of one inverse kinematics solution of each on the IRB 1200 within
    its limits, and of no solution a quadrant or a wrist flip away: an independent check of the definitions."""
    r = irb1200()
    prog = pg.read_program(MODULE, r)
    model = pg.flange_of(r).model()
    assert [p.name for p in prog.points] == [f"Target_{k}0" for k in range(1, 8)]
    assert {p.config[3] for p in prog.points} == {0, 1}
    for p in prog.points:
        Tf = pg.flange_pose(p, abb.to_pose(p.values), np.eye(3))
        sols = pg.candidates(model, Tf)
        cfs = [abb.configuration(model, q, {}) for q in sols]
        assert cfs.count(p.config) == 1, (p.name, p.config, sorted(set(cfs)))
        q = sols[cfs.index(p.config)]
        assert abs(np.degrees(q[4])) > 15  # no wrist singularity: the axis-5 bit is the taught one
        assert len(set(cfs)) >= 6  # a real choice: the other solutions have other configurations


@pytest.mark.parametrize(("path", "robot"), REAL)
def test_a_real_program_round_trips_byte_identical(path, robot, tmp_path):
    """Read and written with the nominal model as the identified one: the same bytes (RobotStudio's CRLF and its
    9-digit numbers; PolyScope's UTF-8 comments, `.120000000000` numbers without a leading zero)."""
    r = robot()
    prog = pg.read_program(path, r)
    assert len(prog.points) == (7 if path == MODULE else 2) and not prog.notes
    pc = pg.compensate_program(prog, r, r)
    assert not pc.left and sorted(pc.new_values) == list(range(len(prog.points))) and not pc.configs
    paths = pc.write(tmp_path / path.name)
    assert Path(paths[0]).read_bytes() == path.read_bytes()


def _at_a_quadrant_boundary(prog, r, k) -> bool:
    """Whether position ``k``'s nominal solution has axis 1, 4 or 6 within 1e-3 deg of a multiple of 90 deg."""
    q = np.degrees(pg.controller_joints(prog, r)[k][[0, 3, 5]])
    return bool((np.abs(q - 90 * np.round(q / 90)) < 1e-3).any())


@pytest.mark.parametrize(("path", "robot"), REAL)
def test_a_real_program_compensated_changes_only_its_positions_and_reaches_them(path, robot, tmp_path):
    """The true robot (0.5 mm / 0.05 deg errors) runs the compensated program on a nominal controller that keeps each
    position's configuration as the written file states it (RAPID: its confdata; PolyScope: the solution nearest the
    waypoint's qnear): every position within 0.1 mm RMS, >= 10x better than as written; only the position fields
    differ. The three RobotStudio positions with the tool straight down have axis 4 at -0.0000 deg (cf4 -1): their
    compensated commands cross to +0.07-0.09 deg, the same arm in quadrant 0, so their confdata is written cf4 0 (the
    only configuration field that changes, listed as rewritten) and the controller runs the commands; with cf4 left
    at -1 it would find no solution of the compensated poses."""
    r = robot()
    true = perturbed(r)
    src = copy_program(path, tmp_path)
    prog = pg.read_program(src, r)
    pc = pg.compensate_program(prog, r, true)
    assert not pc.left and sorted(pc.new_values) == list(range(len(prog.points)))
    relabelled = sorted(pc.configs)
    assert [w for w, _ in pc.relabelled] == [prog.points[k].where for k in relabelled]
    if path == MODULE:
        assert [prog.points[k].name for k in relabelled] == ["Target_50", "Target_60", "Target_70"]
        for k, (_, why) in zip(relabelled, pc.relabelled, strict=True):
            stated, written = prog.points[k].config, pc.configs[k]
            assert stated[1] == -1 and written == (stated[0], 0, stated[2], stated[3]), (stated, written)
            assert _at_a_quadrant_boundary(prog, r, k)
            assert "cf4 -1 -> 0 (axis 4 -0.0000 -> +0.0" in why and "quadrant boundary at 0 deg" in why, why
    else:
        assert not relabelled
    (tmp_path / "out").mkdir()
    paths = pc.write(tmp_path / "out" / src.name)
    # the rewrites alone carry their configurations (written without configs=, cf4 had stayed -1: a stale label)
    (tmp_path / "alone").mkdir()
    alone = pg.write_program(prog, tmp_path / "alone" / src.name, pc.new_values)
    assert Path(alone[0]).read_bytes() == Path(paths[0]).read_bytes()
    back = pg.read_program(paths[0], r)
    assert _without_positions(back, relabelled) == _without_positions(prog, relabelled)
    assert [p.config for p in back.points] == [pc.configs.get(k, p.config) for k, p in enumerate(prog.points)]
    assert Path(paths[0]).read_bytes() != src.read_bytes()
    F = prog.vendor.flange_rotation(r)
    fm, tm = pg.flange_of(r).model(), pg.flange_of(true).model()
    Q_program, Q_comp = pg.controller_joints(prog, r), pg.controller_joints(back, r)
    np.testing.assert_allclose(Q_comp, pc.compensation.q_command, atol=1e-6)  # the commands, as written
    target = pg.tool_poses(prog, fm, Q_program, F)[:, :3, 3]
    before = np.linalg.norm(pg.tool_poses(prog, tm, Q_program, F)[:, :3, 3] - target, axis=1)
    after = np.linalg.norm(pg.tool_poses(back, tm, Q_comp, F)[:, :3, 3] - target, axis=1)
    rms_before, rms_after = np.sqrt(np.mean(before**2)), np.sqrt(np.mean(after**2))
    assert rms_after < 1e-4 and rms_before > 10 * rms_after, (rms_before, rms_after)
    assert np.abs(Q_comp - Q_program).max() < np.radians(5)  # the same branches
    if relabelled:  # the positions written with the stated configuration: no solution of the compensated poses has it
        stale = pg.controller_joints(prog, r, pc.new_values)
        assert np.isnan(stale[relabelled]).all()
        assert np.isfinite(np.delete(stale, relabelled, axis=0)).all()


def test_egm_moves_give_their_positions_frames():
    """Target_60 and Target_70 are used only by EGMMoveL (EGM path correction: the EGM identity first, then MoveL's
    arguments): their tool and work object are the instruction's, as for MoveL (tool0, wobj0), not "unused"."""
    prog = pg.read_program(MODULE, irb1200())
    by = {p.name: p for p in prog.points}
    for name in ("Target_60", "Target_70"):
        assert by[name].problem is None
        np.testing.assert_array_equal(by[name].tool, np.eye(4))
        np.testing.assert_array_equal(by[name].base, np.eye(4))


def test_polyscope_waypoints_are_solved_nearest_their_qnear(tmp_path):
    """PolyScope writes a MoveJ waypoint as ``movej(get_inverse_kin(Waypoint_1_p, qnear=Waypoint_1_q), ...)``: the
    pose is the position (compensated), the joint values its configuration hint (kept). With the hint moved onto
    another branch of the same pose (elbow and wrist flipped) the controller's solution follows it."""
    r = load("ur5")
    prog = pg.read_program(SCRIPT, r)
    Q = pg.controller_joints(prog, r)
    model = pg.flange_of(r).model()
    ur = pg.vendor("urscript")
    for p, q in zip(prog.points, Q, strict=True):  # a UR5e's waypoints on the UR5: the solution nearest the hint
        sols = pg.candidates(model, pg.flange_pose(p, ur.to_pose(p.values), np.eye(3)))
        np.testing.assert_allclose(q, min(sols, key=lambda s: np.linalg.norm(s - p.extra["qnear"])), atol=1e-6)
    Tf = pg.flange_pose(prog.points[0], ur.to_pose(prog.points[0].values), np.eye(3))
    wrap = lambda d: (d + np.pi) % (2 * np.pi) - np.pi  # noqa: E731
    other = max(pg.candidates(model, Tf), key=lambda q: np.linalg.norm(wrap(q - Q[0])))
    assert (np.abs(wrap(other - Q[0]))[[2, 4]] > np.radians(90)).all()  # elbow and wrist flipped
    text = SCRIPT.read_text(encoding="utf-8")
    old = re.search(r"global Waypoint_1_q=(\[[^\]]*\])", text).group(1)
    edited = tmp_path / SCRIPT.name
    edited.write_text(text.replace(old, "[" + ", ".join(repr(float(x)) for x in other) + "]"), encoding="utf-8")
    flipped = pg.read_program(edited, r)
    np.testing.assert_allclose(pg.controller_joints(flipped, r)[0], other, atol=1e-6)
    pc = pg.compensate_program(flipped, r, perturbed(r))
    assert not pc.left
    np.testing.assert_allclose(pc.q_program[0], other, atol=1e-6)


def test_a_waypoint_with_another_tcp_is_listed_not_compensated(tmp_path):
    """``get_inverse_kin(x, qnear, tcp=...)`` solves for a TCP other than the one set: a literal equal to the active
    TCP is that TCP; another, or a computed one, is listed and the waypoint not compensated."""
    r = load("ur5")
    text = SCRIPT.read_text(encoding="utf-8")
    call = "get_inverse_kin(Waypoint_1_p, qnear=Waypoint_1_q)"
    for tcp, listed in (("p[0, 0, 0, 0, 0, 0]", False), ("p[0, 0, 0.1, 0, 0, 0]", True), ("get_tcp_offset()", True)):
        f = tmp_path / SCRIPT.name
        f.write_text(text.replace(call, call[:-1] + f", tcp={tcp})"), encoding="utf-8")
        prog = pg.read_program(f, r)
        assert [p.name for p in prog.points] == (["Waypoint_2_p"] if listed else ["Waypoint_1_p", "Waypoint_2_p"])
        assert len(prog.notes) == listed
        if listed:
            assert re.match(r".*timing_debug\.script:179: movej\(.*tcp.*not compensated", prog.notes[0])


@pytest.mark.parametrize(
    ("path", "edit", "message"),
    [
        (
            MODULE,
            lambda t: t.replace("EGMMoveL egmID1,Target_60,v10,z100,tool0", "EGMMoveL egmID1,Target_60,v10,z100,tGun"),
            r"Module1\.mod:66: tooldata tGun is not declared in the module: unsupported",
        ),
        (
            MODULE,
            lambda t: t.replace("Target_40,v1000,z100,tool0\\WObj:=wobj0", "Target_40,v1000,z100,tool0\\WObj:=wTable"),
            r"Module1\.mod:39: wobjdata wTable is not declared in the module: unsupported",
        ),
        (
            SCRIPT,
            lambda t: t.replace("set_tcp(p[0.0,0.0,0.0,0.0,0.0,0.0])", "set_tcp(get_tcp_offset())"),
            r"timing_debug\.script:22: set_tcp\(get_tcp_offset\(\)\): unsupported",
        ),
    ],
)
def test_a_frame_the_real_program_refers_to_unsupported_is_one_line_and_writes_nothing(tmp_path, path, edit, message):
    """A tool or work object the module does not declare, a TCP set from a computed pose: a one-line error naming the
    file and line (``compensate`` exit 2), nothing written."""
    from cli import run
    from denavit.io import robotfile

    src = copy_program(path, tmp_path)
    src.write_bytes(edit(src.read_bytes().decode("utf-8")).encode("utf-8"))
    if path == MODULE:
        nominal = tmp_path / "irb1200.toml"
        robotfile.save(irb1200(), nominal, "mm", "deg")
    else:
        nominal = "ur5"
    out = tmp_path / "out" / src.name
    out.parent.mkdir()
    p = run("compensate", nominal, src, "--identified", nominal, "-o", out, ok=False)
    assert p.returncode == 2 and re.search(message, p.stderr), p.stderr
    assert len(p.stderr.strip().splitlines()) == 1
    assert not any(out.parent.iterdir())


def test_cli_names_the_positions_whose_configuration_it_rewrote(tmp_path):
    """`denavit compensate irb1200.toml Module1.mod --identified true.toml -o OUT --json J`: exit 0, all seven
    compensated; the summary and the JSON name the three robtargets whose confdata was rewritten (cf4 -1 -> 0, at a
    quadrant boundary) and each row says the configuration written; the file holds it."""
    import json

    from cli import run
    from denavit.io import robotfile

    r = irb1200()
    robotfile.save(r, tmp_path / "irb1200.toml", "mm", "deg")
    robotfile.save(perturbed(r), tmp_path / "true.toml", "mm", "deg")
    src = copy_program(MODULE, tmp_path)
    out, js = tmp_path / "out.mod", tmp_path / "c.json"
    p = run(
        "compensate", tmp_path / "irb1200.toml", src, "--identified", tmp_path / "true.toml", "-o", out, "--json", js
    )
    text = " ".join(p.stdout.split())
    assert "7 positions (abb), 7 compensated (3 with their configuration rewritten), 0 left as they were" in text, text
    for line in (12, 13, 14):
        assert re.search(rf"Module1\.mod:{line}: configuration rewritten as the compensated command's, \[-?\d,0,", text)
    assert text.count("across its quadrant boundary at 0 deg") == 3
    d = json.loads(js.read_text())
    assert [x["where"].rsplit(":", 1)[1] for x in d["relabelled"]] == ["12", "13", "14"] and not d["left"]
    written = [row["configuration"]["written"] for row in d["rows"]]
    assert written[:4] == [None] * 4 and all("[-1,0,-1,0]" in w or "[0,0,0,0]" in w for w in written[4:])
    assert [p.config for p in pg.read_program(out, r).points][4:] == [(-1, 0, -1, 0), (-1, 0, -1, 0), (0, 0, 0, 0)]
