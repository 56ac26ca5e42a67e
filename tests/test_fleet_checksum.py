"""The model checksum printed wherever a model is shown or exported (issue 39): ``show``, ``export``, ``convert``
(and their JSON), ``identify --save`` and ``calibrate --save``; what each prints is :func:`model_checksum` of the file
written, and one geometry has one checksum in every convention."""

import json
import re

import pytest

import denavit as dv
from cli import run
from denavit.calibration.parametrization import configurations
from denavit.fleet.checksum import model_checksum
from denavit.io.measurements import to_csv
from denavit.io.robots import load

KR5 = dv.load_robot("kr5")


def _printed(text: str) -> str:
    (found,) = set(re.findall(r"model checksum ([0-9a-f]{16})", text, flags=re.IGNORECASE))
    return found


def test_show_and_export_print_the_checksum():
    want = model_checksum(KR5)
    assert _printed(run("show", "kr5").stdout) == want
    assert json.loads(run("show", "kr5", "--json", "-").stdout)["model_checksum"] == want
    p = run("export", "kr5")
    assert _printed(p.stderr) == want and "checksum" not in p.stdout.lower()  # the robot file stays clean
    assert json.loads(run("export", "kr5", "--json", "-").stdout)["model_checksum"] == want


def test_convert_prints_the_written_files_checksum_the_same_in_every_convention(tmp_path):
    seen = {}
    for to in ("dh", "mdh", "edh", "poe", "urdf"):
        out = tmp_path / f"kr5_{to}.{'urdf' if to == 'urdf' else 'toml'}"
        p = run("convert", "kr5", "--to", to, "-o", out)
        seen[to] = _printed(p.stdout + p.stderr)
        assert seen[to] == model_checksum(load(out)), to
        if to != "urdf":
            doc = json.loads(run("convert", "kr5", "--to", to, "--json", "-").stdout)
            assert doc["model_checksum"] == seen[to] and _printed(run("convert", "kr5", "--to", to).stdout) == seen[to]
    assert set(seen.values()) == {model_checksum(KR5)}, seen


@pytest.fixture(scope="module")
def data(tmp_path_factory):
    d = tmp_path_factory.mktemp("saved")
    meas = dv.simulate(KR5, configurations(KR5, 30, skip=5), noise=2e-5, seed=3)
    (d / "poses.csv").write_text(to_csv(meas))
    run("simulate", "kr5", "-o", d / "sweeps.csv", "--points", "8", "--seed", "2")
    return d


@pytest.mark.parametrize("convention", ["mdh", "edh"])
def test_calibrate_save_prints_the_saved_models_checksum(data, convention):
    out = data / f"cal_{convention}.toml"
    p = run("calibrate", "kr5", data / "poses.csv", "--convention", convention, "--save", out)
    printed = _printed(p.stdout + p.stderr)
    assert f"wrote {out} (model checksum {printed})" in p.stdout + p.stderr
    assert printed == model_checksum(load(out))
    # the saved calibration (its covariance converted) in another convention: the same geometry, the same checksum
    q = run("convert", out, "--to", "poe" if convention == "mdh" else "mdh", "-o", data / f"back_{convention}.toml")
    assert _printed(q.stdout + q.stderr) == printed


def test_identify_save_prints_the_saved_models_checksum(data):
    for convention, name in (("edh", "id.toml"), ("mdh", "id_mdh.toml"), ("edh", "id.urdf")):
        out = data / name
        p = run("identify", "kr5", data / "sweeps.csv", "--convention", convention, "--save", out)
        printed = _printed(p.stdout + p.stderr)
        assert printed == model_checksum(load(out)), name
    p = run("identify", "kr5", data / "sweeps.csv", "--save", "-")
    assert _printed(p.stderr) == model_checksum(load(data / "id.toml"))  # the file as it went to standard output
