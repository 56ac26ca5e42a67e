"""The Python API a pinocchio or roboticstoolbox user finds by guessing (issue 17): top-level functions that take
paths, built-in names or objects; short reprs; saving that keeps the identified geometry."""

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import denavit as dv
from denavit import sweeps as sw
from denavit.io import sweeps as swio

EXAMPLE = Path(dv.__file__).parent / "data" / "kr5_90deg.csv"
HOME = np.radians(sw.PAPER_HOME_DEG)


def test_workflows_are_functions_of_the_package():
    """dv.identify & co. are functions in the namespace (dv.identify was a module: `dv.identify(...)` raised
    "'module' object is not callable"), and importing the identification package afterwards does not rebind them
    (issue 35: the package is named apart from the function, no import hook holds them apart)."""
    code = (
        "import denavit as dv, denavit.identification, denavit.calibration, denavit.compensation, denavit.sweeps\n"
        "from denavit.identification import Identification\n"
        "import types\n"
        "for f in (dv.identify, dv.calibrate, dv.plan, dv.simulate, dv.compensate, denavit.identification.identify):\n"
        "    assert isinstance(f, types.FunctionType), f\n"
        "import sys; assert isinstance(sys.modules['denavit.identification'], types.ModuleType)\n"
        "heavy = [m for m in ('scipy', 'matplotlib', 'plotly', 'yourdfpy', 'lxml', 'typer') if m in sys.modules]\n"
        "assert not heavy, heavy\n"
    )
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert p.returncode == 0, p.stderr
    for name in ("identify", "calibrate", "plan", "simulate", "compensate", "read_sweeps"):
        assert name in dv.__all__


@pytest.mark.parametrize("path", [str(EXAMPLE), EXAMPLE], ids=["str", "Path"])
def test_identify_takes_a_path_and_a_name(path):
    """Regression: dv.identify("file.csv") failed with "'str' object has no attribute 'n_joints'"."""
    res = dv.identify(path, nominal="kr5")
    ref = dv.identify(swio.read_long_csv(EXAMPLE), nominal=dv.load_robot("kr5"))
    np.testing.assert_allclose(res.table.params, ref.table.params, atol=1e-12)
    assert res.nominal.name == "kr5" and res.sweeps.source.endswith("kr5_90deg.csv")


def test_identify_takes_ur5_as_calibrate_does():
    """Regression: nominal="ur5" failed in identify (a string is not a Robot) but worked in calibrate."""
    ur5 = dv.load_robot("ur5")
    home = np.radians([0, -90, 90, -90, -90, 0])
    ranges = home[:, None] + np.radians([-30, 30])
    s = dv.simulate("ur5", home=home, ranges=ranges, points_per_sweep=12)
    for nominal in ("ur5", ur5, ur5.model()):
        res = dv.identify(s, nominal=nominal)
        m = res.model(convention="edh")
        for q in np.random.default_rng(1).uniform(-2, 2, (5, 6)):
            T = dv.fk(ur5.model().with_tool(np.eye(4)), q)
            np.testing.assert_allclose(
                dv.fk(m, q)[:3, 3], T[:3, :3] @ np.array([0.05, 0.03, 0.10]) + T[:3, 3], atol=1e-9
            )
    cal = dv.calibrate(s, "ur5")
    assert cal.rms < 1e-9


def test_identify_reads_per_joint_files_with_a_home(tmp_path):
    s = dv.simulate("kr5", home=HOME, points_per_sweep=10)
    for sweep in s.sweeps:
        (tmp_path / f"j{sweep.joint}.csv").write_text(
            "# units: length=mm\nx,y,z\n"
            + "".join(f"{x * 1e3:.17g},{y * 1e3:.17g},{z * 1e3:.17g}\n" for x, y, z in sweep.points)
        )
    res = dv.identify(tmp_path, nominal="kr5", home=HOME, length="mm")
    np.testing.assert_allclose(res.table.params, dv.identify(s, nominal="kr5").table.params, atol=1e-9)
    with pytest.raises(dv.DenavitError, match="needs home"):
        dv.identify(tmp_path, nominal="kr5")


def test_calibrate_plan_simulate_compensate_take_names_paths_and_arrays(tmp_path):
    kr5 = dv.load_robot("kr5")
    q = dv.calibration.configurations(kr5, 40)  # within the joint limits
    meas = dv.simulate("kr5", q)
    assert isinstance(meas, dv.calibration.Measurements) and meas.n == 40
    a = dv.calibrate(meas.q, "kr5", points=meas.points, holdout=0.0)
    b = dv.calibrate(EXAMPLE, kr5, holdout=0.0)
    assert a.rms < 1e-9 and b.rms < 1e-4
    p = dv.plan("kr5", noise=2e-5)
    assert p.q.shape == (180, 6)  # Hayat Table II's 30 deg protocol, 30 points per sweep
    c = dv.compensate("kr5", kr5, dv.fk_batch(kr5.model(), q[:3]))
    assert c.ok.all() and np.abs(c.before).max() < 1e-9
    positions = tmp_path / "positions.csv"
    positions.write_text(
        "# units: length=mm angle=deg\nq1,q2,q3,q4,q5,q6\n"
        + "".join(",".join(f"{v:.17g}" for v in np.degrees(row)) + "\n" for row in q[:3])
    )
    c2 = dv.compensate("kr5", kr5, positions)
    np.testing.assert_allclose(c2.q, q[:3], atol=1e-7)
    with pytest.raises(
        dv.DenavitError, match="nominal: expected a Robot, a Model, a built-in name or a robot file, got int"
    ):
        dv.calibrate(meas, 42)
    with pytest.raises(dv.DenavitError, match="no such file"):
        dv.identify(tmp_path / "missing.csv")
    with pytest.raises(dv.DenavitError, match="apply to measurements"):
        dv.simulate("kr5", measure="pose")


REPR_LIMIT = 400  # characters: a few lines


def test_reprs_are_short_and_carry_the_key_numbers():
    """Regression: repr(Identification) was 55 kB (every array of every fit)."""
    from denavit import calibration as cal
    from denavit.accuracy import identification_accuracy

    res = dv.identify(EXAMPLE, nominal="kr5")
    c = dv.calibrate(EXAMPLE, "kr5", holdout=0.2)
    p = dv.plan("kr5")
    objects = [
        (res, [f"{res.rms * 1e3:.4g} mm", "global", "240 points", "nominal kr5"]),
        (res.sweeps, ["240 points", "home [90, -90, 90, 0, 90, 0] deg"]),
        (res.sweeps.sweeps[0], ["joint 1", "40 points"]),
        (res.fits[1], [f"radius {res.fits[1].radius * 1e3:.5g} mm", "40 points"]),
        (res.nominal, ["'kr5'", "A1, A2"]),
        (res.box, [f"{res.box.lengths[0] * 1e3:.5g} x"]),
        (c, [f"rms {c.rms * 1e3:.4g} mm", "converged", "240 points"]),
        (c.validation, [f"{c.validation.after_rms * 1e3:.4g} mm"]),
        (c.identifiability, [f"rank {c.identifiability.rank} of"]),
        (p, ["180 poses", "noise 0.02 mm"]),
        (cal.Protocol.paper(30), ["6 sweeps of 30 points"]),
        (dv.simulate("kr5", np.zeros((3, 6))), ["3 points", "6 joints"]),
        (identification_accuracy(res, count=20), ["20 configurations"]),
    ]
    for obj, parts in objects:
        text = repr(obj)
        assert len(text) <= REPR_LIMIT and text.count("\n") <= 2, (type(obj).__name__, len(text), text[:200])
        for part in parts:
            assert part in text, (type(obj).__name__, part, text)


def test_reprs_of_recordings_segmentations_and_positions():
    from denavit.io.positions import Positions
    from denavit.recording import Recording, Segment, Segmentation

    n = 1000
    rec = Recording(
        np.arange(n) * 0.004,
        np.zeros((n, 6)),
        np.zeros((n, 1, 3)),
        [f"log.csv:{k + 2}" for k in range(n)],
        "log.csv",
        "rtde",
        {"length": "m"},
    )
    seg = Segmentation(
        [Segment(1, 0, 500, 0.0, 2.0, "sweep"), Segment(1, 500, 1000, 2.0, 4.0, "transit")],
        "readings",
        6,
        12,
        "log.csv",
    )
    tg = Positions(None, np.zeros((3, 6)), ["t.csv:2", "t.csv:3", "t.csv:4"], {"length": "mm", "angle": "deg"})
    for obj, parts in (
        (rec, ["1000 rows", "250 Hz", "rtde"]),
        (seg, ["1 sweeps, 2 motions", "12 dwell rows"]),
        (tg, ["3 rows of joint rows", "length=mm"]),
    ):
        text = repr(obj)
        assert len(text) <= REPR_LIMIT and "\n" not in text, text
        for part in parts:
            assert part in text, (part, text)


def test_the_identify_module_function_takes_names_and_says_what_it_reads():
    """dv.identify takes a nominal by name as calibrate does (names are read by the api: issue 35's layering), and a
    path given to the module's identify (the one dv.identify calls) gets a one-line error naming the function that
    reads files (it had failed on 'str' has no attribute 'n_joints')."""
    from denavit.identification import identify

    s = dv.simulate("kr5", points_per_sweep=8)
    assert dv.identify(s, nominal="kr5").nominal.name == "kr5"
    with pytest.raises(
        dv.DenavitError, match=r"expected a SweepSet, got str: denavit.identify\(path, nominal=...\) reads files"
    ):
        identify(str(EXAMPLE))


def test_kr5_stands_on_its_base_at_the_papers_home():
    """Regression (issue 17): with Table III's twists as printed (+90 deg) the KR5 hung 200 mm below its base at
    the paper's home. Standing, as a KR5 arc does at A2 -90, A3 90: the shoulder 400 mm above the base, the elbow
    600 mm above the shoulder, the wrist centre 800 mm in front of the A1 axis at 1120 mm (the 120 mm offset
    above the elbow; KUKA's dimensions), the flange facing down at A5 90 and along the forearm at A5 0."""
    kr5 = dv.load_robot("kr5")
    F = np.array(dv.joint_frames(kr5.model(), kr5.home))
    o = F[:, :3, 3]
    assert o[:, 2].min() >= 0
    np.testing.assert_allclose(o[[1, 2, 4], 2], [0.4, 1.0, 1.12], atol=1e-12)  # shoulder, elbow, wrist centre heights
    np.testing.assert_allclose(
        np.hypot(*o[[1, 2, 4], :2].T), [0.18, 0.18, 0.8], atol=1e-12
    )  # their distances from the A1 axis
    T = dv.fk(kr5.model(), kr5.home)
    np.testing.assert_allclose(T[:3, 2], [0, 0, -1], atol=1e-12)  # A5 90: the flange faces down
    forward = o[4, :2] / np.linalg.norm(o[4, :2])
    q = kr5.home.copy()
    q[4] = 0
    np.testing.assert_allclose(dv.fk(kr5.model(), q)[:3, 2], [*forward, 0], atol=1e-12)  # A5 0: along the forearm
    q = kr5.home.copy()
    q[1] += 1e-3  # KUKA's sense: a positive A2 tilts the upper arm forward
    assert (np.array(dv.joint_frames(kr5.model(), q))[2, :2, 3] - o[2, :2]) @ forward > 0


def _tilted_kr5(deg: float = 0.05):
    """The KR5 with every axis direction tilted by ``deg`` (about a direction across it, alternating) and the
    parallel pair A2-A3 no longer parallel: what a DH table cannot hold (a Hayati beta)."""
    kr5 = dv.load_robot("kr5")
    m = kr5.model()
    ax = dv.axes(m, HOME)
    pts, dirs = np.array(ax.points), np.array(ax.directions)
    rng = np.random.default_rng(5)
    for i in range(6):
        u = np.cross(dirs[i], rng.normal(size=3))
        u /= np.linalg.norm(u)
        d = dirs[i] * np.cos(np.radians(deg)) + u * np.sin(np.radians(deg))
        dirs[i] = d / np.linalg.norm(d)
    tilted = dv.JointAxes(
        pts,
        dirs,
        kinds=list(ax.kinds),
        q_ref=HOME,
        T_world_base=ax.T_world_base,
        T_world_tool=ax.T_world_tool,
        lower=ax.lower,
        upper=ax.upper,
    )
    return dv.extract(tilted, "edh").table.to_model("kr5 tilted", kr5.names, kr5.lower, kr5.upper)


def test_save_keeps_the_identified_geometry_and_a_dh_save_states_its_error(tmp_path):
    """Regression (issue 17): `identify --save` wrote the DH table of --convention, 0.051 mm off the identified
    geometry of a KR5 with 0.05 deg errors, and the file did not say so. The default save is the exact geometry
    (reloads within 1e-9 m); a DH save is asked for by name and its file states the error it carries."""
    truth = _tilted_kr5()
    s = sw.simulate(truth, home=HOME, ranges=np.radians(sw.PAPER_RANGES_DEG[90]), points_per_sweep=25)
    res = dv.identify(s, nominal="kr5")  # convention "dh", the default
    exact = res.model(convention="edh")
    q = np.vstack([HOME, np.random.default_rng(3).uniform(-2.5, 2.5, (200, 6))])
    dv.save(res, tmp_path / "exact.toml", length="mm")
    saved = dv.load_robot(tmp_path / "exact.toml")
    assert saved.convention == "edh"
    d = np.linalg.norm(dv.fk_batch(saved.model(), q)[:, :3, 3] - dv.fk_batch(exact, q)[:, :3, 3], axis=1)
    assert d.max() < 1e-9
    dv.save(res, tmp_path / "dh.toml", convention="dh", length="mm")
    # a robot file is TOML: another extension is refused (a .json name had received TOML without a word)
    with pytest.raises(
        dv.DenavitError,
        match=r"r.json: expected a robot file name ending in .toml \(or .urdf for a URDF\), got a .json name",
    ):
        dv.save(res, tmp_path / "r.json")
    assert not (tmp_path / "r.json").exists()
    text = (tmp_path / "dh.toml").read_text()
    lossy = dv.load_robot(tmp_path / "dh.toml")
    assert lossy.convention == "dh"
    err, count = res.carried_error("dh")
    d = np.linalg.norm(dv.fk_batch(lossy.model(), q)[:, :3, 3] - dv.fk_batch(exact, q)[:, :3, 3], axis=1)
    assert d.max() > 1e-5 and err > 1e-5  # 0.05 deg over a 1 m arm: tens of micrometres that DH cannot hold
    assert f"max tool-position deviation {err * 1e3:.3g} mm" in text and f"over {count} configurations" in text
    assert "cannot hold a near-parallel pair's tilt" in text
    assert "max tool-position deviation" in (tmp_path / "exact.toml").read_text()


def test_identify_cli_save_is_exact_unless_asked(tmp_path):
    from cli import run

    csv = tmp_path / "s.csv"
    truth = _tilted_kr5()
    csv.write_text(
        swio.to_long_csv(
            sw.simulate(truth, home=HOME, ranges=np.radians(sw.PAPER_RANGES_DEG[90]), points_per_sweep=25), "mm", "deg"
        )
    )
    run("identify", csv, "--nominal", "kr5", "--save", tmp_path / "a.toml")
    run("identify", csv, "--nominal", "kr5", "--save", tmp_path / "b.toml", "--save-convention", "dh")
    assert dv.load_robot(tmp_path / "a.toml").convention == "edh"
    assert dv.load_robot(tmp_path / "b.toml").convention == "dh"
    assert "cannot hold" in (tmp_path / "b.toml").read_text() and "exactly" in (tmp_path / "a.toml").read_text()


# Corke, Robotics, Vision and Control (2nd ed., Springer 2017), sec. 9.2.2 "Gravity term", the Puma 560 model of the
# toolbox (Corke & Armstrong-Helouvry 1994's parameters): p560.gravload(qz) and p560.gravload(qn), N m.
PUMA_GRAVLOAD = {
    "qz": ([0, 0, 0, 0, 0, 0], [0, 37.4837, 0.2489, 0, 0, 0]),
    "qn": ([0, np.pi / 4, np.pi, 0, np.pi / 4, 0], [0, 31.6399, 6.0351, 0, 0.0283, 0]),
}


@pytest.mark.parametrize("pose", sorted(PUMA_GRAVLOAD))
def test_puma560_gravity_torques_are_the_published_ones(pose):
    """Regression (issue 17): the built-in Puma 560 had no inertial parameters (dynamics printed zeros)."""
    q, tau = PUMA_GRAVLOAD[pose]
    np.testing.assert_allclose(
        dv.gravity_torques(dv.load_model("puma560"), np.array(q, dtype=float)), tau, rtol=0, atol=6e-5
    )  # 4 decimals


def _pinocchio_dh(robot):
    """A pinocchio model of a standard-DH robot built from its table and inertial parameters (frame i of the DH
    convention: Rz(theta + q) then the constant d, a, alpha part), independently of our core."""
    pin = pytest.importorskip("pinocchio")
    model = pin.Model()
    parent, placement = 0, pin.SE3.Identity()
    t = robot.table
    ins = robot.inertials
    for i, (d, theta, a, alpha) in enumerate(np.asarray(t.params)):
        jid = model.addJoint(
            parent, pin.JointModelRZ(), placement * pin.SE3(pin.utils.rotate("z", theta), np.zeros(3)), f"j{i + 1}"
        )
        link = pin.SE3(np.eye(3), np.array([0, 0, d])) * pin.SE3(
            pin.utils.rotate("x", alpha), np.array([a, 0, 0])
        )  # Tz(d), then Tx(a) Rx(alpha)
        R = link.rotation
        model.appendBodyToJoint(
            jid,
            pin.Inertia(float(ins["masses"][i]), link.act(np.asarray(ins["coms"][i])), R @ ins["inertias"][i] @ R.T),
            pin.SE3.Identity(),
        )
        parent, placement = jid, link
    return pin, model


@pytest.mark.parametrize("name", ["puma560", "ur5"])
def test_builtin_dynamics_match_pinocchio_on_the_same_parameters(name):
    robot = dv.load_robot(name)
    assert robot.inertials is not None and robot.inertials["masses"].sum() > 1.0
    pin, model = _pinocchio_dh(robot)
    data = model.createData()
    m = robot.model()
    rng = np.random.default_rng(7)
    for _ in range(5):
        q, qd, qdd = rng.uniform(-2, 2, (3, 6))
        np.testing.assert_allclose(dv.rnea(m, q, qd, qdd), pin.rnea(model, data, q, qd, qdd), rtol=1e-9, atol=1e-9)
        M = pin.crba(model, data, q)
        np.testing.assert_allclose(
            dv.mass_matrix(m, q), np.triu(M) + np.triu(M, 1).T, rtol=1e-9, atol=1e-9
        )  # pinocchio fills the upper triangle


@pytest.mark.parametrize(
    "kw", [{"noise": float("nan")}, {"noise": -1e-5}, {"noise_q": float("inf")}, {"noise_rot": -0.1}]
)
def test_simulate_refuses_a_sigma_that_is_not_one(kw):
    """A NaN or negative sigma is an error (it had given noise-free data without a word; the CLI refused it)."""
    name = next(iter(kw))
    with pytest.raises(
        dv.DenavitError, match=rf"^simulate: {name} must be a finite sigma >= 0 in .*, got {kw[name]!r}$"
    ):
        dv.simulate("kr5", **kw)


def test_an_edh_save_that_drops_a_tilt_does_not_claim_exactness(tmp_path):
    """The audit's KR5 with 0.02 mm point noise: the ED-H save's header said 'The identified geometry, exactly' while
    its own carried-error line said 0.0156 mm (the A2-A3 tilt within 3 sigma dropped against the nominal), and a DH
    run's note said '(ED-H is exact)'. Now the ED-H header and the notes name the dropped tilt; the POE save, which
    carries round-off, is the one that says 'exactly'."""
    s = dv.simulate("kr5", noise=2e-5, seed=0)
    res = dv.identify(s, nominal="kr5", convention="edh")
    err = res.carried_error()[0]
    assert err > 1e-6  # a tilt within the noise, dropped: micrometres, not round-off
    dv.save(res, tmp_path / "edh.toml", length="mm")
    head = (tmp_path / "edh.toml").read_text().splitlines()[:2]
    assert head[0].startswith(
        "# The identified geometry, exactly except the tilt of a pair of axes the nominal has parallel"
    ), head[0]
    assert f"max tool-position deviation {err * 1e3:.3g} mm" in head[1]
    assert any("edh table carries a tool-position error" in n and "exact except the tilt" in n for n in res.notes), (
        res.notes
    )
    dv.save(res, tmp_path / "poe.toml", convention="poe", length="mm")
    assert dv.load_robot(tmp_path / "poe.toml").convention == "poe"
    assert res.carried_error("poe")[0] < 1e-9
    assert (tmp_path / "poe.toml").read_text().startswith("# The identified geometry, exactly (its poe table")
    dh = dv.identify(s, nominal="kr5", convention="dh")
    assert not any("ED-H is exact" in n for n in dh.notes), dh.notes
    assert any("POE is exact; ED-H carries" in n for n in dh.notes), dh.notes


def test_simulate_poses_with_the_default_tool_point_and_none():
    """dv.simulate(measure="pose") with its default tool point had failed ("invalid T_flange_tool: expected (4, 4),
    got (3,)") and tool_point=None had let a numpy error escape (issue 40): a point is a frame there with the
    flange's axes, None is the flange; the positions equal FK's."""
    m = dv.load_model("kr5")
    q = np.random.default_rng(1).uniform(-1, 1, (4, 6))
    p = dv.simulate("kr5", q=q, measure="pose").poses
    T = dv.fk_batch(m, q)
    np.testing.assert_allclose(p[:, :3, 3], T[:, :3, :3] @ np.array([0.05, 0.03, 0.10]) + T[:, :3, 3], atol=1e-15)
    np.testing.assert_allclose(p[:, :3, :3], T[:, :3, :3], atol=1e-15)
    np.testing.assert_allclose(dv.simulate("kr5", q=q, measure="pose", tool_point=None).poses, T, atol=1e-15)
    np.testing.assert_allclose(dv.simulate("kr5", q=q, tool_point=None).points, T[:, :3, 3], atol=1e-15)
    with pytest.raises(
        dv.DenavitError,
        match=(
            r"^simulate: tool: expected a point \(3,\) in the flange frame, a pose \(4, 4\) or None, got shape \(2,\)$"
        ),
    ):
        dv.simulate("kr5", q=q, tool_point=[1, 2])
    with pytest.raises(dv.DenavitError, match=r"^simulate: measure: expected 'point' or 'pose', got 'xyz'$"):
        dv.simulate("kr5", q=q, measure="xyz")
