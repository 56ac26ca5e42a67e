"""A reflector on the flange's axis (an SMR in a nest on the flange centre, tool point 0, 0, 0): joint 6's turning
does not move it, so the data cannot determine joint 6's compliance nor how the last link is turned about the point
(issue 37's audit: auto chose full+compliance with offset_5 moved by 62 deg, a_5 by 72 mm, k_6 0.02 rad/(N m), every
one with a sigma of that size, and compensating the flange with it sent 0 of 25 rows). The identifiability analysis now
drops a parameter the data give a sigma beyond the plausible size of its error (2 deg, 2 % of the robot's size:
fitting.checks.PLAUSIBLE) as unidentifiable; the same arm measured at a point off the axis keeps every one."""

import math

import numpy as np
import pytest

import denavit as dv
from denavit import _core
from denavit import calibration as cal
from denavit.calibration.compliance import gravity_torques
from denavit.calibration.identifiability import plausible_sigmas
from denavit.compensation import compensate
from denavit.io import results

#: The joints' compliances (rad/(N m)): 0.3-1.7 mm at the flange under 5 kg, as bench_compliance's UR5.
K = np.array([0.0, 1.2e-5, 2.5e-5, 1.0e-4, 1.2e-4, 0.0])
PAYLOAD_COM = np.array([0.02, 0.0, 0.06])  # m, in the flange frame
NOISE = 2e-5  # m per coordinate
# the tracker 2.9 m from the robot's base, turned 30 deg about z
_C, _S = math.cos(math.radians(30)), math.sin(math.radians(30))
T_TRACKER_BASE = np.array([[_C, -_S, 0, 2.5], [_S, _C, 0, 1.5], [0, 0, 1, -0.4], [0, 0, 0, 1.0]])


@pytest.fixture(scope="module")
def ur5():
    return dv.load_robot("ur5")


def _truth(ur5, tool, rng):
    """The true arm: the nominal's ED-H chain with its link parameters moved (0.5 mm, 0.05 deg; not those the base
    frame absorbs, so that the robot base frame the positions are in is the nominal's), the target at ``tool``."""
    pz = cal.parametrize(ur5, "edh", tool=tool)
    x = pz.x0.copy()
    for c, name in enumerate(pz.names):
        if not name.startswith(("base_", "tool_")) and name not in ("alpha_0", "a_0", "b_0", "c_0", "b_1", "offset_1"):
            x[c] += rng.normal(0, 5e-4 if pz.units[c] == "length" else math.radians(0.05))
    return pz.model(x)


def _draw(rng, n):
    q = rng.uniform(-np.pi, np.pi, (n, 6))
    q[:, 1] = rng.uniform(-0.9 * np.pi, -0.1 * np.pi, n)  # the upper arm above the base
    return q


def _reached(ur5, truth, q, mass):
    """The true tool poses (robot base frame) at readings q with a payload of ``mass`` kg, and the payload rows."""
    pl = np.tile(np.r_[mass, PAYLOAD_COM], (len(q), 1))
    return _core.fk_batch(truth, q - K * gravity_torques(ur5.model(), q, pl)), pl


def _calibrate(ur5, tool, seed=7):
    """30 poses at no payload and at 5 kg seen by the tracker, calibrated with auto; (result, truth, rng)."""
    rng = np.random.default_rng(seed)
    truth = _truth(ur5, tool, rng)
    q = _draw(rng, 30)
    qs, points, payloads = [], [], []
    for mass in (0.0, 5.0):
        T, pl = _reached(ur5, truth, q, mass)
        p = T[:, :3, 3] @ T_TRACKER_BASE[:3, :3].T + T_TRACKER_BASE[:3, 3]
        qs.append(q)
        points.append(p + rng.normal(0, NOISE, p.shape))
        payloads.append(pl)
    meas = cal.Measurements(np.vstack(qs), np.vstack(points), None, "tracker", payload=np.vstack(payloads))
    return cal.calibrate(meas, ur5, tool=tool, holdout=0), truth, rng


def test_a_reflector_on_the_flange_axis_leaves_what_it_cannot_see_unidentifiable(ur5):
    res, truth, rng = _calibrate(ur5, np.zeros(3))
    assert res.model_choice.chosen.endswith("+compliance")  # the compliances of joints 2-5 are there, and seen
    status = dict(zip(res.names, res.status, strict=True))
    why = {u.name: u for u in res.identifiability.unidentifiable}
    # joint 6's compliance: the reflector on its axis does not move when it twists
    assert status["k_6"] == "unidentifiable" and "beyond the plausible size" in why["k_6"].reason, why.get("k_6")
    # the last link's turn about the point: one of its parameters is held, with the sigma the data would give it
    last = [n for n in ("offset_5", "alpha_5", "a_5", "b_5") if status[n] == "unidentifiable"]
    assert last and all("beyond the plausible size" in why[n].reason for n in last), last
    assert any(why[n].sigma is not None for n in last), [why[n].reason for n in last]
    row = next(r for r in results.to_json(res)["identifiability"]["unidentifiable"] if r["name"] == "k_6")
    assert row["unit"] == "rad/(N m)" and row["sigma"] == pytest.approx(why["k_6"].sigma)
    # what stays free is plausible: within the plausible size of its error of the nominal, and so is its sigma
    bound = plausible_sigmas(res.parametrization)
    for k, name in enumerate(res.names):
        if status[name] == "free" and not name.startswith("base_"):
            assert abs(res.values[k] - res.nominal[k]) <= bound[k] and res.sigma[k] <= bound[k], (
                name,
                res.values[k] - res.nominal[k],
                res.sigma[k],
                bound[k],
            )
    # and the compliances it frees are the true ones within 4 sigma
    for j in (1, 2, 3, 4):
        v, s = res.value(f"k_{j + 1}")
        assert abs(v - K[j]) < 4 * s, (j + 1, v, s, K[j])
    # compensating the flange with it works: a program of 20 joint rows, its nominal flange poses the targets, run on
    # the true arm (no payload); it had sent none of them
    qp = _draw(rng, 20)
    targets = _core.fk_batch(ur5.model(), qp)
    comp = compensate(ur5, res, targets, q_nominal=qp)
    assert comp.ok.sum() >= 18, comp.ok
    after = np.linalg.norm(
        _reached(ur5, truth, comp.q_command[comp.ok], 0.0)[0][:, :3, 3] - targets[comp.ok, :3, 3], axis=1
    )
    before = np.linalg.norm(_reached(ur5, truth, qp, 0.0)[0][:, :3, 3] - targets[:, :3, 3], axis=1)
    # below the noise of one measured point (sqrt(3) x 0.02 mm), from a millimetre and more
    assert np.sqrt(np.mean(before**2)) > 1e-3 and np.sqrt(np.mean(after**2)) < math.sqrt(3) * NOISE, (before, after)


def test_the_same_arm_measured_off_the_axis_keeps_every_parameter(ur5):
    """The contrast (nothing changes on well-conditioned data): the target 100 mm off joint 6's axis, every parameter
    the data can identify stays free (no data-dependent drop), joint 6's compliance with it."""
    res, _, _ = _calibrate(ur5, np.array([0.05, 0.03, 0.1]))
    assert [u.name for u in res.identifiability.unidentifiable if not u.structural] == []
    status = dict(zip(res.names, res.status, strict=True))
    assert res.model_choice.chosen.endswith("+compliance")
    assert all(status[n] == "free" for n in ("offset_5", "alpha_5", "a_5", "b_5")), status
    # joint 6's compliance is estimated (its truth 0: fitted free, or below 0 and held at its bound with its sigma)
    assert status["k_6"] in ("free", "held at 0 (k >= 0)") and res.value("k_6")[1] < 1e-3, res.value("k_6")
