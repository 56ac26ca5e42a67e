"""denavit: find the true kinematic geometry of serial robots and compute with it.

One kinematic model for every convention (standard DH, modified DH, ED-H, POE, URDF), built from and
extracted to joint axis lines; fast kinematics in a Rust core. Conventions: docs/conventions.md; the Python
API by example: docs/python.md.

The workflows are functions of the package, taking paths, built-in names or objects (:mod:`denavit.api`):
:func:`identify` (circle-point identification), :func:`calibrate`, :func:`plan`, :func:`simulate`,
:func:`compensate`, :func:`validate`. ``denavit.identify`` is the function; the
identification's package (its steps, results, JSON) is :mod:`denavit.identification`
(``from denavit.identification import Identification``); :func:`save` writes an identification as a robot file or URDF,
and
:mod:`denavit.io.results` holds the results' JSON. The workflows and :class:`Robot` load on first use,
so ``import denavit`` loads the Rust core only.
"""

from __future__ import annotations

from importlib import import_module

from . import _core
from ._core import (
    Extraction,
    IkBatchResult,
    IkResult,
    JointAxes,
    Model,
    PairDiagnostic,
    Table,
    axes,
    bias_forces,
    bias_forces_batch,
    coriolis_matrix,
    coriolis_matrix_batch,
    extract,
    fk,
    fk_batch,
    forward_dynamics,
    forward_dynamics_batch,
    gravity_torques,
    gravity_torques_batch,
    ik,
    ik_batch,
    ik_path,
    jacobian,
    jacobian_batch,
    joint_frames,
    kinetic_energy,
    mass_matrix,
    mass_matrix_batch,
    potential_energy,
    rnea,
    rnea_batch,
    transfer_inertias,
)
from .errors import DegenerateError, DenavitError, DenavitWarning, NotConvergedError

__version__ = _core.__version__

# The workflows and the robot record load on first use (PEP 562), so that `denavit --help` and `import
# denavit` do not pay for numpy and the Python layers behind them: name -> (module, attribute).
_LAZY = {
    **{f: (".api", f) for f in ("calibrate", "compensate", "identify", "plan", "read_sweeps", "simulate", "validate")},
    "Robot": (".robot", "Robot"),
    "builtin_names": (".io.robots", "builtin_names"),
    "load_robot": (".io.robots", "load"),
    "save": (".io.results", "save"),
}


#: The subpackages and modules reachable as attributes (``dv.calibration.Measurements``), imported on first use as
#: scipy's are.
_SUBMODULES = (
    "api",
    "calibration",
    "compensation",
    "fitting",
    "geometry",
    "identification",
    "io",
    "limits",
    "plotting",
    "recording",
    "report",
    "robot",
    "sweeps",
)


def __getattr__(name: str):
    if name in _SUBMODULES:
        return import_module(f".{name}", __name__)
    if name not in _LAZY:
        raise AttributeError(f"module 'denavit' has no attribute {name!r}")
    module, attr = _LAZY[name]
    value = getattr(import_module(module, __name__), attr)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted({*globals(), *_LAZY, *_SUBMODULES})


def load_model(name_or_path, *, base_link: str | None = None, tip_link: str | None = None) -> Model:
    """The model of a built-in robot name, a robot file (.toml) or a URDF (``base_link`` / ``tip_link`` pick
    a URDF's chain; by default its single leaf, REP-199's ``tool0``, or the leaf through the most moving joints)."""
    from .io.robots import load as load_robot  # noqa: PLC0415

    return load_robot(name_or_path, base_link=base_link, tip_link=tip_link).model()


def to_table(model: Model, convention: str, *, q_ref=None, nominal: Table | None = None, **options) -> Extraction:
    """Express ``model`` in ``convention`` through its joint axes (at ``q_ref``, default zeros).

    Returns the :class:`Extraction` (table, per-pair diagnostics, the tool error the table carries).
    ``options`` are those of :func:`extract` (``parallel_tol``, ``intersect_tol``, ``max_offset``, ``origins``).
    """
    import numpy as np  # noqa: PLC0415

    q = np.zeros(model.nq) if q_ref is None else q_ref
    return extract(axes(model, q), convention, nominal=nominal, **options)


__all__ = [
    "DegenerateError",
    "DenavitError",
    "DenavitWarning",
    "Extraction",
    "IkBatchResult",
    "IkResult",
    "JointAxes",
    "Model",
    "NotConvergedError",
    "PairDiagnostic",
    "Robot",
    "Table",
    "axes",
    "bias_forces",
    "bias_forces_batch",
    "coriolis_matrix",
    "coriolis_matrix_batch",
    "forward_dynamics",
    "forward_dynamics_batch",
    "gravity_torques",
    "gravity_torques_batch",
    "kinetic_energy",
    "mass_matrix",
    "mass_matrix_batch",
    "potential_energy",
    "rnea",
    "rnea_batch",
    "transfer_inertias",
    "builtin_names",
    "calibrate",
    "compensate",
    "identify",
    "plan",
    "read_sweeps",
    "simulate",
    "extract",
    "fk",
    "fk_batch",
    "ik",
    "ik_batch",
    "ik_path",
    "jacobian",
    "jacobian_batch",
    "joint_frames",
    "load_model",
    "load_robot",
    "to_table",
]
