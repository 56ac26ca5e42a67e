"""The static figures of an identification (matplotlib): fitted circles and axes, residuals, the bounding box,
frames, origin paths, accuracy; :func:`figures_for` gathers them by file stem."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from .. import _core
from ..errors import DenavitError
from ..io.units import joint_scale, joint_unit, length_scale
from .common import AXIS_COLOURS, _figure, joint_colour, joint_names
from .parameters import plot_parameters
from .scene import (
    box_edges,
    chain_path,
    circle_points,
    frame_labels,
    frames_along,
    line_span,
    other_convention,
    scene_size,
    sweep_range,
    triad_lengths,
)

if TYPE_CHECKING:  # pragma: no cover
    from matplotlib.figure import Figure

    from ..identification import Identification


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
        or f"Frame origins while joint {joint} moves from {limits[0] / sc:.4g} to {limits[1] / sc:.4g} {unit}"
        " (Guo et al. Fig. 3)",
        fontsize=11,
    )
    return fig


def plot_accuracy(acc, *, length: str = "mm") -> Figure:
    """An :class:`denavit.accuracy.AccuracyMap`: the distribution of the nominal model's position error and of
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
    from ..accuracy import identification_accuracy  # noqa: PLC0415

    return identification_accuracy(result)
