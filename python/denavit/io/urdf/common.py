"""What reading and writing URDF share: the joint kinds, the z-to-axis rotation, numbers as URDF text."""

from __future__ import annotations

import numpy as np

from ...geometry import pose, rotation_between

SUPPORTED_JOINTS = ("revolute", "continuous", "prismatic", "fixed")
UNSUPPORTED_JOINTS = ("floating", "planar")


def z_to(a) -> np.ndarray:
    """The rotation ``R_a`` (3, 3) that takes the z axis to the unit vector ``a``, deterministically.

    The smallest rotation (Rodrigues, about ``z × a``); when ``a`` points into the lower half-space a half
    turn about x comes first (``R_a = Rx(pi) · R_min``), which keeps the formula well conditioned.
    ``z_to([0, 0, 1])`` is exactly the identity.
    """
    a = np.asarray(a, dtype=float)
    a = a / np.linalg.norm(a)
    flip = a[2] < 0.0
    if flip:  # Rx(pi)^T a, now in the upper half-space
        a = np.array([a[0], -a[1], -a[2]])
    R = rotation_between(np.array([0.0, 0.0, 1.0]), a)
    if flip:
        R = np.diag([1.0, -1.0, -1.0]) @ R
    return R


def _num(v: float) -> str:
    """A float as URDF text: repr (the shortest form that reads back to the same double, <= 17
    significant digits); rounding residue below 1e-15 (e.g. cos(pi/2) = 6e-17) is written as 0."""
    v = float(v)
    return "0" if abs(v) < 1e-15 else repr(v)


def _nums(vs) -> str:
    return " ".join(_num(v) for v in vs)


def _mat(T) -> list[list[float]]:
    return [[float(x) for x in row] for row in np.asarray(T, dtype=float)]


def combine_inertials(parts: list[tuple[np.ndarray, float, np.ndarray]]) -> tuple[np.ndarray, float, np.ndarray] | None:
    """One rigid body's inertial from several: ``parts`` = (pose of each inertial frame in the body frame
    (4, 4), mass kg, inertia (3, 3) kg m^2 about the centre of mass in that frame). Returns the pose (at the
    common centre of mass, body orientation), the total mass and the inertia there (parallel-axis theorem,
    Featherstone 2008 sec. 2.13); a single part is returned unchanged; None without mass."""
    parts = [p for p in parts if p[1] > 0.0]
    if not parts:
        return None
    if len(parts) == 1:
        return parts[0]
    M = sum(m for _, m, _ in parts)
    c = sum(m * T[:3, 3] for T, m, _ in parts) / M
    I = np.zeros((3, 3))
    for T, m, Ic in parts:
        R, d = T[:3, :3], T[:3, 3] - c
        I += R @ Ic @ R.T + m * (d @ d * np.eye(3) - np.outer(d, d))
    return pose(None, c), M, I
