"""The accuracy map: over the workspace or a program's configurations, the position error of the nominal model (how
far the robot is from where the nominal model says) beside the predicted error of the identified model
(:func:`denavit.compensation.predicted_sigma`)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import _core
from .compensation import _model, predicted_sigma


@dataclass(frozen=True)
class AccuracyMap:
    """The accuracy of the nominal and of the identified model at configurations ``q`` (N, n):
    ``nominal`` (N,) the position error of the nominal model (|p_identified - p_nominal|, m: what the robot
    misses when commanded with the nominal model), ``identified`` (N,) the predicted 1-sigma position error
    of the identified model (m), ``points`` (N, 3) the tool positions (m)."""

    q: np.ndarray
    points: np.ndarray
    nominal: np.ndarray
    identified: np.ndarray

    def __repr__(self) -> str:
        s = self.summary()
        return (
            f"AccuracyMap({s['configurations']} configurations: nominal model error rms {s['nominal']['rms'] * 1e3:.4g}"
            f" mm (max {s['nominal']['max'] * 1e3:.4g}), identified 1 sigma rms {s['identified']['rms'] * 1e3:.4g} mm"
            f" (max {s['identified']['max'] * 1e3:.4g}))"
        )

    def summary(self) -> dict:
        """RMS, median, 95th percentile and maximum of both, in metres."""

        def stats(v):
            return {
                "rms": float(np.sqrt(np.mean(v**2))),
                "median": float(np.median(v)),
                "p95": float(np.percentile(v, 95)),
                "max": float(v.max()),
            }

        return {"nominal": stats(self.nominal), "identified": stats(self.identified), "configurations": len(self.q)}


def accuracy_map(nominal, identified, result, q=None, *, count: int = 1000) -> AccuracyMap:
    """:class:`AccuracyMap` over ``q`` (N, n; a program's joint values) or, by default, ``count``
    quasi-random configurations within the nominal's joint limits (a Halton sequence)."""
    nom, ide = _model(nominal, "nominal"), _model(identified, "identified")
    if q is None:
        from scipy.stats import qmc  # noqa: PLC0415

        lo, hi = np.asarray(nom.lower, dtype=float), np.asarray(nom.upper, dtype=float)
        rev = np.array([k == "revolute" for k in nom.kinds])
        lo, hi = np.where(rev, np.maximum(lo, -np.pi), lo), np.where(rev, np.minimum(hi, np.pi), hi)
        q = qmc.scale(qmc.Halton(d=nom.nq, scramble=False).random(count + 1)[1:], lo, hi)
    q = np.atleast_2d(np.asarray(q, dtype=float))
    p_nom = _core.fk_batch(nom, q)[:, :3, 3]
    p_id = _core.fk_batch(ide, q)[:, :3, 3]
    return AccuracyMap(q, p_id, np.linalg.norm(p_id - p_nom, axis=1), predicted_sigma(result, q))


def identification_accuracy(result, *, count: int = 1000) -> AccuracyMap | None:
    """The :class:`AccuracyMap` of an identification against its nominal (None without one): the nominal
    model placed as the identification placed it (its base) with the measured tool point attached so that both
    agree at the home configuration, the identified model's ED-H geometry (exact except a near-parallel pair's
    tilt within its noise, as identify's ED-H table), the prediction from the axes' covariance."""
    if result.nominal is None:
        return None
    ident = result.model(convention="edh")
    home = np.asarray(result.sweeps.home, dtype=float)
    flange = result.nominal.model().with_tool(np.eye(4))
    tool = np.linalg.inv(_core.fk(flange, home)) @ _core.fk(ident, home)
    nominal = flange.with_tool(tool)
    return accuracy_map(nominal, ident, result, count=count)
