"""Small rigid-body geometry in one place, on scipy's :class:`~scipy.spatial.transform.Rotation`.

Frames follow docs/conventions.md: ``T_a_b`` (4, 4) is the pose of frame b in frame a; rotations act on
column vectors; angles in radians, lengths in metres. ``rpy`` is URDF's roll-pitch-yaw about fixed axes,
``R = Rz(yaw) Ry(pitch) Rx(roll)``.
"""

from __future__ import annotations

import math

import numpy as np


def _rotation():
    from scipy.spatial.transform import Rotation  # noqa: PLC0415 (scipy is loaded when first needed)

    return Rotation


def skew(v) -> np.ndarray:
    """(3, 3) cross-product matrix of v: ``skew(v) @ u == np.cross(v, u)``."""
    x, y, z = (float(c) for c in v)
    return np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])


def rotvec_matrix(rotvec) -> np.ndarray:
    """Rotation matrices of rotation vectors (rad): (3,) -> (3, 3), (m, 3) -> (m, 3, 3)."""
    return _rotation().from_rotvec(np.asarray(rotvec, dtype=float)).as_matrix()


def matrix_rotvec(R) -> np.ndarray:
    """Rotation vectors (rad) of rotation matrices: (3, 3) -> (3,), (m, 3, 3) -> (m, 3)."""
    return _rotation().from_matrix(np.asarray(R, dtype=float)).as_rotvec()


def axis_angle_matrices(axis, angles) -> np.ndarray:
    """(m, 3, 3) rotations about the unit ``axis`` (3,) by each of ``angles`` (m,) (right-hand rule)."""
    return rotvec_matrix(np.outer(np.asarray(angles, dtype=float), np.asarray(axis, dtype=float)))


def rpy_matrix(rpy) -> np.ndarray:
    """(3, 3) rotation of URDF roll, pitch, yaw (rad): ``Rz(yaw) Ry(pitch) Rx(roll)``."""
    return _rotation().from_euler("xyz", np.asarray(rpy, dtype=float)).as_matrix()


def matrix_rpy(R) -> tuple[float, float, float]:
    """URDF roll, pitch, yaw (rad) of a rotation matrix: ``R = Rz(yaw) Ry(pitch) Rx(roll)``.

    Gimbal-safe and silent: yaw and pitch come first and roll from what remains
    (``Rx(roll) = Ry(-pitch) Rz(-yaw) R``), so the three reproduce ``R`` to rounding error even at and near
    pitch = +-pi/2 (as in UR arms), where scipy's ``as_euler`` warns and loses about 1e-11 rad.
    """
    R = np.asarray(R, dtype=float)
    c = math.hypot(R[0, 0], R[1, 0])
    pitch = math.atan2(-R[2, 0], c)
    yaw = math.atan2(R[1, 0], R[0, 0]) if c > 1e-12 else 0.0
    cy, sy, cp, sp = math.cos(yaw), math.sin(yaw), math.cos(pitch), math.sin(pitch)
    Rz_t = np.array([[cy, sy, 0.0], [-sy, cy, 0.0], [0.0, 0.0, 1.0]])
    Ry_t = np.array([[cp, 0.0, -sp], [0.0, 1.0, 0.0], [sp, 0.0, cp]])
    M = Ry_t @ Rz_t @ R
    roll = math.atan2(M[2, 1], M[1, 1])
    return roll, pitch, yaw


def pose(R=None, p=None) -> np.ndarray:
    """(4, 4) homogeneous transform of a rotation (3, 3) (default identity) and a translation (3,) (default 0)."""
    T = np.eye(4)
    if R is not None:
        T[:3, :3] = R
    if p is not None:
        T[:3, 3] = p
    return T


def xyz_rpy_pose(xyz, rpy) -> np.ndarray:
    """(4, 4) pose of a URDF origin: translation ``xyz`` (m) and ``rpy`` (rad)."""
    return pose(rpy_matrix(rpy), np.asarray(xyz, dtype=float))


def inverse(T) -> np.ndarray:
    """The inverse of a rigid transform (4, 4) (``R^T``, ``-R^T p``)."""
    T = np.asarray(T, dtype=float)
    R, p = T[:3, :3], T[:3, 3]
    return pose(R.T, -R.T @ p)


def orthonormalize(T) -> np.ndarray:
    """The rigid transform nearest to ``T`` (4, 4): its rotation block replaced by the nearest rotation (SVD)."""
    U, _, Vt = np.linalg.svd(np.asarray(T, dtype=float)[:3, :3])
    out = np.array(T, dtype=float)
    out[:3, :3] = U @ np.diag([1.0, 1.0, np.linalg.det(U @ Vt)]) @ Vt
    out[3] = [0.0, 0.0, 0.0, 1.0]
    return out


def perpendicular_basis(n) -> tuple[np.ndarray, np.ndarray]:
    """Two unit vectors t1, t2 with (t1, t2, n) a right-handed orthonormal frame; ``n`` (3,) unit."""
    n = np.asarray(n, dtype=float)
    a = np.eye(3)[np.argmin(np.abs(n))]
    t1 = np.cross(n, a)
    t1 /= np.linalg.norm(t1)
    return t1, np.cross(n, t1)


def rotation_between(u, v) -> np.ndarray:
    """The smallest rotation (3, 3) taking the unit vector ``u`` to the unit vector ``v`` (not opposite)."""
    K = skew(np.cross(u, v))
    return np.eye(3) + K + K @ K / (1.0 + float(np.dot(u, v)))


def closest_point(p1, d1, p2, d2) -> np.ndarray:
    """The point of the line through ``p1`` along ``d1`` nearest the line through ``p2`` along ``d2`` (the foot of
    their common normal on the first; ``p1`` for parallel lines)."""
    p1, d1, p2, d2 = (np.asarray(v, dtype=float) for v in (p1, d1, p2, d2))
    n = np.cross(d1, d2)
    nn = n @ n
    if nn < 1e-18:
        return p1
    return p1 + (np.cross(p2 - p1, d2) @ n / nn) * d1


def kabsch(P, M) -> np.ndarray:
    """The rigid transform W (4, 4) minimising ``sum |W p_k - m_k|^2`` over point pairs ``P``, ``M`` (k, 3)
    (Kabsch / Umeyama without scale, through scipy's ``Rotation.align_vectors``)."""
    P, M = np.asarray(P, dtype=float), np.asarray(M, dtype=float)
    cp, cm = P.mean(axis=0), M.mean(axis=0)
    R = _rotation().align_vectors(M - cm, P - cp)[0].as_matrix()
    return pose(R, cm - R @ cp)
