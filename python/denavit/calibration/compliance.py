"""Joint compliance under gravity and payload: the elastostatic forward model of a calibration (issue 37).

Each joint gives way under the torque it holds: the link sits at ``q_i - k_i tau_i``, ``q_i`` the reading, ``tau_i``
the torque the joint applies to hold the arm still against gravity (recursive Newton-Euler at zero velocity and
acceleration with the nominal robot's link inertials, plus the payload's weight at its centre of mass in the flange
frame: :func:`gravity_torques`) and ``k_i >= 0`` its compliance (rad/(N m) for a revolute joint, m/N for a prismatic
one). A measured pose is the calibrated chain's forward kinematics at ``q - k * tau(q, payload)``.

In a calibration the compliances are parameters ``k_1 .. k_n`` after the geometric ones
(:class:`CompliantParametrization`): the chain is evaluated at the deflected readings and the Jacobian column of
``k_i`` is ``-tau_i dFK/dq_i`` (the joint offset's column times ``-tau_i (1 + scale_i)``). The torques come from the
nominal model (the geometric corrections change them by parts per thousand). A joint whose torque is zero in every
pose (a vertical first axis) has no compliance parameter: nothing in the data can show it.

Their prior (:mod:`~denavit.calibration.priors`, kind ``compliance``): Gaussian about the nominal's compliance (0
without a ``[compliance]`` section), one sigma wide such that the joint twists by 1 mrad (1 mm for a prismatic
joint) under the largest torque it holds in the data (``width / max |tau_i|``), and ``k_i >= 0``: a compliance fitted
negative is held at zero and the fit repeated. Whether they are free at all is chosen by leave-one-pose-out prediction
(:mod:`~denavit.calibration.selection`, the ``+compliance`` candidates).

They are considered when the data declare a payload (a ``payload_mass`` column, ``--payload``, or
:attr:`Measurements.payload`), or with ``compliance=True``, and need the nominal's link inertials; without them
one note says why.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

from .. import _core
from ..errors import DenavitError
from .parametrization import Parametrization, make_chain

#: Gravity (m/s^2), down along the base frame's -z: the core's default (``_core.gravity_torques``), for the links and
#: the payload alike.
GRAVITY = np.array([0.0, 0.0, -9.81])
#: A joint whose largest gravity torque in the data is below this fraction of the largest joint's has no compliance
#: parameter (a vertical axis holds no gravity torque).
TORQUE_FLOOR = 1e-6


def gravity_torques(model: _core.Model, q, payload=None, flange=None) -> np.ndarray:
    """(N, n) the torques (N m; N for a prismatic joint) the joints hold at rest at readings ``q`` (N, n) against the
    links' weight (``model``'s inertials) and the payload's: ``payload`` (N, 4) ``[mass kg, x, y, z m]`` per pose, its
    centre of mass in the flange frame (None: no payload; ``flange`` (4, 4): that frame in the model's flange frame,
    default
    the same); gravity :data:`GRAVITY` in the model's world frame."""
    q = np.atleast_2d(np.asarray(q, dtype=float))
    g = GRAVITY
    m0 = model.with_tool(np.eye(4))
    tau = np.asarray(_core.gravity_torques_batch(m0, q)) if _has_masses(model) else np.zeros(q.shape)
    if payload is None:
        return tau
    pl = np.asarray(payload, dtype=float)
    loaded = np.flatnonzero(pl[:, 0] > 0)
    if loaded.size == 0:
        return tau
    coms, inv = np.unique(pl[loaded, 1:], axis=0, return_inverse=True)
    zero = np.zeros((q.shape[1],))
    for u, c in enumerate(coms):
        rows = loaded[inv.ravel() == u]
        T = np.eye(4)
        T[:3, 3] = c
        mc = m0.with_tool(T if flange is None else np.asarray(flange, dtype=float) @ T)
        R = _core.fk_batch(mc, q[rows])[:, :3, :3]
        f = np.zeros((len(rows), 6))
        f[:, :3] = np.einsum("nji,j->ni", R, g) * pl[rows, :1]  # the weight, in the tool frame's axes, at its origin
        qz = np.tile(zero, (len(rows), 1))
        # rnea with the weight as the environment's wrench, minus the links' share: what the payload adds (-J^T f)
        tau[rows] += np.asarray(_core.rnea_batch(mc, q[rows], qz, qz, f_ext=f)) - (
            np.asarray(_core.rnea_batch(mc, q[rows], qz, qz)) if _has_masses(model) else 0.0
        )
    return tau


def _has_masses(model: _core.Model) -> bool:
    return bool(np.any(np.asarray(model.inertias["masses"]) > 0))


@dataclass(frozen=True, eq=False)
class CompliantParametrization(Parametrization):
    """A calibration chain with joint compliances ``k_1 .. k_n`` after its geometric parameters (module docstring).

    :meth:`inputs` gives the evaluation's readings with each pose's gravity torques appended ((N, 2n)); :meth:`evaluate`
    deflects the readings by them. Readings without torques (N, n) are evaluated rigid."""

    torque_model: _core.Model | None = None
    n_geometric: int = 0
    #: the compliance parameters (indices) the data can show (a joint holding torque in some pose)
    compliance_idx: tuple = ()
    #: per compliance parameter index, the prior width's factor 1 / max |tau_i| over the data (priors.Prior.sigma)
    prior_factors: dict = field(default_factory=dict)
    _cache: dict = field(default_factory=dict, repr=False)

    @property
    def nonnegative(self) -> tuple:
        return self.compliance_idx

    def torques(self, q, payload) -> np.ndarray:
        """(N, n) gravity torques of readings ``q`` with ``payload`` (:func:`gravity_torques`), remembered per data
        set."""
        q = np.asarray(q, dtype=float)
        key = (
            q.shape,
            hash(q.tobytes()),
            None if payload is None else hash(np.asarray(payload, dtype=float).tobytes()),
        )
        hit = self._cache.get(key)
        if hit is None:
            hit = gravity_torques(self.torque_model, q, payload)
            hit.flags.writeable = False
            if len(self._cache) > 16:
                self._cache.clear()
            self._cache[key] = hit
        return hit

    def inputs(self, meas) -> np.ndarray:
        return np.hstack([meas.q, self.torques(meas.q, getattr(meas, "payload", None))])

    def compliance_of(self, x) -> np.ndarray:
        """(n,) the compliances (SI) in parameter vector ``x``."""
        return np.asarray(x, dtype=float)[self.n_geometric : self.n_geometric + self.nq]

    def deflected(self, x, q, tau) -> np.ndarray:
        """The readings the joints sit at: ``q - k tau``."""
        return np.asarray(q, dtype=float) - self.compliance_of(x) * np.asarray(tau, dtype=float)

    def evaluate(self, x, q, jacobian: bool = True, *, rows: int = 6, columns=None, weights=None):
        x = np.asarray(x, dtype=float)
        q = np.atleast_2d(np.asarray(q, dtype=float))
        n = self.nq
        if q.shape[1] == 2 * n:
            q, tau = q[:, :n], q[:, n:]
        else:
            tau = np.zeros_like(q)
        qe = self.deflected(x, q, tau)
        cols = list(range(self.n_params)) if columns is None else [int(c) for c in columns]
        if not jacobian:
            return Parametrization.evaluate(self, x, qe, False, rows=rows, weights=weights)
        kcols = [c for c in cols if c >= self.n_geometric]
        offs = [self.factors[self.joint_factor[c - self.n_geometric]][1] for c in kcols]
        geo = sorted(set(c for c in cols if c < self.n_geometric) | set(offs))
        poses, Jg = Parametrization.evaluate(self, x, qe, True, rows=rows, columns=geo, weights=weights)
        at = {c: i for i, c in enumerate(geo)}
        J = np.empty((len(q), rows, len(cols)))
        for i, c in enumerate(cols):
            if c < self.n_geometric:
                J[:, :, i] = Jg[:, :, at[c]]
            else:
                j = c - self.n_geometric
                s = 1.0
                name = f"scale_{j + 1}"
                if name in self.names:
                    s = 1.0 + x[self.names.index(name)]
                J[:, :, i] = -(tau[:, j] * s)[:, None] * Jg[:, :, at[self.factors[self.joint_factor[j]][1]]]
        return poses, J


def compliance_units(kinds) -> list:
    return ["rad/(N m)" if k == "revolute" else "m/N" for k in kinds]


def held_note(label: str, unit: str, value: float, sigma: float) -> str:
    """The note on a compliance (``label``, e.g. ``k_5`` or ``joint 2 (A2)``) held at its bound 0 (``k >= 0``), fitted
    free at ``value`` < 0 (``unit``) with ``sigma``: calibrate's and identify's."""
    z = -value / sigma if sigma > 0 else math.inf
    why = "check the payload and the nominal's inertials" if z > 2 else "within the noise of 0"
    return (
        f"{label}: compliance held at 0 (k >= 0: a joint gives way under its torque), its sigma {sigma:.3g} from the"
        f" data; fitted free it came to {value:.3g} {unit}, {z:.2g} sigma below 0: {why}"
    )


def checked_compliance(robot) -> np.ndarray | None:
    """A Robot's compliances (n,) SI, checked as a robot file's ``[compliance]`` is (a Robot built in Python too): one
    per joint, finite and >= 0 (a joint gives way under its torque); None for rigid joints."""
    if robot.compliance is None:
        return None
    k = np.asarray(robot.compliance, dtype=float)
    kinds = list(robot.table.kinds)
    if k.shape != (len(kinds),):
        raise DenavitError(
            f"{robot.name}: compliance: expected {len(kinds)} values (one per joint), got shape {k.shape}"
        )
    bad = np.flatnonzero(~(k >= 0) | ~np.isfinite(k))
    if bad.size:
        j = bad[0]
        raise DenavitError(
            f"{robot.name}: compliance: joint {j + 1} ({robot.names[j]}): expected a compliance >= 0 "
            f"(a joint gives way under its torque), got {k[j]:g} {compliance_units(kinds)[j]}"
        )
    return k


def considered(meas, robot, compliance) -> tuple[bool, str | None]:
    """(whether the calibration models joint compliance, the one-line note why not where it was asked or implied)."""
    if compliance is False:
        return False, None
    asked = compliance is True or getattr(meas, "payload", None) is not None
    if not asked:
        return False, None
    if robot.inertials is None or not np.any(np.asarray(robot.inertials["masses"]) > 0):
        return (
            False,
            (
                f"joint compliance not modelled: {robot.name} carries no link masses ([joints.inertia] in a robot file,"
                " <inertial> in a URDF) to give the gravity torques the joints twist under"
            ),
        )
    return True, None


def with_compliance(pz: Parametrization, meas, robot, compliance) -> tuple[Parametrization, list]:
    """``pz`` with the compliance parameters appended when the calibration models compliance (:func:`considered`),
    else ``pz`` itself; and the notes."""
    if compliance not in (None, True, False, "auto"):
        raise DenavitError(
            f"compliance: expected None / 'auto' (when the data declare a payload), True or False, got {compliance!r}"
        )
    use, why = considered(meas, robot, None if compliance == "auto" else compliance)
    if not use:
        return pz, [why] if why else []
    n = pz.nq
    kinds = list(robot.table.kinds)
    torque_model = robot.model()
    tau = gravity_torques(torque_model, meas.q, getattr(meas, "payload", None))
    tmax = np.max(np.abs(tau), axis=0)
    P = pz.n_params
    show = [j for j in range(n) if tmax[j] > TORQUE_FLOOR * max(tmax.max(), 1e-300)]
    k0 = checked_compliance(robot)
    k0 = np.zeros(n) if k0 is None else k0
    names = list(pz.names) + [f"k_{j + 1}" for j in range(n)]
    units = list(pz.units) + compliance_units(kinds)
    scales = [pz.names.index(f"scale_{j + 1}") if f"scale_{j + 1}" in pz.names else -1 for j in range(n)]
    chain = make_chain(pz.factors, P + n, n, scales)
    out = CompliantParametrization(
        pz.convention,
        pz.measure,
        names,
        np.r_[pz.x0, k0],
        units,
        list(pz.order) + [P + j for j in range(n)],
        dict(pz.rules),
        pz.factors,
        chain,
        pz.robot,
        pz.joint_factor,
        pz.tool_start,
        pz.base_end,
        torque_model,
        P,
        tuple(P + j for j in show),
        {P + j: 1.0 / tmax[j] for j in show},
    )
    notes = []
    still = [j for j in range(n) if j not in show]
    if still:
        notes.append(
            f"no compliance for joint(s) {', '.join(f'{j + 1} ({robot.names[j]})' for j in still)}: they hold no"
            " gravity torque in these poses"
        )
    return out, notes


def robot_compliance(cal) -> tuple[np.ndarray | None, np.ndarray | None]:
    """(compliances (n,) SI, their covariance (n, n) SI or None) of a calibration whose model freed them; (None, None)
    otherwise. Compliances not free are their nominal values (0 without a ``[compliance]``), with zero variance."""
    pz = cal.parametrization
    if not isinstance(pz, CompliantParametrization) or not any(nm.startswith("k_") for nm in cal.free_names):
        return None, None
    k = pz.compliance_of(cal.values).copy()
    n = pz.nq
    C = np.zeros((n, n))
    pos = {nm: i for i, nm in enumerate(cal.free_names)}
    idx = [(j, pos.get(f"k_{j + 1}")) for j in range(n)]
    have = [(j, i) for j, i in idx if i is not None]
    cov = np.asarray(cal.covariance)
    for a, ia in have:
        for b, ib in have:
            C[a, b] = cov[ia, ib]
    return k, C if np.all(np.isfinite(C)) else None


def as_payload(payload, n: int) -> np.ndarray | None:
    """``payload`` as (n, 4) SI rows: None; a mass (kg) at the flange; ``(mass, (x, y, z))``; or (n, 4) / (4,) rows."""
    if payload is None:
        return None
    expected = "expected a mass (kg), (mass, (x, y, z)) or (N, 4) rows [kg, m, m, m]"
    if isinstance(payload, (str, bytes)):  # (the command line's text: denavit.io.payload.parse_payload reads it)
        raise DenavitError(f"payload: {expected}, got the text {payload!r} (parse_payload of denavit.io.payload)")
    try:
        if isinstance(payload, (int, float)):
            a = np.tile([float(payload), 0.0, 0.0, 0.0], (n, 1))
        elif isinstance(payload, tuple) and len(payload) == 2 and np.ndim(payload[1]) == 1:
            a = np.tile(np.r_[float(payload[0]), np.asarray(payload[1], dtype=float)], (n, 1))
        else:
            a = np.asarray(payload, dtype=float)
            a = np.tile(a, (n, 1)) if a.shape == (4,) else a
    except (TypeError, ValueError):
        raise DenavitError(f"payload: {expected}, got {type(payload).__name__} {str(payload)[:80]!r}") from None
    if a.shape != (n, 4):
        raise DenavitError(f"payload: {expected}, got shape {a.shape}")
    bad = np.flatnonzero(~(a[:, 0] >= 0) | ~np.all(np.isfinite(a), axis=1))
    if bad.size:
        raise DenavitError(
            f"payload: row {bad[0]}: expected a mass >= 0 kg and a finite centre of mass, got {a[bad[0]].tolist()}"
        )
    return a


def with_payload(meas, payload):
    """``meas`` with ``payload`` (:func:`as_payload`) on every pose (rows of its own kept where given None)."""
    if payload is None:
        return meas
    return replace(meas, payload=as_payload(payload, meas.n))


@dataclass(frozen=True, eq=False)
class Elastic:
    """The compliance of an identified robot, for compensation and validation: its compliances ``k`` (n,) SI, the model
    that gives its gravity torques (with its inertials), the compliances' covariance (n, n) or None, and the calibration
    it came from (its full covariance predicts the error exactly) or None."""

    k: np.ndarray
    torque_model: _core.Model
    covariance: np.ndarray | None = None
    calibration: object = None
    #: (4, 4) the flange (where a payload's centre of mass is given) in the model's flange frame, or None: the same
    flange: np.ndarray | None = None
    #: (P, n) the covariance of the robot's geometric parameters (its ``covariance``'s entries) with the compliances,
    #: or None: uncorrelated (:attr:`denavit.robot.Robot.compliance_cross`)
    cross: np.ndarray | None = None
    #: (n,) N m the torques at which the geometry's covariance holds the links, or None: none. An identification's
    #: axes are the arm's at home under its own weight, so a compliance's error turns its link by its torque from there
    #: (:meth:`jacobian`), as in its joint fit.
    torque_reference: np.ndarray | None = None

    def torques(self, q, payload=None) -> np.ndarray:
        return gravity_torques(self.torque_model, q, payload, self.flange)

    def deflected(self, q, payload=None) -> np.ndarray:
        """The joint values the links sit at for readings ``q`` (N, n): ``q - k tau(q)``."""
        q = np.atleast_2d(np.asarray(q, dtype=float))
        return q - self.k * self.torques(q, payload)

    def command(self, q_link, payload=None, iterations: int = 30, tol: float = 1e-13) -> np.ndarray:
        """The readings that put the links at ``q_link`` (N, n) under gravity and ``payload``: the fixed point of
        ``q = q_link + k tau(q)`` (a contraction: ``k dtau/dq`` is far below 1)."""
        q_link = np.atleast_2d(np.asarray(q_link, dtype=float))
        q = q_link.copy()
        for _ in range(iterations):
            new = q_link + self.k * self.torques(q, payload)
            done = float(np.max(np.abs(new - q))) < tol if q.size else True
            q = new
            if done:
                break
        return q

    def jacobian(self, q, payload=None) -> np.ndarray:
        """(N, 3, n) the tool position's derivatives by the compliances at readings ``q``: ``-J_q diag(tau)``, ``J_q``
        the position rows of the joints' Jacobian at the deflected joints (``tau`` less :attr:`torque_reference`)."""
        q = np.atleast_2d(np.asarray(q, dtype=float))
        tau = self.torques(q, payload)
        qd = q - self.k * tau
        dt = tau - (0.0 if self.torque_reference is None else self.torque_reference)
        return np.stack([-np.asarray(_core.jacobian(self.torque_model, qd[i]))[:3] * dt[i] for i in range(len(q))])

    def sigma(self, q, payload=None) -> np.ndarray:
        """(N,) the tool-position sigma (m, 3-D) the compliances' own covariance adds at readings ``q``:
        ``sqrt(trace(A C A^T))``, ``A`` :meth:`jacobian` (zeros without a covariance)."""
        q = np.atleast_2d(np.asarray(q, dtype=float))
        if self.covariance is None:
            return np.zeros(len(q))
        A = self.jacobian(q, payload)
        return np.sqrt(np.maximum(np.einsum("nij,jk,nik->n", A, np.asarray(self.covariance), A), 0.0))


def elastic(identified) -> Elastic | None:
    """The :class:`Elastic` of an identified robot whose joints are compliant (a Robot with a ``[compliance]``, a
    calibration that freed its compliances, an identification whose joint fit did: its saved robot's), else None."""
    from ..robot import Robot  # noqa: PLC0415

    if isinstance(identified, Robot):
        k = checked_compliance(identified)
        if k is None or not np.any(k > 0):
            return None
        if identified.inertials is None:
            raise DenavitError(
                f"{identified.name}: joint compliances without the links' inertial parameters: no gravity torques to"
                " deflect under"
            )
        m = identified.model()
        return Elastic(
            k, m, identified.compliance_covariance, None, _model_flange(identified, m), identified.compliance_cross
        )
    if isinstance(getattr(identified, "compliance", None), dict) and hasattr(identified, "axis_cov"):
        # an identification whose joint fit freed them: as its saved robot, but beside its own covariance (of the axes
        # at home: compensation's _axes_propagation) with the compliances' cross-covariance with it, as the fit's
        el = elastic(identified.robot())
        c, n = identified.compliance, len(identified.compliance["k"])
        full, scale = getattr(identified, "axis_scale_cov", None), getattr(identified, "reading_scale", None)
        rows = 6 * n + 3 if full is None or scale is None else len(full)
        cross = None if c.get("cross") is None else np.asarray(c["cross"], dtype=float)[:rows]
        return None if el is None else replace(el, cross=cross, torque_reference=np.asarray(c["torque_home"]))
    pz = getattr(identified, "parametrization", None)
    if isinstance(pz, CompliantParametrization) and any(
        n.startswith("k_") for n in getattr(identified, "free_names", ())
    ):
        return Elastic(pz.compliance_of(identified.values).copy(), pz.torque_model, None, identified)
    return None


def _model_flange(robot, model: _core.Model) -> np.ndarray | None:
    """A Robot's ``compliance_flange`` (in its table's last frame; None: that frame itself) in its model's flange frame,
    where :func:`gravity_torques` takes it (None: the same). They differ for a POE table, whose model's flange frame
    is its home pose ``M``'s (a payload's centre of mass had been taken 0.29 m off on a UR5's)."""
    z = np.zeros(model.nq)
    last = np.asarray(robot.table.frames(z))[-1]
    F = np.eye(4) if robot.compliance_flange is None else np.asarray(robot.compliance_flange, dtype=float)
    F = np.linalg.inv(np.asarray(_core.joint_frames(model, z))[-1] @ np.asarray(model.T_last_flange)) @ last @ F
    return None if np.allclose(F, np.eye(4), rtol=0, atol=1e-12) else F


def elastic_of(model) -> Elastic | None:
    """:func:`elastic` of whatever a command scores or compensates with: a calibration, an identification or a Robot
    (a URDF's has no compliances); None for anything else (a Model)."""
    from ..robot import Robot  # noqa: PLC0415

    if isinstance(model, Robot) or hasattr(model, "parametrization") or hasattr(model, "axis_cov"):
        return elastic(model)
    return None


@dataclass(frozen=True)
class CompliancePlan:
    """The predicted sigmas (Cramér-Rao bound, SI: rad/(N m), m/N) of the joints' compliances for poses ``q`` (N, n)
    each measured at every payload of ``payloads`` (kg, at ``com`` in the flange frame), with the geometry
    (every parameter the data identify) fitted with them: ``sigma`` (n,) (NaN: no parameter, a joint holding no
    torque), ``torque_max`` (n,) the largest torque each joint holds, ``notes``."""

    names: list
    sigma: np.ndarray
    torque_max: np.ndarray
    payloads: tuple
    n_poses: int
    notes: list


def plan_compliance(
    nominal, q, payloads, *, com=(0.0, 0.0, 0.0), noise: float = 2e-5, tool=(0.05, 0.03, 0.10), convention: str = "edh"
) -> CompliancePlan:
    """Predict the compliances' sigmas of a planned calibration (:class:`CompliancePlan`): the whitened Jacobian of the
    geometry and the compliances at the nominal (zero compliances), its covariance ``noise^2 (J^T J)^-1`` over the
    identifiable parameters (no priors: what the data alone determine). The two-payload protocol is
    ``payloads=(0, rated)``."""
    from ..robot import robot_of  # noqa: PLC0415
    from .identifiability import analyze  # noqa: PLC0415
    from .least_squares import covariance, jacobian_rows, weights  # noqa: PLC0415
    from .measurements import Measurements  # noqa: PLC0415
    from .parametrization import parametrize  # noqa: PLC0415

    robot = robot_of(nominal)
    q = np.atleast_2d(np.asarray(q, dtype=float))
    loads = [float(m) for m in np.atleast_1d(payloads)]
    if not loads or any(not (math.isfinite(m) and m >= 0) for m in loads):
        raise DenavitError(f"payloads: expected one or more masses >= 0 kg, got {payloads!r}")
    c = np.asarray(com, dtype=float).reshape(3)
    Q = np.vstack([q] * len(loads))
    pl = np.vstack([np.tile(np.r_[m, c], (len(q), 1)) for m in loads])
    meas = Measurements(Q, np.zeros((len(Q), 3)), None, "planned poses", payload=pl)
    pz, notes = with_compliance(parametrize(robot, convention, tool=np.asarray(tool, dtype=float)), meas, robot, True)
    n = len(robot.names)
    if not isinstance(pz, CompliantParametrization):
        return CompliancePlan(
            [f"k_{j + 1}" for j in range(n)], np.full(n, np.nan), np.zeros(n), tuple(loads), len(Q), notes
        )
    w = weights("point", noise, noise)
    cand = [i for i in range(pz.n_geometric) if pz.names[i] not in pz.rules] + list(pz.compliance_idx)
    kept = analyze(pz, pz.x0, meas, cand, w, explain=False).kept_idx
    J = jacobian_rows(pz, pz.x0, pz.inputs(meas), w, kept)[1]
    cov = covariance(J, 1.0)
    sigma = np.full(n, np.nan)
    for i, c_ in enumerate(kept):
        if c_ >= pz.n_geometric:
            sigma[c_ - pz.n_geometric] = math.sqrt(max(cov[i, i], 0.0))
    dropped = [pz.names[c_] for c_ in pz.compliance_idx if c_ not in kept]
    if dropped:
        notes.append(f"not identifiable from these poses and payloads: {', '.join(dropped)}")
    tmax = np.abs(pz.torques(Q, pl)).max(axis=0)
    return CompliancePlan([f"k_{j + 1}" for j in range(n)], sigma, tmax, tuple(loads), len(Q), notes)
