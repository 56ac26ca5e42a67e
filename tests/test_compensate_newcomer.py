"""Issues 37 and 38 as a newcomer meets them: identify, then compensate with the result, on every built-in arm (the
kr210's flange is a pure rotation of its DH frame 6, REP-199's tool0), and the command line's words for it."""

import numpy as np

import denavit as dv
from denavit import _core
from denavit import compensation as cp
from denavit.sweeps import simulate

HOME = np.radians([0, -90, 90, 0, 30, 0])
TOOL = np.array([0.05, 0.0, 0.25])  # m, the reflector on the flange


def test_identify_then_compensate_on_an_arm_whose_flange_is_a_turned_frame():
    """The kr210's model carries its flange as a half turn about DH frame 6's z (a tool with no offset). identify's
    result of sweeps simulated from that very model, used to compensate joint rows on it, had every row flagged
    'branch changed' (joint 6 half a turn away: the measured point's frame compensated against the nominal's flange)."""
    robot = dv.load_robot("kr210")
    nom = robot.model()
    ranges = [(h - np.radians(50), h + np.radians(50)) for h in HOME]
    ss = simulate(nom, home=HOME, ranges=ranges, points_per_sweep=30, tool_point=TOOL, seed=1, noise=2e-5)
    idf = dv.identify(ss, nominal=robot)
    q = HOME + np.radians(np.random.default_rng(5).uniform(-40, 40, (20, 6)))
    T = _core.fk_batch(nom, q)
    c = cp.compensate(robot, idf, T, q_nominal=q)
    assert c.ok.all(), f"{int((~c.ok).sum())} of {len(q)} rows flagged"
    # the identified robot is the nominal within the noise: the commands stay on the program's arm, a degree at most
    # (near the wrist's singularity), and the nominal run at them is within the flange's identification error
    assert np.degrees(np.abs(c.q_command - q)).max() < 2.0
    after = np.linalg.norm(_core.fk_batch(nom, c.q_command)[:, :3, 3] - T[:, :3, 3], axis=1)
    assert np.sqrt(np.mean(after**2)) < 5e-4
