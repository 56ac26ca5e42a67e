import numpy as np
import pytest

import denavit as dv


@pytest.fixture(scope="session")
def kr5():
    return dv.load_robot("kr5")


@pytest.fixture
def rng():
    return np.random.default_rng(12345)
