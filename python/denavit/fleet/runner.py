"""``fleet run MANIFEST``: a manifest's jobs run as Dask tasks (or in this process), their results registered by
this process alone (docs/fleet.md).

A manifest is TOML: ``[[robot]]`` tables with ``id``, ``nominal`` (a built-in name, robot file or URDF), ``job``
(:data:`~denavit.fleet.jobs.JOBS`), ``data`` (a path, or a list of paths: one job per file; relative to the
manifest; not for ``add``), optionally ``family`` (default: the nominal's name) and the job's options as further keys
(the Python API's keyword arguments, SI). Model jobs (add, identify, calibrate) run first; validate and check then
score each robot's latest registered model.

Every job is keyed by its content (:func:`~denavit.fleet.registry.content_key`); a job whose key is registered is
not run again. Results are registered as they arrive, one transaction each, so an interrupted run keeps what it
finished. A worker lost mid-task is Dask's to retry (the task runs again elsewhere; nothing was written for it); a
task that still cannot finish (Dask's ``KilledWorker`` after its allowed failures) is counted as lost, not
registered, and runs again next time.
"""

from __future__ import annotations

import inspect
import os
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

from ..errors import DenavitError
from .jobs import JOBS, JobSpec, Outcome, run_job
from .registry import Entry, Input, Registry, content_key, now, sha256_bytes

#: Manifest keys that are not the job's options.
RESERVED = ("id", "nominal", "job", "data", "family")
#: Dask's retries of a task whose run raised (worker losses are retried by the scheduler on their own).
RETRIES = 2


@dataclass(frozen=True)
class Job:
    """A planned job: the task's spec, and what the registry records beside the outcome."""

    spec: JobSpec
    family: str
    key: str
    inputs: tuple
    call: str
    missing: str | None = None  # a data file that is not there: registered as failed without running


@dataclass
class Summary:
    """What a run did: jobs ``added`` (ok / failed), ``skipped`` (registered already), ``lost`` (not finished, not
    registered) and every outcome's time on its worker (s)."""

    added_ok: int = 0
    added_failed: int = 0
    skipped: int = 0
    lost: list = field(default_factory=list)
    job_seconds: list = field(default_factory=list)

    @property
    def added(self) -> int:
        return self.added_ok + self.added_failed


def _option_names(job: str) -> set[str]:
    from .. import api  # noqa: PLC0415
    from ..calibration import solve  # noqa: PLC0415
    from ..calibration import validate as va  # noqa: PLC0415
    from ..identification import run  # noqa: PLC0415
    from . import check  # noqa: PLC0415

    functions = {
        "add": (),
        "identify": (api.identify, run.identify),
        "calibrate": (api.calibrate, solve.calibrate),
        "validate": (api.validate, va.validate),
        "check": (check.drift_check,),
    }[job]
    names = {p for f in functions for p in inspect.signature(f).parameters}
    scored = {"model", "robot"} if job in ("validate", "check") else set()  # the registered model, not an option
    return names - {"data", "nominal", "meas", "sweeps", "options", "progress", "points", "poses"} - scored


def read_manifest(path: str | os.PathLike) -> list[dict]:
    """The ``[[robot]]`` tables of a manifest, checked (one-line errors naming the table)."""
    from ..io.robotfile import tomllib  # noqa: PLC0415 (Python 3.10's tomli where 3.11's tomllib is absent)
    from ..io.text import read_text  # noqa: PLC0415

    p = Path(path)
    try:
        doc = tomllib.loads(read_text(p, "manifest"))
    except tomllib.TOMLDecodeError as e:
        raise DenavitError(f"{p}: expected a TOML manifest ([[robot]] tables), got invalid TOML ({e})") from None
    tables = doc.get("robot")
    if not isinstance(tables, list) or not tables or set(doc) - {"robot"}:
        raise DenavitError(f"{p}: expected [[robot]] tables only, got keys {sorted(doc)}")
    seen = set()
    for k, t in enumerate(tables, 1):
        where = f"{p}, robot {k}" + (f" ({t.get('id')})" if isinstance(t.get("id"), str) else "")
        if not isinstance(t.get("id"), str) or not t["id"].strip():
            raise DenavitError(f'{where}: expected id = "..." (a serial number or name)')
        if not isinstance(t.get("nominal"), str):
            raise DenavitError(f'{where}: expected nominal = "..." (a built-in name, robot file or URDF)')
        if t.get("job") not in JOBS:
            raise DenavitError(f"{where}: job: expected one of {', '.join(JOBS)}, got {t.get('job')!r}")
        data = t.get("data")
        if t["job"] == "add":
            if data is not None:
                raise DenavitError(f"{where}: job add registers the nominal as it is; data does not apply")
        elif not (isinstance(data, str) or (isinstance(data, list) and data and all(isinstance(d, str) for d in data))):
            raise DenavitError(f'{where}: expected data = "path" or a list of paths (relative to the manifest)')
        wrong = sorted(set(t) - set(RESERVED) - _option_names(t["job"]))
        if wrong:
            raise DenavitError(
                f"{where}: unknown option {', '.join(wrong)} for {t['job']} "
                f"(expected: {', '.join(sorted(_option_names(t['job'])))})"
            )
        if (t["id"], t["job"], str(data)) in seen:
            raise DenavitError(f"{where}: the same robot, job and data as an earlier table")
        seen.add((t["id"], t["job"], str(data)))
    return tables


def _read_input(role: str, path: Path, name: str) -> tuple[Input, bytes | None]:
    try:
        data = path.read_bytes()
    except OSError:
        return Input(role, name, "missing"), None
    return Input(role, name, sha256_bytes(data)), data


def plan_jobs(path: str | os.PathLike, registry: Registry, tables: list[dict], models: bool) -> list[Job]:
    """The jobs of a manifest's ``tables``: model jobs (``models``) or the scoring jobs (validate, check), these at
    each robot's latest registered model."""
    from ..io.robots import builtin_names, resolve  # noqa: PLC0415

    base = Path(path).parent
    jobs = []
    for t in tables:
        if (t["job"] in ("add", "identify", "calibrate")) != models:
            continue
        options = {k: v for k, v in t.items() if k not in RESERVED}
        files, inputs, nominal = [], [], None
        if t["nominal"].lower().replace("-", "_") in builtin_names() and not (base / t["nominal"]).exists():
            nominal = t["nominal"]
            inputs.append(Input("nominal", nominal, sha256_bytes(resolve(nominal).read_bytes())))
        else:
            inp, data = _read_input("nominal", base / t["nominal"], t["nominal"])
            if data is None:
                raise DenavitError(f"{path}, robot {t['id']}: nominal {t['nominal']!r}: no such file or built-in name")
            inputs.append(inp)
            files.append(("nominal", t["nominal"], data))
        model_file = []
        if not models:
            e = registry.entry(t["id"])
            inputs.append(Input("model", f"registry entry {e.seq}", sha256_bytes(e.robot_file.encode())))
            model_file = [("model", f"registry entry {e.seq}.toml", e.robot_file.encode())]
        data_names = [t["data"]] if isinstance(t.get("data"), str) else (t.get("data") or [None])
        for name in data_names:
            job_inputs, job_files, missing = list(inputs), list(files) + model_file, None
            if name is not None:
                inp, data = _read_input("data", base / name, name)
                job_inputs.append(inp)
                if data is None:
                    missing = f"{name}: no such file"
                else:
                    job_files.append(("data", name, data))
            spec = JobSpec(t["id"], t["job"], nominal, tuple(job_files), options)
            args = ", ".join([repr(name)] * (name is not None) + [f"{k}={v!r}" for k, v in sorted(options.items())])
            call = f"fleet run {Path(path).name}: {t['job']}({args}) nominal={t['nominal']!r}"
            family = t.get("family") or Path(t["nominal"]).stem
            key = content_key(t["id"], t["job"], job_inputs, options)
            jobs.append(Job(spec, str(family), key, tuple(job_inputs), call, missing))
    return jobs


def _entry(job: Job, out: Outcome) -> Entry:
    from .. import __version__  # noqa: PLC0415

    return Entry(
        robot_id=job.spec.robot_id,
        key=job.key,
        job=job.spec.job,
        status=out.status,
        error=out.error,
        robot_file=out.robot_file,
        convention=out.convention,
        method=out.method,
        model_checksum=out.model_checksum,
        metrics=out.metrics,
        call=job.call,
        inputs=job.inputs,
        created=now(),
        denavit_version=__version__,
    )


def execute(jobs: list[Job], registry: Registry, summary: Summary, *, client=None, progress=None) -> None:
    """Run ``jobs`` (in this process without a ``client``, else as Dask tasks) and register each outcome as it
    arrives; ``progress(done, total)`` after each."""
    todo = []
    for job in jobs:
        if registry.has(job.key):
            summary.skipped += 1
        elif job.missing is not None:
            _register(registry, job, Outcome("failed", job.missing), summary)
        else:
            todo.append(job)
    total = len(todo)
    if progress is not None:
        progress(0, total)
    if client is None:
        for done, job in enumerate(todo, 1):
            _register(registry, job, run_job(job.spec), summary)
            if progress is not None:
                progress(done, total)
        return
    from dask.distributed import as_completed  # noqa: PLC0415

    futures = {
        client.submit(run_job, job.spec, key=f"denavit-job-{job.key[:24]}", pure=False, retries=RETRIES): job
        for job in todo
    }
    for done, fut in enumerate(as_completed(futures), 1):
        job = futures[fut]
        try:
            out = fut.result()
        except Exception as e:  # noqa: BLE001 (Dask's KilledWorker, a lost connection: not the job's data)
            summary.lost.append(f"{job.spec.robot_id} {job.spec.job}: {type(e).__name__}: {e}")
        else:
            _register(registry, job, out, summary)
        if progress is not None:
            progress(done, total)


def _register(registry: Registry, job: Job, out: Outcome, summary: Summary) -> None:
    if registry.add(_entry(job, out), job.family):
        summary.job_seconds.append(out.seconds)
        if out.status == "ok":
            summary.added_ok += 1
        else:
            summary.added_failed += 1
    else:
        summary.skipped += 1


def run_manifest(
    path: str | os.PathLike, registry: Registry, *, client=None, progress: Callable[[int, int], None] | None = None
) -> Summary:
    """Run a manifest's jobs (module docstring): without ``client`` in this process, else on its Dask cluster."""
    tables = read_manifest(path)
    summary = Summary()
    for models in (True, False):
        jobs = plan_jobs(path, registry, tables, models)
        if jobs:
            execute(jobs, registry, summary, client=client, progress=progress)
    return summary


def connect(scheduler: str | None = None, workers: int | None = None, *, required: bool = True):
    """A Dask client: to the scheduler at ``scheduler`` (``tcp://HOST:8786``), else of a new local cluster of
    ``workers`` processes (default: one per core), one thread each; None (run in this process) for ``workers=0``,
    and without Dask installed unless ``required`` or a cluster was asked for. Needs ``denavit[fleet]``."""
    if workers is not None and workers < 0:
        raise DenavitError(f"--workers: expected 0 or more worker processes, got {workers}")
    if workers == 0 and scheduler is None:
        return None
    try:
        from dask.distributed import Client, LocalCluster  # noqa: PLC0415
    except ImportError:
        if not required and scheduler is None and workers is None:
            return None
        raise DenavitError(
            "this runs on Dask: install the extra with pip install 'denavit[fleet]' (or --workers 0: in this process)"
        ) from None
    if scheduler is not None:
        return Client(scheduler)
    import logging  # noqa: PLC0415

    cluster = LocalCluster(
        n_workers=workers,
        threads_per_worker=1,
        processes=True,
        dashboard_address=None,
        silence_logs=logging.CRITICAL,  # a worker's own log lines (heartbeats at shutdown) are not the user's
    )
    return Client(cluster)


def disconnect(client) -> None:
    """Close a client of :func:`connect`: a local cluster is shut down with it (scheduler and workers), a remote one
    left running (None: nothing to close)."""
    if client is None:
        return
    if client.cluster is not None:
        client.shutdown()
    client.close()
