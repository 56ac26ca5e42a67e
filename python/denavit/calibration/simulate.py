"""Simulated calibration measurements of a model: tool points or poses with Gaussian noise."""

from __future__ import annotations

import numpy as np

from .. import _core, limits
from ..errors import DenavitError, check_seed
from ..geometry import rotvec_matrix
from ..robot import robot_of
from .measurements import Measurements


def simulate(
    model,
    q,
    *,
    tool=(0.05, 0.03, 0.10),
    noise: float = 0.0,
    noise_rot: float = 0.0,
    measure: str = "point",
    seed: int = 0,
    T_world_base=None,
) -> Measurements:
    """Measurements of ``model`` (a Model / Robot / name) at configurations ``q`` (N, n): the tool point (3,)
    in the flange frame (for ``measure="pose"``, ``T_flange_tool`` (4, 4), or a point: a frame there with the
    flange's axes; None: the flange) with Gaussian noise ``noise``
    (m, per coordinate) and ``noise_rot`` (rad, a rotation vector per pose); ``T_world_base`` moves the robot
    in the measurement frame."""
    m = model if isinstance(model, _core.Model) else robot_of(model).model()
    if T_world_base is not None:
        m = m.with_base(np.asarray(T_world_base, dtype=float))
    if measure not in ("point", "pose"):
        raise DenavitError(f"simulate: measure: expected 'point' or 'pose', got {measure!r}")
    Q = np.atleast_2d(limits.floats(q, "simulate: q"))
    # the tool: a point (3,) in the flange frame, a pose (4, 4) T_flange_tool, or None (the flange itself); a pose
    # measurement of a point is the pose of a frame at that point with the flange's axes
    tool_point = np.zeros(3) if tool is None else np.asarray(tool, dtype=float)
    if tool_point.shape not in ((3,), (4, 4)):
        raise DenavitError(
            "simulate: tool: expected a point (3,) in the flange frame, a pose (4, 4) or None, got shape"
            f" {tool_point.shape}"
        )
    if measure == "point" and tool_point.shape == (4, 4):
        tool_point = tool_point[:3, 3]
    if measure == "pose" and tool_point.shape == (3,):
        tool_point = np.block([[np.eye(3), tool_point[:, None]], [np.zeros((1, 3)), np.ones((1, 1))]])
    limits.check_lengths(tool_point[:3, 3] if tool_point.shape == (4, 4) else tool_point, "simulate: tool")
    limits.check_noise(noise, "simulate: noise", m, tool_point[:3, 3] if tool_point.shape == (4, 4) else tool_point)
    limits.check_angle_noise(noise_rot, "simulate: noise_rot")
    rng = np.random.default_rng(check_seed(seed))
    if measure == "pose":
        T = _core.fk_batch(m.with_tool(tool_point), Q)
        if noise > 0:
            T[:, :3, 3] += rng.normal(0.0, noise, (len(Q), 3))
        if noise_rot > 0:
            T[:, :3, :3] = rotvec_matrix(rng.normal(0.0, noise_rot, (len(Q), 3))) @ T[:, :3, :3]
        return Measurements(Q, None, T, f"simulated {m.name}", kinds=m.kinds)
    F = _core.fk_batch(m.with_tool(np.eye(4)), Q)
    p = F[:, :3, :3] @ tool_point + F[:, :3, 3]
    if noise > 0:
        p = p + rng.normal(0.0, noise, p.shape)
    return Measurements(Q, p, None, f"simulated {m.name}", kinds=m.kinds)
