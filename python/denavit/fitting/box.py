"""The minimum-volume oriented bounding box of a point set: the measuring volume of Hayat et al. (Table IV)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import DenavitError
from ..geometry import rotvec_matrix
from .checks import COINCIDENT_TOL, prefix

#: Number of best bounding-box candidates refined by Nelder-Mead.
REFINE_STARTS = 4
#: Points above which the convex hull is taken of the hull vertices of chunks of this many (the hull of a set is the
#: hull of its parts' hulls: the same hull, qhull's memory that of one chunk) and the principal axes come from the
#: 3 x 3 scatter matrix instead of the thin SVD of the (m, 3) points (issue 41: 6 x 10^6 points had taken 0.7 GB).
HULL_CHUNK = 200_000


@dataclass(frozen=True, eq=False)
class BoundingBox:
    """An oriented bounding box in ``world``.

    Attributes
    ----------
    center : ndarray, shape (3,), metres, frame ``world``
        Centre of the box.
    axes : ndarray, shape (3, 3), frame ``world``
        Rotation matrix (det +1) whose columns are the box axes, ordered as ``lengths``.
    lengths : ndarray, shape (3,), metres
        Edge lengths along the columns of ``axes``, sorted descending ([H]_ Table IV's l1, l2, l3).
    volume : float, m^3
        ``prod(lengths)``.
    """

    center: np.ndarray
    axes: np.ndarray
    lengths: np.ndarray
    volume: float

    def __repr__(self) -> str:
        return (
            f"BoundingBox({' x '.join(f'{v * 1e3:.5g}' for v in self.lengths)} mm, {self.volume:.4g} m^3, centre"
            f" [{', '.join(f'{v * 1e3:.5g}' for v in self.center)}] mm)"
        )

    def __post_init__(self):
        for name in ("center", "axes", "lengths"):
            a = np.array(getattr(self, name), dtype=float, copy=True)
            a.flags.writeable = False
            object.__setattr__(self, name, a)


def _min_area_rect(xy: np.ndarray):
    """Minimum-area enclosing rectangle of 2-D points (rotating calipers over the convex-hull edges).

    Returns (area, u (2,) unit first side direction, lo (2,), hi (2,)) with extents in the (u, u_perp) basis.
    """
    from scipy import spatial  # noqa: PLC0415 (scipy is loaded when a box is first asked for)

    try:
        hull = spatial.ConvexHull(xy)
        hv = xy[hull.vertices]  # counter-clockwise
    except spatial.QhullError:  # collinear in 2-D
        hv = xy
    if len(hv) < 3:
        hv = xy
    edges = np.roll(hv, -1, axis=0) - hv
    lens = np.linalg.norm(edges, axis=1)
    keep = lens > 0
    if not keep.any():
        return 0.0, np.array([1.0, 0.0]), hv.min(axis=0), hv.max(axis=0)
    u = edges[keep] / lens[keep, None]  # (E, 2)
    uperp = np.column_stack([-u[:, 1], u[:, 0]])
    a = hv @ u.T  # (k, E)
    b = hv @ uperp.T
    lo_a, hi_a, lo_b, hi_b = a.min(0), a.max(0), b.min(0), b.max(0)
    area = (hi_a - lo_a) * (hi_b - lo_b)
    i = int(np.argmin(area))
    return float(area[i]), u[i], np.array([lo_a[i], lo_b[i]]), np.array([hi_a[i], hi_b[i]])


def _hull_points(pc: np.ndarray) -> np.ndarray:
    """``pc`` itself up to :data:`HULL_CHUNK` points, else the hull vertices of each chunk of that many (all of a
    chunk's points where qhull finds it flat), whose convex hull is that of ``pc``."""
    from scipy import spatial  # noqa: PLC0415 (scipy is loaded when a box is first asked for)

    if len(pc) <= HULL_CHUNK:
        return pc
    keep = []
    for a in range(0, len(pc), HULL_CHUNK):
        c = pc[a : a + HULL_CHUNK]
        try:
            keep.append(c[spatial.ConvexHull(c).vertices])
        except spatial.QhullError:  # a flat chunk (one sweep's arc without noise): all its points
            keep.append(c)
    return np.concatenate(keep)


def _principal_axes(pc: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The singular values (3,) of the centred points ``pc`` (m, 3) and their right singular vectors (rows of vt):
    the thin SVD, or above :data:`HULL_CHUNK` points the eigenvectors of the scatter matrix pc^T pc (the same axes
    without an (m, 3) U)."""
    if len(pc) <= HULL_CHUNK:
        # full (three axes) only for two points: an (m, m) U for m = 6e5 is 2.6 TiB
        _, s, vt = np.linalg.svd(pc, full_matrices=len(pc) < 3)
        return s, vt
    w, V = np.linalg.eigh(pc.T @ pc)
    order = np.argsort(w)[::-1]
    return np.sqrt(np.clip(w[order], 0.0, None)), V[:, order].T


def _box_from_rotation(hv: np.ndarray, rot: np.ndarray):
    loc = hv @ rot
    lo, hi = loc.min(axis=0), loc.max(axis=0)
    return float(np.prod(hi - lo)), lo, hi


def _finish_box(rot, lo, hi) -> BoundingBox:
    lengths = hi - lo
    centre = rot @ ((lo + hi) / 2)
    order = np.argsort(-lengths, kind="stable")
    axes = rot[:, order]
    lengths = lengths[order]
    if np.linalg.det(axes) < 0:
        axes[:, 2] = -axes[:, 2]
    return BoundingBox(center=centre, axes=axes, lengths=lengths, volume=float(np.prod(lengths)))


def _face_candidates(hull, pc: np.ndarray, hv: np.ndarray) -> list:
    """(volume, rotation) of the box flush with each distinct face direction ``n`` of the 3-D hull: the
    minimum-area rectangle of the hull projected along ``n`` (rotating calipers, Toussaint 1983: a side lies along
    an edge of the projected polygon) times the hull's extent along ``n``, all directions at once.

    The projected polygon's edges are the projections of the silhouette along ``n``: the hull edges between a
    face turned towards ``n`` and one that is not (qhull's face neighbours give the edges), so no 2-D hull is
    computed per direction. A rectangle with a side along an edge needs the polygon's support function at the
    edge's normal and direction, both ways: with the edges sorted by the angle of their outward normals (sorted
    for every direction at once, each direction's angles offset by 8 rad), the vertex farthest along a direction
    is shared by the two edges whose normals bracket it (one ``searchsorted``): O(S log S) per direction for S
    silhouette edges. The volume is that rectangle's area times the hull's extent along ``n``; the best
    candidates are measured again on all hull vertices by the caller.
    """
    normals = hull.equations[:, :3] / np.linalg.norm(hull.equations[:, :3], axis=1, keepdims=True)
    f = np.repeat(np.arange(len(hull.simplices)), 3)
    g = hull.neighbors.ravel()
    a = hull.simplices[:, [1, 2, 0]].ravel()  # the edge of face f opposite its vertex j is shared with neighbour j
    b = hull.simplices[:, [2, 0, 1]].ravel()
    once = f < g
    f, g, a, b = f[once], g[once], a[once], b[once]
    # one candidate per distinct face direction (n and -n give the same box; coplanar facets repeat normals)
    sign = np.where(normals[np.arange(len(normals)), np.argmax(np.abs(normals), axis=1)] < 0, -1.0, 1.0)
    _, first = np.unique(np.round(normals * sign[:, None], 9), axis=0, return_index=True)
    dirs = normals[np.sort(first)]
    t1 = np.cross(dirs, np.eye(3)[np.argmin(np.abs(dirs), axis=1)])  # geometry.perpendicular_basis, row by row
    t1 /= np.linalg.norm(t1, axis=1, keepdims=True)
    t2 = np.cross(dirs, t1)
    out = []
    for c in range(0, len(dirs), 256):  # 256 directions at a time: memory linear in the hull
        n = dirs[c : c + 256]
        front = normals @ n.T > 1e-12
        i, e = np.nonzero((front[f] != front[g]).T)  # (direction, silhouette edge) pairs, grouped by direction
        A, B = pc[a[e]], pc[b[e]]
        xa = np.column_stack([np.einsum("pk,pk->p", A, t1[c + i]), np.einsum("pk,pk->p", A, t2[c + i])])
        xb = np.column_stack([np.einsum("pk,pk->p", B, t1[c + i]), np.einsum("pk,pk->p", B, t2[c + i])])
        d = xa - xb
        lens = np.hypot(d[:, 0], d[:, 1])
        keep = lens > 0
        i, xa, xb, d = i[keep], xa[keep], xb[keep], d[keep] / lens[keep, None]
        count = np.bincount(i, minlength=len(n))
        start = np.cumsum(count) - count
        mid = (
            np.column_stack([np.bincount(i, xa[:, k] + xb[:, k], len(n)) for k in range(2)])
            / np.maximum(2 * count, 1)[:, None]
        )
        nu = np.column_stack([-d[:, 1], d[:, 0]])
        nu *= np.where(np.einsum("pk,pk->p", nu, xa - mid[i]) < 0, -1.0, 1.0)[:, None]  # outward
        key = np.arctan2(nu[:, 1], nu[:, 0]) + 8.0 * i
        order = np.argsort(key, kind="stable")
        key, xa, xb, nu, d = key[order], xa[order], xb[order], nu[order], d[order]
        psi = np.vstack([nu, -nu, d, -d])
        gi = np.tile(i, 4)
        k = np.searchsorted(key, np.arctan2(psi[:, 1], psi[:, 0]) + 8.0 * gi) - 1 - start[gi]
        near = start[gi][:, None] + (k[:, None] + np.arange(2)) % count[gi][:, None]  # the two edges of the bracket
        h = (
            np.maximum(np.einsum("qjk,qk->qj", xa[near], psi), np.einsum("qjk,qk->qj", xb[near], psi))
            .max(axis=1)
            .reshape(4, -1)
        )
        area = (h[0] + h[1]) * (h[2] + h[3])
        best = np.lexsort((area, i))[start[count > 0]]  # each direction's smallest rectangle
        j = i[best]
        e1 = t1[c + j] * d[best, :1] + t2[c + j] * d[best, 1:]
        rots = np.stack([e1, np.cross(n[j], e1), n[j]], axis=2)  # (k, 3, 3): columns e1, n x e1, n
        along = hv @ n[j].T  # the hull's extent along each direction, on all its vertices
        vols = area[best] * (along.max(axis=0) - along.min(axis=0))
        out += list(zip(vols.tolist(), rots, strict=True))
    return out


def oriented_bounding_box(points, *, where: str = "") -> BoundingBox:
    """Minimum-volume oriented bounding box of a 3-D point set ([H]_ section III.C, Table IV).

    Candidates: the PCA box, and for every distinct face normal of the convex hull (one box axis flush with a
    hull face) the minimum-area rectangle of the hull projected along it (rotating calipers). The best few
    candidates are refined by Nelder-Mead over a rotation vector (a minimal box need not have a face flush with
    the hull -- O'Rourke 1985 -- so the face candidates alone are near-exact). The result is never larger than the
    PCA box. Degenerate (planar or collinear) sets give a flat box of volume 0.

    Parameters
    ----------
    points : array_like, shape (m, 3), metres, frame ``world``
        The points (m >= 1).
    where : str
        Prefix for error messages.

    Returns
    -------
    BoundingBox
        ``axes`` columns sorted by decreasing edge length, det +1.
    """
    from scipy import optimize, spatial  # noqa: PLC0415 (scipy is loaded when a box is first asked for)

    pre = prefix(where)
    try:
        p = np.asarray(points, dtype=float)  # (not written to: no copy of a large set)
    except (TypeError, ValueError) as exc:
        raise DenavitError(
            f"{pre}bounding box expects points as an (m, 3) array of numbers, got {type(points).__name__} ({exc})"
        ) from None
    if p.ndim != 2 or p.shape[1] != 3 or p.shape[0] < 1:
        raise DenavitError(f"{pre}bounding box expects points of shape (m, 3) with m >= 1, got shape {p.shape}")
    if not np.isfinite(p).all():
        raise DenavitError(f"{pre}bounding box expects finite coordinates, got NaN/inf")
    centroid = p.mean(axis=0)
    pc = p - centroid
    if math.sqrt(float(np.max(np.einsum("ij,ij->i", pc, pc)))) <= COINCIDENT_TOL:
        return BoundingBox(center=p.mean(axis=0), axes=np.eye(3), lengths=np.zeros(3), volume=0.0)
    s, vt = _principal_axes(pc)
    s = np.pad(s, (0, 3 - len(s)))
    pca = vt.T.copy()
    if np.linalg.det(pca) < 0:
        pca[:, 2] = -pca[:, 2]
    hull = None
    if s[2] > 1e-12 * s[0]:
        try:
            hp = _hull_points(pc)
            hull = spatial.ConvexHull(hp)
        except spatial.QhullError:  # too flat for qhull
            hull = None
    if hull is None:  # planar (or collinear): minimum-area rectangle in the plane, zero height
        n = pca[:, 2]
        _, u, _, _ = _min_area_rect(pc @ pca[:, :2])
        e1 = pca[:, :2] @ u
        rot = np.column_stack([e1, np.cross(n, e1), n])
        _, lo, hi = _box_from_rotation(pc, rot)
        return _finish_box(rot, lo + rot.T @ centroid, hi + rot.T @ centroid)
    hv = hp[hull.vertices]
    faces = sorted(_face_candidates(hull, hp, hv), key=lambda c: c[0])
    # the best few measured again on all hull vertices (the calipers' volumes agree with it to round-off: the
    # ranking of the refinement's starts is that of measuring every candidate, at a fraction of the cost)
    cands = [(_box_from_rotation(hv, pca)[0], pca)] + [
        (_box_from_rotation(hv, r)[0], r) for _, r in faces[: 4 * REFINE_STARTS]
    ]
    cands.sort(key=lambda c: c[0])
    best_v, best_r = cands[0]

    def vol(rv, r0):
        return _box_from_rotation(hv, r0 @ rotvec_matrix(rv))[0]

    for v0, r0 in cands[:REFINE_STARTS]:
        x, fx = np.zeros(3), v0
        for _ in range(4):  # restart Nelder-Mead from its own end point: the volume is only piecewise smooth
            res = optimize.minimize(
                vol,
                x,
                args=(r0,),
                method="Nelder-Mead",
                options={
                    "initial_simplex": x + np.vstack([np.zeros(3), 0.02 * np.eye(3)]),
                    "xatol": 1e-10,
                    "fatol": 1e-15 * max(v0, 1e-300),
                    "maxiter": 2000,
                },
            )
            if not res.fun < fx * (1 - 1e-12):
                break
            x, fx = res.x, float(res.fun)
        if fx < best_v * (1 - 1e-12):
            best_v, best_r = fx, r0 @ rotvec_matrix(x)
    _, lo, hi = _box_from_rotation(hp, best_r)  # (the extents of all points are those of the hull's)
    return _finish_box(best_r, lo + best_r.T @ centroid, hi + best_r.T @ centroid)
