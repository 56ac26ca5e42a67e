"""One fleet job as a task: the existing API functions (:mod:`denavit.api`) on pickled inputs, run anywhere (a Dask
worker, or this process), returning what the registry records.

A task carries its input files as bytes (a worker need not see the client's disk), writes them into a temporary
folder under their own names (so the readers sniff formats as they do for the command line) and calls the API.
A job that fails for its data (a :class:`~denavit.errors.DenavitError`, an unreadable file) returns ``failed`` with
the one-line message, the temporary folder replaced by the file's name as the manifest gives it; so does any other
error, as ``internal error: ...`` (a defect of denavit, reported once rather than retried).
"""

from __future__ import annotations

import os
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import DenavitError

#: The jobs a manifest may name: ``add`` registers a model as it is; the others call the API.
JOBS = ("add", "identify", "calibrate", "validate", "check")
#: How many configurations (within the limits) the predicted error of a registered model is the median over.
PREDICTED_CONFIGURATIONS = 32


@dataclass(frozen=True)
class JobSpec:
    """A job, picklable: ``files`` are (role, name as given, bytes); ``nominal`` a built-in name (or None when the
    nominal is a file among ``files``); ``options`` the API function's keyword arguments (SI)."""

    robot_id: str
    job: str
    nominal: str | None
    files: tuple
    options: dict = field(default_factory=dict)


@dataclass(frozen=True)
class Outcome:
    """What a job returns: ``status`` ok / failed, ``error`` (one line), the model's robot file text (mm, deg) and
    checksum, ``metrics`` (SI) and the job's own time (s, on the worker)."""

    status: str
    error: str | None = None
    robot_file: str | None = None
    convention: str | None = None
    method: str | None = None
    model_checksum: str | None = None
    metrics: dict = field(default_factory=dict)
    seconds: float = 0.0


def _one_line(e: BaseException, names: dict) -> str:
    if isinstance(e, OSError) and e.filename:
        text = f"{e.filename}: {e.strerror or e}"
    elif isinstance(e, (DenavitError, OSError)):
        text = str(e)
    else:
        text = f"internal error: {type(e).__name__}: {e}"
    for tmp, name in names.items():
        text = text.replace(tmp, name)
    return " ".join(text.split())


def run_job(spec: JobSpec) -> Outcome:
    """Run one job (module docstring); never raises for the job's data."""
    start = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="denavit-job-") as tmp:
        paths: dict[str, list[Path]] = {}
        names: dict[str, str] = {}
        for k, (role, name, data) in enumerate(spec.files):
            p = Path(tmp) / str(k) / Path(name).name
            p.parent.mkdir()
            p.write_bytes(data)
            paths.setdefault(role, []).append(p)
            names[str(p)] = name
        try:
            out = _JOBS[spec.job](spec, paths)
        except Exception as e:  # noqa: BLE001 (every failure becomes the entry's one-line error)
            out = Outcome("failed", _one_line(e, names))
    text = out.robot_file
    for tmp, name in names.items():  # the file's source lines name the input as given, not the temporary copy
        text = text.replace(tmp, name) if text is not None else None
    return Outcome(**{**out.__dict__, "robot_file": text, "seconds": time.perf_counter() - start})


def _nominal(spec: JobSpec, paths: dict):
    from ..io.robots import load  # noqa: PLC0415

    return load(os.fspath(paths["nominal"][0]) if "nominal" in paths else spec.nominal)


def _registered(robot, method: str | None) -> Outcome:
    """The outcome of a job that made ``robot``: its file text (mm, deg), read back for the checksum and the predicted
    error (so both are those of the registered text)."""
    from ..compensation import table_sigma  # noqa: PLC0415
    from ..io.robotfile import dumps, from_dict, tomllib  # noqa: PLC0415
    from .checksum import model_checksum  # noqa: PLC0415

    text = dumps(robot, "mm", "deg")
    back = from_dict(tomllib.loads(text), "registered model")
    metrics = {}
    if back.covariance is not None:
        from ..calibration.parametrization import configurations  # noqa: PLC0415

        q = configurations(back, PREDICTED_CONFIGURATIONS)
        metrics["predicted_error_m"] = float(np.median(table_sigma(back, q)))
    return Outcome("ok", None, text, back.convention, method, model_checksum(back), metrics)


def _add(spec: JobSpec, paths: dict) -> Outcome:
    return _registered(_nominal(spec, paths), "given")


def _identify(spec: JobSpec, paths: dict) -> Outcome:
    from ..api import identify  # noqa: PLC0415

    res = identify(paths["data"][0], nominal=_nominal(spec, paths), **spec.options)
    out = _registered(res.robot(), res.method)
    metrics = {**out.metrics, "rms_m": float(res.rms), "points": int(sum(len(s.points) for s in res.sweeps.sweeps))}
    return Outcome(**{**out.__dict__, "metrics": metrics})


def _calibrate(spec: JobSpec, paths: dict) -> Outcome:
    from ..api import calibrate  # noqa: PLC0415

    cal = calibrate(paths["data"][0], _nominal(spec, paths), **spec.options)
    chosen = cal.model_choice.chosen if cal.model_choice is not None else None
    out = _registered(cal.robot(convention=cal.convention), f"least squares ({chosen})" if chosen else "least squares")
    metrics = {**out.metrics, "rms_m": float(cal.rms), "poses": int(cal.measurements.n), "converged": cal.converged}
    if cal.validation is not None:
        metrics["held_out_rms_m"] = float(cal.validation.after_rms)
    return Outcome(**{**out.__dict__, "metrics": metrics})


def _model(paths: dict):
    from ..io.robotfile import read  # noqa: PLC0415

    return read(paths["model"][0])


def _validate(spec: JobSpec, paths: dict) -> Outcome:
    from ..api import validate  # noqa: PLC0415
    from .checksum import model_checksum  # noqa: PLC0415

    robot = _model(paths)
    v = validate(robot, paths["data"][0], **spec.options)
    metrics = {"rms_m": float(v.rms), "max_m": float(v.max), "poses": int(v.n), "flagged": int(v.n_flagged)}
    return Outcome("ok", None, None, robot.convention, "validate", model_checksum(robot), metrics)


def _check(spec: JobSpec, paths: dict) -> Outcome:
    from .check import drift_check  # noqa: PLC0415
    from .checksum import model_checksum  # noqa: PLC0415

    robot = _model(paths)
    c = drift_check(robot, paths["data"][0], **spec.options)
    return Outcome("ok", None, None, robot.convention, "chi-square drift check", model_checksum(robot), c.metrics())


_JOBS = {"add": _add, "identify": _identify, "calibrate": _calibrate, "validate": _validate, "check": _check}
