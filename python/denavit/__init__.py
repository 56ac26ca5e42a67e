"""denavit: find the true kinematic geometry of serial robots and compute with it.

One kinematic model for every convention (standard DH, modified DH, ED-H, POE, URDF), built from and
extracted to joint axis lines; fast kinematics in a Rust core. Conventions: docs/conventions.md.
"""

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
from .robot import Robot, builtin_names
from .robot import load as load_robot

__version__ = _core.__version__


def load_model(name_or_path) -> Model:
    """The model of a built-in robot name, a robot file (.toml) or a URDF."""
    return load_robot(name_or_path).model()


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
