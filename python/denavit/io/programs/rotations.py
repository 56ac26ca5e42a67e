"""Rotations of the controllers' position formats: ZYX Euler angles (KUKA A, B, C; FANUC R, P, W), quaternions
(ABB), poses from a position and a rotation."""

from __future__ import annotations

import numpy as np


def rot(axis: str, a: float) -> np.ndarray:
    c, s = np.cos(a), np.sin(a)
    if axis == "x":
        return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])
    if axis == "y":
        return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])


def zyx_matrix(a: float, b: float, c: float) -> np.ndarray:
    """``Rz(a) Ry(b) Rx(c)`` (rad): KUKA's A, B, C; FANUC's R, P, W."""
    return rot("z", a) @ rot("y", b) @ rot("x", c)


def matrix_zyx(R: np.ndarray, near=None) -> np.ndarray:
    """(a, b, c) with ``R = Rz(a) Ry(b) Rx(c)``, of the two solutions (b within +-90 deg, or beyond) the one nearest
    ``near`` (each angle wrapped to within half a turn of ``near``'s), rad."""
    b = np.arctan2(-R[2, 0], np.hypot(R[0, 0], R[1, 0]))
    if abs(np.cos(b)) < 1e-12:  # gimbal lock: c kept (the nearest's, else 0), the rest in a
        c = 0.0 if near is None else float(near[2])
        sols = [np.array([_gimbal(R, b, c), b, c])]
    else:
        a = np.arctan2(R[1, 0], R[0, 0])
        c = np.arctan2(R[2, 1], R[2, 2])
        sols = [np.array([a, b, c]), np.array([a + np.pi, np.pi - b, c + np.pi])]
    if near is None:
        return _wrap(sols[0], np.zeros(3))
    near = np.asarray(near, dtype=float)
    sols = [_wrap(s, near) for s in sols]
    return min(sols, key=lambda s: float(np.abs(s - near).sum()))


def _gimbal(R, b, c):
    # R = Rz(a) Ry(+-90) Rx(c): find a by removing Rx(c)
    M = R @ rot("x", c).T @ rot("y", b).T
    return float(np.arctan2(M[1, 0], M[0, 0]))


def _wrap(v, near):
    return near + (np.asarray(v) - near + np.pi) % (2 * np.pi) - np.pi


def quaternion_matrix(q) -> np.ndarray:
    """Rotation of a unit quaternion ``(w, x, y, z)`` (ABB's q1..q4), normalised."""
    w, x, y, z = np.asarray(q, dtype=float) / np.linalg.norm(q)
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )


def matrix_quaternion(R: np.ndarray, near=None) -> np.ndarray:
    """``(w, x, y, z)`` of ``R``, the sign nearest ``near``'s."""
    from ...geometry import matrix_rotvec  # noqa: PLC0415

    v = matrix_rotvec(np.asarray(R)[None])[0]
    a = np.linalg.norm(v)
    q = np.array([1.0, 0, 0, 0]) if a < 1e-300 else np.concatenate([[np.cos(a / 2)], np.sin(a / 2) * v / a])
    if near is not None and float(np.dot(q, near)) < 0:
        q = -q
    return q


def pose_matrix(p, R) -> np.ndarray:
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = R, p
    return T
