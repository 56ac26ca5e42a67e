"""``denavit fleet`` and ``denavit check`` from the shell (issue 39): two calibrations of one robot, the second after
a 0.02 deg change of A2's offset; status, diff, export and the drift check see it."""

import dataclasses
import json
import subprocess
import sys

import numpy as np
import pytest

import denavit as dv
from cli import env
from denavit.calibration import Measurements
from denavit.calibration.parametrization import configurations
from denavit.fleet.checksum import model_checksum
from denavit.io.measurements import to_csv
from denavit.io.robotfile import read

KR5 = dv.load_robot("kr5")


def _robot(offset_deg: float):
    rng = np.random.default_rng(39)
    t = KR5.table
    P = np.array(t.params) + rng.normal(0, 1, t.params.shape) * [3e-4, np.radians(0.03), 3e-4, np.radians(0.03)]
    P[1, 1] += np.radians(offset_deg)  # A2's offset (the DH theta of joint 2)
    return dataclasses.replace(KR5, table=dv.Table(t.convention, P, t.kinds, t.T_world_base, t.T_last_tool))


def denavit(*args, cwd, code=0):
    p = subprocess.run(
        [sys.executable, "-m", "denavit.cli", *map(str, args)], capture_output=True, text=True, env=env(), cwd=cwd
    )
    assert p.returncode == code, p.stdout + p.stderr
    return p


@pytest.fixture(scope="module")
def fleet(tmp_path_factory):
    d = tmp_path_factory.mktemp("fleet")
    for k, (offset, skip) in enumerate(((0.0, 7), (0.02, 100)), 1):
        meas = dv.simulate(_robot(offset), configurations(KR5, 40, skip=skip), noise=2e-5, seed=k)
        (d / f"cal{k}.csv").write_text(to_csv(meas))
        (d / f"m{k}.toml").write_text(
            f'[[robot]]\nid = "R1"\nnominal = "kr5"\njob = "calibrate"\ndata = "cal{k}.csv"\n'
            'model = "full"\nconvention = "mdh"\n'
        )
    denavit("fleet", "add", "R0", "kr5", cwd=d)
    denavit("fleet", "run", "m1.toml", "--workers", "0", cwd=d)
    out = denavit("fleet", "run", "m2.toml", "--workers", "0", cwd=d).stdout
    assert "1 entries added (1 ok, 0 failed)" in out
    return d


def test_status_diff_and_export(fleet):
    doc = json.loads(denavit("fleet", "status", "--json", cwd=fleet).stdout)
    robots = {r["id"]: r for r in doc["robots"]}
    assert robots["R0"]["entries"] == 1 and robots["R0"]["latest"]["job"] == "add"
    assert robots["R0"]["latest"]["model_checksum"] == model_checksum(KR5)  # the built-in's geometry
    r1 = robots["R1"]
    assert r1["entries"] == 2 and r1["latest"]["status"] == "ok" and r1["latest"]["error"] is None
    assert r1["latest"]["job"] == "calibrate" and r1["latest"]["rms_m"] < 4e-5
    diff = json.loads(denavit("fleet", "diff", "R1", "--json", cwd=fleet).stdout)
    changed = [p["name"] for p in diff["parameters"] if p["changed"]]
    assert changed == ["theta_2"]  # the offset changed, nothing else beyond 3 sigma
    (theta_2,) = [p for p in diff["parameters"] if p["name"] == "theta_2"]
    assert abs(np.degrees(theta_2["change"]) - 0.02) < 4 * np.degrees(theta_2["sigma"])
    p = denavit("fleet", "export", "R1", "-o", "r1.toml", cwd=fleet)
    assert f"model checksum {r1['latest']['model_checksum']}" in p.stderr
    assert model_checksum(read(fleet / "r1.toml")) == r1["latest"]["model_checksum"]


def test_check_registered_robot(fleet):
    denavit("check", "R1", "--design", "8", "-o", "poses.csv", cwd=fleet)
    q = np.radians(np.loadtxt(fleet / "poses.csv", delimiter=",", comments="#", skiprows=2))
    assert q.shape == (8, 6)
    for name, offset, code in (("same.csv", 0.02, 0), ("moved.csv", 0.03, 1)):  # as calibrated; 0.01 deg more
        pts = dv.simulate(_robot(offset), q, noise=2e-5, seed=11 + code).points  # the target the calibrations saw
        (fleet / name).write_text(to_csv(Measurements(q, pts, None, name, kinds=tuple(KR5.table.kinds))))
        p = denavit("check", "R1", name, "--noise", "0.02", cwd=fleet, code=code)
        assert ("CHANGED" in p.stdout) == bool(code)
    doc = json.loads(denavit("fleet", "status", "--json", cwd=fleet).stdout)
    (r1,) = [r for r in doc["robots"] if r["id"] == "R1"]
    assert r1["entries"] == 4 and r1["drift"]["metrics"]["changed"] and r1["drift"]["metrics"]["dof"] == 24
