"""A robot's history in the registry: the fleet's status (latest model, accuracy, drift per robot), the parameter
changes between two calibrations with their sigmas, a registered model as a Robot, and registering a given model."""

from __future__ import annotations

import os
from dataclasses import dataclass

import numpy as np

from ..errors import DenavitError
from .registry import MODEL_JOBS, Entry, Registry

#: A parameter changed beyond noise when its change exceeds this many sigmas of the change.
CHANGE_SIGMAS = 3.0
#: Changes below this (m, rad) are rounding, not changes (the model checksum's resolution).
RESOLUTION = 1e-8


def robot_of(entry: Entry):
    """The Robot (SI) of an entry's robot file text."""
    from ..io.robotfile import from_dict, tomllib  # noqa: PLC0415

    if not entry.robot_file:
        raise DenavitError(f"robot {entry.robot_id!r}, entry {entry.seq}: holds no model ({entry.job}, {entry.status})")
    return from_dict(tomllib.loads(entry.robot_file), f"registry entry {entry.seq} of {entry.robot_id}")


def status(registry: Registry) -> dict:
    """The fleet's status as JSON (SI): per robot its entries, the latest entry, the latest model and the latest
    drift check (docs/fleet.md)."""
    robots = []
    for rid, family in registry.robots():
        entries = registry.entries(rid)
        models = [e for e in entries if e.job in MODEL_JOBS and e.status == "ok"]
        checks = [e for e in entries if e.job == "check" and e.status == "ok"]
        latest = entries[-1]
        robots.append(
            {
                "id": rid,
                "family": family,
                "entries": len(entries),
                "latest": {**latest.summary(), **latest.metrics},
                "model": None if not models else models[-1].summary(),
                "drift": None if not checks else checks[-1].summary(),
            }
        )
    return {"registry": str(registry.path), "robots": robots}


@dataclass(frozen=True)
class Diff:
    """The parameter changes from entry ``a`` to entry ``b`` of one robot: per parameter its name, the values (SI),
    the change and its sigma (independent calibrations: ``sqrt(sigma_a^2 + sigma_b^2)``; NaN where either model carries
    no covariance or did not estimate it), and whether it changed beyond :data:`CHANGE_SIGMAS` sigmas (and beyond
    :data:`RESOLUTION`; a parameter without a sigma is never flagged). Entries of different conventions compare in
    ``a``'s: ``b`` converted (:func:`in_convention`) from ``converted_from``."""

    robot_id: str
    a: Entry
    b: Entry
    names: list
    angle: np.ndarray
    value_a: np.ndarray
    value_b: np.ndarray
    sigma: np.ndarray
    converted_from: str | None = None

    @property
    def change(self) -> np.ndarray:
        return self.value_b - self.value_a

    @property
    def changed(self) -> np.ndarray:
        return np.abs(self.change) > np.maximum(CHANGE_SIGMAS * np.nan_to_num(self.sigma, nan=np.inf), RESOLUTION)

    def to_json(self) -> dict:
        return {
            "robot": self.robot_id,
            "a": self.a.summary(),
            "b": self.b.summary(),
            "convention": self.a.convention,
            "b_converted_from": self.converted_from,
            "parameters": [
                {
                    "name": n,
                    "unit": "rad" if ang else "m",
                    "a": float(va),
                    "b": float(vb),
                    "change": float(vb - va),
                    "sigma": None if not np.isfinite(s) else float(s),
                    "changed": bool(c),
                }
                for n, ang, va, vb, s, c in zip(
                    self.names, self.angle, self.value_a, self.value_b, self.sigma, self.changed
                )
            ],
        }


def _values(robot) -> tuple[list, np.ndarray, np.ndarray, np.ndarray]:
    from .. import _core  # noqa: PLC0415

    t = robot.table
    info = _core.convention_info(t.convention)
    names = [f"{c}_{i + 1}" for i in range(len(robot.names)) for c in info["columns"]]
    angle = np.array(list(info["angle_columns"]) * len(robot.names) + [False] * 3)
    values = np.concatenate([np.asarray(t.params, dtype=float).ravel(), np.asarray(t.T_last_tool)[:3, 3]])
    n = len(values)
    cov = robot.covariance
    sigma = np.sqrt(np.maximum(np.diag(cov)[:n], 0.0)) if cov is not None else np.full(n, np.nan)
    sigma[sigma == 0] = np.nan  # not estimated (fixed by the calibration): no sigma to judge a change by
    return [*names, "tool_x", "tool_y", "tool_z"], angle, values, sigma


def diff(registry: Registry, robot_id: str, a: int | None = None, b: int | None = None) -> Diff:
    """The changes between entries ``a`` and ``b`` of a robot (default: its two latest models)."""
    if (a is None) != (b is None):
        raise DenavitError("fleet diff: expected two entries A B, or none (the two latest models)")
    if a is None:
        models = [e for e in registry.entries(robot_id) if e.status == "ok" and e.robot_file and e.job in MODEL_JOBS]
        if len(models) < 2:
            registry.entry(robot_id)  # an unknown robot's message
            raise DenavitError(f"robot {robot_id!r}: {len(models)} model(s) registered, a diff needs two")
        ea, eb = models[-2], models[-1]
    else:
        ea, eb = registry.entry(robot_id, a), registry.entry(robot_id, b)
    ra, rb = robot_of(ea), robot_of(eb)
    if list(ra.table.kinds) != list(rb.table.kinds):
        raise DenavitError(
            f"robot {robot_id!r}: entries {ea.seq} ({''.join(k[0].upper() for k in ra.table.kinds)}) and {eb.seq} "
            f"({''.join(k[0].upper() for k in rb.table.kinds)}): expected the same joints, got different chains"
        )
    converted = None
    if rb.convention != ra.convention:
        converted = rb.convention
        rb = in_convention(rb, ra.table)
    names, angle, va, sa = _values(ra)
    _, _, vb, sb = _values(rb)
    vb[angle] = va[angle] + (vb[angle] - va[angle] + np.pi) % (2 * np.pi) - np.pi  # one turn is no change
    return Diff(robot_id, ea, eb, names, angle, va, vb, np.sqrt(sa**2 + sb**2), converted)


def in_convention(robot, reference):
    """``robot`` re-expressed in the convention of the table ``reference`` (the core's extraction from its joint
    axes at q = 0, following ``reference``'s frame choices), its covariance converted with it
    (:func:`denavit.conversion.converted_robot`)."""
    from .. import _core  # noqa: PLC0415
    from ..conversion import converted_robot  # noqa: PLC0415

    m = robot.model()
    r = reference  # placed where the robot is (its base: a calibration's registration), as calibrate extracts
    reference = _core.Table(r.convention, r.params, r.kinds, m.T_world_base, r.T_last_tool)
    table = _core.extract(_core.axes(m, np.zeros(m.nq)), reference.convention, nominal=reference).table
    return converted_robot(robot, table, nominal=reference)[0]


def add_model(registry: Registry, robot_id: str, model: str | os.PathLike, family: str | None = None) -> tuple:
    """Register ``model`` (a built-in name, robot file, URDF or UR kinematics file) as given for ``robot_id``:
    (entry, added: False when the same model was registered for it already)."""
    from pathlib import Path  # noqa: PLC0415

    from .. import __version__  # noqa: PLC0415
    from ..io.robots import builtin_names, resolve  # noqa: PLC0415
    from .jobs import JobSpec, run_job  # noqa: PLC0415
    from .registry import Input, content_key, now, sha256_bytes  # noqa: PLC0415

    name = os.fspath(model)
    builtin = name.lower().replace("-", "_") in builtin_names() and not Path(name).exists()
    data = resolve(name).read_bytes()
    files = () if builtin else (("nominal", name, data),)
    inputs = (Input("nominal", name, sha256_bytes(data)),)
    out = run_job(JobSpec(robot_id, "add", name if builtin else None, files, {}))
    if out.status != "ok":
        raise DenavitError(out.error)
    entry = Entry(
        robot_id=robot_id,
        key=content_key(robot_id, "add", inputs, {}),
        job="add",
        status="ok",
        robot_file=out.robot_file,
        convention=out.convention,
        method=out.method,
        model_checksum=out.model_checksum,
        metrics=out.metrics,
        call=f"fleet add {robot_id} {name}",
        inputs=inputs,
        created=now(),
        denavit_version=__version__,
    )
    return entry, registry.add(entry, family or Path(name).stem)


def record_check(registry: Registry, robot_id: str, data: str | os.PathLike, **options) -> tuple:
    """The drift check (:func:`denavit.fleet.check.drift_check`) of a registered robot's latest model on ``data``,
    registered as a ``check`` entry: (DriftCheck, entry, added: False when this check was registered already)."""
    from pathlib import Path  # noqa: PLC0415

    from .. import __version__  # noqa: PLC0415
    from .check import drift_check  # noqa: PLC0415
    from .checksum import model_checksum  # noqa: PLC0415
    from .registry import Input, content_key, now, sha256_bytes  # noqa: PLC0415

    model = registry.entry(robot_id)
    robot = robot_of(model)
    result = drift_check(robot, data, **options)  # a bad file raises: nothing registered for a command line's typo
    name = os.fspath(data)
    inputs = (
        Input("model", f"registry entry {model.seq}", sha256_bytes(model.robot_file.encode())),
        Input("data", name, sha256_bytes(Path(name).read_bytes())),
    )
    entry = Entry(
        robot_id=robot_id,
        key=content_key(robot_id, "check", inputs, options),
        job="check",
        status="ok",
        convention=robot.convention,
        method="chi-square drift check",
        model_checksum=model_checksum(robot),
        metrics=result.metrics(),
        call=f"check {robot_id} {name}" + "".join(f" {k}={v!r}" for k, v in sorted(options.items())),
        inputs=inputs,
        created=now(),
        denavit_version=__version__,
    )
    family = dict(registry.robots()).get(robot_id, "")
    return result, entry, registry.add(entry, family)
