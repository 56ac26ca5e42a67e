"""A robot file's [prior] table (issue 36: plausible-size priors overridable in a robot file): read and written with
units, one-line errors at its table, and used by calibrate unless an explicit prior is given."""

import math

import numpy as np
import pytest

from denavit import calibration as cal
from denavit.errors import DenavitError
from denavit.io import robotfile
from denavit.io.robots import as_robot

TOOL = np.array([0.05, 0.03, 0.10])
HOME = np.radians([0, -90, 90, 0, 45, 0])


@pytest.fixture(scope="module")
def kr5_text(tmp_path_factory):
    path = tmp_path_factory.mktemp("prior") / "kr5.toml"
    robotfile.save(as_robot("kr5"), path, length="mm", angle="deg")
    return path.read_text()


def with_prior(tmp_path, text, table):
    p = tmp_path / "robot.toml"
    p.write_text(text + "\n[prior]\n" + table + "\n")
    return p


def test_the_prior_table_is_read_with_units_and_written_back(tmp_path, kr5_text):
    p = with_prior(tmp_path, kr5_text, 'length = "0.5 mm"\nangle = 0.02\na_5 = "2 mm"\nscale = "50 ppm"')
    robot = robotfile.read(p)
    # a bare number of a kind is in the file's [units] (written here in mm and deg)
    assert robot.prior == "length=0.5mm, angle=0.02deg, a_5=2mm, scale=50ppm"
    spec = cal.priors.as_prior(robot.prior)
    assert spec.widths["length"] == pytest.approx(5e-4) and spec.widths["angle"] == pytest.approx(math.radians(0.02))
    assert spec.widths["scale"] == pytest.approx(5e-5) and dict(spec.overrides)["a_5"][0] == pytest.approx(2e-3)
    out = tmp_path / "again.toml"
    robotfile.save(robot, out)
    assert robotfile.read(out).prior == robot.prior


@pytest.mark.parametrize(
    "table, match",
    [
        ("a_5 = 2", r"\[prior\]: a_5 = 2: expected a width with its unit"),
        ('length = "-1 mm"', r"\[prior\]: expected a finite width > 0 for length, got -1"),
        ('length = "1 parsec"', r"\[prior\]"),
        ("length = true", r"\[prior\]: length = True: expected a width with its unit"),
    ],
)
def test_a_bad_prior_table_is_one_line_at_its_table(tmp_path, kr5_text, table, match):
    with pytest.raises(DenavitError, match=match) as e:
        robotfile.read(with_prior(tmp_path, kr5_text, table))
    assert "\n" not in str(e.value) and "robot.toml" in str(e.value)


def test_calibrate_uses_the_files_prior_and_an_explicit_one_wins(tmp_path, kr5_text):
    """Link errors of 0.5 mm in the data: under the default 1 mm prior the MAP fit moves the link lengths; under the
    file's prior of 1 um it cannot (they stay within a few um of nominal); an explicit prior= overrides the file."""
    kr5 = as_robot("kr5")
    pz = cal.parametrize(kr5, "edh", tool=TOOL)
    rng = np.random.default_rng(5)
    x = pz.x0.copy()
    links = [
        c
        for c, nm in enumerate(pz.names)
        if not nm.startswith(("base_", "tool_", "offset_")) and pz.units[c] == "length"
    ]
    x[links] += rng.normal(0, 5e-4, len(links))
    truth = pz.model(x, "truth")
    q = np.clip(HOME + rng.uniform(-1, 1, (40, 6)) * math.radians(40), kr5.lower, kr5.upper)
    meas = cal.simulate(truth, q, tool=TOOL, noise=2e-5, seed=6)
    tight = robotfile.read(with_prior(tmp_path, kr5_text, 'length = "0.001 mm"'))

    def moved(res):
        return max(abs(res.value(pz.names[c])[0] - pz.x0[c]) for c in links if res.status[c] == "free")

    default = cal.calibrate(meas, kr5, tool=TOOL, model="full-prior")
    from_file = cal.calibrate(meas, tight, tool=TOOL, model="full-prior")
    explicit = cal.calibrate(meas, tight, tool=TOOL, model="full-prior", prior={"length": 1e-3})
    assert moved(default) > 1e-4  # the data move them by tenths of a millimetre
    # (a parameter the tight prior dominates is held at nominal and listed: "fixed (prior)"; the structurally
    # redundant ones are not estimated under either prior)
    held = [c for c in links if from_file.status[c] == "fixed (prior)"]
    held_default = [c for c in links if default.status[c] == "fixed (prior)"]
    assert len(held) > len(held_default) and all(
        from_file.status[c] in ("fixed (prior)", "redundant") for c in links
    ), (held, held_default)
    assert all(abs(from_file.value(pz.names[c])[0] - pz.x0[c]) < 5e-6 for c in links)
    assert moved(explicit) == pytest.approx(moved(default), rel=1e-6)
