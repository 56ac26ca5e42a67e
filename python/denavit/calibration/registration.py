"""Where the measurement frame and the tool stand, in closed form, before any iterative fit.

A laser tracker may stand anywhere: 2 m or 10 m from the robot, turned any way. The base registration
``T_world_base`` (the measurement frame) and the tool are therefore found first without iterating on the
kinematics: the nominal model's tool points at the measured joint readings are matched to the measured points by
Horn / Kabsch (:func:`denavit.geometry.kabsch`, scipy's ``Rotation.align_vectors``: the rigid transform that
minimises the sum of squared distances, whatever its size), then the tool point in the flange frame by linear least
squares given that frame (the tool translation enters the tool point linearly), the two alternated until they
settle. For 6-DoF poses the tool's orientation is then the chordal mean of ``R_pred^T R_meas`` over the poses
(the rotation nearest, in the Frobenius norm, to their average), and the tool's rotation parameters become small
rotations about that estimate (the fixed factor before ``tool_rx, tool_ry, tool_rz`` takes the estimate, the three
angles restart at zero), so a tool turned by 90 degrees from the nominal's is no gimbal lock: the Euler angles of
the remaining correction are near zero, where they are a rotation vector to first order.

The iterative fit then starts from the registration, so its result does not depend on where the tracker stood
(the kinematic parameters of a tracker 10 m away and turned agree with those at 2 m to 1e-9 of their sigmas), and
the plausibility of a calibration is judged on the kinematic parameters alone, never on the registration
(:func:`registration_names`).
"""

from __future__ import annotations

import numpy as np

from ..geometry import kabsch, matrix_rotvec, orthonormalize
from .least_squares import REGISTER_RMS, jacobian_rows
from .measurements import Measurements
from .parametrization import Parametrization, _elementary, _replace_factors

#: The tool's rotation parameters are re-centred on the closed-form estimate when it is farther than this from the
#: current one (rad): nearer, the nominal's parametrisation is far from its singularity (pitch +-90 deg) already.
TOOL_RECENTRE = np.radians(10.0)
#: Alternations of base (Kabsch) and tool point (linear least squares) at most; they stop earlier when the tool
#: point moves by less than :data:`SETTLED` (m).
ALTERNATIONS = 30
SETTLED = 1e-9


def registration_names(names) -> list:
    """The parameters of the registration (where the measurement frame and the tool stand): ``base_*`` and
    ``tool_*``; every other parameter is the robot's kinematics."""
    return [n for n in names if n.startswith(("base_", "tool_"))]


def is_registration(name: str) -> bool:
    """Whether parameter ``name`` is part of the registration (base or tool), not of the kinematics."""
    return name.startswith(("base_", "tool_"))


def _rms(P, M) -> float:
    return float(np.sqrt(np.mean(np.sum((P - M) ** 2, axis=1))))


def register(
    pz: Parametrization, x, meas: Measurements, base_free: bool, tool_free=()
) -> tuple[Parametrization, np.ndarray, list]:
    """The base (and tool) registration in closed form; returns (parametrisation, x, notes).

    ``base_free``: all six base parameters may move (else the base stays). ``tool_free``: indices of the tool's
    translation (and, for poses, rotation) parameters that may move. The base is moved only when the nominal model
    misses the measured points by more than :data:`~denavit.calibration.least_squares.REGISTER_RMS` and the
    registration at least halves that miss (the measurement frame is then not the robot's base frame).
    """
    x = np.array(x, dtype=float)
    notes: list[str] = []
    if meas.n < 3:
        return pz, x, notes
    names = pz.names
    # the tool point's translations, or several targets' points (calibration.targets): linear in the predicted points
    trans = [c for c in tool_free if names[c] in ("tool_x", "tool_y", "tool_z") or names[c].startswith("target")]
    rots = [c for c in tool_free if names[c] in ("tool_rx", "tool_ry", "tool_rz")]
    pred, _ = pz.evaluate(x, pz.inputs(meas), False)
    before = _rms(pred[:, :3, 3], meas.points)
    if base_free and before > REGISTER_RMS:
        P = pred[:, :3, 3]
        if np.linalg.matrix_rank(P - P.mean(axis=0), tol=1e-9) >= 2:
            cand_pz, cand_x = pz, x
            for _ in range(ALTERNATIONS if trans else 1):
                p_now, _ = cand_pz.evaluate(cand_x, cand_pz.inputs(meas), False)
                W = kabsch(p_now[:, :3, 3], meas.points)
                cand_pz, cand_x = cand_pz.rebased(cand_x, W)
                if not trans:
                    break
                step = _tool_step(cand_pz, cand_x, meas, trans)
                cand_x[trans] += step
                if np.linalg.norm(step) < SETTLED:
                    break
            after = _rms(cand_pz.evaluate(cand_x, cand_pz.inputs(meas), False)[0][:, :3, 3], meas.points)
            if after < 0.5 * before:
                pz, x = cand_pz, cand_x
                dist = float(np.linalg.norm(pz.base_pose(x)[:3, 3]))
                notes.append(
                    f"base registered in closed form (Kabsch{', alternated with the tool point' if trans else ''}): the"
                    f" robot's base stands {dist:.4g} m from the measurement frame's origin; the nominal model's tool"
                    f" points miss the data by {before * 1e3:.4g} mm rms before, {after * 1e3:.4g} mm after"
                )
    if pz.measure == "pose" and len(rots) == 3 and meas.poses is not None:
        pz, x, angle = _register_tool_rotation(pz, x, meas, rots)
        if angle > 0:
            notes.append(
                f"tool orientation registered in closed form: {np.degrees(angle):.4g} deg from the nominal's (chordal"
                " mean over the poses); tool_rx, tool_ry, tool_rz are small rotations about it"
            )
    return pz, x, notes


def _tool_step(pz: Parametrization, x, meas: Measurements, trans: list) -> np.ndarray:
    """The least-squares change of the tool translation parameters ``trans`` (exact: the tool point is linear in
    them) that best matches the measured points at the current base."""
    pred, J = jacobian_rows(pz, x, pz.inputs(meas), np.ones(6), trans)
    J = J.reshape(meas.n, -1, len(trans))[:, :3].reshape(-1, len(trans))  # the position rows
    r = (pred[:, :3, 3] - meas.points).ravel()
    step, *_ = np.linalg.lstsq(J, -r, rcond=None)
    return step


def _register_tool_rotation(
    pz: Parametrization, x, meas: Measurements, rots: list
) -> tuple[Parametrization, np.ndarray, float]:
    """The tool's fixed rotation factor moved to the chordal mean of ``R_pred^T R_meas`` (the correction in the
    tool frame) and its angle parameters reset to zero; returns (parametrisation, x, angle of the move in rad)."""
    pred, _ = pz.evaluate(x, pz.inputs(meas), False)
    M = np.einsum("nji,njk->ik", pred[:, :3, :3], meas.poses[:, :3, :3]) / meas.n
    U, _, Vt = np.linalg.svd(M)
    D = np.diag([1.0, 1.0, np.sign(np.linalg.det(U @ Vt))])
    R_delta = U @ D @ Vt
    angle = float(np.linalg.norm(matrix_rotvec(R_delta[None])[0]))
    if angle <= TOOL_RECENTRE:
        return pz, x, 0.0
    factors = list(pz.factors)
    pos = {p: k for k, (axis, p, _, _) in enumerate(factors) if axis in ("rx", "ry", "rz")}
    ks = sorted(pos[c] for c in rots if c in pos)
    if (
        len(ks) != 3
        or ks != list(range(ks[0], ks[0] + 3))
        or ks[-1] != len(factors) - 1
        or factors[ks[0] - 1][0] != "fixed"
    ):
        return pz, x, 0.0  # not the expected tail [fixed, rx, ry, rz]: leave it
    F = np.array(factors[ks[0] - 1][3], dtype=float)
    for k in ks:
        F = F @ _elementary(factors[k][0], x[factors[k][1]])
    F[:3, :3] = F[:3, :3] @ R_delta
    factors[ks[0] - 1] = ("fixed", -1, -1, orthonormalize(F))
    x = np.array(x, dtype=float)
    x[[factors[k][1] for k in ks]] = 0.0
    return _replace_factors(pz, factors), x, angle


__all__ = ["is_registration", "register", "registration_names"]
