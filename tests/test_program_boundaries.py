"""A position on the boundary of an axis's value (ABB's quadrants, KUKA's T bits: an axis's sign) whose compensated
command crosses it: the same arm, written with the configuration the controller records for the command
(denavit.io.programs.relabelled); a shoulder, elbow or wrist-flip field changing is a branch: listed, never rewritten.
The real RobotStudio module's three such positions are in tests/test_programs_real.py."""

import re
from pathlib import Path

import numpy as np
import pytest
from test_programs import _without_positions, perturbed

import denavit as dv
from denavit.io import programs as pg
from denavit.io.programs import abb, fanuc, kuka
from denavit.io.programs.rotations import matrix_zyx
from denavit.io.robots import load

# KR5 positions in KUKA's axis senses (deg): A4 exactly 0, A6 exactly 0 (both taught on the boundary, their T bit
# clear: the axis >= 0), and the wrist centre 10 um behind A1 (the shoulder singularity, S bit 0 set).
A4_AT_0 = [28, -89, 140, 0, 83, 45]
A6_AT_0 = [62, -79, 131, -130, 97, 0]
SHOULDER_A3 = 90.0


def _behind_a1(r, offset=-1e-5):
    """KUKA axis values with the wrist centre ``offset`` (m) along the A1 frame's x (< 0: behind A1, overhead)."""
    m, sg = r.model(), kuka.signs(r)
    a = [20.0, 0.0, SHOULDER_A3, 30.0, 50.0, 20.0]

    def front(a2):
        a[1] = a2
        return pg.arm(m, np.radians(a) * sg).front - offset

    lo, hi = -150.0, -100.0
    assert front(lo) < 0 < front(hi)
    for _ in range(80):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if front(mid) < 0 else (lo, mid)
    a[1] = 0.5 * (lo + hi)
    return a


def _krl(tmp_path, r, axes, forms):
    """A KRL pair moving to E6POS positions at the KUKA axis values ``axes`` (deg), each with the S and T the
    controller records there written in ``forms`` ("binary": ``S 'B010',T 'B000010'``; "decimal": ``S 2,T 2``)."""
    fm, sg = pg.flange_of(r).model(), kuka.signs(r)
    F = np.eye(4)
    F[:3, :3] = kuka.flange_rotation(r)
    decl, moves = [], []
    for k, (a, form) in enumerate(zip(axes, forms, strict=True)):
        q = np.radians(a) * sg
        T = dv.fk(fm, q) @ F
        x = np.concatenate([T[:3, 3] * 1e3, np.degrees(matrix_zyx(T[:3, :3]))])
        s, t = kuka.configuration(fm, q, {"signs": sg})
        st = f"S 'B{s:03b}',T 'B{t:06b}'" if form == "binary" else f"S {s},T {t}"
        xyz = ",".join(f"{n} {v:.6f}" for n, v in zip("XYZABC", x, strict=True))
        decl.append(f"DECL E6POS XP{k + 1}={{{xyz},{st},E1 0.0,E2 0.0,E3 0.0,E4 0.0,E5 0.0,E6 0.0}}")
        moves.append(f"PTP XP{k + 1}")
    (tmp_path / "edge.src").write_text("\r\n".join(["DEF EDGE( )", *moves, "END", ""]))
    (tmp_path / "edge.dat").write_text("\r\n".join(["DEFDAT EDGE", *decl, "ENDDAT", ""]))
    return tmp_path / "edge.src"


def _errors(prog, back, r, true, rows):
    """(before, after) (m) of the true robot's tool at ``rows`` running ``prog`` and ``back`` on a nominal controller
    that honours each file's configuration."""
    F = prog.vendor.flange_rotation(r)
    fm, tm = pg.flange_of(r).model(), pg.flange_of(true).model()
    Qp, Qb = pg.controller_joints(prog, r)[rows], pg.controller_joints(back, r)[rows]
    from dataclasses import replace

    sub = lambda p: replace(p, points=[p.points[k] for k in rows])  # noqa: E731
    target = pg.tool_poses(sub(prog), fm, Qp, F)[:, :3, 3]
    before = np.linalg.norm(pg.tool_poses(sub(prog), tm, Qp, F)[:, :3, 3] - target, axis=1)
    after = np.linalg.norm(pg.tool_poses(sub(back), tm, Qb, F)[:, :3, 3] - target, axis=1)
    return before, after


def test_kuka_a4_and_a6_at_0_compensated_across_it_get_their_t_bit_rewritten(tmp_path):
    """E6POS positions taught at A4 = 0 and A6 = 0 (T bit clear) whose compensated commands cross to A4 -0.04 and A6
    -0.06 deg (the same arm, every axis within 0.1 deg): compensated, their T written as the controller records it
    for the command (bit 3, bit 5 set) in the position's own form (``'B001010'`` binary, ``42`` decimal), S kept, the
    change listed; only the position fields and T differ; the nominal controller honouring the written S and T runs
    the commands and the true robot's tool reaches the positions (>= 10x better than as written). Written with the
    stated T, the controller would find no solution of the compensated poses."""
    r = load("kr5")
    true = perturbed(r)
    src = _krl(tmp_path, r, [A4_AT_0, A6_AT_0], ["binary", "decimal"])
    prog = pg.read_program(src, r)
    assert [p.config for p in prog.points] == [(2, 2), (2, 10)]
    np.testing.assert_allclose(
        np.degrees(pg.controller_joints(prog, r) * kuka.signs(r)), [A4_AT_0, A6_AT_0], atol=1e-4
    )  # the program's own solutions (A4 and A6 within 1e-4 deg of 0, read on the side its T states)
    pc = pg.compensate_program(prog, r, true)
    assert not pc.left and sorted(pc.new_values) == [0, 1]
    assert pc.configs == {0: (2, 2 | 8), 1: (2, 10 | 32)}
    assert [w for w, _ in pc.relabelled] == [p.where for p in prog.points]
    # (the nominal solutions a hair either side of 0: the program's rounded numbers)
    assert re.search(r"T bit 3 0 -> 1 \(axis 4 [+-]0\.0000 -> -0\.0\d+ deg", pc.relabelled[0][1]), pc.relabelled[0][1]
    assert re.search(r"T bit 5 0 -> 1 \(axis 6 [+-]0\.0000 -> -0\.0\d+ deg", pc.relabelled[1][1]), pc.relabelled[1][1]
    assert all("sign boundary at 0 deg" in why for _, why in pc.relabelled)
    out = tmp_path / "out"
    out.mkdir()
    paths = pc.write(out / "edge.src")
    dat = Path(paths[1]).read_text()
    assert "S 'B010',T 'B001010'" in dat and "S 2,T 42" in dat, dat
    back = pg.read_program(paths[0], r)
    assert [p.config for p in back.points] == [(2, 10), (2, 42)]
    assert _without_positions(back, [0, 1]) == _without_positions(prog, [0, 1])
    for p, b in zip(prog.points, back.points, strict=True):  # S as written, T's token rewritten
        assert (
            b.config_fields[0].token == p.config_fields[0].token
            and b.config_fields[1].token != p.config_fields[1].token
        )
    Q = pg.controller_joints(back, r)
    np.testing.assert_allclose(Q, pc.compensation.q_command, atol=1e-6)
    a = np.degrees(Q * kuka.signs(r))
    assert a[0, 3] < -0.01 and a[1, 5] < -0.01  # across 0: the arm the compensation chose, not half a turn away
    before, after = _errors(prog, back, r, true, [0, 1])
    assert after.max() < 1e-5 and before.min() > 10 * after.max(), (before, after)
    stale = pg.controller_joints(prog, r, pc.new_values)  # the positions with the T the program stated
    assert np.isnan(stale).all()
    np.testing.assert_allclose(pg.controller_joints(prog, r, pc.new_values, configs=pc.configs), Q, atol=1e-6)


def test_a_shoulder_change_is_listed_not_rewritten(tmp_path):
    """A position 10 um behind A1 (S bit 0 set, the shoulder singularity): its compensated command swings A1 by about
    50 deg to the front (S bit 0 clear, T bit 0 with it). With the default branch tolerance it is a branch change;
    with a tolerance that lets it through (90 deg) the command still leaves S: a branch, listed, not rewritten,
    while the A4 = 0 position of the same program gets its T bit. The files keep the shoulder position as written."""
    r = load("kr5")
    true = perturbed(r)
    src = _krl(tmp_path, r, [A4_AT_0, _behind_a1(r)], ["binary", "binary"])
    prog = pg.read_program(src, r)
    assert prog.points[1].config[0] & 1 == 1
    pc = pg.compensate_program(prog, r, true)
    assert [w for w, _ in pc.left] == [prog.points[1].where] and "branch changed" in pc.left[0][1]
    assert sorted(pc.configs) == [0]
    wide = pg.compensate_program(prog, r, true, branch_tol=np.radians(90))
    assert wide.compensation.ok.all()
    assert [w for w, _ in wide.left] == [prog.points[1].where] and sorted(wide.configs) == [0]
    why = wide.left[0][1]
    assert "leaves the configuration S 3 ('B011')" in why and "for S 2 ('B010')" in why, why
    (tmp_path / "out").mkdir()
    back = pg.read_program(wide.write(tmp_path / "out" / "edge.src")[0], r)
    assert back.points[1].values.tolist() == prog.points[1].values.tolist()
    assert back.points[1].config == prog.points[1].config


def test_only_the_boundaries_of_an_axis_s_value_are_relabelled():
    """The vendors' rule (the configuration fields that are an axis's value, not a branch): ABB's cf1, cf4 and cf6
    (cfx kept as stated), KUKA's T bits (S and T's bits beyond 5 kept); never ABB's cfx (behind axis 1, behind the
    lower arm, axis 5's sign), KUKA's S bits 0-2 (A5 crossing 0 flips S bit 2 with T bit 4), any FANUC field."""
    assert abb.relabel((-1, -1, -1, 0), (-1, 0, -1, 0)) == (
        (-1, 0, -1, 0),
        [("cf4 -1 -> 0", 3, 0.0, "quadrant boundary")],
    )
    assert abb.relabel((1, 1, 2, 1), (2, 1, 1, 1))[1] == [
        ("cf1 1 -> 2", 0, 180.0, "quadrant boundary"),
        ("cf6 2 -> 1", 5, 180.0, "quadrant boundary"),
    ]
    for cfx in (1, 2, 4):  # axis 5's sign, the lower arm, axis 1: branches
        assert abb.relabel((-1, -1, -1, 0), (-1, 0, -1, cfx)) is None
    assert abb.relabel((0, 0, 0, 0), (0, 0, 0, 0)) is None
    assert kuka.relabel((2 | 16, 2 | 64), (2, 2 | 8)) == (
        (2 | 16, 2 | 8 | 64),
        [("T bit 3 0 -> 1", 3, 0.0, "sign boundary")],
    )
    assert kuka.relabel((2, 2), (6, 2 | 16)) is None  # A5 crossing 0: S bit 2 (the wrist flip)
    assert kuka.relabel((2, 2), (0, 2 | 4)) is None  # A3 crossing phi: S bit 1
    assert kuka.relabel((3, 2), (2, 3)) is None  # the shoulder: S bit 0
    assert fanuc.relabel(("N", "U", "T", 0, 0, 0), ("N", "U", "T", 0, 1, 0)) is None


def test_a_relabelled_configuration_keeps_its_number_form():
    """KUKA's S and T as written: binary with its quotes and at least its digits, decimal as decimal; ABB's confdata
    integers; an unchanged field keeps its token."""
    tok = lambda t: pg.Number(0, 0, len(t), t, "")  # noqa: E731
    p = pg.Point("XP1", "x:1", "pose", [], (2, 2), config_fields=[tok("'B010'"), tok("'B000010'")])
    assert kuka.config_tokens((2, 10), p) == ["'B010'", "'B001010'"]
    p.config_fields = [tok("2"), tok("35")]
    assert kuka.config_tokens((2, 34), p) == ["2", "34"]
    p.config_fields = [tok('"b10"'), tok("'B10'")]
    assert kuka.config_tokens((2, 34), p) == ['"b10"', "'B100010'"]
    p.config_fields = [tok("-1"), tok("-1"), tok("0"), tok("1")]
    assert abb.config_tokens((-1, 0, 0, 1), p) == ["-1", "0", "0", "1"]


@pytest.mark.parametrize("side", [1, -1])
def test_an_axis_within_the_resolution_of_a_boundary_is_stated_by_either_side(side):
    """A position taught at A4 = 0.000 deg solves, from its rounded numbers, a hair either side of 0: T bit 3 set or
    clear states it within pg.ON_BOUNDARY_DEG; 0.01 deg from 0 only its own side's bit does."""
    r = load("kr5")
    fm, sg, cache = pg.flange_of(r).model(), kuka.signs(r), {"signs": kuka.signs(r)}
    for a4, stated_either in ((side * 1e-5, True), (side * 1e-2, False)):
        a = np.array(A4_AT_0, dtype=float)
        a[3] = a4
        q = np.radians(a) * sg
        s, t = kuka.configuration(fm, q, cache)
        other = (s, t ^ 8)
        assert pg.states(kuka, fm, (s, t), q, cache)
        assert pg.states(kuka, fm, other, q, cache) == stated_either
        pt = pg.Point("XP1", "x:1", "pose", [], other)
        sol = pg.configuration_solution(kuka, fm, pt, dv.fk(fm, q), q, cache)
        if stated_either:
            np.testing.assert_allclose(sol, q, atol=1e-6)
        else:
            assert sol is None or np.abs(sol - q).max() > 1.0
