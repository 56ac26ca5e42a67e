"""Several targets per pose (SMRs on a nest) and 6-DoF poses in identify: one joint fit with shared axes, and the
tool frame's orientation identified with its sigma (issue 12, "Several targets per pose and full poses")."""

import json
import math
from types import SimpleNamespace

import numpy as np
import pytest
from real_effects import CHI2_99, NEST, axis_chi2, recordings

import denavit as dv
from cli import run
from denavit import sweeps as sw
from denavit.geometry import matrix_rotvec
from denavit.io import sweeps as swio

HOME = np.radians(sw.PAPER_HOME_DEG)
RANGES = np.radians(sw.PAPER_RANGES_DEG[90])
#: Reading errors as a real controller's (30-200 arcsec, offsets, scale errors); with and without the home drifting.
READINGS = {"reading_arcsec": (30, 200), "offset_deg": 0.05, "scale": 3e-4}
DRIFT = {**READINGS, "drift": 2e-4}


def truth_line(model, j, fit):
    """The true axis j at home as a fit with no uncertainty, its point at the foot of ``fit``'s point."""
    ax = dv.axes(model, HOME)
    c, n = np.asarray(ax.points[j]), np.asarray(ax.directions[j])
    return SimpleNamespace(point=c + n * ((fit.point - c) @ n), direction=n, cov=np.zeros((6, 6)))


def axis_error(model, j, fit) -> float:
    """Distance (m) of the true axis from the identified one, at the identified axis's point."""
    t = truth_line(model, j, fit)
    return float(np.linalg.norm(np.cross(t.point - fit.point, fit.direction)))


def rotation_chi2(res, R_true) -> float:
    e = matrix_rotvec(np.asarray(res.axes.T_world_tool)[:3, :3] @ R_true.T)
    return float(e @ np.linalg.solve(res.tool_rotation_cov, e))


def flange_at_home(model) -> np.ndarray:
    return dv.fk(model.with_tool(np.eye(4)), HOME)[:3, :3]


def test_three_targets_in_one_fit_beat_each_target_alone(kr5):
    """Three SMRs on one nest, readings 30-200 arcsec off with offsets and scale errors, 0.02 mm tracker noise: the
    shared fit (one set of axes for the three targets) has a smaller sigma on every axis than each target's own fit,
    a smaller RMS axis error than each, every axis within its sigmas of the truth (chi-square of position and
    direction across the axis, 99 %), and the tool frame's orientation from the nest within its sigma of the truth
    (before: one target only, the orientation copied from the nominal)."""
    m = kr5.model()
    recs = recordings(m, HOME, RANGES, targets=NEST[:3], seed=0, **READINGS)
    shared = dv.identify(sw.merge_targets(recs, NEST[:3]), nominal=kr5)
    singles = [dv.identify(r, nominal=kr5) for r in recs]
    assert shared.method == "global" and shared.tool_orientation == "nest"
    for j, f in enumerate(shared.fits):
        assert all(f.sigma_point_perp < s.fits[j].sigma_point_perp for s in singles), j + 1
        assert axis_chi2(f, truth_line(m, j, f))[0] < CHI2_99[4], j + 1
    rms = [math.sqrt(np.mean([axis_error(m, j, f) ** 2 for j, f in enumerate(r.fits)])) for r in (shared, *singles)]
    assert rms[0] < min(rms[1:]), rms
    assert rotation_chi2(shared, flange_at_home(m)) < CHI2_99[3]
    assert 0 < shared.tool_rotation_sigma < math.radians(0.01)
    T = dv.fk(m.with_tool(np.eye(4)), HOME)
    np.testing.assert_allclose(shared.target_points, np.array(NEST[:3]) @ T[:3, :3].T + T[:3, 3], atol=2e-4)


def test_three_targets_with_home_drift_agree_with_the_truth(kr5):
    """The same with the home drifting 0.2 mm between sweeps (the whole body moves: all targets alike): auto takes
    a home per sweep for the three targets together, and every axis and the tool orientation stay within their
    sigmas of the truth."""
    m = kr5.model()
    recs = recordings(m, HOME, RANGES, targets=NEST[:3], seed=0, **DRIFT)
    shared = dv.identify(sw.merge_targets(recs, NEST[:3]), nominal=kr5)
    assert shared.method == "readings"
    for j, f in enumerate(shared.fits):
        assert axis_chi2(f, truth_line(m, j, f))[0] < CHI2_99[4], j + 1
    assert rotation_chi2(shared, flange_at_home(m)) < CHI2_99[3]


def test_without_a_nest_the_tool_frame_is_the_targets_frame(kr5):
    """Without the nest declared, three targets give the frame of their points (x from target 1 to 2, z across the
    plane of 1-3), within its sigma of that frame built from the true points; two targets keep the nominal's, with
    a note saying why."""
    m = kr5.model()
    recs = recordings(m, HOME, RANGES, targets=NEST[:3], seed=3, **READINGS)
    res = dv.identify(sw.merge_targets(recs), nominal=kr5)
    T = dv.fk(m.with_tool(np.eye(4)), HOME)
    P = np.array(NEST[:3]) @ T[:3, :3].T + T[:3, 3]
    x = (P[1] - P[0]) / np.linalg.norm(P[1] - P[0])
    z = np.cross(x, P[2] - P[0])
    z /= np.linalg.norm(z)
    assert (
        res.tool_orientation == "targets" and rotation_chi2(res, np.column_stack([x, np.cross(z, x), z])) < CHI2_99[3]
    )
    assert any("no nest declared" in n for n in res.notes)
    two = dv.identify(sw.merge_targets(recs[:2]), nominal=kr5)
    assert (
        two.tool_orientation == "nominal"
        and two.tool_rotation_cov is None
        and any("two targets" in n for n in two.notes)
    )


def test_6dof_poses_identify_the_axes_and_the_tool_orientation(kr5):
    """6-DoF poses (position + orientation, 1e-4 rad orientation noise) with readings 30-200 arcsec off: one fit of
    points and orientations gives every axis within its sigmas of the truth and the tool frame's orientation (the
    probe's) within its sigma; the orientation noise is estimated (a variance component) within 10 %. The positions
    alone leave the orientation to the nominal."""
    m = kr5.model()
    rec = recordings(m, HOME, RANGES, poses=True, noise_rot=1e-4, seed=2, **READINGS)[0]
    assert rec.has_rotations
    res = dv.identify(rec, nominal=kr5)
    assert res.tool_orientation == "poses"
    for j, f in enumerate(res.fits):
        assert axis_chi2(f, truth_line(m, j, f))[0] < CHI2_99[4], j + 1
    assert rotation_chi2(res, flange_at_home(m)) < CHI2_99[3]
    assert 0 < res.tool_rotation_sigma < 1e-4
    points_only = dv.identify(rec.target(0), nominal=kr5)
    assert points_only.tool_orientation == "nominal" and math.isnan(points_only.tool_rotation_sigma)


def test_the_orientation_noise_is_estimated_or_declared(kr5):
    """The orientation residuals are weighted by their noise: estimated from the data (within 10 % of the simulated
    3e-4 rad), or declared (``rotation_noise``): the true value gives the estimated fit's orientation sigma (within
    20 %); a value the data contradicts (30x too small) buys no precision, the misfit inflates the sigmas."""
    import importlib

    ident = importlib.import_module("denavit.identification.prepare")
    from denavit.fitting import joint

    s = sw.simulate(
        kr5.model(), home=HOME, ranges=RANGES, points_per_sweep=25, noise=2e-5, poses=True, noise_rot=3e-4, seed=5
    )
    fits = ident._per_sweep(s, "global", "linear", None, lambda _m: None)
    starts = [(f.point, f.direction) for f in fits]
    homes, R0 = joint.start_homes(s, starts)

    def fit(**kw):
        r = joint.fit_sweeps(s, ident._motions(s, []), starts, homes[0], rotation0=R0, **kw)
        return r, math.sqrt(np.trace(r["cov_all"][-3:, -3:]))

    (est, s_est), (true, s_true), (small, s_small) = fit(), fit(rotation_sigma=3e-4), fit(rotation_sigma=1e-5)
    assert (
        est["rotation_sigma"] == pytest.approx(3e-4, rel=0.1)
        and true["rotation_sigma"] == 3e-4
        and small["rotation_sigma"] == 1e-5
    )
    assert s_true == pytest.approx(s_est, rel=0.2) and s_small > 0.5 * s_est


def test_the_joint_fit_of_several_targets_is_the_same_a_chunk_at_a_time(kr5, monkeypatch):
    """Three targets and orientations per pose: the normal equations accumulated CHUNK poses at a time give the fit of
    the whole sweep at once, and the memory stays a few hundred bytes per measured component (linear in the points)."""
    import importlib
    import tracemalloc

    ident = importlib.import_module("denavit.identification.prepare")
    from denavit.fitting import joint

    s = sw.simulate(
        kr5.model(),
        home=HOME,
        ranges=RANGES,
        points_per_sweep=1500,
        noise=2e-5,
        noise_q=2e-5,
        targets=NEST[:3],
        poses=True,
        noise_rot=1e-4,
        seed=4,
    )
    dqs = ident._motions(s, [])
    starts = [(f.point, f.direction) for f in ident._per_sweep(s, "global", "linear", None, lambda _m: None)]
    homes, R0 = joint.start_homes(s, starts)
    kw = {"offsets0": homes[1:] - homes[0], "rotation0": R0}
    tracemalloc.start()
    whole = joint.fit_sweeps(s, dqs, starts, homes[0], **kw)
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    monkeypatch.setattr(joint, "CHUNK", 333)
    parts = joint.fit_sweeps(s, dqs, starts, homes[0], **kw)
    # (the covariance entry by entry in units of its row's and column's sigmas: a cross term of round-off size, 1e-7 of
    # the sigmas' product, has no relative precision of its own)
    a, c = whole["cov_all"], parts["cov_all"]
    assert (
        np.allclose(parts["points"], whole["points"], rtol=0, atol=1e-12)
        and np.max(np.abs(c - a) / np.sqrt(np.outer(np.diag(a), np.diag(a)))) < 1e-8
    )
    assert whole["components"] == 12 and peak / (6 * 1500 * 12) < 400


def test_sweep_files_carry_targets_nest_and_orientations(tmp_path):
    """The long-form CSV writes further targets as x2, y2, z2, ..., the nest as a '# nest:' line and orientations as
    a unit quaternion per row; reading it back gives the same targets, nest and rotations."""
    m = dv.load_model("kr5")
    s = sw.simulate(
        m,
        home=HOME,
        ranges=RANGES,
        points_per_sweep=6,
        noise=2e-5,
        targets=NEST[:3],
        poses=True,
        noise_rot=1e-4,
        seed=1,
    )
    f = tmp_path / "s.csv"
    f.write_text(swio.to_long_csv(s, "mm", "deg"))
    text = f.read_text()
    assert "# nest: 50,30,100; -40,60,80; 30,-70,130" in text and "x,y,z,x2,y2,z2,x3,y3,z3,qw,qx,qy,qz" in text
    back = swio.read_long_csv(f)
    assert back.n_targets == 3 and back.has_rotations
    np.testing.assert_allclose(back.nest, np.array(NEST[:3]), atol=1e-15)
    for a, b in zip(s.sweeps, back.sweeps, strict=True):
        np.testing.assert_allclose(b.targets, a.targets, rtol=0, atol=1e-15)
        np.testing.assert_allclose(b.rotations, a.rotations, rtol=0, atol=1e-14)
    one = back.target(1)
    assert (
        one.n_targets == 1
        and not one.has_rotations
        and np.array_equal(one.sweeps[0].points, back.sweeps[0].targets[:, 1])
    )


@pytest.mark.parametrize(
    ("text", "match"),
    [
        ("# nest: 50,30,100; -40,60,80\njoint,q1,x,y,z,x2,y2,z2,x3,y3,z3\n", r"b\.csv:1: nest: expected 3 points"),
        (
            "joint,q1,x,y,z,qw,qx,qy,qz\n1,0,1,2,3,1,0,0,0\n1,1,1,2,3,0.9,0,0,0\n",
            r"b\.csv:4: quaternion norm 0\.9: expected a unit quaternion",
        ),
        ("joint,q1,x,y,z,x2,y2\n", r"missing z2"),
    ],
)
def test_bad_target_and_orientation_columns_are_one_line_errors(tmp_path, text, match):
    f = tmp_path / "b.csv"
    f.write_text(
        "# units: length=mm angle=deg\n" + text
        if not text.startswith("#")
        else text.replace("\n", "\n# units: length=mm angle=deg\n", 1)
    )
    with pytest.raises(dv.DenavitError, match=match):
        swio.read_long_csv(f)


def _same_sweeps(a, b):
    """Two sweep sets hold the same doubles (orientations: the rotations of the same quaternions)."""
    assert (a.n_joints, list(a.kinds), a.units, a.n_targets, a.has_rotations) == (
        b.n_joints,
        list(b.kinds),
        b.units,
        b.n_targets,
        b.has_rotations,
    )
    assert (
        np.array_equal(a.home, b.home)
        and (a.nest is None) == (b.nest is None)
        and (a.nest is None or np.array_equal(a.nest, b.nest))
    )
    for x, y in zip(a.sweeps, b.sweeps, strict=True):
        assert x.joint == y.joint and np.array_equal(x.points, y.points) and np.array_equal(x.q, y.q)
        assert (x.targets is None) == (y.targets is None) and (
            x.targets is None or np.array_equal(x.targets, y.targets)
        )
        assert (x.rotations is None) == (y.rotations is None) and (
            x.rotations is None or np.allclose(x.rotations, y.rotations, rtol=0, atol=1e-15)
        )


@pytest.mark.parametrize(("targets", "poses"), [(3, True), (2, False), (1, True)])
def test_sweep_json_carries_what_the_csv_carries(tmp_path, targets, poses):
    """The sweep JSON holds the long-form CSV's further targets ("targets", per pose a list of [x, y, z]), its nest
    ("nest") and its orientations ("quaternions", qw, qx, qy, qz): CSV -> JSON and JSON -> CSV give the same sweep
    set (the same doubles; the rotations to 1e-15, a quaternion computed again from its matrix), and one target of
    either file is the same set."""
    m = dv.load_model("kr5")
    s = sw.simulate(
        m,
        home=HOME,
        ranges=RANGES,
        points_per_sweep=6,
        noise=2e-5,
        targets=NEST[:targets] if targets > 1 else None,
        poses=poses,
        noise_rot=1e-4,
        seed=1,
    )
    c, j = tmp_path / "s.csv", tmp_path / "s.json"
    c.write_text(swio.to_long_csv(s, "mm", "deg"))
    from_csv = swio.read_long_csv(c)
    doc = swio.to_json(from_csv, "mm", "deg")
    j.write_text(json.dumps(doc))
    assert ("nest" in doc) == (targets > 1) and all(
        ("targets" in d) == (targets > 1) and ("quaternions" in d) == poses for d in doc["sweeps"]
    )
    from_json = swio.read_json(j)
    _same_sweeps(from_json, from_csv)
    c2 = tmp_path / "s2.csv"
    c2.write_text(swio.to_long_csv(from_json, "mm", "deg"))
    _same_sweeps(swio.read_long_csv(c2), from_json)
    for k in range(targets):
        _same_sweeps(dv.read_sweeps(j, target=k), dv.read_sweeps(c, target=k))


def _bad_sweeps_doc() -> dict:
    s = sw.simulate(
        dv.load_model("kr5"), home=HOME, ranges=RANGES, points_per_sweep=6, targets=NEST[:3], poses=True, seed=1
    )
    return swio.to_json(s, "mm", "deg")


def _edit(doc, k, key, value):
    out = json.loads(json.dumps(doc))
    if value is None:
        out["sweeps"][k].pop(key)
    else:
        out["sweeps"][k][key] = value
    return out


@pytest.mark.parametrize(
    ("change", "match"),
    [
        (
            lambda d: _edit(d, 0, "points", [[1, 2, 3]] * 6),
            r"s\.json: sweeps\[0\]: expected 'points' \(one target per pose\) or 'targets' .*got both$",
        ),
        (lambda d: _edit(d, 0, "targets", None), r"s\.json: sweeps\[0\]: expected 'points' .*got neither$"),
        (
            lambda d: _edit(d, 2, "targets", [t[:2] for t in d["sweeps"][2]["targets"]]),
            r"s\.json: sweeps\[2\]\.targets: 2 target\(s\) per pose, but sweeps\[0\] has 3: expected the same targets",
        ),
        (
            lambda d: _edit(d, 1, "targets", [t[:2] if i == 3 else t for i, t in enumerate(d["sweeps"][1]["targets"])]),
            (
                r"s\.json: sweeps\[1\]\.targets\[3\]: rows of different lengths \(2 here, 3 in the first row\):"
                r" expected a rectangular array$"
            ),
        ),
        (
            lambda d: _edit(
                d, 1, "targets", [[[1e300, 0, 0]] * 3 if i == 4 else t for i, t in enumerate(d["sweeps"][1]["targets"])]
            ),
            r"s\.json: sweeps\[1\]\.targets\[4\]\[0\]\[0\]: a coordinate of 1e\+297 m is beyond",
        ),
        (
            lambda d: _edit(d, 3, "quaternions", None),
            (
                r"s\.json: sweeps\[3\]: sweeps\[0\] has 'quaternions', sweeps\[3\] has none: expected 6-DoF poses in"
                r" every sweep or in none$"
            ),
        ),
        (
            lambda d: _edit(d, 1, "quaternions", [[0.9, 0, 0, 0]] * 6),
            (
                r"s\.json: sweeps\[1\]\.quaternions\[0\]: quaternion norm 0\.9: expected a unit quaternion \(qw, qx,"
                r" qy, qz\)$"
            ),
        ),
        (
            lambda d: _edit(d, 1, "quaternions", [[1, 0, 0]] * 6),
            r"s\.json: sweeps\[1\]\.quaternions\[0\]: expected a list of 4 numbers, got \[1, 0, 0\]$",
        ),
        (
            lambda d: _edit(d, 1, "quaternions", [[1, 0, 0, 0]] * 5),
            r"s\.json: sweeps\[1\]: quaternions must have one row per point: expected 6 rows, got 5$",
        ),
        (
            lambda d: _edit(d, 1, "quaternion", [[1, 0, 0, 0]] * 6),
            r"s\.json: sweeps\[1\]: unknown key\(s\) 'quaternion': expected joint, points, targets, q, quaternions$",
        ),
        (
            lambda d: {**d, "nest": d["nest"][:2]},
            r"s\.json: nest: expected 3 points \[x, y, z\] \(one per target of the sweeps\), got 2$",
        ),
        (
            lambda d: {**d, "nest": [[1, 2, "a"]] * 3},
            r"s\.json: nest\[0\]\[2\]: expected a number, got 'a' \(a string\)$",
        ),
    ],
)
def test_bad_targets_nest_and_quaternions_in_sweep_json_are_one_line_errors(tmp_path, change, match):
    f = tmp_path / "s.json"
    doc = _bad_sweeps_doc()
    f.write_text(json.dumps(doc))
    assert swio.read_json(f).n_targets == 3
    f.write_text(json.dumps(change(doc)))
    with pytest.raises(dv.DenavitError, match=match):
        swio.read_json(f)


def test_cli_simulates_and_identifies_several_targets_and_poses(tmp_path):
    """`denavit simulate --targets ... / --poses` writes such files; `denavit identify` fits every target at once and
    prints and writes the tool frame's orientation with its sigma; `--target 2` fits that target alone."""
    f, p = tmp_path / "t.csv", tmp_path / "p.csv"
    run(
        "simulate",
        "kr5",
        "-o",
        f,
        "--targets",
        "50,30,100; -40,60,80; 30,-70,130",
        "--noise-q",
        "0.01",
        "--points",
        "20",
    )
    out = run("identify", f, "--nominal", "kr5", "--json", tmp_path / "t.json", columns=250).stdout
    doc = json.loads((tmp_path / "t.json").read_text())
    assert (
        "Tool frame at home" in out
        and doc["tool_frame"]["orientation_from"] == "nest"
        and len(doc["targets_home_m"]) == 3
    )
    assert 0 < np.degrees(doc["tool_frame"]["sigma_rad"]) < 0.01
    R = np.array(doc["tool_frame"]["R_world_tool"])
    assert np.degrees(np.linalg.norm(matrix_rotvec(R @ flange_at_home(dv.load_model("kr5")).T))) < 5 * np.degrees(
        doc["tool_frame"]["sigma_rad"]
    )
    run("identify", f, "--nominal", "kr5", "--target", "2", "--json", tmp_path / "t2.json")
    assert json.loads((tmp_path / "t2.json").read_text())["tool_frame"]["orientation_from"] == "nominal"
    run("simulate", "kr5", "-o", p, "--poses", "--points", "20")
    run("identify", p, "--nominal", "kr5", "--json", tmp_path / "p.json")
    assert json.loads((tmp_path / "p.json").read_text())["tool_frame"]["orientation_from"] == "poses"
    bad = run("identify", f, "--nominal", "kr5", "--target", "4", ok=False)
    assert (
        bad.returncode == 2
        and "--target 4" in bad.stderr + bad.stdout
        and "3 target(s) per pose" in bad.stderr + bad.stdout
    )


def test_recordings_with_several_targets_or_poses_reach_the_shared_fit(kr5):
    """The committed recordings (tests/test_recordings.py makes them): a delimited file with three targets per row
    reaches identify with every target (one fit, the tool frame from the targets' points), ``target=`` picks one
    alone; a UR RTDE log (TCP poses) reaches it with its orientations, and the tool frame is the TCP's (the
    simulated tool frame, tilted by roll-pitch-yaw 0.1, -0.2, 0.3 rad on the flange) to the file's digits."""
    from test_recordings import DATA, tool_poses
    from test_recordings import HOME as REC_HOME
    from test_recordings import NEST as REC_NEST

    cols = "t,q1..q6,x1,y1,z1,x2,y2,z2,x3,y3,z3"
    s = dv.read_sweeps(DATA / "columns.txt", nominal=kr5, format="columns", columns=cols)
    assert (
        s.n_targets == 3
        and dv.read_sweeps(DATA / "columns.txt", nominal=kr5, format="columns", columns=cols, target=1).n_targets == 1
    )
    res = dv.identify(s, nominal=kr5)
    T = dv.fk(kr5.model().with_tool(np.eye(4)), REC_HOME)
    np.testing.assert_allclose(res.target_points, REC_NEST @ T[:3, :3].T + T[:3, 3], atol=1e-4)
    assert res.tool_orientation == "targets"
    rtde = dv.identify(DATA / "rtde.csv", nominal=kr5)
    assert rtde.sweeps.has_rotations and rtde.tool_orientation == "poses"
    R_true = tool_poses(rtde.sweeps.home[None])[0, :3, :3]
    e = matrix_rotvec(np.asarray(rtde.axes.T_world_tool)[:3, :3] @ R_true.T)
    assert np.linalg.norm(e) < 1e-7  # (noise-free poses, written to 9-10 digits)
