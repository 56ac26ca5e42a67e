"""What the identification tests share (tests/test_identify*.py): the paper's home and Table III, the KR5's sweeps
simulated on the paper's protocols."""

import numpy as np

from denavit import sweeps as sw

HOME = np.radians(sw.PAPER_HOME_DEG)


# Hayat et al. Table III, "Specified" (b = d in mm, a in mm, alpha in deg; the twists as printed, theta offsets 0)
TABLE_III = {
    "d": [400, 0, 0, 620, 0, 0],
    "theta": [0] * 6,
    "a": [180, 600, 120, 0, 0, 0],
    "alpha": [90, 0, 90, 90, 90, 0],
}


# The convention kr5.toml takes where Table III gives no sign (models/kr5.toml): KUKA's axis senses for A2, A3,
# A5 and A3's zero with the forearm in line with the upper arm, which stand the arm on its base at the home
KUKA_TWIST_SIGNS = [-1, 1, -1, 1, -1, 1]


KUKA_THETA_OFFSETS = [0, 0, -90, 0, 0, 0]


def simulate(kr5, protocol, **kw):
    return sw.simulate(kr5.model(), home=HOME, ranges=np.radians(sw.PAPER_RANGES_DEG[protocol]), **kw)


def truth_dh(kr5):
    """Hayat et al. Table III, "Specified": the KR5's DH table (d, theta, a, alpha; m, rad), with KUKA's twist
    signs and A3 offset (the convention kr5.toml takes)."""
    return np.column_stack(
        [
            np.array(TABLE_III["d"]) * 1e-3,
            np.radians(np.add(TABLE_III["theta"], KUKA_THETA_OFFSETS)),
            np.array(TABLE_III["a"]) * 1e-3,
            np.radians(np.multiply(KUKA_TWIST_SIGNS, TABLE_III["alpha"])),
        ]
    )
