"""A robot re-expressed in another convention: its table extracted from its joint axes, and everything given in the
old table's frames or entries carried with it, so that the converted robot predicts, deflects and moves as the
original does (``denavit convert``, ``fleet diff``)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from . import _core
from .compensation import conversion_jacobian
from .errors import DenavitError
from .robot import Robot, inertials_for_table


def converted_robot(robot: Robot, table: _core.Table, **extract_options) -> tuple[Robot, str | None]:
    """(``robot`` with ``table``, its geometry in another convention extracted from its joint axes at q = 0 with
    ``extract_options``; a warning or None). Carried with it: the ``[covariance]`` (``J C J^T``, ``J`` the
    :func:`~denavit.compensation.conversion_jacobian`), the compliances' cross block with it (``J X``), the
    compliances' flange (where a payload's centre of mass is given) into the new last frame, and the link inertias into
    the new frames (:func:`~denavit.robot.inertials_for_table`; left out with the warning when the table does not
    reproduce the joint axes exactly). The compliances and their covariance are per joint: as they are."""
    m = robot.model()
    J = None if robot.covariance is None else conversion_jacobian(robot, table, **extract_options)
    cov = None if J is None else J @ np.asarray(robot.covariance, dtype=float) @ J.T
    cross = None if J is None or robot.compliance_cross is None else J @ np.asarray(robot.compliance_cross)
    flange = robot.compliance_flange
    if robot.compliance is not None:  # the mechanical flange in the new last frame: the same body, other frames
        q = np.zeros(m.nq)
        old = np.asarray(robot.table.frames(q))[-1] @ (np.eye(4) if flange is None else np.asarray(flange))
        flange = np.linalg.inv(np.asarray(table.frames(q))[-1]) @ old
        flange = None if np.allclose(flange, np.eye(4), rtol=0.0, atol=1e-12) else flange
    new = replace(robot, table=table, covariance=cov, compliance_cross=cross, compliance_flange=flange)
    if robot.inertials is None:
        return new, None
    try:  # the same physical links, re-expressed in the new convention's frames
        ins = inertials_for_table(m, table, robot.names, robot.lower, robot.upper)
    except DenavitError as e:
        lost = " nor the joints' compliances (they need them)" if robot.compliance is not None else ""
        warning = (
            f"link inertias not carried over{lost} (the {table.convention} table does not reproduce the joint axes"
            f" exactly): {e}"
        )
        bare = dict(compliance=None, compliance_covariance=None, compliance_cross=None, compliance_flange=None)
        return replace(new, inertials=None, **(bare if lost else {})), warning
    return replace(new, inertials=ins), None
