"""The payload in pose and sweep files (issue 37): the CSV's payload_mass, payload_x, payload_y, payload_z columns and
the JSON's payload_mass and payload_com keys, read and written back; the one-line errors of a payload without a unit,
a negative mass, a centre of mass of the wrong shape; a calibration from a JSON pose file equal to the CSV's; the CLI's
--payload without a unit and a robot file's bad [compliance] as one line."""

from __future__ import annotations

import json
import math
from dataclasses import replace

import numpy as np
import pytest

import denavit as dv
from cli import error_line, run
from denavit import _core
from denavit.calibration import Measurements
from denavit.calibration.compliance import elastic, gravity_torques
from denavit.calibration.selection import COMPLIANCE
from denavit.io import measurements as iom
from denavit.io import robotfile as rf
from denavit.io import sweeps as ios
from denavit.sweeps import simulate

NOISE = 2e-5
TOOL = np.array([0.04, 0.03, 0.10])
COM = np.array([0.02, 0.0, 0.06])
#: joint compliances of a UR5-like cobot (rad/(N m)): about 1 mm at the tool under 5 kg
K_TRUE = np.array([0.0, 1.2e-5, 2.5e-5, 1.0e-4, 1.2e-4, 0.0])


def _one_line(exc) -> str:
    msg = str(exc.value)
    assert "\n" not in msg
    return msg


def _two_payloads(n: int, seed: int = 0) -> Measurements:
    """n UR5 poses measured at no payload and at 5 kg at COM, the joints deflected by K_TRUE."""
    robot = dv.load_robot("ur5")
    rng = np.random.default_rng(seed)
    lo, hi = np.maximum(robot.lower, -math.pi), np.minimum(robot.upper, math.pi)
    q = np.vstack([lo + (hi - lo) * rng.random((n, 6))] * 2)
    pl = np.c_[np.repeat([0.0, 5.0], n), np.tile(COM, (2 * n, 1))]
    m = robot.model().with_tool(dv.geometry.pose(p=TOOL))
    p = _core.fk_batch(m, q - K_TRUE * gravity_torques(robot.model(), q, pl))[:, :3, 3]
    return Measurements(q, p + rng.normal(0, NOISE, p.shape), None, "simulated", payload=pl)


# --- round trips ------------------------------------------------------------------------------------------------


@pytest.mark.parametrize("kind", ["point", "pose"])
def test_a_pose_file_carries_its_payload_through_csv_and_json(tmp_path, kind):
    rng = np.random.default_rng(1)
    q = rng.uniform(-2, 2, (5, 6))
    T = np.tile(np.eye(4), (5, 1, 1))
    T[:, :3, :3] = dv.geometry.rotvec_matrix(rng.normal(0, 1, (5, 3)))
    T[:, :3, 3] = rng.uniform(-1, 1, (5, 3))
    pl = np.array([[0, 0, 0, 0], [0, 0, 0, 0], [5, 0.02, 0, 0.06], [5, 0.02, 0, 0.06], [2.5, -0.01, 0.03, 0.1]])
    m = Measurements(q, T[:, :3, 3] if kind == "point" else None, T if kind == "pose" else None, "m", payload=pl)
    (tmp_path / "m.json").write_text(json.dumps(iom.to_json(m, "mm", "deg")))
    (tmp_path / "m.csv").write_text(iom.to_csv(m, "mm", "deg"))
    for f, tol in (("m.json", 1e-15), ("m.csv", 1e-11)):  # the JSON's shortest round trip, the CSV's 12 digits
        back = iom.read_measurements(tmp_path / f)
        assert back.kind == kind, f
        np.testing.assert_allclose(back.payload, pl, rtol=tol, atol=1e-15, err_msg=f)
        np.testing.assert_allclose(back.points, T[:, :3, 3], rtol=tol, atol=1e-15, err_msg=f)
    doc = iom.to_json(replace(m, payload=np.tile([5.0, 0, 0, 0], (5, 1))), "m", "rad")
    assert doc["payload_mass"] == 5.0 and "payload_com" not in doc and doc["units"]["mass"] == "kg"
    without = iom.to_json(replace(m, payload=None))
    assert "payload_mass" not in without and "mass" not in without["units"]


def test_a_hand_written_payload_is_read_in_the_file_s_declared_units(tmp_path):
    """500 g at 8 cm on the flange's z axis, whatever the spelling: [0.5 kg, 0, 0, 0.08 m] (by hand)."""
    head = {"units": {"length": "mm", "angle": "deg", "mass": "g"}, "q": [[0] * 6, [10] * 6], "points": [[1, 2, 3]] * 2}
    f = tmp_path / "m.json"
    f.write_text(json.dumps(head | {"payload_mass": [0, 500], "payload_com": [0, 0, 80]}))
    np.testing.assert_allclose(iom.read_measurements(f).payload, [[0, 0, 0, 0.08], [0.5, 0, 0, 0.08]], rtol=1e-15)
    f.write_text(json.dumps(head | {"payload_mass": 500, "payload_com": [[0, 0, 80], [0, 0, 0]]}))
    np.testing.assert_allclose(iom.read_measurements(f).payload, [[0.5, 0, 0, 0.08], [0.5, 0, 0, 0]], rtol=1e-15)
    c = tmp_path / "m.csv"
    c.write_text(
        "# units: length=cm angle=deg mass=g\nq1,q2,q3,q4,q5,q6,x,y,z,payload_mass,payload_z\n0,0,0,0,0,0,1,2,3,500,8\n"
    )
    np.testing.assert_allclose(iom.read_measurements(c).payload, [[0.5, 0, 0, 0.08]], rtol=1e-15)
    c.write_text("# units: length=mm angle=deg\nq1,q2,q3,q4,q5,q6,x,y,z,payload_mass\n0,0,0,0,0,0,1,2,3,5\n")
    np.testing.assert_allclose(iom.read_measurements(c).payload, [[5, 0, 0, 0]])  # the column's kg by default


def _sweeps_with_payload():
    s = simulate(
        dv.load_robot("ur5").model(), home=np.zeros(6), ranges=np.tile([-0.5, 0.5], (6, 1)), points_per_sweep=4
    )
    out = []
    for w in s.sweeps:  # joint 1: a payload per point; the others one payload for the whole sweep
        m = len(w.points)
        pl = np.c_[np.arange(m) * 1.25, np.zeros((m, 2)), np.full(m, 0.01)] if w.joint == 1 else None
        pl = np.tile([2.5 * (w.joint % 2), 0.02, 0, 0.001 * w.joint], (m, 1)) if pl is None else pl
        out.append(replace(w, payload=pl))
    return replace(s, sweeps=out)


def test_a_sweep_file_carries_its_payload_through_csv_and_json(tmp_path):
    s = _sweeps_with_payload()
    doc = ios.to_json(s, "mm", "deg")
    assert isinstance(doc["sweeps"][0]["payload_mass"], list) and doc["sweeps"][1]["payload_mass"] == 2.5 * 0
    assert doc["sweeps"][2]["payload_com"] == pytest.approx([20, 0, 3]) and doc["units"]["mass"] == "kg"
    (tmp_path / "s.json").write_text(json.dumps(doc))
    (tmp_path / "s.csv").write_text(ios.to_long_csv(s, "mm", "deg"))
    for f in ("s.json", "s.csv"):
        back = ios.read(tmp_path / f)
        for a, b in zip(back.sweeps, s.sweeps, strict=True):
            np.testing.assert_allclose(a.payload, b.payload, rtol=1e-15, atol=1e-18, err_msg=f)
        np.testing.assert_allclose(
            iom.read_measurements(tmp_path / f).payload,
            np.vstack([w.payload for w in s.sweeps]),
            rtol=1e-15,
            atol=1e-18,
        )


# --- one-line errors ----------------------------------------------------------------------------------------------

POSES = {"units": {"length": "mm", "angle": "deg", "mass": "kg"}, "q": [[0] * 6, [10] * 6], "points": [[1, 2, 3]] * 2}


@pytest.mark.parametrize(
    ("change", "expected"),
    [
        ({"units": {"length": "mm", "angle": "deg"}, "payload_mass": 5}, 'mass unit is not declared: expected "units"'),
        ({"units": {"length": "mm", "angle": "deg", "mass": "lb"}, "payload_mass": 5}, "unknown mass unit 'lb'"),
        ({"payload_mass": -1}, "payload_mass: expected a mass >= 0 kg, got -1 kg"),
        ({"payload_mass": [0, -2]}, "payload_mass[1]: expected a mass >= 0 kg, got -2 kg"),
        ({"payload_mass": [0, 5, 5]}, "payload_mass: expected one number for every pose or a list of 2 (one per pose)"),
        ({"payload_mass": "5 kg"}, "payload_mass: expected a number, got '5 kg' (a string)"),
        ({"payload_mass": 5, "payload_com": [0, 80]}, "payload_com: expected a list of 3 numbers, got [0, 80]"),
        ({"payload_mass": 5, "payload_com": [[0, 0, 80]] * 3}, "payload_com: expected one [x, y, z] for every pose"),
        ({"payload_mass": 5, "payload_com": [[0, 0, 80], [0, 80]]}, "payload_com[1]: expected a list of 3 numbers"),
        ({"payload_com": [0, 0, 80]}, "payload_com without payload_mass"),
        ({"payload_mas": 5}, "'payload_mas': expected units, kinds, q, and points or poses, payload_mass, payload_com"),
    ],
)
def test_a_json_pose_file_s_bad_payload_is_one_line(tmp_path, change, expected):
    f = tmp_path / "m.json"
    f.write_text(json.dumps(POSES | change))
    with pytest.raises(dv.DenavitError) as e:
        iom.read_measurements(f)
    assert _one_line(e).startswith(str(f)) and expected in str(e.value)


def test_a_json_sweep_file_s_bad_payload_is_one_line(tmp_path):
    doc = ios.to_json(_sweeps_with_payload(), "mm", "deg")
    f = tmp_path / "s.json"
    for change, expected in (
        (lambda d: d["sweeps"][3].pop("payload_mass"), "sweeps[3]: sweeps[0] has 'payload_mass', sweeps[3] has none"),
        (
            lambda d: d["sweeps"][0]["payload_mass"].__setitem__(2, -1),
            "sweeps[0].payload_mass[2]: expected a mass >= 0",
        ),
        (
            lambda d: d["sweeps"][1].__setitem__("payload_com", [1, 2, 3, 4]),
            "sweeps[1].payload_com: expected a list of 3",
        ),
        (lambda d: d["units"].pop("mass"), 'sweeps[0].payload_mass: the mass unit is not declared: expected "units"'),
        (
            lambda d: d["sweeps"][2].__setitem__("payload_cm", [0, 0, 1]),
            (
                "sweeps[2]: unknown key(s) 'payload_cm': expected joint, points, targets, q, quaternions, payload_mass,"
                " payload_com"
            ),
        ),
    ):
        bad = json.loads(json.dumps(doc))
        change(bad)
        f.write_text(json.dumps(bad))
        with pytest.raises(dv.DenavitError) as e:
            ios.read_json(f)
        assert _one_line(e).startswith(str(f)) and expected in str(e.value), (expected, str(e.value))


def test_a_python_robot_s_negative_compliance_is_one_line():
    robot = replace(dv.load_robot("ur5"), compliance=np.array([0, 1e-5, -2e-5, 0, 0, 0]))
    with pytest.raises(dv.DenavitError) as e:
        elastic(robot)
    assert "joint 3 (elbow): expected a compliance >= 0" in _one_line(e) and "-2e-05 rad/(N m)" in str(e.value)
    with pytest.raises(dv.DenavitError) as e:
        dv.calibrate(_two_payloads(6), robot, tool=TOOL)
    assert "joint 3 (elbow): expected a compliance >= 0" in _one_line(e)
    bare = replace(dv.load_robot("ur5"), compliance=K_TRUE, inertials=None)
    with pytest.raises(dv.DenavitError) as e:
        elastic(bare)
    assert "without the links' inertial parameters" in _one_line(e)


@pytest.mark.parametrize("command", ["calibrate", "validate", "plan"])
def test_the_cli_s_payload_without_a_unit_is_one_line(tmp_path, command):
    f = tmp_path / "m.csv"
    f.write_text(iom.to_csv(replace(_two_payloads(6), payload=None)))
    args = {"calibrate": ["ur5", f], "validate": ["ur5", f], "plan": ["ur5", "--points", "10"]}[command]
    r = run(command, *args, "--payload", "5", ok=False)
    line = error_line(r.stderr)
    assert r.returncode == 2 and line is not None, r.stderr
    assert "--payload: the payload's mass 5 has no unit: expected one of kg, g" in line


@pytest.mark.parametrize(
    ("section", "expected"),
    [
        ('unit = "urad/(N m)"\nvalues = [0, 1, -2, 3, 4, 5]', "joint 3 (elbow): expected a compliance >= 0"),
        ("values = [0, 1, 2, 3, 4, 5]", "missing 'unit'"),
        ('unit = "rad/(N m)"\nvalues = [0, 0, 0, 0, 0, 1]', "need the links' inertial parameters"),
    ],
)
def test_the_cli_s_bad_compliance_section_is_one_line(tmp_path, section, expected):
    """A negative compliance, one without its unit, one in a robot file without inertials (the KR5's)."""
    p = tmp_path / "r.toml"
    name = "kr5" if "inertial" in expected else "ur5"
    p.write_text(rf.dumps(dv.load_robot(name), "mm", "deg") + f"\n[compliance]\n{section}\n")
    r = run("show", p, ok=False)
    line = error_line(r.stderr)
    assert r.returncode == 2 and line is not None and expected in line and str(p) in line, r.stderr


# --- the calibration -------------------------------------------------------------------------------------------


def test_calibrate_from_a_json_pose_file_with_two_payloads_equals_the_csv(tmp_path):
    meas = _two_payloads(25, seed=7)
    (tmp_path / "m.csv").write_text(iom.to_csv(meas, "mm", "deg"))
    (tmp_path / "m.json").write_text(json.dumps(iom.to_json(meas, "mm", "deg")))
    a = dv.calibrate(tmp_path / "m.csv", "ur5", tool=TOOL)
    b = dv.calibrate(tmp_path / "m.json", "ur5", tool=TOOL)
    assert a.model_choice.chosen == b.model_choice.chosen and a.model_choice.chosen.endswith(COMPLIANCE)
    assert a.names == b.names
    sig = np.asarray(a.sigma, dtype=float)
    free = np.isfinite(sig) & (sig > 0)
    assert np.all(np.abs(a.values - b.values)[free] < 1e-3 * sig[free])  # the CSV's 12 digits only
    for j in (1, 2, 3, 4):
        v, s = b.value(f"k_{j + 1}")
        assert abs(v - K_TRUE[j]) < 4 * s, (j, v, s)
    rigid = tmp_path / "rigid.json"  # the same file without its payload keys: no compliance to fit
    doc = iom.to_json(meas, "mm", "deg")
    del doc["payload_mass"], doc["payload_com"]
    rigid.write_text(json.dumps(doc))
    assert not dv.calibrate(rigid, "ur5", tool=TOOL).model_choice.chosen.endswith(COMPLIANCE)
