"""Checks shared by the fits (one-line errors and notes): their inputs (points, joint readings, losses, positive
lengths, sweeps labelled with the joint they move), and their results against a nominal robot (issue 16: a unit
slip, a mirrored frame, swapped joints or the wrong robot must not pass with small sigmas) and against a circle
(a systematic misfit far above the point-to-point noise)."""

from __future__ import annotations

import math

import numpy as np

from .. import _core
from ..errors import DegenerateError, DenavitError

#: Points closer than this to their centroid (m) are "coincident".
COINCIDENT_TOL = 1e-12
#: The per-point losses of the geometric and readings fits (scipy.optimize.least_squares' names).
LOSSES = ("linear", "soft_l1", "huber")


def prefix(where: str) -> str:
    """``"where: "`` for the start of an error message, or nothing when ``where`` is empty."""
    return f"{where}: " if where else ""


def check_points(points, min_points: int, what: str, where: str) -> np.ndarray:
    """Points as a float (m, 3) array, or a clear error (shape, count, finiteness, coincidence)."""
    pre = prefix(where)
    try:
        p = np.array(points, dtype=float)
    except (TypeError, ValueError) as exc:
        raise DenavitError(
            f"{pre}{what} expects points as an (m, 3) array of numbers, got {type(points).__name__} ({exc})"
        ) from None
    if p.ndim != 2 or p.shape[1] != 3:
        raise DenavitError(f"{pre}{what} expects points of shape (m, 3), got shape {p.shape}")
    m = p.shape[0]
    if m < min_points:
        raise DegenerateError(f"{pre}{what} needs at least {min_points} points, got {m}")
    bad = np.flatnonzero(~np.isfinite(p).all(axis=1))
    if bad.size:
        raise DenavitError(
            f"{pre}{what} expects finite coordinates, got NaN/inf in {bad.size} row(s), first at index"
            f" {bad[:5].tolist()}"
        )
    spread = np.max(np.linalg.norm(p - p.mean(axis=0), axis=1))
    if spread <= COINCIDENT_TOL:
        raise DegenerateError(
            f"{pre}{what} needs distinct points, got all {m} points within {spread:.1e} m of their centroid "
            f"(tolerance {COINCIDENT_TOL:g} m; is the measured point on the joint axis?)"
        )
    return p


def check_q(q, m: int, where: str) -> np.ndarray:
    """Joint readings as a float (m,) array that varies, or a clear error (shape, finiteness, constant)."""
    pre = prefix(where)
    try:
        qa = np.array(q, dtype=float)
    except (TypeError, ValueError) as exc:
        raise DenavitError(f"{pre}joint readings q must be numbers, got {type(q).__name__} ({exc})") from None
    if qa.shape != (m,):
        raise DenavitError(
            f"{pre}joint readings q must have one value per point: expected shape ({m},), got {qa.shape}"
        )
    if not np.isfinite(qa).all():
        bad = np.flatnonzero(~np.isfinite(qa))
        raise DenavitError(f"{pre}joint readings q must be finite, got NaN/inf at index {bad[:5].tolist()}")
    if np.ptp(qa) == 0.0:
        raise DegenerateError(f"{pre}joint readings q must vary, got all {m} readings equal to {qa[0]:g}")
    return qa


def check_loss(loss: str, f_scale, where: str) -> None:
    """``loss`` one of :data:`LOSSES` and ``f_scale`` a positive length (m) or None, or a clear error."""
    if loss not in LOSSES:
        raise DenavitError(f"{prefix(where)}loss must be one of {', '.join(LOSSES)}, got {loss!r}")
    if f_scale is not None and not (np.isfinite(f_scale) and f_scale > 0):
        raise DenavitError(f"{prefix(where)}f_scale must be a positive length in metres or None, got {f_scale!r}")


def check_positive(name: str, value, where: str) -> None:
    """``value`` a positive length (m) or None, or a clear error naming ``name``."""
    if value is not None and not (np.isfinite(value) and value > 0):
        raise DenavitError(f"{prefix(where)}{name} must be a positive length in metres or None, got {value!r}")


#: Two sweeps whose points agree to this (m, every coordinate) are one sweep twice: a tracker's noise alone
#: (0.02 mm) keeps two recordings of the same motion a thousand times further apart.
DUPLICATE_TOL = 1e-9
#: A sweep's own joint must move at least this fraction of the most moving other reading.
MOVING_FRACTION = 0.01


def check_sweep_labels(sweeps, wheres: list[str]) -> None:
    """A :class:`DenavitError` for a sweep that is another's copy (the same points: a file copied over another)
    or that, by its readings, moves another joint than its label (files or labels exchanged). Two sweeps with the
    same points and their own, different readings are not a copy: coaxial joints at home trace one circle. ``wheres``: a
    description of each sweep for the message (file and lines)."""
    ss = sweeps.sweeps
    for a in range(len(ss)):
        for b in range(a + 1, len(ss)):
            pa, pb = ss[a].points, ss[b].points
            qa, qb = ss[a].q, ss[b].q
            if qa is not None and qb is not None and qa.shape == qb.shape and not np.array_equal(qa, qb):
                # each its own readings: two coaxial joints at home (a wrist's 4 and 6, a Panda's 1 and 3) trace one
                # circle
                continue
            if pa.shape == pb.shape and np.all(np.abs(pa - pb) <= DUPLICATE_TOL):
                raise DenavitError(
                    f"{wheres[b]}: the sweep repeats the {len(pa)} points of {wheres[a]} (within"
                    f" {DUPLICATE_TOL * 1e3:g} mm): expected a recording of joint {ss[b].joint} moving (a file copied"
                    " over another?)"
                )
    for s, w in zip(ss, wheres, strict=True):
        if s.q is None or not np.isfinite(s.q).all():
            continue  # the readings' own checks name the bad values
        span = np.ptp(s.q, axis=0)
        j = s.joint - 1
        others = np.delete(span, j)
        if others.size and others.max() > 0 and span[j] < MOVING_FRACTION * others.max():
            k = int(np.argmax(np.where(np.arange(len(span)) == j, -1.0, span)))
            unit = (1.0, "m") if sweeps.kinds[k] == "prismatic" else (math.degrees(1.0), "deg")
            raise DenavitError(
                f"{w}: the readings move joint {k + 1} (over {span[k] * unit[0]:.4g} {unit[1]}) while joint {s.joint} "
                f"moves {span[j] * (1.0 if sweeps.kinds[j] == 'prismatic' else math.degrees(1.0)):.3g}: expected joint "
                f"{s.joint} moving (the sweeps of joints {s.joint} and {k + 1} exchanged, or misnumbered?)"
            )


#: A pair of consecutive identified axes whose angle or distance differs from the nominal pair's by more than this
#: (rad; fraction of the robot's size) and ``PLAUSIBLE_SIGMAS`` of its uncertainty gets a note; when more than
#: half of all pairs of axes, or of the consecutive ones, differ by more than ``IMPLAUSIBLE`` the fit is an error. Pairs
#: are compared, not the
#: axes themselves, so that data in another frame (a tracker's, without --base) is not suspect; the axes
#: themselves are compared after the rigid motion that best carries them onto the nominal's
#: (:func:`register_axes`), which shows joints swapped (the pairs cannot: two parallel axes exchanged keep every
#: pairwise angle and distance).
PLAUSIBLE = (math.radians(2.0), 0.02)
IMPLAUSIBLE = (math.radians(30.0), 0.25)
PLAUSIBLE_SIGMAS = 5.0
#: A revolute joint's circle smaller than this fraction of the robot's size (1 mm on a 1 m robot) is named as the
#: likely cause when the axes are implausible: the target on or next to that joint's axis (a 0.006 mm circle of
#: joint 6 had been reported as "points in another unit? the wrong robot?").
SPECK = 1e-3


def _line_pair(p0, z0, p1, z1, parallel: bool) -> tuple[float, float]:
    """(angle, distance) of two lines: the angle of their directions (0..pi) and the length of their common
    normal, or for a pair taken as parallel the distance of the second point from the first line measured across
    their mean direction (the common normal of nearly parallel lines can lie anywhere: it is no measure of them)."""
    ang = math.acos(max(-1.0, min(1.0, float(np.dot(z0, z1)))))
    d = np.asarray(p1, dtype=float) - np.asarray(p0, dtype=float)
    if parallel:
        m = np.asarray(z0) + np.sign(np.dot(z0, z1) or 1.0) * np.asarray(z1)
        m = m / np.linalg.norm(m)
        return ang, float(np.linalg.norm(d - m * (d @ m)))
    c = np.cross(z0, z1)
    return ang, abs(float(d @ c)) / float(np.linalg.norm(c))


def robot_size(model: _core.Model, q) -> float:
    """The robot's size (m): the farthest of its axis points and its tool from its base at ``q`` (at least 1 mm)."""
    base = np.asarray(model.T_world_base)[:3, 3]
    pts = np.vstack([np.asarray(_core.axes(model, q).points), _core.fk(model, q)[:3, 3]])
    return max(float(np.linalg.norm(pts - base, axis=1).max()), 1e-3)


def _far(da: float, dd: float, sig_a: float, sig_d: float, size: float) -> bool:
    return (da > PLAUSIBLE[0] and da > PLAUSIBLE_SIGMAS * sig_a) or (
        dd > PLAUSIBLE[1] * size and dd > PLAUSIBLE_SIGMAS * sig_d
    )


def _far_axes(dev, sig_a, sig_d, size: float) -> list[int]:
    """The axes (0-based) whose (angle, distance) from their nominal (``dev``, (n, 2)) are far (:func:`_far`)."""
    return [k for k in range(len(dev)) if _far(dev[k, 0], dev[k, 1], sig_a[k], sig_d[k], size)]


def _finite(x: float) -> float:
    return x if np.isfinite(x) else 0.0


def _kabsch(D, N) -> np.ndarray:
    """The rotation R minimising sum |R d_k - n_k|^2 (Kabsch 1976), a proper one (det +1)."""
    U, _, Vt = np.linalg.svd(D.T @ N)
    return Vt.T @ np.diag([1.0, 1.0, np.sign(np.linalg.det(Vt.T @ U.T)) or 1.0]) @ U.T


#: The reflection a mirrored measurement frame applies (any one serves: with the rotations it makes them all).
REFLECTION = np.diag([1.0, 1.0, -1.0])


def register_axes_globally(
    points, dirs, nom_points, nom_dirs, kinds, size: float, sig_a, sig_d, mirrored: bool = False
):
    """:func:`register_axes` from every start the directions allow, the best kept: (R, t, dev). The directions'
    signs are free (lines), so a rotation from the directions alone is ambiguous (at the KR5's home its axes run
    along three lines only, and four rotations carry them onto the nominal's); each sign pattern's Kabsch
    rotation is a start, and the registration that leaves the fewest axes far from their nominal (:func:`_far`,
    with the axes' sigmas ``sig_a`` (rad), ``sig_d`` (m)) wins, then the least misfit (angles times the robot's
    size, and distances): two exchanged axes stay two far axes, not a compromise that moves all of them.
    ``mirrored``: the axes reflected (``REFLECTION``) first, so that (R, t) with the reflection carries the axes
    onto the nominal's as a left-handed frame would."""
    import itertools  # noqa: PLC0415

    P, D, N = (np.asarray(a, dtype=float) for a in (points, dirs, nom_dirs))
    if mirrored:
        P, D = P @ REFLECTION, D @ REFLECTION
    starts: list[np.ndarray] = []
    for signs in itertools.product((1.0, -1.0), repeat=len(D) - 1):
        R = _kabsch(D * np.r_[1.0, signs][:, None], N)
        if not any(np.abs(R - S).max() < 1e-3 for S in starts):
            starts.append(R)
    best = None
    for R in starts:
        reg = register_axes(P, D, nom_points, N, kinds, size, R)
        cost = (
            len(_far_axes(reg[2], sig_a, sig_d, size)),
            float(np.sum((reg[2][:, 0] * size) ** 2 + reg[2][:, 1] ** 2)),
        )
        if best is None or cost < best[0]:
            best = (cost, reg)
    return best[1]


def register_axes(
    points, dirs, nom_points, nom_dirs, kinds, size: float, R_start=None
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The rigid motion (R, t) that best carries the identified axes (``points``, ``dirs``: (n, 3)) onto the
    nominal's, as lines (a direction's sign, which without readings comes from the point order, does not count;
    directions weighted by the robot's ``size``, positions across each nominal axis; a prismatic axis by its
    direction only), and each axis's (angle (rad, 0..pi/2), distance (m)) from its nominal after it:
    (R, t, dev (n, 2)). ``R_start``: a first guess (default: from the directions, the frames taken as near)."""
    from scipy.optimize import least_squares  # noqa: PLC0415 (scipy loads with the fits that need it)
    from scipy.spatial.transform import Rotation  # noqa: PLC0415

    P, D, C, N = (np.asarray(a, dtype=float) for a in (points, dirs, nom_points, nom_dirs))
    rev = np.array([k != "prismatic" for k in kinds])
    A = np.eye(3) - N[:, :, None] * N[:, None, :]  # projectors across each nominal axis
    R0 = np.eye(3) if R_start is None else np.asarray(R_start, dtype=float)
    for _ in range(3):  # each direction's sign to its nominal's under the rotation so far, then the rotation again
        D = D * np.where(np.einsum("ki,ki->k", D @ R0.T, N) < 0, -1.0, 1.0)[:, None]
        R0 = _kabsch(D, N)
    D = D * np.where(np.einsum("ki,ki->k", D @ R0.T, N) < 0, -1.0, 1.0)[:, None]
    t0 = (
        np.linalg.lstsq(A[rev].sum(axis=0), np.einsum("kij,kj->i", A[rev], C[rev] - P[rev] @ R0.T), rcond=None)[0]
        if rev.any()
        else np.zeros(3)
    )

    def across(R, t):
        e = np.einsum("kij,kj->ki", A, P @ R.T + t - C)
        e[~rev] = 0.0
        return e

    def resid(x):
        R = Rotation.from_rotvec(x[:3]).as_matrix() @ R0
        return np.concatenate([((D @ R.T) - N).ravel() * size, across(R, x[3:]).ravel()])

    x = least_squares(resid, np.concatenate([np.zeros(3), t0]), x_scale=np.r_[np.ones(3), np.full(3, size)]).x
    R = Rotation.from_rotvec(x[:3]).as_matrix() @ R0
    ang = np.arccos(np.clip(np.abs(np.einsum("ki,ki->k", D @ R.T, N)), 0.0, 1.0))
    return R, x[3:], np.column_stack([ang, np.linalg.norm(across(R, x[3:]), axis=1)])


def nominal_plausibility(
    ex,
    fits: list,
    nominal,
    home,
    names: list[str],
    source: str,
    notes: list[str],
    short: list[str] = (),
    short_sigma: float = math.inf,
    allow: bool = False,
    lone_axis: bool = False,
) -> None:
    """The identified axes against the nominal's (issue 16), in units of their uncertainty and of the robot's size:

    - a note naming the joints of each consecutive pair whose angle or distance is far from the nominal pair's;
    - an error when the axes are the nominal's mirror image (x and y swapped), when they match the nominal's far
      better with two joints exchanged (files of two joints exchanged), or when most pairs of axes are far (a unit
      slip, the wrong robot). ``allow``: these become notes (the fit is returned as it is).

    ``short``: the notes of arcs too short for their axis (``short_sigma``, m), which the error cites as the cause.
    ``lone_axis``: also refuse one axis alone far from its nominal (:func:`_lost_axes`): for sweeps without readings,
    as per-joint files are (one file can be in another unit); with readings, a far axis has other causes the
    readings' checks name (a coupling not declared moves the fits of several joints)."""
    model = nominal.model()
    ax = _core.axes(model, home)
    kinds = list(model.kinds)
    size = robot_size(nominal.model(), home)
    nom = _core.extract(ax, "dh").pairs
    npts, ndirs = np.asarray(ax.points), np.asarray(ax.directions)
    sig_a = np.array([_finite(f.sigma_direction) for f in fits])
    sig_d = np.array([_finite(f.sigma_point_perp) for f in fits])

    def refuse(message: str) -> None:
        if not allow:
            raise DenavitError(f"{source}: {message}; --allow-implausible (allow_implausible=True) keeps the fit")
        notes.append(f"implausible against the nominal {nominal.name} (kept as asked): {message}")

    swap = _swapped(fits, npts, ndirs, kinds, size, sig_a, sig_d)
    if swap:
        (a, b), dev = swap
        refuse(
            f"the axes match the nominal {nominal.name}'s with joints {names[a]} and {names[b]} exchanged: in the order"
            f" given {names[a]} is {dev[a, 1] * 1e3:.4g} mm and {math.degrees(dev[a, 0]):.3g} deg off its nominal,"
            f" {names[b]} {dev[b, 1] * 1e3:.4g} mm and {math.degrees(dev[b, 0]):.3g} deg (after the best rigid fit of"
            f" all axes); exchanged, every axis is within {PLAUSIBLE[1] * size * 1e3:.3g} mm and"
            f" {math.degrees(PLAUSIBLE[0]):g} deg (the files of joints {a + 1} and {b + 1} exchanged, or the joints"
            " misnumbered?)"
        )
        return
    mirror = _mirrored(fits, npts, ndirs, kinds, size)
    if mirror:
        refuse(
            f"the identified axes are the mirror image of the nominal {nominal.name}'s ({mirror[0]} of {mirror[1]} skew"
            " pairs have their common normal's distance flipped): expected a right-handed measurement frame (x and y"
            " swapped? a left-handed tracker export? a joint's readings reversed?)"
        )
    else:
        lines = _mirrored_lines(fits, npts, ndirs, kinds, size, sig_a, sig_d)
        if lines:
            refuse(
                f"the identified axes are the mirror image of the nominal {nominal.name}'s (after the best rigid fit"
                f" {lines[0]} of {len(fits)} axes are far from their nominal, up to {lines[1] * 1e3:.4g} mm and"
                f" {math.degrees(lines[2]):.3g} deg; after the best reflection none): expected a right-handed"
                " measurement frame (x and y swapped? a left-handed tracker export?)"
            )
    lost = _lost_axes(fits, npts, ndirs, kinds, size, sig_a, sig_d) if lone_axis else None
    if lost:
        k, dev, others = lost
        refuse(
            f"the axis of joint {names[k]} is {dev[1] * 1e3:.5g} mm and {math.degrees(dev[0]):.3g} deg from its nominal"
            f" after the best rigid fit of all axes onto the nominal {nominal.name}'s, the others within"
            f" {others[1] * 1e3:.3g} mm and {math.degrees(others[0]):.3g} deg: expected the same robot within"
            f" {IMPLAUSIBLE[1]:g} robot sizes ({IMPLAUSIBLE[1] * size * 1e3:.4g} mm) and"
            f" {math.degrees(IMPLAUSIBLE[0]):g} deg (that joint's points in another unit? the points of another joint"
            " or target?)"
        )
    far_next = 0  # consecutive pairs (the table's links) beyond IMPLAUSIBLE
    for pi, pn in zip(ex.pairs, nom, strict=True):
        k = pi.joint - 1
        sa, sd = math.hypot(sig_a[k], sig_a[k + 1]), math.hypot(sig_d[k], sig_d[k + 1])
        da, dd = abs(pi.angle - pn.angle), abs(pi.distance - pn.distance)
        if "prismatic" in (kinds[k], kinds[k + 1]):
            dd = 0.0  # a prismatic axis is a direction: where its line lies is a convention, not a measurement
        far_next += da > IMPLAUSIBLE[0] or dd > IMPLAUSIBLE[1] * size
        if _far(da, dd, sa, sd, size):
            notes.append(
                f"axes {names[k]}-{names[k + 1]}: {math.degrees(pi.angle):.4g} deg apart and {pi.distance * 1e3:.5g} mm"
                f" apart, the nominal's {math.degrees(pn.angle):.4g} deg and {pn.distance * 1e3:.5g} mm (off by"
                f" {da / max(sa, 1e-300):.3g} and {dd / max(sd, 1e-300):.3g} sigma, {dd / size:.2g} robot sizes): check"
                " the joint order, the units and the nominal"
            )
    # every pair of axes, not only consecutive ones: a wrong robot can match some links by chance
    n = len(fits)
    far, pairs = 0, 0
    for i in range(n):
        for j in range(i + 1, n):
            pairs += 1
            par = abs(float(np.dot(ndirs[i], ndirs[j]))) > math.cos(
                math.radians(10.0)
            )  # nominally near-parallel: distance across
            an, dn = _line_pair(npts[i], ndirs[i], npts[j], ndirs[j], par)
            ai, di = _line_pair(fits[i].point, fits[i].direction, fits[j].point, fits[j].direction, par)
            an, ai = min(an, math.pi - an), min(ai, math.pi - ai)  # lines, not directions: signs are checked elsewhere
            if "prismatic" in (kinds[i], kinds[j]):
                dn = di = 0.0
            # no sigmas here: a fit this far off is of no use however uncertain (arcs too short say so)
            far += abs(ai - an) > IMPLAUSIBLE[0] or abs(di - dn) > IMPLAUSIBLE[1] * size
    if pairs and (far > pairs / 2 or far_next > (n - 1) / 2):
        # a revolute joint whose circle is a speck (the target on or next to its axis) gives an axis of no use
        specks = [
            k
            for k, f in enumerate(fits)
            if kinds[k] == "revolute" and np.isfinite(f.radius) and f.radius < SPECK * size
        ]
        if short:
            cause = (
                f"(the arcs are too short: {len(short)} axes known no better than {short_sigma * 1e3:g} mm, up to "
                f"{max(f.sigma_point_perp for f in fits) * 1e3:.3g} mm; sweep longer arcs)"
            )
        elif specks:
            cause = (
                "("
                + ", ".join(
                    f"joint {names[k]}'s points lie on a circle of radius {fits[k].radius * 1e3:.3g} mm" for k in specks
                )
                + f": the target is on or next to {'that axis' if len(specks) == 1 else 'those axes'}; put it off every"
                " joint's axis)"
            )
        else:
            cause = "(points in another unit? joints swapped or misnumbered? the wrong robot?)"
        refuse(
            f"{far} of {pairs} pairs of axes ({far_next} of {n - 1} consecutive) differ from the nominal"
            f" {nominal.name}'s by more than {math.degrees(IMPLAUSIBLE[0]):g} deg or {IMPLAUSIBLE[1]:g} robot sizes"
            f" ({IMPLAUSIBLE[1] * size * 1e3:.4g} mm): expected the same robot " + cause
        )


def _mirrored(fits: list, pts, dirs, kinds, size: float) -> tuple[int, int] | None:
    """(flipped, compared) when the identified axes are the mirror image of the nominal's: the pairwise angles and
    distances do not see a reflection, the signed common-normal distances do (skew pairs, in both models clearly
    skew, the distance beyond 2 % of the robot and 5 sigma; most of them flipped)."""
    flips = []
    for k in range(len(fits) - 1):
        zi0, zi1 = fits[k].direction, fits[k + 1].direction
        if (
            "prismatic" in (kinds[k], kinds[k + 1])
            or min(np.linalg.norm(np.cross(zi0, zi1)), np.linalg.norm(np.cross(dirs[k], dirs[k + 1]))) < 0.05
        ):
            continue
        dn = _signed_distance(pts[k], dirs[k], pts[k + 1], dirs[k + 1])
        di = _signed_distance(fits[k].point, zi0, fits[k + 1].point, zi1)
        sig = math.hypot(fits[k].sigma_point_perp, fits[k + 1].sigma_point_perp)
        if min(abs(dn), abs(di)) > max(0.02 * size, 5 * _finite(sig)):
            flips.append(np.sign(dn) != np.sign(di))
    return (int(sum(flips)), len(flips)) if len(flips) >= 2 and sum(flips) > len(flips) / 2 else None


def _mirrored_lines(fits: list, pts, dirs, kinds, size: float, sig_a, sig_d) -> tuple[int, float, float] | None:
    """(far axes, their largest distance (m) and angle (rad)) when the identified axes, as lines (without
    readings a sweep's sense is not measured), match the nominal's after a reflection and not after any rigid
    motion; else None. Where the nominal's axes at home are their own mirror image as lines (the KR5 at the
    paper's home: every axis lies in the arm's plane or across it), both fit and no check on the lines can see
    a reflection: the readings' senses (``_mirrored``) or another home can."""
    P = np.array([f.point for f in fits])
    D = np.array([f.direction for f in fits])

    def far(mirrored):
        dev = register_axes_globally(P, D, pts, dirs, kinds, size, sig_a, sig_d, mirrored)[2]
        return _far_axes(dev, sig_a, sig_d, size), dev

    bad, dev = far(False)
    if len(bad) < 2 or far(True)[0]:
        return None
    return len(bad), float(dev[bad, 1].max()), float(dev[bad, 0].max())


def _signed_distance(p0, z0, p1, z1) -> float:
    """The distance of two skew lines along their common normal z0 x z1, signed: a mirror image (a reflection of
    the points, e.g. x and y swapped) flips it, a rigid motion does not."""
    c = np.cross(z0, z1)
    return float((np.asarray(p1) - np.asarray(p0)) @ c / np.linalg.norm(c))


def _lost_axes(fits: list, pts, dirs, kinds, size: float, sig_a, sig_d):
    """(joint, its (angle, distance) from its nominal, the largest of the others') when, after the best rigid fit of
    the axes onto the nominal's, one axis alone is beyond ``IMPLAUSIBLE`` (30 deg or a quarter of the robot's size;
    a prismatic axis by its angle only) and every other within it: one joint's file in another unit, or the points of
    another joint (issue 16's pair checks had only noted it: a wrist file in m among files in mm gave a4 = 1119 mm).
    More axes far are the pairs' refusal (a unit slip of the whole file, the wrong robot); None otherwise."""
    P = np.array([f.point for f in fits])
    D = np.array([f.direction for f in fits])
    _, _, dev = register_axes_globally(P, D, pts, dirs, kinds, size, sig_a, sig_d)
    beyond = [
        dev[k, 0] > IMPLAUSIBLE[0] or (kinds[k] != "prismatic" and dev[k, 1] > IMPLAUSIBLE[1] * size)
        for k in range(len(fits))
    ]
    if sum(beyond) != 1 or len(fits) < 3:
        return None
    k = beyond.index(True)
    rest = np.delete(dev, k, axis=0)
    return k, dev[k], (float(rest[:, 0].max()), float(rest[:, 1].max()))


def _swapped(fits: list, pts, dirs, kinds, size: float, sig_a, sig_d):
    """((a, b), deviations in the order given) when, after the best rigid fit of the axes onto the nominal's, some
    axes are far from their nominal in the order given and every axis is near its nominal with joints a and b
    (0-based, of one kind) exchanged; else None."""
    P = np.array([f.point for f in fits])
    D = np.array([f.direction for f in fits])

    def far_joints(order, R_start=None):
        R, _, dev = register_axes(P, D, pts[order], dirs[order], [kinds[k] for k in order], size, R_start)
        return _far_axes(dev, sig_a, sig_d, size), dev, R

    R, _, dev = register_axes_globally(P, D, pts, dirs, kinds, size, sig_a, sig_d)
    bad = _far_axes(dev, sig_a, sig_d, size)
    if len(bad) < 2:
        return None
    for a in bad:
        for b in bad:
            if a < b and kinds[a] == kinds[b]:
                order = list(range(len(fits)))
                order[a], order[b] = b, a
                if not far_joints(order, R)[0]:
                    return (a, b), dev
    return None


#: A circle fit whose misfit, varying smoothly along the arc, is this many times the point-to-point noise and
#: ``SYSTEMATIC_Z`` standard deviations from what white noise gives gets a note (issue 16: a 5 % ellipse had
#: been fitted as a circle with small sigmas and no word).
SYSTEMATIC_RATIO = 2.0
SYSTEMATIC_Z = 4.0
#: ... and above this rms (m): the smooth misfit of noise-free data at the fits' convergence tolerance is not news.
SYSTEMATIC_FLOOR = 1e-6
#: Fewer points than this say nothing about the misfit's structure.
SYSTEMATIC_MIN_POINTS = 12


def systematic_misfit(points, centre, direction) -> tuple[float, float]:
    """(rms, point-to-point noise) of the points' misfit to the circle about the axis (``centre``, ``direction``):
    the radial and axial offsets from their means, in order along the arc. The noise is the von Neumann estimate
    from successive differences (``sqrt(sum |e_k+1 - e_k|^2 / (2 (m - 1)))``), which a misfit that varies smoothly
    along the arc (an ellipse, a deflection) leaves out: white noise gives a ratio near 1, a shape other than a
    circle a ratio far above it (von Neumann 1941, the ratio of the mean square successive difference to the variance).
    """
    p = np.asarray(points, dtype=float) - np.asarray(centre, dtype=float)
    n = np.asarray(direction, dtype=float)
    h = p @ n
    w = p - np.outer(h, n)
    u = np.cross(n, [1.0, 0.0, 0.0] if abs(n[0]) < 0.9 else [0.0, 1.0, 0.0])
    u /= np.linalg.norm(u)
    theta = np.arctan2(w @ np.cross(n, u), w @ u)
    order = np.argsort(theta)
    gaps = np.diff(np.r_[theta[order], theta[order[0]] + 2 * np.pi])
    order = np.roll(order, -(int(np.argmax(gaps)) + 1))  # start after the largest gap: in order along the arc
    e = np.column_stack([np.linalg.norm(w, axis=1), h])[order]
    e -= e.mean(axis=0)
    rms = float(np.sqrt(np.mean(np.sum(e**2, axis=1))))
    noise = float(np.sqrt(np.sum(np.diff(e, axis=0) ** 2) / (2 * (len(e) - 1))))
    return rms, noise


def misfit_notes(sweeps, fits: list, wheres: list[str], notes: list[str], deflections: list | None = None) -> None:
    """A note (one line) per circle fit whose misfit is systematic and far above the noise the points show: the
    data is not a circle about the fitted axis, and the axis and its sigmas (which assume one) are not to be trusted.
    ``deflections``: None, or per sweep (m, 3) m the displacement of each point by the joints' compliances the joint fit
    modelled (identify's, issue 37): the points less it are checked, and the note names what is left beyond that
    model (a deflection under load is no longer a guess the note can offer: it is fitted)."""
    for i, (s, f, w) in enumerate(zip(sweeps.sweeps, fits, wheres, strict=True)):
        if (
            sweeps.kinds[s.joint - 1] == "prismatic"
            or not np.isfinite(f.radius)
            or len(s.points) < SYSTEMATIC_MIN_POINTS
        ):
            continue
        points = s.points if deflections is None else s.points - deflections[i]
        rms, noise = systematic_misfit(points, f.point, f.direction)
        # white noise: (noise / rms)^2, half the von Neumann ratio, is 1 with a standard deviation of about 1 / sqrt(m)
        z = (1.0 - (noise / rms) ** 2) * math.sqrt(len(s.points)) if rms > 0 else 0.0
        if rms > SYSTEMATIC_FLOOR and rms > SYSTEMATIC_RATIO * noise and z > SYSTEMATIC_Z:
            less, what = (
                ("", "an ellipse? the arm deflecting under load? a loose joint?")
                if deflections is None
                else (
                    ", less the deflection the fitted compliances model,",
                    "an ellipse? a loose joint? a payload or link masses other than declared?",
                )
            )
            notes.append(
                f"{w}: the points{less} leave the fitted circle systematically, rms {rms * 1e3:.3g} mm against a"
                f" point-to-point noise of {noise * 1e3:.2g} mm ({rms / max(noise, 1e-300):.3g} x), varying smoothly"
                f" along the arc: not a circle ({what}; {z:.3g} sigma from white noise): the axis and its sigmas assume"
                " a circle"
            )
