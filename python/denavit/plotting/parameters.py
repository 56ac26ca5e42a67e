"""The parameter charts' data (numpy): which identified parameters the data determine, in display units, with the
axis helpers of the charts; and the static chart itself (:func:`plot_parameters`, matplotlib)."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, NamedTuple

import numpy as np

from ..io.units import cell_scale, column_scale
from .common import _figure, joint_names
from .scene import scene_size

if TYPE_CHECKING:  # pragma: no cover
    from matplotlib.figure import Figure

    from ..identification import Identification


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
