"""Fleets on Dask (issue 39): a manifest of 40 simulated robots run on a LocalCluster of 2 worker processes gives the
serial run's registry, bad files recorded as failed once, a worker killed mid-run changes nothing, a rerun adds
nothing."""

import os
import signal
import sqlite3

import numpy as np
import pytest

import denavit as dv
from denavit.calibration.parametrization import configurations
from denavit.fleet.jobs import JobSpec, run_job
from denavit.fleet.registry import Registry
from denavit.fleet.runner import run_manifest
from denavit.io.measurements import to_csv
from denavit.io.sweeps import to_long_csv

ROBOTS = 40
BAD = {8: "this is not a sweep file\n", 23: "q1,q2,q3,q4,q5,q6,x,y,z\n1,2,3\n"}


def _manifest(folder) -> str:
    kr5 = dv.load_robot("kr5")
    q = configurations(kr5, 20, skip=5)
    tables = []
    for i in range(ROBOTS):
        rid = f"KR5-{i:03d}"
        if i % 4 == 0:  # sweeps (10 robots; the identification takes longer than the calibration)
            name, job = f"{rid}_sweeps.csv", "identify"
            text = to_long_csv(dv.simulate(kr5, noise=2e-5, points_per_sweep=6, ranges="paper30", seed=i))
        else:  # poses
            name, job = f"{rid}_poses.csv", "calibrate"
            text = to_csv(dv.simulate(kr5, q, noise=2e-5, seed=i))
        (folder / name).write_text(BAD.get(i, text))
        options = 'model = "full"\nconvention = "mdh"\n' if job == "calibrate" else ""
        tables.append(f'[[robot]]\nid = "{rid}"\nnominal = "kr5"\njob = "{job}"\ndata = "{name}"\n{options}')
    path = folder / "fleet.toml"
    path.write_text("\n".join(tables))
    return path


def _rows(path) -> list:
    db = sqlite3.connect(path)
    rows = db.execute(
        "SELECT robot_id, key, job, status, error, robot_file, convention, method, model_checksum, metrics "
        "FROM entries ORDER BY robot_id, key"
    ).fetchall()
    db.close()
    return rows


@pytest.fixture(scope="module")
def client():
    from dask import distributed  # denavit[test] holds dask[distributed]: never skipped

    cluster = distributed.LocalCluster(
        n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None, silence_logs=50
    )
    c = distributed.Client(cluster)
    yield c
    c.close()
    cluster.close()


def test_fleet_on_two_workers_matches_serial_survives_a_killed_worker_and_reruns_to_nothing(tmp_path, client):
    manifest = _manifest(tmp_path)
    with Registry(tmp_path / "serial.sqlite") as reg:
        serial = run_manifest(manifest, reg)
    assert (serial.added_ok, serial.added_failed, serial.lost) == (38, 2, [])

    pids = list(client.run(os.getpid).values())
    killed = []

    def kill_one(done, total):  # mid-run: a worker with a task under way dies (SIGKILL, no goodbye)
        if done == 10 and not killed:
            os.kill(pids[0], signal.SIGKILL)
            killed.append(pids[0])

    with Registry(tmp_path / "cluster.sqlite") as reg:
        summary = run_manifest(manifest, reg, client=client, progress=kill_one)
        assert killed, "the worker was killed during the run"
        assert (summary.added_ok, summary.added_failed, summary.lost) == (38, 2, [])
        again = run_manifest(manifest, reg, client=client)
        assert (again.added, again.skipped) == (0, 40)
        entries = reg.entries()
    assert len(entries) == 40 and len({e.robot_id for e in entries}) == 40  # each robot once
    failed = {e.robot_id: e.error for e in entries if e.status == "failed"}
    assert sorted(failed) == ["KR5-008", "KR5-023"]
    for rid, err in failed.items():
        assert "\n" not in err and f"{rid}_" in err  # one line, naming the file as the manifest does
        assert "denavit-job-" not in err  # not the worker's temporary folder
    ok = [e for e in entries if e.status == "ok"]
    assert all(e.model_checksum and e.robot_file and e.inputs for e in ok)
    assert _rows(tmp_path / "serial.sqlite") == _rows(tmp_path / "cluster.sqlite")  # identical to the serial run


def test_a_job_that_fails_for_its_data_returns_its_one_line_error(tmp_path):
    out = run_job(JobSpec("R1", "calibrate", "kr5", (("data", "logs/r1.csv", b"q1,x\n1,oops\n"),), {}))
    assert out.status == "failed" and out.error.startswith("logs/r1.csv") and "\n" not in out.error
    good = to_csv(dv.simulate("kr5", configurations(dv.load_robot("kr5"), 15), noise=2e-5, seed=3)).encode()
    out = run_job(JobSpec("R1", "calibrate", "kr5", (("data", "r1.csv", good),), {"model": "offsets"}))
    assert out.status == "ok" and out.metrics["rms_m"] < 5e-5 and len(out.model_checksum) == 16
    assert np.isfinite(out.metrics["predicted_error_m"])


def test_validate_and_check_jobs_score_the_model_the_manifest_just_made(tmp_path):
    kr5 = dv.load_robot("kr5")
    for name, skip in (("cal.csv", 5), ("session2.csv", 300)):
        (tmp_path / name).write_text(
            to_csv(dv.simulate(kr5, configurations(kr5, 25, skip=skip), noise=2e-5, seed=skip))
        )
    (tmp_path / "check.csv").write_text(to_csv(dv.simulate(kr5, configurations(kr5, 8, skip=900), noise=2e-5, seed=9)))
    head = '[[robot]]\nid = "R1"\nnominal = "kr5"\n'
    (tmp_path / "m.toml").write_text(
        head
        + 'job = "calibrate"\ndata = "cal.csv"\nmodel = "offsets"\n\n'
        + head
        + 'job = "validate"\ndata = ["session2.csv", "missing.csv"]\n\n'
        + head
        + 'job = "check"\ndata = "check.csv"\nnoise = 2e-5\n'
    )
    with Registry(tmp_path / "r.sqlite") as reg:
        s = run_manifest(tmp_path / "m.toml", reg)
        assert (s.added_ok, s.added_failed) == (3, 1)
        entries = reg.entries("R1")
        assert sorted(e.job for e in entries) == ["calibrate", "check", "validate", "validate"]
        cal, chk = (next(e for e in entries if e.job == job) for job in ("calibrate", "check"))
        val, missing = sorted((e for e in entries if e.job == "validate"), key=lambda e: e.status != "ok")
        assert val.model_checksum == cal.model_checksum == chk.model_checksum  # the model just made, scored
        assert val.metrics["rms_m"] < 1e-4 and missing.error == "missing.csv: no such file"
        assert not chk.metrics["changed"] and chk.metrics["dof"] == 24
        assert run_manifest(tmp_path / "m.toml", reg).added == 0
