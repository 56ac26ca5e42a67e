"""The registry of calibrations: every model a robot was given or computed, with its metrics and provenance, in one
SQLite file (stdlib :mod:`sqlite3`; schema in docs/fleet.md).

One writer: the process that runs ``fleet`` (a Dask cluster's client), never a worker. Every write is one
transaction, and an entry is keyed by the content of what made it (:func:`content_key`: the job, the robot, the
SHA-256 of every input and the options), so running a job again adds nothing (``INSERT ... ON CONFLICT DO NOTHING``).

The schema carries its version (table ``schema_version``); :data:`MIGRATIONS` step an older file up to
:data:`SCHEMA_VERSION` in one transaction when it is opened; a newer file than this denavit knows is refused.
"""

from __future__ import annotations

import datetime
import hashlib
import json
import os
import sqlite3
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path

from ..errors import DenavitError

#: The registry file used when none is named (in the working directory).
DEFAULT_PATH = "denavit-registry.sqlite"
#: Entry statuses: the job ran (``ok``) or failed for its data (``failed``, with the one-line error).
STATUSES = ("ok", "failed")

#: Step k takes a version-k file to version k + 1 (step 0 creates version 1 from an empty file).
MIGRATIONS = (
    # version 1: robots and their entries, the inputs' hashes inside the entry's provenance (JSON)
    """
    CREATE TABLE schema_version (version INTEGER NOT NULL);
    INSERT INTO schema_version VALUES (0);
    CREATE TABLE robots (
        id TEXT PRIMARY KEY,
        family TEXT NOT NULL,
        created TEXT NOT NULL
    );
    CREATE TABLE entries (
        seq INTEGER PRIMARY KEY AUTOINCREMENT,
        robot_id TEXT NOT NULL REFERENCES robots(id),
        key TEXT NOT NULL UNIQUE,
        job TEXT NOT NULL,
        status TEXT NOT NULL CHECK (status IN ('ok', 'failed')),
        error TEXT,
        robot_file TEXT,
        convention TEXT,
        method TEXT,
        model_checksum TEXT,
        metrics TEXT NOT NULL,
        provenance TEXT NOT NULL
    );
    """,
    # version 2: the inputs in their own table (which entries read a file, by its SHA-256), the time and the denavit
    # version as columns, indexes for a robot's history
    """
    CREATE TABLE inputs (
        entry_seq INTEGER NOT NULL REFERENCES entries(seq),
        role TEXT NOT NULL,
        name TEXT NOT NULL,
        sha256 TEXT NOT NULL
    );
    ALTER TABLE entries ADD COLUMN created TEXT NOT NULL DEFAULT '';
    ALTER TABLE entries ADD COLUMN denavit_version TEXT NOT NULL DEFAULT '';
    INSERT INTO inputs (entry_seq, role, name, sha256)
        SELECT e.seq, json_extract(i.value, '$.role'), json_extract(i.value, '$.name'),
               json_extract(i.value, '$.sha256')
        FROM entries e, json_each(json_extract(e.provenance, '$.inputs')) i;
    UPDATE entries SET created = json_extract(provenance, '$.time'),
                       denavit_version = json_extract(provenance, '$.denavit_version');
    UPDATE entries SET provenance = json_remove(provenance, '$.inputs', '$.time', '$.denavit_version');
    CREATE INDEX entries_robot ON entries (robot_id, seq);
    CREATE INDEX inputs_sha ON inputs (sha256);
    """,
)
SCHEMA_VERSION = len(MIGRATIONS)


@dataclass(frozen=True)
class Input:
    """One input file of a job: its role (``data``, ``nominal``, ``model``), its name as given, its SHA-256."""

    role: str
    name: str
    sha256: str


@dataclass(frozen=True)
class Entry:
    """One registered model or job result (a row of ``entries`` with its inputs); ``metrics`` SI (m, rad)."""

    robot_id: str
    key: str
    job: str
    status: str
    error: str | None = None
    robot_file: str | None = None
    convention: str | None = None
    method: str | None = None
    model_checksum: str | None = None
    metrics: dict = field(default_factory=dict)
    call: str = ""
    inputs: tuple = ()
    created: str = ""
    denavit_version: str = ""
    seq: int | None = None

    def summary(self) -> dict:
        """The entry as JSON (SI), without its robot file text."""
        return {
            "seq": self.seq,
            "job": self.job,
            "status": self.status,
            "error": self.error,
            "model_checksum": self.model_checksum,
            "convention": self.convention,
            "method": self.method,
            "metrics": self.metrics,
            "created": self.created,
        }


def sha256_bytes(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()


def content_key(robot_id: str, job: str, inputs, options: dict) -> str:
    """The entry's identity (SHA-256 hex): the robot, the job, the inputs' roles and SHA-256 (names left out: a file
    moved or renamed is the same input) and the options, as canonical JSON (sorted keys, no spaces)."""
    doc = {
        "robot": robot_id,
        "job": job,
        "inputs": [[i.role, i.sha256] for i in inputs],
        "options": options,
    }
    return sha256_bytes(json.dumps(doc, sort_keys=True, separators=(",", ":"), default=str).encode())


def now() -> str:
    """The time in UTC, ISO 8601 to the second."""
    return datetime.datetime.now(datetime.timezone.utc).replace(microsecond=0).isoformat()


def _migrate(db: sqlite3.Connection, where: str) -> None:
    has = db.execute("SELECT name FROM sqlite_master WHERE type = 'table' AND name = 'schema_version'").fetchone()
    version = db.execute("SELECT version FROM schema_version").fetchone()[0] if has else 0
    if version > SCHEMA_VERSION:
        raise DenavitError(
            f"{where}: registry schema version {version}, this denavit reads up to {SCHEMA_VERSION} (upgrade denavit)"
        )
    if version == 0 and db.execute("SELECT count(*) FROM sqlite_master").fetchone()[0]:
        raise DenavitError(
            f"{where}: expected a denavit registry (SQLite with a schema_version table), got other tables"
        )
    if version == SCHEMA_VERSION:
        return
    db.execute("BEGIN IMMEDIATE")  # one transaction: a crash leaves the old version whole
    try:
        for step in range(version, SCHEMA_VERSION):
            for statement in MIGRATIONS[step].split(";"):
                if statement.strip():
                    db.execute(statement)
            db.execute("UPDATE schema_version SET version = ?", (step + 1,))
    except BaseException:
        db.execute("ROLLBACK")
        raise
    db.execute("COMMIT")


class Registry:
    """An open registry file (created at the current schema if absent). Use as a context manager or :meth:`close`."""

    def __init__(self, path: str | os.PathLike = DEFAULT_PATH):
        self.path = Path(path)
        if self.path.is_dir():
            raise DenavitError(f"{self.path}: expected a registry file (SQLite), got a folder")
        try:
            self.db = sqlite3.connect(self.path, isolation_level=None)  # transactions explicit (BEGIN / COMMIT)
            self.db.execute("PRAGMA foreign_keys = ON")
            _migrate(self.db, str(self.path))
        except sqlite3.DatabaseError as e:
            raise DenavitError(
                f"{self.path}: expected a denavit registry (SQLite), got an unreadable file ({e})"
            ) from None

    def close(self) -> None:
        self.db.close()

    def __enter__(self) -> Registry:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    @contextmanager
    def transaction(self) -> Iterator[sqlite3.Connection]:
        self.db.execute("BEGIN IMMEDIATE")
        try:
            yield self.db
        except BaseException:
            self.db.execute("ROLLBACK")
            raise
        self.db.execute("COMMIT")

    @property
    def version(self) -> int:
        return self.db.execute("SELECT version FROM schema_version").fetchone()[0]

    def add(self, entry: Entry, family: str) -> bool:
        """Register ``entry`` (and its robot, if new, in ``family``) in one transaction; False if an entry of the
        same content key is there already (nothing written)."""
        if entry.status not in STATUSES:
            raise DenavitError(f"entry status: expected one of {', '.join(STATUSES)}, got {entry.status!r}")
        with self.transaction() as db:
            db.execute(
                "INSERT INTO robots (id, family, created) VALUES (?, ?, ?) ON CONFLICT(id) DO NOTHING",
                (entry.robot_id, family, entry.created or now()),
            )
            cur = db.execute(
                "INSERT INTO entries (robot_id, key, job, status, error, robot_file, convention, method, "
                "model_checksum, metrics, provenance, created, denavit_version) "
                "VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?) ON CONFLICT(key) DO NOTHING",
                (
                    entry.robot_id,
                    entry.key,
                    entry.job,
                    entry.status,
                    entry.error,
                    entry.robot_file,
                    entry.convention,
                    entry.method,
                    entry.model_checksum,
                    json.dumps(entry.metrics, sort_keys=True),
                    json.dumps({"call": entry.call}, sort_keys=True),
                    entry.created or now(),
                    entry.denavit_version,
                ),
            )
            if cur.rowcount == 0:
                return False
            db.executemany(
                "INSERT INTO inputs (entry_seq, role, name, sha256) VALUES (?, ?, ?, ?)",
                [(cur.lastrowid, i.role, i.name, i.sha256) for i in entry.inputs],
            )
        return True

    def has(self, key: str) -> bool:
        return self.db.execute("SELECT 1 FROM entries WHERE key = ?", (key,)).fetchone() is not None

    def robots(self) -> list[tuple[str, str]]:
        """(id, family) of every robot, by id."""
        return [tuple(r) for r in self.db.execute("SELECT id, family FROM robots ORDER BY id")]

    def entries(self, robot_id: str | None = None) -> list[Entry]:
        """Every entry (of one robot), oldest first."""
        where, args = ("WHERE robot_id = ?", (robot_id,)) if robot_id is not None else ("", ())
        rows = self.db.execute(
            "SELECT seq, robot_id, key, job, status, error, robot_file, convention, method, model_checksum, metrics, "
            f"provenance, created, denavit_version FROM entries {where} ORDER BY seq",
            args,
        ).fetchall()
        inputs: dict[int, list[Input]] = {}
        for seq, role, name, sha in self.db.execute("SELECT entry_seq, role, name, sha256 FROM inputs ORDER BY rowid"):
            inputs.setdefault(seq, []).append(Input(role, name, sha))
        return [
            Entry(
                robot_id=r[1],
                key=r[2],
                job=r[3],
                status=r[4],
                error=r[5],
                robot_file=r[6],
                convention=r[7],
                method=r[8],
                model_checksum=r[9],
                metrics=json.loads(r[10]),
                call=json.loads(r[11]).get("call", ""),
                inputs=tuple(inputs.get(r[0], ())),
                created=r[12],
                denavit_version=r[13],
                seq=r[0],
            )
            for r in rows
        ]

    def entry(self, robot_id: str, seq: int | None = None, *, model: bool = True) -> Entry:
        """Entry ``seq`` of a robot, or (None) its latest one that holds a model (``model``) or its latest one."""
        found = self.entries(robot_id)
        if not found:
            known = ", ".join(r for r, _ in self.robots()[:10]) or "none"
            raise DenavitError(f"robot {robot_id!r}: not in {self.path} (robots: {known})")
        if seq is not None:
            hit = [e for e in found if e.seq == seq]
            if not hit:
                seqs = ", ".join(str(e.seq) for e in found)
                raise DenavitError(f"robot {robot_id!r}: no entry {seq} in {self.path} (its entries: {seqs})")
            return hit[0]
        if model:
            found = [e for e in found if e.status == "ok" and e.robot_file and e.job in MODEL_JOBS]
            if not found:
                raise DenavitError(
                    f"robot {robot_id!r}: no model registered in {self.path} (fleet add, or a calibration)"
                )
        return found[-1]


#: The jobs whose entries hold a model of the robot (the others, validate and check, hold the model they scored).
MODEL_JOBS = ("add", "identify", "calibrate")
