"""The registry of calibrations (issue 39): schema version and upgrade, idempotent writes by content, the model
checksum."""

import sqlite3

import numpy as np
import pytest

import denavit as dv
from denavit.errors import DenavitError
from denavit.fleet import checksum
from denavit.fleet.registry import MIGRATIONS, SCHEMA_VERSION, Entry, Input, Registry, content_key


def _entry(robot="R1", key="k1", status="ok", **kw) -> Entry:
    return Entry(robot_id=robot, key=key, job="calibrate", status=status, metrics={"rms_m": 2e-5}, **kw)


def test_writes_are_idempotent_by_content(tmp_path):
    inputs = (Input("data", "a.csv", "ab" * 32),)
    key = content_key("R1", "calibrate", inputs, {"holdout": 0.2})
    assert key == content_key("R1", "calibrate", (Input("data", "moved/b.csv", "ab" * 32),), {"holdout": 0.2})
    assert key != content_key("R1", "calibrate", inputs, {"holdout": 0.3})
    assert key != content_key("R2", "calibrate", inputs, {"holdout": 0.2})
    with Registry(tmp_path / "r.sqlite") as reg:
        assert reg.version == SCHEMA_VERSION
        assert reg.add(_entry(key=key, inputs=inputs), "kr5")
        assert not reg.add(_entry(key=key, inputs=inputs), "kr5")  # the same content: nothing added
        assert reg.add(_entry(key="k2", status="failed", error="bad.csv: line 3: expected 9 numbers"), "kr5")
    with Registry(tmp_path / "r.sqlite") as reg:  # reopened: the same entries, the inputs with their entry
        entries = reg.entries("R1")
        assert [e.status for e in entries] == ["ok", "failed"]
        assert entries[0].inputs == inputs and entries[1].inputs == ()
        assert reg.robots() == [("R1", "kr5")]


def test_a_version_one_registry_is_upgraded_with_its_entries(tmp_path):
    path = tmp_path / "old.sqlite"
    db = sqlite3.connect(path)
    db.executescript(MIGRATIONS[0] + "UPDATE schema_version SET version = 1;")
    db.execute("INSERT INTO robots VALUES ('R7', 'ur5', '2024-01-02T03:04:05+00:00')")
    provenance = (
        '{"call": "calibrate", "time": "2024-01-02T03:04:05+00:00", "denavit_version": "0.0.9", '
        '"inputs": [{"role": "data", "name": "p.csv", "sha256": "' + "cd" * 32 + '"}]}'
    )
    db.execute(
        "INSERT INTO entries (robot_id, key, job, status, metrics, provenance) VALUES (?, ?, ?, ?, ?, ?)",
        ("R7", "kk", "calibrate", "ok", '{"rms_m": 3e-05}', provenance),
    )
    db.commit()
    db.close()
    with Registry(path) as reg:
        assert reg.version == SCHEMA_VERSION == 2
        (e,) = reg.entries("R7")
    assert e.inputs == (Input("data", "p.csv", "cd" * 32),)
    assert (e.created, e.denavit_version, e.call, e.metrics) == (
        "2024-01-02T03:04:05+00:00",
        "0.0.9",
        "calibrate",
        {"rms_m": 3e-05},
    )


def test_a_newer_or_foreign_file_is_refused(tmp_path):
    newer = tmp_path / "newer.sqlite"
    Registry(newer).close()
    db = sqlite3.connect(newer)
    db.execute("UPDATE schema_version SET version = 99")
    db.commit()
    db.close()
    with pytest.raises(DenavitError, match="schema version 99, this denavit reads up to 2"):
        Registry(newer)
    other = tmp_path / "other.sqlite"
    db = sqlite3.connect(other)
    db.execute("CREATE TABLE t (x)")
    db.commit()
    db.close()
    with pytest.raises(DenavitError, match="expected a denavit registry"):
        Registry(other)
    (tmp_path / "text.sqlite").write_text("not a database at all, just text " * 20)
    with pytest.raises(DenavitError, match="expected a denavit registry"):
        Registry(tmp_path / "text.sqlite")


def test_model_checksum_is_one_per_geometry_whatever_the_convention(tmp_path):
    robot = dv.load_robot("kr5")
    base = checksum.model_checksum(robot)
    assert len(base) == checksum.DIGITS and int(base, 16) >= 0
    for conv in ("mdh", "edh", "poe"):  # the same geometry in other conventions
        table = dv.extract(dv.axes(robot.model(), np.zeros(6)), conv).table
        assert checksum.model_checksum(table.to_model()) == base, conv
    path = tmp_path / "kr5_mm.toml"  # written in mm and degrees, read back: the same
    from denavit.io.robotfile import read, save

    save(robot, path, "mm", "deg")
    assert checksum.model_checksum(read(path)) == base
    P = np.array(robot.table.params)
    P[1, 2] += 1e-6  # 1 um on a link length: another model
    t = robot.table
    moved = dv.Table(t.convention, P, t.kinds, t.T_world_base, t.T_last_tool).to_model()
    assert checksum.model_checksum(moved) != base


def test_checksum_bytes_follow_the_documented_layout():
    m = dv.load_model("kr5")
    b = checksum.canonical_bytes(m)
    head = b"denavit-model-v1\n6:RRRRRR\n"
    assert b.startswith(head)
    ints = np.frombuffer(b[len(head) :], dtype=">i8")
    assert len(ints) == 6 * 6 + 12  # per revolute joint w and p, then the tool's rotation and translation
    T = dv.fk(m, np.zeros(6))
    assert np.array_equal(ints[-3:], np.rint(T[:3, 3] / 1e-8).astype(np.int64))  # big-endian int64 of 10 nm steps
