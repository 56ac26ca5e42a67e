"""The result of a calibration (:class:`Calibration`, with its held-out :class:`Validation`); the fit itself is
:func:`denavit.calibration.calibrate` (:mod:`.solve`), its files :mod:`denavit.io.results`."""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

from .. import _core
from ..robot import Robot
from .compliance import robot_compliance
from .identifiability import Identifiability
from .measurements import Measurements
from .parametrization import Parametrization, configurations
from .selection import ModelChoice

#: Points whose 3-D misfit exceeds this many robust sigmas are flagged (4-sigma tail of a 1-D deviation for a
#: 3-D misfit, as :data:`denavit.fitting.robust.CHI_4SIGMA` [3]).
OUTLIER_SIGMAS = 4.70


@dataclass(frozen=True)
class Validation:
    """Tool-position errors (m) on held-out poses, before (nominal geometry, base and tool fitted on the
    training poses) and after calibration."""

    n_train: int
    n_test: int
    before_rms: float
    before_max: float
    after_rms: float
    after_max: float
    test_indices: np.ndarray

    def __repr__(self) -> str:
        return (
            f"Validation({self.n_test} held-out of {self.n_train + self.n_test} poses: tool-position error rms"
            f" {self.before_rms * 1e3:.4g} -> {self.after_rms * 1e3:.4g} mm, max {self.before_max * 1e3:.4g} ->"
            f" {self.after_max * 1e3:.4g} mm)"
        )


@dataclass(frozen=True, eq=False)
class Calibration:
    """The result of :func:`calibrate` (SI inside; ``world`` = the measurement frame).

    ``values`` / ``sigma`` / ``status`` are per parameter (``names``); ``sigma`` is NaN for parameters not
    estimated (``status`` "fixed" by the user or the parametrisation, or "unidentifiable": see
    ``identifiability.unidentifiable`` for the reason). ``covariance`` and ``correlation`` are over
    ``free_names`` (in that order).
    """

    parametrization: Parametrization
    names: list
    values: np.ndarray
    sigma: np.ndarray
    status: list
    nominal: np.ndarray
    start: np.ndarray
    free_names: list
    covariance: np.ndarray
    correlation: np.ndarray
    identifiability: Identifiability
    residuals: np.ndarray
    rms: float
    rms_rotation: float
    outliers: np.ndarray
    validation: Validation | None
    measurements: Measurements
    loss: str
    converged: bool
    evaluations: int
    elapsed: float
    noise: float
    notes: list = field(default_factory=list)
    #: the candidate models scored by leave-one-pose-out prediction error and the one chosen
    #: (:mod:`~denavit.calibration.selection`)
    model_choice: ModelChoice | None = None
    #: the prior width of every parameter (SI; inf: no prior) when the chosen model is maximum a posteriori, else None
    prior_sigma: np.ndarray | None = None

    @property
    def convention(self) -> str:
        return self.parametrization.convention

    def __repr__(self) -> str:
        est = int(np.count_nonzero(np.isfinite(self.sigma)))
        v = self.validation
        held = "" if v is None else f"; held-out error rms {v.before_rms * 1e3:.4g} -> {v.after_rms * 1e3:.4g} mm"
        return (
            f"Calibration({self.parametrization.robot.name}, {self.convention}, {self.measurements.n}"
            f" {self.measurements.kind}s of {self.measurements.source}, {est} of {len(self.names)} parameters"
            f" estimated, {'converged' if self.converged else 'NOT converged'})\n  rms {self.rms * 1e3:.4g} mm{held};"
            f" {len(self.notes)} notes" + ("" if self.model_choice is None else f"\n  {self.model_choice.short()}")
        )

    def value(self, name: str) -> tuple[float, float]:
        """(value, sigma) of one parameter (SI)."""
        k = self.parametrization.index(name)
        return float(self.values[k]), float(self.sigma[k])

    @property
    def scales(self) -> dict:
        """Joint scale corrections (``q -> q (1 + scale)``), when estimated."""
        return {n: float(v) for n, v in zip(self.names, self.values, strict=True) if n.startswith("scale_")}

    def model(self, name: str | None = None) -> _core.Model:
        """The calibrated kinematic model (world = the measurement frame)."""
        return self.parametrization.model(self.values, name or f"{self.parametrization.robot.name} calibrated")

    def table(self, convention: str | None = None) -> _core.Table:
        """The calibrated model as a parameter table (default: the calibration convention; an MDH table
        cannot hold Hayati angles: prefer ``edh`` or :meth:`model` then)."""
        conv = self.convention if convention is None else _core.convention_info(convention)["name"]
        m = self.model()
        return _core.extract(_core.axes(m, np.zeros(m.nq)), conv, **self._extract_options(conv)).table

    def _extract_options(self, convention: str) -> dict:
        """The extraction of a ``convention`` table against the nominal's own table in that convention (and, for
        ED-H, the nominal's frame origins on the body): without that reference a pair of axes that is parallel on
        the nominal takes the common normal of its small tilt, which slides along the axes with the noise (a KR5's
        b_2, b_3 and theta_2 had sigmas of 2.5 m and 1.5 rad in the saved covariance)."""
        # (identify imports this package)
        from ..identification.frames import nominal_convention_table, origins  # noqa: PLC0415

        robot = self.parametrization.robot
        home = np.zeros(len(robot.names))
        # the nominal where the calibration registered the robot (the measurement frame's base, as identify's --base):
        # its frame origins on the body, not where the nominal's own world puts them (a tracker 2 m away)
        t, m = robot.table, self.model()
        robot = replace(robot, table=_core.Table(t.convention, t.params, t.kinds, m.T_world_base, t.T_last_tool))
        ref = nominal_convention_table(robot, convention, home)
        opts = {"nominal": ref, "origins": origins(ref, convention, home, _core.axes(m, home))}
        if convention == "edh":
            opts["parallel_tol"] = self._edh_parallel_tol()
        return opts

    def _edh_parallel_tol(self) -> float:
        """ED-H's ``parallel_tol`` against the nominal, as identify's (``identify.EDH_PARALLEL_SIGMAS`` sigmas of the
        tilt of the pairs of axes the nominal has parallel, at least 1e-9): only a tilt the data cannot tell from zero
        is dropped. The tilt ``z_i x z_(i+1)`` and its covariance from this calibration's, by central differences."""
        from ..identification.frames import EDH_PARALLEL_SIGMAS  # noqa: PLC0415

        pz = self.parametrization
        nom = pz.robot.model()
        z = np.asarray(_core.axes(nom, np.zeros(nom.nq)).directions)
        pairs = [k for k in range(len(z) - 1) if np.linalg.norm(np.cross(z[k], z[k + 1])) < 1e-9]
        if not pairs:
            return 1e-3

        def tilts(x):
            m = pz.model(x)
            d = np.asarray(_core.axes(m, np.zeros(m.nq)).directions)
            return np.concatenate([np.cross(d[k], d[k + 1]) for k in pairs])

        free = [pz.index(k) for k in self.free_names]
        J = np.zeros((3 * len(pairs), len(free)))
        for c, i in enumerate(free):
            e = np.zeros_like(self.values)
            e[i] = 1e-7
            J[:, c] = (tilts(self.values + e) - tilts(self.values - e)) / 2e-7
        C = J @ np.asarray(self.covariance) @ J.T
        sig = [math.sqrt(max(np.trace(C[3 * k : 3 * k + 3, 3 * k : 3 * k + 3]), 0.0)) for k in range(len(pairs))]
        sig = [v for v in sig if math.isfinite(v)]
        return min(1e-3, max(EDH_PARALLEL_SIGMAS * max(sig, default=0.0), 1e-9))

    def robot(self, name: str | None = None, convention: str = "edh") -> Robot:
        """A :class:`Robot` of the calibrated model (for :func:`denavit.io.robotfile.save` and
        :func:`denavit.io.urdf.save_urdf`): the nominal's names, limits, home and extras (a URDF nominal's meshes,
        inertials and limits ride along), and the joint scales when estimated (``reading_scale``, about zero: what
        compensate applies to the readings)."""
        r = self.parametrization.robot
        table = self.table(convention)
        carried = self._carried(table)
        comp = _compliance_fields(self, r, table)
        cov, cross = self._table_covariances(table, "compliance" in comp)
        if cross is not None and comp.get("compliance_covariance") is not None:
            comp["compliance_cross"] = cross  # (one covariance of the geometry and the compliances: the file's too)
        lossy = (
            f"; the {table.convention} table carries a tool-position error up to {carried * 1e3:.3g} mm (a tilt of axes"
            " the nominal has parallel, within 3 sigma of zero, dropped)"
            if carried > 1e-9
            else ""
        )
        return Robot(
            name or f"{r.name}_calibrated",
            table,
            list(r.names),
            r.lower,
            r.upper,
            description=(
                f"{r.name} calibrated from {self.measurements.source} ({self.convention}, {self.measurements.n}"
                f" poses{lossy})"
            ),
            source=self.measurements.source,
            home=r.home,
            extra=dict(r.extra),
            inertials=comp.pop("inertials", r.inertials if r.convention == convention else None),
            reading_scale=(
                np.array([self.scales.get(f"scale_{j + 1}", 0.0) for j in range(len(r.names))]) if self.scales else None
            ),
            covariance=cov,
            **comp,
        )

    def carried_error(self, convention: str = "edh", count: int = 256) -> tuple[float, int]:
        """(max tool-position deviation in m, configurations checked) of the table :meth:`robot` writes in
        ``convention`` from the calibrated model: over the home (zeros without one) and ``count`` configurations spread
        over the joint limits (``configurations``, deterministic), as :meth:`Identification.carried_error`."""
        return self._carried(self.table(convention), count), count + 1

    def _carried(self, table: _core.Table, count: int = 256) -> float:
        m, r = self.model(), self.parametrization.robot
        home = np.zeros(m.nq) if r.home is None else np.asarray(r.home, dtype=float)
        q = np.vstack([home, configurations(r, count)])
        tm = table.to_model("table", list(r.names), r.lower, r.upper)
        return float(np.max(np.linalg.norm(_core.fk_batch(tm, q)[:, :3, 3] - _core.fk_batch(m, q)[:, :3, 3], axis=1)))

    def table_covariance(self, table: _core.Table) -> np.ndarray | None:
        """The SI covariance of [``table``'s parameters (row-major), its tool translation in the last frame (, the
        joint scales, when estimated)], the robot file's ``[covariance]``: :attr:`covariance` of the free parameters
        mapped through this calibration's model and the core's extraction of ``table`` (``J C J^T``, ``J`` by central
        differences; angles wrapped about ``table``'s). The base registration is left out (it is where the measurement
        frame stands, not the robot's geometry: targets are given in the robot base frame, as ``compensate`` assumes).
        """
        return self._table_covariances(table)[0]

    def _table_covariances(self, table: _core.Table, compliance: bool = False) -> tuple:
        """(:meth:`table_covariance`, with ``compliance`` its cross-covariance (P, n) with the joints' compliances
        (zero rows and columns for those not free; the robot file's ``[compliance] cross_covariance``), else None):
        the compliances' rows of the same ``J`` select them."""
        pz = self.parametrization
        opts = self._extract_options(table.convention)
        n = len(pz.robot.names)
        free = [pz.index(k) for k in self.free_names]
        keep = [i for i, k in enumerate(self.free_names) if not k.startswith("base_")]
        p_ref = np.asarray(table.params)
        angle_cols = np.array(table.angle_columns)
        scale_idx = [pz.index(f"scale_{j + 1}") if f"scale_{j + 1}" in self.names else None for j in range(n)]
        has_scales = bool(self.scales)

        def converted(x):
            m = pz.model(x)
            new = _core.extract(_core.axes(m, np.zeros(m.nq)), table.convention, fidelity=False, **opts).table
            d = np.asarray(new.params) - p_ref
            d[:, angle_cols] = (d[:, angle_cols] + np.pi) % (2 * np.pi) - np.pi
            sc = [x[i] if i is not None else 0.0 for i in scale_idx] if has_scales else []
            k = pz.compliance_of(x) if compliance else []
            return np.concatenate([(p_ref + d).ravel(), np.asarray(new.T_last_tool)[:3, 3], sc, k])

        y0 = converted(self.values)
        J = np.zeros((len(y0), len(keep)))
        for c, i in enumerate(keep):
            e = np.zeros_like(self.values)
            e[free[i]] = 1e-7
            J[:, c] = (converted(self.values + e) - converted(self.values - e)) / 2e-7
        C = np.asarray(self.covariance)[np.ix_(keep, keep)]
        out = J @ C @ J.T
        if not np.all(np.isfinite(out)):
            return None, None  # (no [covariance]: a fit without one)
        out = (out + out.T) / 2
        P = len(y0) - (n if compliance else 0)
        return out[:P, :P], (out[:P, P:] if compliance else None)


def _compliance_fields(cal: Calibration, r: Robot, table) -> dict:
    """The saved robot's compliances and their covariance (compliance.py), with the nominal's inertials re-expressed in
    ``table``'s frames when the conventions differ (the compliances need them)."""
    k, cov = robot_compliance(cal)
    if k is None:
        return {}
    out = {"compliance": k, "compliance_covariance": cov}
    if r.inertials is not None:
        # each link's centre of mass and inertia carried from the nominal table's frame i to the saved table's, body by
        # body at q = 0 in the base frame (the bodies coincide within millimetres; their frames may not: a calibrated
        # table of near-parallel axes places them otherwise)
        z = np.zeros(len(r.names))
        Fn = (
            np.linalg.inv(np.asarray(r.table.T_world_base)) @ np.asarray(r.table.frames(z))[1:]
        )  # (frames 0..n: frame i is link i's)
        Ft = np.linalg.inv(np.asarray(table.T_world_base)) @ np.asarray(table.frames(z))[1:]
        M = np.linalg.inv(Ft) @ Fn  # nominal frame i in saved frame i
        R, p = M[:, :3, :3], M[:, :3, 3]
        ins = r.inertials
        out["inertials"] = {
            "masses": np.array(ins["masses"], dtype=float),
            "coms": np.einsum("nij,nj->ni", R, np.asarray(ins["coms"], dtype=float)) + p,
            "inertias": R @ np.asarray(ins["inertias"], dtype=float) @ R.transpose(0, 2, 1),
        }
    # the mechanical flange (where a payload's centre of mass is given) in the saved table's last frame
    m = cal.model()
    z = np.zeros(m.nq)
    F = (
        np.linalg.inv(np.asarray(table.frames(z))[-1])
        @ np.asarray(_core.joint_frames(m, z))[-1]
        @ np.asarray(m.T_last_flange)
    )
    if not np.allclose(F, np.eye(4), rtol=0, atol=1e-12):
        out["compliance_flange"] = F
    return out


def strong_correlations(corr: np.ndarray, names: list, limit: float = 0.999) -> list:
    out = []
    for i in range(len(names)):
        for j in range(i + 1, len(names)):
            if abs(corr[i, j]) > limit:
                out.append((names[i], names[j], float(corr[i, j])))
    return sorted(out, key=lambda t: -abs(t[2]))[:5]


def correlation_notes(corr: np.ndarray, names: list) -> list[str]:
    """The note on the most strongly correlated pairs of free parameters (:func:`strong_correlations`), if any."""
    strong = strong_correlations(corr, names)
    if not strong:
        return []
    return [
        "strongly correlated (their combination is far better determined than either): "
        + ", ".join(f"{a} / {b} (rho {rho:+.5f})" for a, b, rho in strong)
    ]
