"""What the calibration tests share (tests/test_calibrate*.py; tests/test_tracker_noise.py takes TOOL through
test_calibrate): the point noise, the tool point in the flange, the paper's home."""

import numpy as np

from denavit import sweeps as sw

NOISE = 2e-5  # 0.02 mm per coordinate
TOOL = np.array([0.05, 0.03, 0.10])
HOME = np.radians(sw.PAPER_HOME_DEG)
