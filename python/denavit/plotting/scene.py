"""The geometry the figures and the HTML reports draw (pure numpy): circles, lines and box edges, the 3-D view's
ranges and camera, frame labels and triads of coincident frames, the robot along its chain, frame origins while a
joint moves. Metres in the measurement frame ``world`` unless told otherwise."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from .. import _core
from ..errors import DenavitError
from ..geometry import perpendicular_basis

if TYPE_CHECKING:  # pragma: no cover
    from ..identification import Identification


def circle_points(centre, normal, radius: float, count: int = 181) -> np.ndarray:
    """(count, 3) points of the full circle of ``radius`` about ``centre`` in the plane normal to ``normal``."""
    u, v = perpendicular_basis(normal)
    t = np.linspace(0.0, 2.0 * math.pi, count)
    return np.asarray(centre, dtype=float) + radius * (np.outer(np.cos(t), u) + np.outer(np.sin(t), v))


def line_span(point, direction, points: np.ndarray, margin: float = 0.1) -> np.ndarray:
    """(2, 3) ends of the line through ``point`` along ``direction`` covering the projections of ``points``."""
    d = np.asarray(direction, dtype=float)
    s = (np.asarray(points) - point) @ d
    lo, hi = float(s.min()), float(s.max())
    pad = margin * max(hi - lo, 1e-9)
    return np.array([point + (lo - pad) * d, point + (hi + pad) * d])


def box_edges(center, axes, lengths) -> list[np.ndarray]:
    """The 12 edges of an oriented box, each (2, 3); ``axes`` (3, 3) has the box axes as columns, ``lengths`` (3,)."""
    c, A, h = np.asarray(center, float), np.asarray(axes, float), np.asarray(lengths, float) / 2.0
    edges = []
    for k in range(3):  # edges parallel to box axis k: the other two coordinates at +-h
        for s1 in (-1.0, 1.0):
            for s2 in (-1.0, 1.0):
                s = np.zeros(3)
                s[(k + 1) % 3], s[(k + 2) % 3] = s1, s2
                a, b = s.copy(), s.copy()
                a[k], b[k] = -1.0, 1.0
                edges.append(np.array([c + A @ (a * h), c + A @ (b * h)]))
    return edges


def scene_size(points: np.ndarray) -> float:
    """The largest extent of a point cloud (m), at least 1 mm."""
    p = np.asarray(points).reshape(-1, 3)
    return max(float(np.max(np.ptp(p, axis=0))), 1e-3)


def scene_view(points, *, min_ratio: float = 0.5, pad: float = 0.06, direction=(1.25, -1.0, 0.75)) -> dict:
    """Axis ranges, aspect ratio and camera of a 3-D view that frames ``points`` (any length unit, (m, 3)).

    The scale is the same on the three axes (circles stay round), but no axis is drawn shorter than
    ``min_ratio`` of the longest (a tall robot keeps a readable x axis: ticks and title not squashed), and the
    ranges are padded by ``pad`` of the half-extent on each side. The camera looks at the centre from
    ``direction`` (plotly's scene coordinates, where the box is ``aspectratio`` wide), as far as needed for
    the box's bounding sphere to fit plotly's 45 degree vertical field of view with 15 % to spare (room for the tick
    labels and axis titles outside the box).

    Returns ``{"ranges": (3, 2), "aspectratio": (3,) (largest 1), "eye": (3,), "center": (3,)}``.
    """
    p = np.asarray(points, dtype=float).reshape(-1, 3)
    p = p[np.all(np.isfinite(p), axis=1)]
    if not len(p):
        raise DenavitError("scene_view: expected at least one finite point, got none")
    lo, hi = p.min(axis=0), p.max(axis=0)
    centre, span = (lo + hi) / 2, hi - lo
    half = np.maximum(span, min_ratio * max(float(span.max()), 1e-9)) / 2 * (1 + pad)
    aspect = half / half.max()
    radius = float(np.linalg.norm(aspect)) / 2  # plotly draws the scene box aspectratio units wide, centred on 0
    d = np.asarray(direction, dtype=float)
    eye = d / np.linalg.norm(d) * 1.15 * radius / math.sin(math.radians(22.5))
    return {
        "ranges": np.stack([centre - half, centre + half], axis=1),
        "aspectratio": aspect,
        "eye": eye,
        "center": np.zeros(3),
    }


def clusters(points, tol: float) -> list[list[int]]:
    """Indices of ``points`` grouped by proximity: each point joins the first group whose first point lies
    within ``tol`` (same unit), else starts a new one. Used to merge the labels of coincident frames
    ("4,5,6" once, not three labels on top of each other) and to tell their triads apart."""
    p = np.asarray(points, dtype=float).reshape(-1, 3)
    groups: list[list[int]] = []
    for i, x in enumerate(p):
        for g in groups:
            if float(np.linalg.norm(p[g[0]] - x)) <= tol:
                g.append(i)
                break
        else:
            groups.append([i])
    return groups


def triad_lengths(origins, size: float, tol: float | None = None) -> np.ndarray:
    """(n,) length of each frame's drawn axes: ``size``, shortened to 70 %, 49 %, ... for the second, third...
    frame at the same place (within ``tol``, default 2 % of ``size``), so that coincident wrist frames stay
    visible inside each other instead of the last one hiding the others."""
    o = np.asarray(origins, dtype=float).reshape(-1, 3)
    out = np.full(len(o), float(size))
    for g in clusters(o, 0.02 * size if tol is None else tol):
        out[g] = size * 0.7 ** np.arange(len(g))
    return out


def frame_labels(origins, tol: float) -> list[tuple[int, str]]:
    """(index of the first frame, label) per group of frame origins within ``tol``: "4,5,6" for coincident
    frames 4, 5 and 6, "2" for a frame on its own."""
    return [(g[0], ",".join(str(i) for i in g)) for g in clusters(origins, tol)]


def chain_path(table: _core.Table, q) -> np.ndarray:
    """(m, 3) the robot drawn along its chain: from frame 0 to frame n through the points between each link's
    elementary translations (docs/conventions.md), so that every segment follows a frame axis.

    * ``dh``: frame i-1 -> along z_{i-1} by d_i -> along x_i by a_i -> frame i;
    * ``mdh``: frame i-1 -> along x_{i-1} by a_{i-1} -> along z_i by d_i -> frame i;
    * ``edh``: frame i-1 -> along x_{i-1} by a -> along y' by b -> along z_i by c -> frame i (Guo et al. eq. 1-2,
      ``y'`` the y axis after ``Rx(alpha)``), instead of a diagonal between two points of the axes;
    * ``poe``: straight segments between the joint frames (the screws carry no link geometry).

    Consecutive repeated points (a zero length) are dropped. Metres, frame ``world``.
    """
    F = table.frames(np.asarray(q, dtype=float))
    conv, cols, P = table.convention, list(table.columns), table.params
    pts = [F[0, :3, 3]]
    for i in range(1, len(F)):
        A, B, row = F[i - 1], F[i], P[i - 1]
        if conv == "dh":
            mid = [B[:3, 3] - row[cols.index("a")] * B[:3, 0]]
        elif conv == "mdh":
            mid = [A[:3, 3] + row[cols.index("a")] * A[:3, 0]]
        elif conv == "edh":
            al = row[cols.index("alpha")]
            p1 = A[:3, 3] + row[cols.index("a")] * A[:3, 0]
            mid = [p1, p1 + row[cols.index("b")] * (A[:3, :3] @ np.array([0.0, math.cos(al), math.sin(al)]))]
        else:
            mid = []
        for x in [*mid, B[:3, 3]]:
            if float(np.linalg.norm(x - pts[-1])) > 1e-12:
                pts.append(x)
    return np.array(pts)


def frames_along(table: _core.Table, q0, joint: int, values) -> np.ndarray:
    """(m, n+1, 4, 4): ``table.frames(q)`` for q = q0 with joint ``joint`` (1-based) set to each of ``values``."""
    q0 = np.asarray(q0, dtype=float)
    out = []
    for v in np.asarray(values, dtype=float):
        q = q0.copy()
        q[joint - 1] = v
        out.append(table.frames(q))
    return np.array(out)


def other_convention(convention: str) -> str:
    """The convention drawn beside ``convention`` by default: ED-H, or modified DH beside ED-H (Guo et al. Fig. 6)."""
    return "mdh" if convention == "edh" else "edh"


def sweep_range(result: Identification, joint: int) -> tuple[float, float]:
    """The swept range of ``joint`` (1-based; rad / m): the readings' span, else +-90 deg (+-0.1 m) about home."""
    s = result.sweeps.sweep(joint)
    if s.moving is not None and np.ptp(s.moving) > 0:
        return float(np.min(s.moving)), float(np.max(s.moving))
    h = float(result.sweeps.home[joint - 1])
    w = math.pi / 2 if result.sweeps.kinds[joint - 1] == "revolute" else 0.1
    return h - w, h + w


def motion_range(lower, upper, q0, joint: int, kind: str = "revolute") -> tuple[float, float]:
    """A joint's range for drawing origin paths: its limits, clipped to one turn (+-0.5 m prismatic) about q0."""
    w = math.pi if kind == "revolute" else 0.5
    c = float(np.asarray(q0)[joint - 1])
    lo = -w if lower is None else float(np.asarray(lower)[joint - 1])
    hi = w if upper is None else float(np.asarray(upper)[joint - 1])
    return max(lo, c - w), min(hi, c + w)
