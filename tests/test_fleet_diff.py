"""``fleet diff`` between calibrations of different conventions (issue 39): the later entry is converted to the
earlier's convention (the core's extraction, its covariance converted with it), and reads as the diff of the same
calibration kept in one convention."""

import dataclasses

import numpy as np
import pytest

import denavit as dv
from denavit.calibration.parametrization import configurations
from denavit.fleet.history import diff
from denavit.fleet.registry import Registry
from denavit.fleet.runner import run_manifest
from denavit.io.measurements import to_csv

KR5 = dv.load_robot("kr5")


def _robot(offset_deg: float):
    rng = np.random.default_rng(39)
    t = KR5.table
    P = np.array(t.params) + rng.normal(0, 1, t.params.shape) * [3e-4, np.radians(0.03), 3e-4, np.radians(0.03)]
    P[1, 1] += np.radians(offset_deg)  # A2's offset (theta of joint 2)
    return dataclasses.replace(KR5, table=dv.Table(t.convention, P, t.kinds, t.T_world_base, t.T_last_tool))


@pytest.fixture(scope="module")
def registry(tmp_path_factory):
    """Robot R: a calibration in modified DH, then (0.02 deg more on A2) the same data calibrated in modified DH and
    in ED-H; robot S: one calibration in modified DH and in ED-H."""
    d = tmp_path_factory.mktemp("diff")
    tables = []
    for k, (offset, skip) in enumerate(((0.0, 7), (0.02, 100)), 1):
        meas = dv.simulate(_robot(offset), configurations(KR5, 40, skip=skip), noise=2e-5, seed=k)
        (d / f"cal{k}.csv").write_text(to_csv(meas))
        (d / f"copy{k}.csv").write_text(to_csv(meas))  # (a manifest runs one job of a robot per file)
    job = 'nominal = "kr5"\njob = "calibrate"\nmodel = "full"\n'
    tables = [
        f'[[robot]]\nid = "R"\n{job}data = "cal1.csv"\nconvention = "mdh"\n',
        f'[[robot]]\nid = "R"\n{job}data = "cal2.csv"\nconvention = "mdh"\n',
        f'[[robot]]\nid = "R"\n{job}data = "copy2.csv"\nconvention = "edh"\n',
        f'[[robot]]\nid = "S"\n{job}data = "cal1.csv"\nconvention = "mdh"\n',
        f'[[robot]]\nid = "S"\n{job}data = "copy1.csv"\nconvention = "edh"\n',
    ]
    (d / "m.toml").write_text("\n".join(tables))
    reg = Registry(d / "r.sqlite")
    summary = run_manifest(d / "m.toml", reg)
    assert summary.added_ok == 5, summary
    yield reg
    reg.close()


def test_an_edh_calibration_diffs_in_the_earlier_modified_dh(registry):
    first, second, second_edh = (e.seq for e in registry.entries("R"))
    same = diff(registry, "R", first, second)  # both modified DH
    mixed = diff(registry, "R", first, second_edh)  # the second converted from ED-H
    assert same.converted_from is None and mixed.converted_from == "edh"
    assert mixed.names == same.names and mixed.names[:4] == ["alpha_1", "a_1", "theta_1", "d_1"]
    assert [n for n, c in zip(mixed.names, mixed.changed) if c] == ["theta_2"]
    # one calibration in two conventions: the same geometry (two fits of one data: within a tenth of the sigmas)
    # and the same sigmas (of the parameters estimated: a fixed one's is round-off, ~1e-16)
    ok = np.isfinite(same.sigma) & (same.sigma > 1e-9)
    assert np.all(np.abs(mixed.value_b - same.value_b)[ok] < 0.1 * same.sigma[ok])
    np.testing.assert_allclose(mixed.sigma[ok], same.sigma[ok], rtol=0.05)
    k = mixed.names.index("theta_2")
    assert abs(np.degrees(mixed.change[k]) - 0.02) < 4 * np.degrees(mixed.sigma[k])
    assert mixed.to_json()["b_converted_from"] == "edh" and mixed.to_json()["convention"] == "mdh"


def test_one_calibration_in_two_conventions_changes_nothing(registry):
    d = diff(registry, "S", *(e.seq for e in registry.entries("S")))
    assert d.converted_from == "edh"
    assert not d.changed.any(), [n for n, c in zip(d.names, d.changed) if c]
    ok = np.isfinite(d.sigma) & (d.sigma > 1e-9)
    assert ok.sum() >= 20 and np.all(np.abs(d.change)[ok] < 0.1 * d.sigma[ok])
