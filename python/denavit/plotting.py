"""Static figures (matplotlib): fitted circles and axes, residuals, the bounding box, frames, origin paths, parameters.

Every function returns a :class:`matplotlib.figure.Figure` built with the object-oriented API (``Figure()``,
never ``pyplot``), so nothing depends on a display or on the user's backend: saving goes through Agg (PNG) or
the SVG backend, and the figure's artists can be counted by tests. Artists carry ``gid`` labels
(``circle-3``, ``axis-3``, ``frame-2``, ``path-4``, ``box-edge`` ...) that name what they show.

matplotlib is an optional extra (``pip install 'denavit[plot]'``): it is imported inside the functions, and a
missing install raises :class:`~denavit.errors.DenavitError` naming that command. The geometry helpers at the
top of this module (circles, box edges, frame origins along a joint motion) are pure numpy and are shared with
the HTML report (:mod:`denavit.report`).

Frames and units: every input is SI in the measurement frame ``world`` (docs/conventions.md); figures show
lengths in ``length`` units (default mm, as in Hayat et al.) and angles in degrees.

Figures after the papers:

* :func:`plot_circles` -- Hayat et al. Fig. 7, "fitted circle for each joint motion": full circles (not the
  measured arcs), centres and normals.
* :func:`plot_bounding_box` -- Hayat et al. Fig. 8 / Table IV, the minimum-volume oriented bounding box.
* :func:`plot_frames` -- Guo et al. Figs. 6-7: the frames of two conventions side by side (MD-H frames off
  the body and overlapping, ED-H frames on the joint axes).
* :func:`plot_origin_paths` -- Guo et al. Fig. 3: the path of each frame origin while one joint moves.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, NamedTuple

import numpy as np

from . import _core
from .errors import DenavitError
from .geometry import perpendicular_basis
from .io.units import cell_scale, column_scale, joint_scale, joint_unit, length_scale

if TYPE_CHECKING:  # pragma: no cover
    from matplotlib.figure import Figure

    from .identification import Identification


def install_hint(extra: str = "plot") -> str:
    """The command that installs an optional extra for the installation at hand (issue 40): from a checkout (the
    package's PEP 610 ``direct_url.json`` names a local folder), ``pip install "FOLDER[plot]"`` (``-e`` when it is an
    editable install); from the package index, ``pip install 'denavit[plot]'``."""
    import json  # noqa: PLC0415
    from importlib import metadata  # noqa: PLC0415
    from urllib.parse import unquote, urlparse  # noqa: PLC0415

    try:
        text = metadata.distribution("denavit").read_text("direct_url.json")
        info = json.loads(text) if text else {}
    except (metadata.PackageNotFoundError, ValueError, OSError):
        info = {}
    url = urlparse(str(info.get("url", "")))
    if url.scheme == "file":
        editable = bool(info.get("dir_info", {}).get("editable", False))
        return f'install the {extra} extra: pip install {"-e " if editable else ""}"{unquote(url.path)}[{extra}]"'
    return f"install the {extra} extra: pip install 'denavit[{extra}]'"


#: Colours of the frame axes x, y, z (the usual red, green, blue).
AXIS_COLOURS = ("#d62728", "#2ca02c", "#1f77b4")
#: Per-joint colours (matplotlib's tab10, repeated).
JOINT_COLOURS = (
    "#1f77b4",
    "#ff7f0e",
    "#2ca02c",
    "#d62728",
    "#9467bd",
    "#8c564b",
    "#e377c2",
    "#7f7f7f",
    "#bcbd22",
    "#17becf",
)


def joint_colour(j: int) -> str:
    """The colour of joint ``j`` (0-based) in every figure and in the report."""
    return JOINT_COLOURS[j % len(JOINT_COLOURS)]


# ------------------------------------------------------------------------------------- geometry (numpy only)


def joint_names(result: Identification) -> list[str]:
    """The nominal model's joint names, else j1..jn."""
    return list(result.nominal.names) if result.nominal else [f"j{i + 1}" for i in range(result.axes.nq)]


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


# ------------------------------------------------------------------------------------------------ matplotlib


def _figure(**kw) -> Figure:
    """A new headless Figure (no pyplot, so no GUI backend); 3-D projection registered."""
    try:
        from matplotlib.figure import Figure  # noqa: PLC0415
        from mpl_toolkits.mplot3d import Axes3D  # noqa: F401, PLC0415  (registers projection="3d")
    except ImportError as e:
        raise DenavitError(f"the figures need matplotlib, which is not installed ({e}): {install_hint()}") from None
    return Figure(**kw)


def _equal_3d(ax, points: np.ndarray) -> None:
    """Cubic limits around ``points`` so that circles look round and lengths compare across axes."""
    p = np.asarray(points).reshape(-1, 3)
    lo, hi = p.min(axis=0), p.max(axis=0)
    c, r = (lo + hi) / 2, max(float(np.max(hi - lo)) / 2, 1e-9) * 1.05
    ax.set_xlim(c[0] - r, c[0] + r)
    ax.set_ylim(c[1] - r, c[1] + r)
    ax.set_zlim(c[2] - r, c[2] + r)
    ax.set_box_aspect((1, 1, 1), zoom=0.86)  # room for the z label inside the figure (it was clipped on the right)


def _labels_3d(ax, length: str) -> None:
    ax.set_xlabel(f"x [{length}]", labelpad=6)
    ax.set_ylabel(f"y [{length}]", labelpad=6)
    ax.set_zlabel(f"z [{length}]", labelpad=14)  # clear of the tick labels


def plot_circles(result: Identification, *, length: str = "mm") -> Figure:
    """Measured points, fitted full circles, centres and axis arrows per joint (Hayat et al. Fig. 7).

    Parameters
    ----------
    result : Identification
        From :func:`denavit.identification.identify` (points and fits in ``world``, metres).
    length : str
        Display unit of lengths.

    Returns
    -------
    Figure with one 3-D axes. Per revolute joint ``j`` (1-based): a Line3D ``circle-j`` (the full fitted
    circle), a scatter ``points-j`` (the measured points), a scatter ``centre-j`` and an arrow ``axis-j``
    (a quiver along the identified axis, pointing so that the joint turns counter-clockwise about it as its
    value increases); prismatic joints get a Line3D ``line-j`` instead of the circle. Outliers flagged by the
    fit are drawn as black crosses (``outliers-j``).
    """
    fig = _figure(figsize=(8.0, 7.0), layout="constrained")
    ax = fig.add_subplot(projection="3d")
    ls = length_scale(length)
    names = joint_names(result)
    pts_all = result.sweeps.all_points
    arrow = 0.25 * scene_size(pts_all)
    drawn = [pts_all]
    for s, f in zip(result.sweeps.sweeps, result.fits, strict=True):
        j = s.joint
        col = joint_colour(j - 1)
        name = names[j - 1]
        p = s.points / ls
        ax.scatter(*p.T, color=col, s=9, depthshade=False).set_gid(f"points-{j}")
        if np.any(f.outliers):
            ax.scatter(*p[f.outliers].T, color="black", marker="x", s=30, depthshade=False).set_gid(f"outliers-{j}")
        if result.sweeps.kinds[j - 1] == "revolute" and np.isfinite(f.radius):
            c = circle_points(f.point, f.direction, f.radius)
            (line,) = ax.plot(*(c / ls).T, color=col, lw=1.3, label=f"{name}: r = {f.radius / ls:.4g} {length}")
            line.set_gid(f"circle-{j}")
            ax.scatter(*(f.point / ls), color=col, marker="o", s=28, edgecolor="black", depthshade=False).set_gid(
                f"centre-{j}"
            )
            drawn.append(c)
        else:
            e = line_span(f.point, f.direction, s.points)
            (line,) = ax.plot(*(e / ls).T, color=col, lw=1.3, label=f"{name}: line")
            line.set_gid(f"line-{j}")
        tip = f.point + arrow * f.direction
        q = ax.quiver(*(f.point / ls), *((tip - f.point) / ls), color=col, lw=1.8, arrow_length_ratio=0.18)
        q.set_gid(f"axis-{j}")
        ax.text(*(tip / ls), f" {name}", color=col, fontsize=8)
        drawn.append(tip[None])
    ax.scatter(
        *(result.tool_point / ls), color="black", marker="*", s=60, depthshade=False, label="tool point at home"
    ).set_gid("tool-point")
    _equal_3d(ax, np.vstack(drawn) / ls)
    _labels_3d(ax, length)
    ax.set_title(f"Fitted circles and joint axes (method {result.method}; Hayat et al. Fig. 7)", fontsize=10)
    ax.legend(loc="upper left", fontsize=7)
    return fig


def plot_residuals(result: Identification, *, length: str = "mm") -> Figure:
    """Residual of every measured point, one axes per joint (gid ``residuals-j``), outliers in red.

    Circle fits give signed orthogonal distances to the circle (positive outside); the global and readings
    fits give the distance of each point to its prediction (docs of :class:`denavit.fitting.AxisFit`).
    """
    fig = _figure(figsize=(10.0, 5.5), layout="constrained")
    ls = length_scale(length)
    names = joint_names(result)
    n = len(result.fits)
    cols = min(n, 3)
    rows = math.ceil(n / cols)
    for k, (s, f) in enumerate(zip(result.sweeps.sweeps, result.fits, strict=True)):
        ax = fig.add_subplot(rows, cols, k + 1)
        ax.set_gid(f"residuals-{s.joint}")
        r = np.asarray(f.residuals) / ls
        idx = np.arange(len(r))
        ax.axhline(0.0, color="0.6", lw=0.8)
        ax.plot(idx, r, "o", color=joint_colour(s.joint - 1), ms=3, ls="none")  # one distance per point: not a curve
        if np.any(f.outliers):
            ax.plot(idx[f.outliers], r[f.outliers], "x", color="red", ms=8, mew=2)
        ax.set_title(
            f"{names[s.joint - 1]}: rms {f.rms / ls:.3g} {length}, arc {math.degrees(f.arc):.0f} deg", fontsize=9
        )
        ax.set_xlabel("point", fontsize=8)
        ax.set_ylabel(f"residual [{length}]", fontsize=8)
        ax.tick_params(labelsize=7)
    fig.suptitle(f"Residuals per joint (method {result.method})", fontsize=10)
    return fig


def plot_bounding_box(result: Identification, *, length: str = "mm") -> Figure:
    """All measured points and their minimum-volume oriented bounding box (Hayat et al. Fig. 8, Table IV).

    Returns a Figure with one 3-D axes: 12 Line3D edges (gid ``box-edge``), the box axes l1, l2, l3 as
    arrows from its centre (gid ``box-axis-1..3``) and the points coloured by sweep (``points-j``).
    """
    fig = _figure(figsize=(8.0, 7.0), layout="constrained")
    ax = fig.add_subplot(projection="3d")
    ls = length_scale(length)
    b = result.box
    for s in result.sweeps.sweeps:
        ax.scatter(*(s.points / ls).T, color=joint_colour(s.joint - 1), s=7, depthshade=False).set_gid(
            f"points-{s.joint}"
        )
    edges = box_edges(b.center, b.axes, b.lengths)
    for e in edges:
        (line,) = ax.plot(*(e / ls).T, color="0.25", lw=1.0)
        line.set_gid("box-edge")
    for k in range(3):
        v = b.axes[:, k] * b.lengths[k] / 2
        q = ax.quiver(*(b.center / ls), *(v / ls), color=AXIS_COLOURS[k], lw=1.5, arrow_length_ratio=0.1)
        q.set_gid(f"box-axis-{k + 1}")
        ax.text(*((b.center + v) / ls), f" l{k + 1} = {b.lengths[k] / ls:.1f}", color=AXIS_COLOURS[k], fontsize=8)
    _equal_3d(ax, np.vstack([np.vstack(edges), result.sweeps.all_points]) / ls)
    _labels_3d(ax, length)
    l1, l2, l3 = b.lengths / ls
    ax.set_title(
        f"Oriented bounding box {l1:.1f} x {l2:.1f} x {l3:.1f} {length}, {b.volume:.4f} m$^3$ (Hayat et al. Table IV)",
        fontsize=10,
    )
    return fig


def _named_tables(tables) -> list[tuple[str, _core.Table]]:
    items = (
        list(tables.items())
        if isinstance(tables, dict)
        else [(t.convention, t) if isinstance(t, _core.Table) else tuple(t) for t in tables]
    )
    if not items:
        raise DenavitError("expected at least one table to draw, got none")
    n = {t.params.shape[0] for _, t in items}
    if len(n) != 1:
        raise DenavitError(f"the tables drawn side by side must have the same number of joints, got {sorted(n)}")
    return items


def _label(label: str, table: _core.Table) -> str:
    return label if table.convention in label.lower() else f"{label} ({table.convention})"


def _draw_frames(
    ax,
    F: np.ndarray,
    ls: float,
    size: float,
    *,
    alpha: float = 1.0,
    labels: bool = True,
    table: _core.Table | None = None,
    q=None,
) -> None:
    """The skeleton (Line3D ``skeleton``: :func:`chain_path` when ``table`` and ``q`` are given, else straight
    between the origins) and a triad per frame (coincident frames shorter, :func:`triad_lengths`), one label
    per group of coincident origins (:func:`frame_labels`)."""
    o = F[:, :3, 3]
    path = chain_path(table, q) if table is not None else o
    (sk,) = ax.plot(*(path / ls).T, "-", color="0.35", lw=2.0, alpha=0.6 * alpha)
    sk.set_gid("skeleton")
    ax.plot(*(o / ls).T, "o", color="0.35", ms=3, alpha=0.6 * alpha)
    sizes = triad_lengths(o, size)
    for i, T in enumerate(F):
        for k in range(3):
            e = np.array([T[:3, 3], T[:3, 3] + sizes[i] * T[:3, k]]) / ls
            (line,) = ax.plot(*e.T, color=AXIS_COLOURS[k], lw=1.4, alpha=alpha)
            line.set_gid(f"frame-{i}-{'xyz'[k]}")
    if labels:
        for i, text in frame_labels(o, 0.4 * size):
            ax.text(*(o[i] / ls), f" {text}", fontsize=8)


def _distinct(points: np.ndarray, tol: float = 1e-4) -> int:
    """How many of ``points`` (m) lie more than ``tol`` (default 0.1 mm) from every earlier one."""
    out: list[np.ndarray] = []
    for p in points:
        if all(np.linalg.norm(p - o) > tol for o in out):
            out.append(p)
    return len(out)


def plot_frames(tables, q=None, *, length: str = "mm", triad: float | None = None, title: str | None = None) -> Figure:
    """The robot as a skeleton with the frames of several conventions side by side (Guo et al. Figs. 6-7).

    Parameters
    ----------
    tables : sequence of Table or (label, Table), or dict label -> Table
        The same robot in different conventions, e.g. ``robot.table`` and ``denavit.to_table(model, "edh").table``
        (frames from :meth:`Table.frames`: frames 0..n in ``world``, metres).
    q : array-like, shape (n,), optional
        Joint values (rad / m), default zeros.
    triad : float, metres, optional
        Length of the drawn frame axes (default 8 % of the robot's extent).

    Returns
    -------
    Figure with one 3-D axes per table (gid ``frames-<label>``), all with the same limits; in each the
    skeleton through the frame origins (Line3D ``skeleton``) and, per frame i = 0..n, three Line3D
    ``frame-i-x``, ``frame-i-y``, ``frame-i-z`` (red, green, blue). Titles count the distinct origins (0.1 mm
    apart): modified DH frames can overlap where ED-H frames do not (Guo et al. sec. IV.A).
    """
    items = _named_tables(tables)
    n = items[0][1].params.shape[0]
    qv = np.zeros(n) if q is None else np.asarray(q, dtype=float)
    ls = length_scale(length)
    Fs = [t.frames(qv) for _, t in items]
    allo = np.vstack([F[:, :3, 3] for F in Fs])
    size = triad if triad is not None else 0.08 * scene_size(allo)
    fig = _figure(figsize=(5.5 * len(items), 5.8), layout="constrained")
    ends = np.vstack([allo] + [F[:, :3, 3] + size * F[:, :3, k] for F in Fs for k in range(3)])
    for k, ((label, t), F) in enumerate(zip(items, Fs, strict=True)):
        ax = fig.add_subplot(1, len(items), k + 1, projection="3d")
        ax.set_gid(f"frames-{label}")
        _draw_frames(ax, F, ls, size, table=t, q=qv)
        _equal_3d(ax, ends / ls)
        _labels_3d(ax, length)
        ax.set_title(f"{_label(label, t)}: {len(F)} frames, {_distinct(F[:, :3, 3])} distinct origins", fontsize=10)
    fig.suptitle(title or "Frames of each convention (x red, y green, z blue)", fontsize=11)
    return fig


def plot_origin_paths(
    tables, joint: int, q0=None, *, limits=None, steps: int = 73, length: str = "mm", title: str | None = None
) -> Figure:
    """The path of every frame origin while joint ``joint`` moves, one 3-D axes per convention (Guo et al. Fig. 3).

    The joint's own frame in modified DH and ED-H turns about its z axis and stays put; a standard-DH frame
    sits at the far end of its link and sweeps a circle; frames placed off the body (on the extension of an
    axis) trace paths away from the physical joint.

    Parameters
    ----------
    tables : as in :func:`plot_frames`.
    joint : int
        The moving joint, 1-based.
    q0 : array-like, shape (n,), optional
        The other joints' values (rad / m), default zeros.
    limits : (float, float), optional
        The moving joint's range (rad / m), default q0 +- 90 deg (+- 0.1 m prismatic).

    Returns
    -------
    Figure with one 3-D axes per table (gid ``paths-<label>``); in each, per frame i = 0..n a Line3D
    ``path-i`` (frames that do not move draw a single marker), and the robot at ``q0`` in grey (:func:`chain_path`).
    """
    items = _named_tables(tables)
    n = items[0][1].params.shape[0]
    if not 1 <= joint <= n:
        raise DenavitError(f"joint: expected 1..{n}, got {joint}")
    qv = np.zeros(n) if q0 is None else np.asarray(q0, dtype=float)
    kind = items[0][1].kinds[joint - 1]
    if limits is None:
        w = math.pi / 2 if kind == "revolute" else 0.1
        limits = (qv[joint - 1] - w, qv[joint - 1] + w)
    values = np.linspace(limits[0], limits[1], steps)
    ls = length_scale(length)
    paths = [frames_along(t, qv, joint, values)[:, :, :3, 3] for _, t in items]  # (steps, n+1, 3)
    allp = np.vstack([p.reshape(-1, 3) for p in paths])
    fig = _figure(figsize=(5.5 * len(items), 5.8), layout="constrained")
    unit = joint_unit(kind, length, "deg")
    sc = float(joint_scale([kind], length, "deg")[0])
    for k, ((label, t), P) in enumerate(zip(items, paths, strict=True)):
        ax = fig.add_subplot(1, len(items), k + 1, projection="3d")
        ax.set_gid(f"paths-{label}")
        (sk,) = ax.plot(*(chain_path(t, qv) / ls).T, "-", color="0.6", lw=1.5)
        sk.set_gid("skeleton")
        for i in range(P.shape[1]):
            c = joint_colour(i)
            moved = float(np.max(np.linalg.norm(P[:, i] - P[0, i], axis=1))) > 1e-9
            if moved:
                (line,) = ax.plot(*(P[:, i] / ls).T, color=c, lw=1.6, label=f"frame {i}")
            else:
                (line,) = ax.plot(*(P[:1, i] / ls).T, color=c, marker="o", ms=4, ls="none", label=f"frame {i} (fixed)")
            line.set_gid(f"path-{i}")
        _equal_3d(ax, allp / ls)
        _labels_3d(ax, length)
        ax.set_title(_label(label, t), fontsize=10)
        ax.legend(loc="upper left", fontsize=7)
    fig.suptitle(
        title
        or f"Frame origins while joint {joint} moves from {limits[0] / sc:.4g} to {limits[1] / sc:.4g} {unit} (Guo et al. Fig. 3)",
        fontsize=11,
    )
    return fig


#: One sigma beyond which a parameter is not determined by the data and is left out of the parameter charts:
#: lengths beyond this fraction of the measured extent, angles beyond 0.1 rad (5.7 deg), unitless screw
#: components beyond 0.1. Such a sigma (ED-H b and c of a near-parallel pair: hundreds of millimetres) says
#: "the data fix a combination, not this number"; the table still lists it.
UNDETERMINED_LENGTH, UNDETERMINED_ANGLE, UNDETERMINED_RATIO = 0.05, 0.1, 0.1


class ParameterErrors(NamedTuple):
    """One column of a parameter table in display units: ``identified``, ``sigma`` and ``nominal`` (n,) (None
    without a nominal of the same convention), ``shown`` (n,) bool, ``why`` (n,) "" (shown), "held" (sigma 0:
    fixed by the convention or the fit) or "undetermined" (sigma beyond :data:`UNDETERMINED_LENGTH` ...)."""

    column: str
    unit: str
    identified: np.ndarray
    sigma: np.ndarray
    nominal: np.ndarray | None
    shown: np.ndarray
    why: list


def parameter_errors(result: Identification, length: str = "mm", angle: str = "deg") -> list[ParameterErrors]:
    """Per column k of the table: its :class:`ParameterErrors` in display units (``length``, ``angle``).

    Angle differences are wrapped to (-180, 180] deg when compared with the nominal.
    """
    t, nt = result.table, result.nominal_table
    extent = scene_size(result.sweeps.all_points)
    out = []
    for k, c in enumerate(t.columns):
        unit = column_scale(t, k, length, angle)[1]
        cells = [cell_scale(t, i, k, length, angle) for i in range(len(t.kinds))]  # a prismatic POE v is unitless
        sc = np.array([s for s, _ in cells])
        limit = np.array(
            [
                UNDETERMINED_ANGLE
                if t.angle_columns[k]
                else UNDETERMINED_LENGTH * extent
                if u == length
                else UNDETERMINED_RATIO
                for _, u in cells
            ]
        )
        ident = t.params[:, k] / sc
        nom = None if nt is None or nt.convention != t.convention else nt.params[:, k] / sc
        if nom is not None and t.angle_columns[k]:
            half = math.pi / sc
            nom = ident - ((ident - nom + half) % (2 * half) - half)
        sig = np.asarray(result.sigma[:, k], dtype=float)
        why = [
            "held" if s == 0 else "undetermined" if not (np.isfinite(s) and s <= lim) else ""
            for s, lim in zip(sig, limit, strict=True)
        ]
        out.append(ParameterErrors(c, unit, ident, sig / sc, nom, np.array([w == "" for w in why]), why))
    return out


def clean_ticks(values, tol: float = 1e-9) -> np.ndarray:
    """``values`` with round-off set to exactly 0: |v| <= ``tol`` times the largest |v| (and <= ``tol`` itself
    when all are that small), so that a difference of -3.9e-15 mm reads 0, not a tick of its own."""
    v = np.asarray(values, dtype=float).copy()
    big = float(np.nanmax(np.abs(v))) if v.size and np.any(np.isfinite(v)) else 0.0
    v[np.abs(v) <= tol * max(big, 1.0)] = 0.0
    return v


def symmetric_limit(values, sigma, floor: float = 1e-6) -> float:
    """Half-height of a y axis centred on 0 holding every ``value +- sigma`` with 15 % to spare, at least
    ``floor`` (so that zeros get a sensible axis instead of one of +-1e-15)."""
    v, s = np.abs(np.asarray(values, dtype=float)), np.abs(np.asarray(sigma, dtype=float))
    m = float(np.nanmax(v + np.where(np.isfinite(s), s, 0.0))) if v.size else 0.0
    return max(1.15 * m, floor)


def plot_parameters(result: Identification, *, length: str = "mm", angle: str = "deg") -> Figure:
    """Identified minus nominal parameters with one-sigma error bars, one axes per table column.

    Without a nominal model the identified values themselves are drawn. Only determined parameters are drawn
    (:class:`ParameterErrors`: not held by the convention, sigma within :data:`UNDETERMINED_LENGTH` ...); the
    others are named under the axes. Each axes (gid ``param-<column>``) holds one errorbar container whose x
    data are the joint numbers drawn (1-based); tick labels are the joint names, slanted so that they never
    overlap; round-off differences are drawn as 0 (:func:`clean_ticks`) on an axis centred on 0.
    """
    from matplotlib.ticker import MaxNLocator, ScalarFormatter  # noqa: PLC0415

    rows = parameter_errors(result, length, angle)
    fig = _figure(figsize=(2.9 * len(rows) + 0.6, 4.2), layout="constrained")
    names = joint_names(result)
    x = np.arange(1, len(names) + 1)
    for k, r in enumerate(rows):
        ax = fig.add_subplot(1, len(rows), k + 1)
        ax.set_gid(f"param-{r.column}")
        y = clean_ticks(r.identified - r.nominal if r.nominal is not None else r.identified)
        m = r.shown
        ax.errorbar(x[m], y[m], yerr=r.sigma[m], fmt="o", color="#1f77b4", ecolor="#1f77b4", capsize=3, ms=4)
        if r.nominal is not None:
            ax.axhline(0.0, color="0.6", lw=0.8)
            lim = symmetric_limit(y[m], r.sigma[m], 1e-6 if not m.any() else 1e-9)
            ax.set_ylim(-lim, lim)
        ax.set_title(
            f"{r.column} [{r.unit}]" + (": identified - nominal" if r.nominal is not None else ": identified"),
            fontsize=9,
        )
        ax.set_xticks(
            x,
            names,
            fontsize=7,
            rotation=30 if max(len(nm) for nm in names) > 3 else 0,
            ha="right" if max(len(nm) for nm in names) > 3 else "center",
        )
        ax.set_xlim(0.4, len(names) + 0.6)
        ax.yaxis.set_major_locator(MaxNLocator(6, symmetric=r.nominal is not None))
        fmt = ScalarFormatter(useOffset=False, useMathText=True)
        fmt.set_powerlimits((-3, 4))
        ax.yaxis.set_major_formatter(fmt)
        ax.tick_params(axis="y", labelsize=7)
        left = [f"{names[i]} ({w})" for i, w in enumerate(r.why) if w]
        if left:
            ax.set_xlabel("not drawn: " + ", ".join(left), fontsize=6.5, color="0.35", wrap=True)
    fig.suptitle(
        f"{result.table.convention.upper()} parameters, error bars one sigma propagated from the fits", fontsize=10
    )
    return fig


def figures_for(
    result: Identification, *, length: str = "mm", other: str | None = None, joint: int | None = None
) -> dict[str, Figure]:
    """Every figure of an identification, by file stem: circles, residuals, bounding_box, parameters, frames,
    origin_paths (frames of the identified convention and ``other`` at the home configuration; origin paths
    over joint ``joint``'s swept range, default joint 2 as in Guo et al. Fig. 3)."""
    conv = result.table.convention
    other = other_convention(conv) if other is None else _core.convention_info(other)["name"]
    model = result.model()
    tables = [
        (f"identified {conv}", result.table),
        (f"identified {other}", _core.extract(_core.axes(model, np.zeros(model.nq)), other).table),
    ]
    n = result.axes.nq
    joint = joint or (2 if n >= 2 else 1)
    return {
        "circles": plot_circles(result, length=length),
        "residuals": plot_residuals(result, length=length),
        "bounding_box": plot_bounding_box(result, length=length),
        "parameters": plot_parameters(result, length=length),
        "frames": plot_frames(tables, result.sweeps.home, length=length),
        "origin_paths": plot_origin_paths(
            tables, joint, result.sweeps.home, limits=sweep_range(result, joint), length=length
        ),
        **({"accuracy": plot_accuracy(acc, length=length)} if (acc := _accuracy(result)) is not None else {}),
    }


def _accuracy(result: Identification):
    from .compensation import identification_accuracy  # noqa: PLC0415

    return identification_accuracy(result)


__all__ = [
    "install_hint",
    "box_edges",
    "circle_points",
    "figures_for",
    "frames_along",
    "joint_colour",
    "other_convention",
    "ParameterErrors",
    "chain_path",
    "clean_ticks",
    "clusters",
    "frame_labels",
    "parameter_errors",
    "plot_accuracy",
    "plot_bounding_box",
    "plot_circles",
    "plot_frames",
    "plot_origin_paths",
    "plot_parameters",
    "plot_residuals",
    "scene_view",
    "symmetric_limit",
    "triad_lengths",
]


def plot_accuracy(acc, *, length: str = "mm") -> Figure:
    """An :class:`denavit.compensation.AccuracyMap`: the distribution of the nominal model's position error and of
    the identified model's predicted error (gid ``accuracy-histogram``, log-spaced bins), and the nominal error
    over the tool positions seen from above (gid ``accuracy-map``)."""
    fig = _figure(figsize=(10.0, 4.2), layout="constrained")
    ls = length_scale(length)
    nom, ide = np.asarray(acc.nominal) / ls, np.asarray(acc.identified) / ls
    ax = fig.add_subplot(1, 2, 1)
    ax.set_gid("accuracy-histogram")
    both = np.concatenate([nom, ide])
    positive = both[both > 0]
    lo, hi = (positive.min(), positive.max()) if positive.size else (1e-6, 1.0)
    bins = np.geomspace(lo * 0.9, hi * 1.1, 40)
    ax.hist(
        np.maximum(nom, lo),
        bins=bins,
        color="#c0392b",
        alpha=0.7,
        label=f"nominal model: rms {np.sqrt(np.mean(nom**2)):.3g} {length}",
    )
    ax.hist(
        np.maximum(ide, lo),
        bins=bins,
        color="#2471a3",
        alpha=0.7,
        label=f"identified, predicted 1σ: rms {np.sqrt(np.mean(ide**2)):.3g} {length}",
    )
    ax.set_xscale("log")
    ax.set_xlabel(f"tool position error [{length}]", fontsize=9)
    ax.set_ylabel("configurations", fontsize=9)
    ax.legend(fontsize=8)
    ax.tick_params(labelsize=8)
    ax2 = fig.add_subplot(1, 2, 2)
    ax2.set_gid("accuracy-map")
    P = np.asarray(acc.points) / ls
    sc = ax2.scatter(P[:, 0], P[:, 1], c=nom, s=6, cmap="viridis")
    fig.colorbar(sc, ax=ax2, label=f"nominal model error [{length}]")
    ax2.set_aspect("equal", adjustable="datalim")
    ax2.set_xlabel(f"x [{length}]", fontsize=9)
    ax2.set_ylabel(f"y [{length}]", fontsize=9)
    ax2.tick_params(labelsize=8)
    fig.suptitle(f"Accuracy over {len(P)} configurations within the joint limits", fontsize=10)
    return fig
