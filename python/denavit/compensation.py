"""Compensation: put an identified model to work on a robot whose controller keeps its nominal model.

For each position (a row of a program: a tool pose ``T``, robot base frame), :func:`compensate` finds the joint values
``q`` that reach it on the identified model, solved from the nominal solution's branch, and the pose ``T' =
FK_nominal(q')`` to send to the controller: its nominal inverse kinematics turns ``T'`` into ``q'``, and the robot
reaches ``T`` (RoboDK calls this "filtering" a program). ``q' = q`` unless the identified robot reads its joints
otherwise than the nominal does (its reading model: a coupling, the reading scale errors that identify or calibrate
estimated, :func:`denavit.robot.joint_values`): then ``q'`` is the nominal's joint values of the readings that put the
identified joints at ``q``. The solves run in the Rust core (``denavit._core.compensate``), without the GIL, on every
core.

:func:`predicted_sigma` gives the predicted tool-position error (1 sigma, 3-D RMS) of an identified model at given
configurations from the covariance of an identification or calibration result; :func:`denavit.accuracy.accuracy_map`
compares, over the workspace or a program, the error of the nominal model (how far the robot is from where the nominal
model says) with that prediction.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from . import _core
from .calibration.compliance import as_payload, elastic
from .errors import DenavitError
from .fitting.checks import robot_size
from .robot import Robot, joint_values, readings

#: The largest joint change (rad; m for a prismatic joint) that keeps a row's branch (5.7 deg), the CLI's default too.
BRANCH_TOL = 0.1

#: An identified base farther than this fraction of the robot's size or this angle (rad) from the nominal's is where a
#: tracker in a frame of its own saw the robot; compensate takes the nominal's base then (:func:`compensate`).
BASE_FRACTION, BASE_ANGLE = 0.1, np.radians(5.0)


@dataclass(frozen=True)
class Compensation:
    """The compensation of N positions (SI: m, rad). Per position:

    ``positions`` (N, 4, 4) as given; ``commands`` (N, 4, 4) ``T' = FK_nominal(q_command)``, the poses to send; ``q``
    (N, n) the identified model's joint values; ``q_nominal`` (N, n) the program's nominal ones; ``q_command`` (N, n)
    the nominal model's joint values of the commands (the joint rows to send: ``q`` itself unless the identified robot's
    readings differ from the nominal's, by its reading scales or coupling); ``reached``, ``branch_changed``,
    ``path_jump`` flags (never silently kept: a row with a flag is not a valid command); ``residual`` (N,) position
    residual of the identified solve (m); ``before`` (N,) the position error the robot makes without compensation (m);
    ``predicted_after`` (N,) the predicted position error after it (1 sigma, m; at the flange with ``flange``, its
    position along the last axis left out) when a result with a covariance was given, else None; ``notes`` what the
    compensation assumed (e.g. the flange compensated when only the identified robot has a tool).

    With a prediction, over the ``ok`` rows: ``predicted_rms`` (m) and ``predicted_dof``, the effective degrees of
    freedom of the RMS's spread (every row's error comes from one error of the parameters: a generalised chi-square,
    not an average of independent errors; :meth:`predicted_rms_bound`).
    """

    positions: np.ndarray
    commands: np.ndarray
    q: np.ndarray
    q_nominal: np.ndarray
    reached: np.ndarray
    branch_changed: np.ndarray
    path_jump: np.ndarray
    residual: np.ndarray
    residual_rotation: np.ndarray
    before: np.ndarray
    before_rotation: np.ndarray
    predicted_after: np.ndarray | None = None
    q_command: np.ndarray | None = None
    notes: tuple[str, ...] = ()
    assumed: np.ndarray | None = None
    """(N,) the rows that came without a configuration: ``q_nominal`` is the one assumed for them (the nominal's
    solution nearest ``q0``), and ``branch_changed`` compares with it; the others' ``q_nominal`` is the program's."""
    predicted_rms: float | None = None
    predicted_dof: float | None = None
    flange: bool = False
    """The flange compensated, and ``predicted_after`` there (an identified robot measured at one point: ``notes``)."""

    def __post_init__(self):
        if self.q_command is None:
            object.__setattr__(self, "q_command", self.q)
        if self.assumed is None:
            object.__setattr__(self, "assumed", np.zeros(len(self.positions), dtype=bool))

    def predicted_rms_bound(self, level: float = 0.95) -> float | None:
        """The ``level`` quantile (m) of the RMS position error after over the ``ok`` rows (None without a
        prediction): the mean square error is ``sum_j lambda_j chi2_1`` (``lambda`` the eigenvalues of ``C G``, ``C``
        the parameters' covariance, ``G`` the mean over the rows of ``J_i^T J_i``), taken as Satterthwaite's scaled
        chi-square of the same mean and variance, ``predicted_dof = (tr CG)^2 / tr((CG)^2)`` degrees of freedom
        (Satterthwaite 1946, Biometrics Bulletin 2(6), 110-114; a test checks the 95 % bound against sampled errors).
        """
        if self.predicted_rms is None:
            return None
        if not 0 < level < 1:
            raise DenavitError(f"level: expected a probability between 0 and 1, got {level!r}")
        from scipy.stats import chi2  # noqa: PLC0415

        nu = self.predicted_dof
        return float(self.predicted_rms * np.sqrt(chi2.ppf(level, nu) / nu)) if nu > 0 else 0.0

    @property
    def ok(self) -> np.ndarray:
        """(N,) rows whose command can be sent: reached, on the nominal branch, no path jump."""
        return self.reached & ~self.branch_changed & ~self.path_jump

    def __len__(self) -> int:
        return len(self.positions)

    def __repr__(self) -> str:
        flagged = int((~self.ok).sum())
        before = float(np.sqrt(np.mean(self.before**2))) if len(self) else float("nan")
        return f"Compensation({len(self)} positions, {flagged} flagged, error before {before * 1e3:.4g} mm RMS)"


def _model(m, what: str) -> _core.Model:
    if isinstance(m, _core.Model):
        return m
    if hasattr(m, "model") and callable(m.model):
        return m.model()
    if isinstance(m, str) or hasattr(m, "__fspath__"):
        raise DenavitError(
            f"{what}: expected a Model, a Robot or a result with .model(), got the name or path {str(m)!r}: read it"
            " with denavit.load_robot, or call denavit.compensate (which reads names and files)"
        )
    raise DenavitError(f"{what}: expected a Model, a Robot or a result with .model(), got {type(m).__name__}")


def reading_model(m) -> tuple | None:
    """(coupling, scale, reference) of how ``m`` reads its joints (:func:`denavit.robot.joint_values`), or None when
    its readings are its joint values (a bare Model). ``m``: a Robot (its ``coupling`` and ``reading_scale`` /
    ``reading_reference``, e.g. from a robot file's ``[couplings]`` and ``[readings]``), an identification (the
    coupling it decoupled the sweeps with; the reading scales auto fitted, about the sweeps' home) or a calibration
    (its scales, about zero)."""
    if isinstance(m, Robot):
        return (m.coupling, m.reading_scale, m.reading_reference) if m.has_reading_model else None
    if hasattr(m, "axis_cov") and hasattr(m, "sweeps"):  # an Identification
        scale = getattr(m, "reading_scale", None)
        ref = None if scale is None else np.asarray(m.sweeps.home, dtype=float)
        coupling = getattr(m, "coupling", None)
        return None if scale is None and coupling is None else (coupling, scale, ref)
    if hasattr(m, "parametrization") and hasattr(m, "scales"):  # a Calibration
        sc = m.scales
        if not sc:
            return None
        return (None, np.array([sc.get(f"scale_{j + 1}", 0.0) for j in range(m.parametrization.nq)]), None)
    return None


def _angle(R: np.ndarray) -> np.ndarray:
    """(N,) rotation angles of (N, 3, 3) rotations."""
    return np.arccos(np.clip((np.einsum("nii->n", R) - 1) / 2, -1.0, 1.0))


def compensate(
    nominal,
    identified,
    positions,
    *,
    q_nominal=None,
    q0=None,
    path: bool = False,
    result=None,
    predict: bool = True,
    branch_tol: float = BRANCH_TOL,
    payload=None,
    registration: bool = False,
    **ik_options,
) -> Compensation:
    """Compensate ``positions`` for a controller that keeps ``nominal`` while the robot is ``identified``.

    Parameters
    ----------
    nominal, identified : Model, Robot, Identification, Calibration, built-in name or robot file
        The controller's model and the robot's identified model (same joints; both in the robot base frame: an
        identified base far from the nominal's, where a tracker in a frame of its own saw it, is taken as the
        nominal's and a note says so, unless ``registration``).
    positions : array-like, shape (N, 4, 4)
        The tool poses ``T_world_tool`` to reach (m): a program's rows.
    q_nominal : array-like, shape (N, n), optional
        The program's configuration: its nominal joint values (rad / m), when it was written as joint rows or
        its configuration is known (e.g. a controller's configuration bits); a row of NaN: none. Rows without one
        are compensated on the nominal's solution nearest ``q0`` (:func:`nearest_solutions`; ``assumed`` says which).
    q0 : array-like, shape (n,), optional
        The configuration the rows without one are nearest to; default the nominal's home (a Robot's ``home``),
        else zeros.
    path : bool
        The positions form a path: nominal solutions are warm-started along it (from ``q0``) and jumps are flagged.
    result : Identification or Calibration, optional
        Gives ``predicted_after`` (:func:`predicted_sigma` at the compensated joint values, at the flange when that is
        compensated); default ``identified`` itself when it is one, or its ``covariance`` when it is a Robot that has
        one (:func:`table_sigma`).
    predict : bool
        False: no ``predicted_after`` (its central differences cost more than the solves).
    branch_tol : float
        Largest joint change (rad / m) from the nominal solution that keeps its branch (default 0.1 rad, as the CLI's).
    payload : float, (mass, (x, y, z)) or (N, 4), optional
        The payload of each row (kg; its centre of mass in the flange frame, m) when ``identified`` has compliant
        joints (a robot file's ``[compliance]``, a calibration that freed them: :mod:`denavit.calibration.compliance`):
        the commands are the readings that the joints, deflected under gravity and this payload, turn into ``q``;
        ``predicted_after`` includes the compliances' covariance. None: no payload (the links' own weight only).
    registration : bool
        False: ``predicted_after`` is the error in the robot base frame (positions given relative to the robot). True:
        in ``world``, a calibration's measurement frame, its base registration's covariance included (positions located
        by the tracker: a fixture, a part it measured). An identification's prediction is ``world``'s either way (its
        axes are lines measured there); a robot file's ``[covariance]`` carries no registration (an error).
    ik_options
        Options of the IK solves (``method``, ``tol_position``, ``tol_rotation``, ``restarts``, ...).
    """
    nom, ide = _model(nominal, "nominal"), _model(identified, "identified")
    ide, notes, place = _flange(nominal, nom, identified, ide, registration)
    T = np.asarray(positions, dtype=float)
    if T.ndim == 2:
        T = T[None]
    if q0 is None:
        home = getattr(nominal, "home", None)
        q0 = np.zeros(nom.nq) if home is None else np.asarray(home, dtype=float)
    q0 = np.asarray(q0, dtype=float)
    q_nominal, assumed, unreachable = _configurations(nom, T, q_nominal, q0, path, ik_options)
    r = _core.compensate(nom, ide, T, q_nominal, q0, path=path, branch_tol=branch_tol, **ik_options)
    q = r.q
    # compliant joints (calibration/compliance.py): the commanded readings deflect to q under gravity and the payload
    el = elastic(identified)
    pl = None if el is None else as_payload(payload, len(T))
    qc = q if el is None else el.command(q, pl)
    prop = _predicted(identified, result, q, el, qc, pl, registration, place, ide) if predict else None
    predicted = None if prop is None else _sigma(*prop)
    ok = r.reached & ~unreachable & ~r.branch_changed & ~r.path_jump
    rms_dof = (None, None) if prop is None else _rms_dof(prop[0][ok], prop[1])
    commands, q_cmd, before, before_rot = r.commands, q, r.before_position, r.before_rotation
    if el is not None:
        q_cmd, commands = qc, _core.fk_batch(nom, qc)
        # the program run as written, the joints deflected
        before, before_rot = _errors(T, _core.fk_batch(ide, el.deflected(r.q_nominal, pl)))
    through = _through_readings(nominal, identified, nom, ide, T, r.q_nominal, qc, el, pl)
    if through is not None:
        q_cmd, commands, before, before_rot = through
    if place is not None:  # what no measurement of one point tells; its scale: the robot's error before
        notes.append(
            "the flange's position along the last axis is the nominal's, not measured: one measured point cannot tell"
            " it from the tool's length, so a constant error along the flange's z is in neither the compensation nor"
            " the prediction, as large as the robot's errors before compensation can be"
            f" ({np.sqrt(np.mean(before[ok] ** 2)) * 1e3 if ok.any() else np.nan:.3g} mm RMS here; its centring on the"
            " axis is the nominal's too); only where the point sits on the flange tells it (a nest of known height:"
            " give the nominal that tool, compensate its poses)"
        )
    if el is None and payload is not None:
        notes.append(
            f"the payload changes nothing: {getattr(identified, 'name', 'the identified robot')} has no joint"
            " compliances (a robot file's [compliance], a calibration that freed them): the commands are a rigid arm's"
        )
    if assumed.any():
        notes.append(
            f"{int(assumed.sum())} of {len(T)} rows without a configuration: "
            "compensated on the nominal's solution nearest q0 "
            f"({', '.join(f'{v:.4g}' for v in q0)} rad / m){' warm-started along the path' if path else ''}"
            + (f"; {int(unreachable.sum())} of them unreachable on the nominal" if unreachable.any() else "")
        )
    return Compensation(
        T,
        commands,
        q,
        r.q_nominal,
        r.reached & ~unreachable,
        r.branch_changed,
        r.path_jump,
        r.position_error,
        r.rotation_error,
        before,
        before_rot,
        predicted,
        q_cmd,
        tuple(notes),
        assumed,
        *rms_dof,
        place is not None,
    )


def _configurations(nom: _core.Model, T: np.ndarray, q_nominal, q0: np.ndarray, path: bool, ik_options: dict):
    """(the program's configurations for the core, which rows had none (assumed), which of those the nominal cannot
    reach): outside path mode, a row without one takes the nominal's solution nearest ``q0``."""
    qarr = None if q_nominal is None else np.asarray(q_nominal, dtype=float)
    if qarr is not None and qarr.shape != (len(T), nom.nq):  # (the core says what is wrong)
        assumed = np.zeros(len(T), dtype=bool)
    else:
        assumed = np.ones(len(T), dtype=bool) if qarr is None else ~np.all(np.isfinite(qarr), axis=1)
    unreachable = np.zeros(len(T), dtype=bool)
    if assumed.any() and not path and _valid_poses(T):
        # the rows without a configuration: the nominal's solution nearest q0 (the core's solve from q0 is local:
        # it gives whatever branch its descent falls into, 36 % of a program's rows off the program's)
        qn = np.full((len(T), nom.nq), np.nan) if q_nominal is None else np.array(q_nominal, dtype=float)
        ik_solve = {
            k: v
            for k, v in ik_options.items()
            if k in ("method", "tol_position", "tol_rotation", "max_iterations", "damping")
        }
        qa, found = nearest_solutions(nom, T[assumed], q0, **ik_solve)
        qn[assumed] = qa
        unreachable[np.flatnonzero(assumed)[~found]] = True
        q_nominal = qn
    elif assumed.any():
        q_nominal = None if assumed.all() else q_nominal
        if q_nominal is not None:
            raise DenavitError(
                "q_nominal: path mode takes a configuration for every row or for none (rows of NaN among given ones)"
            )
    return q_nominal, assumed, unreachable


def _predicted(identified, result, q: np.ndarray, el, qc: np.ndarray, pl, registration: bool, place=None, ide=None):
    """(J (N, 3, P), C (P, P)) of ``predicted_after`` (:func:`_propagation`) at the compensated joint values ``q``
    (from ``result``, else from ``identified``'s own covariance), with the compliances' at the commands ``qc`` when the
    joints are compliant; None without a covariance. At the compensated point: the flange of ``place`` (a model of the
    robot turned into the one compensated, :func:`_flange`) when it is given, ``ide`` that model."""
    prop = None
    if result is not None:
        prop = _propagation(result, q, registration, place)
    elif hasattr(identified, "axis_cov") or hasattr(identified, "parametrization"):
        prop = _propagation(identified, q, registration, place)  # an identification or a calibration: its own
    elif isinstance(identified, Robot) and identified.covariance is not None:
        prop = _table_propagation(identified, q, registration, place)  # e.g. a robot file's [covariance]
    if el is not None:
        el = el if result is None else replace(el, cross=None, torque_reference=None)  # (both of its own covariance)
        prop = _compliant_propagation(el, prop, qc, pl, registration, place, None if place is None else ide)
    return prop


def _sigma(J: np.ndarray, C: np.ndarray) -> np.ndarray:
    """(N,) ``sqrt(trace(J_i C J_i^T))``."""
    return np.sqrt(np.maximum(np.einsum("nij,jk,nik->n", J, C, J), 0.0))


def _rms_dof(J: np.ndarray, C: np.ndarray) -> tuple[float | None, float | None]:
    """(predicted RMS over the rows of ``J``, its effective degrees of freedom ``(tr CG)^2 / tr((CG)^2)``, ``G`` the
    mean of ``J_i^T J_i``: :meth:`Compensation.predicted_rms_bound`); (None, None) without rows."""
    if not len(J):
        return None, None
    CG = C @ (np.einsum("nip,niq->pq", J, J) / len(J))
    t1, t2 = float(np.trace(CG)), float(np.sum(CG * CG.T))
    return float(np.sqrt(max(t1, 0.0))), (t1 * t1 / t2 if t2 > 0 else 0.0)


def _errors(T: np.ndarray, exe: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(position error m, rotation error rad) of the executed poses ``exe`` from the positions ``T``."""
    before = np.linalg.norm(exe[:, :3, 3] - T[:, :3, 3], axis=1)
    return before, _angle(np.swapaxes(T[:, :3, :3], 1, 2) @ exe[:, :3, :3])


def _through_readings(nominal, identified, nom: _core.Model, ide: _core.Model, T, q_program, qc, el, pl):
    """(commanded joint values, commanded poses, position and rotation errors before) when the nominal and the
    identified robot read their joints differently, else None: the controller turns the nominal's joint values into
    readings (its coupling), the identified robot turns readings into its joint values (its coupling, else the
    nominal's; its reading scales). ``q_program``: the program's nominal joint values; ``qc``: the commands."""
    rm_nom = reading_model(nominal)
    rm_id = reading_model(identified)
    if rm_id is not None and rm_id[0] is None and rm_nom is not None:
        rm_id = (rm_nom[0], *rm_id[1:])
    rm_id = rm_nom if rm_id is None else rm_id
    if _same_readings(rm_nom, rm_id):
        return None

    def to_nominal(qi):
        rd = readings(qi, *rm_id) if rm_id is not None else qi
        return joint_values(rd, *rm_nom) if rm_nom is not None else rd

    def to_identified(qn):
        rd = readings(qn, *rm_nom) if rm_nom is not None else qn
        return joint_values(rd, *rm_id) if rm_id is not None else rd

    q_cmd = to_nominal(qc)
    commands = _core.fk_batch(nom, q_cmd)
    q_run = to_identified(q_program)
    exe = _core.fk_batch(ide, q_run if el is None else el.deflected(q_run, pl))  # the program run as written
    return (q_cmd, commands, *_errors(T, exe))


def _valid_poses(T: np.ndarray) -> bool:
    """Every position a finite rigid pose (else the core's check says which is not)."""
    R = T[:, :3, :3]
    return bool(
        np.all(np.isfinite(T))
        and np.allclose(R @ np.swapaxes(R, 1, 2), np.eye(3), atol=1e-6)
        and np.allclose(T[:, 3], [0, 0, 0, 1])
    )


def nearest_solutions(model, positions, q_ref, *, seeds: int = 24, **ik_options) -> tuple[np.ndarray, np.ndarray]:
    """The inverse kinematics of ``positions`` (N, 4, 4) on ``model`` nearest ``q_ref`` ((n,) or (N, n)): among the
    solutions found from ``q_ref`` and from ``seeds`` fixed configurations spread over the joint limits (local
    solves, no restarts: one per branch they fall into), each revolute joint moved by whole turns to the value within
    its limits nearest ``q_ref``'s, the one nearest ``q_ref`` (Euclidean, rad / m). Returns ``q`` (N, n) and
    ``found`` (N,); a row not found keeps ``q_ref``."""
    m = _model(model, "model")
    T = np.asarray(positions, dtype=float).reshape(-1, 4, 4)
    N, n = len(T), m.nq
    ref = np.broadcast_to(np.asarray(q_ref, dtype=float), (N, n))
    if N == 0:
        return np.zeros((0, n)), np.zeros(0, dtype=bool)
    lo, hi = np.asarray(m.lower, dtype=float), np.asarray(m.upper, dtype=float)
    rev = np.array([k == "revolute" for k in m.kinds])
    lo2, hi2 = np.where(rev, np.maximum(lo, -np.pi), lo), np.where(rev, np.minimum(hi, np.pi), hi)
    S = lo2 + (hi2 - lo2) * np.random.default_rng(20260538).random((seeds, n))
    K = seeds + 1
    starts = np.concatenate([ref[:, None, :], np.broadcast_to(S, (N, seeds, n))], axis=1).reshape(-1, n)
    res = _core.ik_batch(m, np.repeat(T, K, axis=0), starts, restarts=0, **ik_options)
    q = res.q.reshape(N, K, n)
    ok = res.success.reshape(N, K)
    R = np.repeat(ref[:, None, :], K, axis=1)
    inside = (q >= lo - 1e-12) & (q <= hi + 1e-12)
    best, dist = q.copy(), np.where(inside, np.abs(q - R), np.inf)
    for turns in (-1, 1, -2, 2):  # the same joint angle whole turns away (a wrist within +-350 deg), within the limits
        c = q + turns * 2 * np.pi
        d = np.where(rev & (c >= lo - 1e-12) & (c <= hi + 1e-12), np.abs(c - R), np.inf)
        closer = d < dist
        best, dist = np.where(closer, c, best), np.where(closer, d, dist)
    total = np.where(
        ok & np.all(np.isfinite(dist), axis=2),
        np.sqrt(np.sum(np.where(np.isfinite(dist), dist, 0.0) ** 2, axis=2)),
        np.inf,
    )
    k = np.argmin(total, axis=1)
    found = np.isfinite(total[np.arange(N), k])
    return np.where(found[:, None], best[np.arange(N), k], ref), found


#: An identified tool farther than this fraction of the robot's size from the flange is a tool (identify's measured
#: point), not the flange's own error: the plausibility checks' bound on an axis's error (fitting.checks.PLAUSIBLE,
#: 2 %: 27 mm on the KR5), beyond which identify calls a link implausible.
TOOL_FRACTION = 0.02


def _is_identity(T) -> bool:
    return bool(np.allclose(np.asarray(T, dtype=float), np.eye(4), rtol=0.0, atol=1e-12))


def _flange(nominal, nom: _core.Model, identified, ide: _core.Model, registration=False):
    """(the identified model compensate uses (:func:`flange_model`), the notes that say so, ``place``: what turns any
    model of the identified robot into it, or None: as it is). Unless ``registration``, a model whose base is farther
    from the nominal's than :data:`BASE_FRACTION` of the robot's size or :data:`BASE_ANGLE` stands where the nominal
    stands: its base is where a tracker in a frame of its own saw the robot (a calibration's registration), and
    positions are in the robot base frame. Nearer, the measurement frame is the robot base frame (a tracker registered
    to it): the base's small error is the robot's and is kept."""
    notes, orig, base = [], ide, None
    d = np.asarray(ide.T_world_base) @ np.linalg.inv(np.asarray(nom.T_world_base))
    far = np.linalg.norm(d[:3, 3]) > BASE_FRACTION * robot_size(nom, np.zeros(nom.nq))
    if not registration and (far or _angle(d[None, :3, :3])[0] > BASE_ANGLE):
        ide, base = ide.with_base(nom.T_world_base), np.asarray(nom.T_world_base)
        notes.append(
            f"the identified robot's base (where it was measured: {np.linalg.norm(d[:3, 3]) * 1e3:.4g} mm,"
            f" {np.degrees(_angle(d[None, :3, :3])[0]):.3g} deg from the nominal's) taken as the nominal's: the"
            " positions are in the robot base frame (positions in the measurement frame: registration=True, in Python)"
        )
    if not np.allclose(np.asarray(nom.T_flange_tool)[:3, 3], 0.0, rtol=0.0, atol=1e-12):
        return ide, notes, None  # a tool with an offset: the positions are its poses, the identified robot's tool one
    # (a tool that is a pure rotation is the flange frame the model names its own, REP-199's tool0: the kr210's half
    # turn about its DH frame 6's z; the identified robot's flange is then placed as that frame is, below)
    home = getattr(nominal, "home", None)
    # its tool as the nominal's flange sees it (a POE table has no flange of its own: its home pose M is its tool)
    try:
        nom_tool = canonical_tool(nom, nom, home)
        canon = canonical_tool(nom, ide, home) @ np.linalg.inv(nom_tool)
    except DenavitError:
        if getattr(identified, "convention", None) == "poe":
            raise
        return ide, notes, None
    off = canon[:3, 3]
    if np.linalg.norm(off) <= TOOL_FRACTION * robot_size(nom, np.zeros(nom.nq)):
        return ide, notes, None
    # identify's tool is the point it measured (a reflector on the flange), not the controller's tool: with a nominal
    # that has none, the flange is compensated, placed on its last body as the nominal's is (canonical_tool: where a
    # table puts its last frame along the last axis, the split of d6 and the tool's z that no measurement of one point
    # tells apart, is each convention's own, and a file saved in another would compensate another flange)

    def place(m: _core.Model) -> _core.Model:
        m = m if base is None else m.with_base(base)
        return m.with_tool(np.asarray(m.T_flange_tool) @ nom_tool @ np.linalg.inv(canonical_tool(nom, m, home)))

    ide = place(orig)
    has = "has no tool" if _is_identity(nom.T_flange_tool) else "has its flange frame (a rotation) as its only tool"
    notes.append(
        f"the nominal {getattr(nominal, 'name', 'model')} {has} and the identified robot has one"
        f" ({np.linalg.norm(off) * 1e3:.4g} mm from the flange: the point it was measured at): the flange compensated"
        " (the identified flange placed on its last body as the nominal's is), the prediction after it at the flange"
        " (the measured point's error and its orientation's over that lever); for tool poses give the nominal its"
        " tool (a program's own tool frames are applied as its controller applies them)"
    )
    return ide, notes, place


def flange_model(nominal, identified) -> _core.Model:
    """The identified model as :func:`compensate` uses it against ``nominal``: as it is, unless the nominal has no tool
    (or one that is a pure rotation: its own flange frame, the kr210's tool0) and the identified robot has one farther
    than :data:`TOOL_FRACTION` of the robot's size (the point identify or calibrate measured): then its flange is its
    canonical flange (:func:`canonical_tool`) and it has no tool, the same
    from the in-memory result and from every file saved of it. What to export for a controller that takes a corrected
    model (``io.ur_calibration.save``) so that it and a compensation agree."""
    ide = _flange(nominal, _model(nominal, "nominal"), identified, _model(identified, "identified"))[0]
    if _is_identity(ide.T_flange_tool):
        return ide
    # the flange itself there (a kinematics file writes the flange, not a tool)
    return _core.Model.from_placements(
        ide.placements,
        list(ide.kinds),
        offsets=ide.offsets,
        lower=ide.lower,
        upper=ide.upper,
        names=list(ide.names),
        T_world_base=ide.T_world_base,
        T_last_flange=np.asarray(ide.T_last_flange) @ np.asarray(ide.T_flange_tool),
        name=ide.name,
    )


def canonical_tool(nom: _core.Model, ide: _core.Model, home=None) -> np.ndarray:
    """The tool of the identified model ``ide`` in its canonical flange: the flange of its exact ED-H table extracted
    as identify extracts one (the nominal's ED-H frame origins at ``home``, the nominal's home, else zeros, projected
    on the axes), the last origin at the nominal's distance from the wrist (the last axis's common normal with the one
    before). Where a table puts its last frame along the last axis (the split of d6 and the tool's z, which no
    measurement of one point tells apart) is each convention's own: a DH
    file, a URDF or a UR kinematics file of one result would each compensate another flange; this one is the same
    for all of them, for the ED-H file identify and calibrate save, and for the in-memory result. A POE model has no
    flange of its own (its home pose ``M``, identify's measured point, is its flange, its tool the identity)."""
    home = np.zeros(nom.nq) if home is None else np.asarray(home, dtype=float)
    # (identify and its fits load only when an identified tool is compensated)
    from .identification.frames import origins  # noqa: PLC0415

    nt = _core.extract(_core.axes(nom, np.zeros(nom.nq)), "edh").table
    ia = _core.axes(ide, home)
    ex = _core.extract(ia, "edh", nominal=nt, origins=origins(nt, "edh", home, ia), parallel_tol=1e-9, fidelity=False)
    return np.asarray(ex.table.to_model().T_flange_tool)


def _same_readings(a, b) -> bool:
    """Two reading models map readings to joint values alike."""

    def parts(m):
        c, s, ref = (None, None, None) if m is None else m
        s = None if s is None or not np.any(np.asarray(s)) else np.asarray(s, dtype=float)
        return c, s, (None if s is None or ref is None else np.asarray(ref, dtype=float))

    (ca, sa, ra), (cb, sb, rb) = parts(a), parts(b)

    def eq(x, y, default):
        if x is None and y is None:
            return True
        return bool(np.all(np.asarray(default if x is None else x) == np.asarray(default if y is None else y)))

    n = None
    for v in (ca, cb):
        n = len(v) if v is not None else n
    eye = np.eye(n) if n else None
    return eq(ca, cb, eye) and eq(sa, sb, 0.0) and (sa is None or eq(ra, rb, 0.0))


def predicted_sigma(result, q, *, registration: bool = False) -> np.ndarray:
    """(N,) predicted tool-position error (1 sigma, 3-D RMS: ``sqrt(trace(J C J^T))``, m) of the model that
    ``result`` identified, at configurations ``q`` (N, n), from its covariance ``C``.

    result : a calibration (:class:`denavit.calibration.Calibration`: the analytic identification Jacobian of
        its chain over the estimated parameters) or an identification (:class:`denavit.identification.Identification`:
        the covariance of the axis lines and the tool point, propagated to the tool by central differences through the
        exact ED-H model of the axes).
    registration : a calibration's base registration (``base_*``) included: the error in ``world``, the measurement
        frame, for positions located there (default: left out, the error in the robot base frame, for positions given
        relative to the robot). An identification's axes are lines in ``world``: its prediction is world's either way.
    """
    return _sigma(*_propagation(result, q, registration))


def _propagation(result, q, registration: bool = False, place=None) -> tuple[np.ndarray, np.ndarray]:
    """(J (N, 3, P), C (P, P)) of :func:`predicted_sigma`: the tool point's derivatives at ``q`` (of ``place(model)``
    with ``place``: the flange compensated, :func:`_flange`) and the covariance of the P parameters they are in."""
    q = np.atleast_2d(np.asarray(q, dtype=float))
    if hasattr(result, "parametrization") and hasattr(result, "covariance"):
        pz = result.parametrization
        free = [pz.index(n) for n in result.free_names]
        keep = [k for k, name in enumerate(result.free_names) if registration or not name.startswith("base_")]
        cols, C = [free[k] for k in keep], np.asarray(result.covariance)[np.ix_(keep, keep)]
        T, J = pz.evaluate(result.values, q, True, rows=3 if place is None else 6, columns=cols)
        if place is None:
            return J, C

        # the placed point is c(x) in the tool frame: its error is the tool point's, the tool's rotation over the
        # lever R c (J's rotation rows w: dR = [w] R) and R dc (c by central differences through the placement)
        def c_of(x):
            m = pz.model(x)
            return (np.linalg.inv(np.asarray(m.T_flange_tool)) @ np.asarray(place(m).T_flange_tool))[:3, 3]

        x0, h, E = np.asarray(result.values, dtype=float), np.sqrt(np.maximum(np.diag(C), 0.0)), np.eye(pz.n_params)
        geo = getattr(pz, "n_geometric", pz.n_params)  # (a compliance moves no frame of the chain)
        dc = np.zeros((3, len(cols)))
        for i, k in enumerate(cols):
            if h[i] > 0 and k < geo:
                dc[:, i] = (c_of(x0 + h[i] * E[k]) - c_of(x0 - h[i] * E[k])) / (2 * h[i])
        R = np.asarray(T)[:, :3, :3]
        lever = np.cross(J[:, 3:], (R @ c_of(x0))[:, :, None], axisa=1, axisb=1, axisc=1)
        return J[:, :3] + lever + np.einsum("nij,jp->nip", R, dc), C
    if hasattr(result, "axis_cov") and hasattr(result, "axes"):
        return _axes_propagation(result, q, place)
    raise DenavitError(
        f"result: expected an identification or a calibration result with a covariance, got {type(result).__name__}"
    )


def compliant_sigma(el, geometric, q, payload=None, *, registration: bool = False) -> np.ndarray | None:
    """The predicted tool-position error (1 sigma, m) at the commanded readings ``q`` of a robot with compliant joints
    (``el``, a :class:`denavit.calibration.compliance.Elastic`): from the calibration's full covariance when it came
    from one (geometry and compliances with their correlations; ``registration`` as :func:`predicted_sigma`'s); else
    ``geometric``: the Robot or identification ``el`` is of, its covariance at the links' joint values and the
    compliances' with their cross-covariance (``el.cross``: a saved calibration or identification predicts as it did),
    or (N,) the geometry's prediction (or None) and the compliances' own part in quadrature."""
    q = np.atleast_2d(np.asarray(q, dtype=float))
    if el.calibration is not None:
        return predicted_sigma(el.calibration, np.hstack([q, el.torques(q, payload)]), registration=registration)
    if isinstance(geometric, Robot) or hasattr(geometric, "axis_cov"):  # (a robot file, an identification: its own)
        rm = reading_model(geometric)  # (the joint values of the readings, deflected: where its geometry is evaluated)
        q = q if rm is None else joint_values(q, *rm)
        qd, of = el.deflected(q, payload), isinstance(geometric, Robot)
        prop = _table_propagation(geometric, qd, registration) if of else _axes_propagation(geometric, qd)
        return _sigma(*_compliant_propagation(el, prop, q, payload, registration))
    if geometric is None and el.covariance is None:
        return None
    g = np.zeros(len(q)) if geometric is None else np.asarray(geometric, dtype=float)
    return np.sqrt(g**2 + el.sigma(q, payload) ** 2)


def _compliant_propagation(el, geometric, q, payload, registration: bool, place=None, point=None):
    """:func:`compliant_sigma`'s (J, C) (:func:`_propagation`): the calibration's own, else the geometry's
    ``geometric`` (J, C) or None beside the compliances' (``-J_q diag(tau)``, their covariance), correlated by their
    cross block when it is carried. With ``place`` (:func:`_flange`), at the flange compensated: of ``point``."""
    q = np.atleast_2d(np.asarray(q, dtype=float))
    if el.calibration is not None:
        return _propagation(el.calibration, np.hstack([q, el.torques(q, payload)]), registration, place)
    if el.covariance is None:
        return geometric
    A, Ck, tau = el.jacobian(q, payload), np.asarray(el.covariance, dtype=float), el.torques(q, payload)
    if point is not None:  # at the flange compensated: the joints' Jacobian there
        dt = (tau if el.torque_reference is None else tau - el.torque_reference)[:, None, :]  # (Elastic.jacobian's)
        A = -np.stack([np.asarray(_core.jacobian(point, x))[:3] for x in q - el.k * tau]) * dt
    if geometric is None:
        return A, Ck
    Cg, X = geometric[1], el.cross  # (the robot's covariance with its compliances, when carried: one covariance)
    if X is not None and np.shape(X) != (len(Cg), len(Ck)):
        raise DenavitError(f"compliance_cross: expected shape ({len(Cg)}, {len(Ck)}), got {np.shape(X)}")
    X = np.zeros((len(Cg), len(Ck))) if X is None else np.asarray(X, dtype=float)
    return np.concatenate([geometric[0], A], axis=2), np.block([[Cg, X], [X.T, Ck]])


def _scaled(q: np.ndarray, scale, reference, theta_scale: np.ndarray) -> np.ndarray:
    """The joint values at fixed readings when the reading scales are ``theta_scale`` instead of ``scale``: the
    readings' motion from the reference ``(q - ref) / (1 + scale)`` times ``1 + theta_scale``."""
    ref = 0.0 if reference is None else np.asarray(reference, dtype=float)
    return ref + (q - ref) / (1 + np.asarray(scale, dtype=float)) * (1 + theta_scale)


def unit_screws(P: np.ndarray, kinds) -> np.ndarray:
    """POE rows ``[w, v]`` made valid screws again: revolute ``|w| = 1``, ``w . v = 0``; prismatic ``w = 0``, ``|v| =
    1``."""
    P = np.array(P, dtype=float)
    for i, k in enumerate(kinds):
        w, v = P[i, :3], P[i, 3:]
        if k == "revolute":
            w = w / np.linalg.norm(w)
            P[i, :3], P[i, 3:] = w, v - (w @ v) * w
        else:
            P[i, 3:] = v / np.linalg.norm(v)
    return P


def converted_covariance(robot, table: _core.Table, **extract_options) -> np.ndarray:
    """The covariance of ``table`` (``robot``'s geometry in another convention, extracted from its joint axes at
    q = 0 with ``extract_options``) from ``robot.covariance`` (its table's parameters, tool translation and reading
    scales, which pass through): ``J C J^T``, ``J`` the :func:`conversion_jacobian`."""
    J = conversion_jacobian(robot, table, **extract_options)
    return J @ np.asarray(robot.covariance, dtype=float) @ J.T


def conversion_jacobian(robot, table: _core.Table, **extract_options) -> np.ndarray:
    """d(``table``'s entries) / d(``robot``'s ``[covariance]`` entries) of :func:`converted_covariance`, by central
    differences through the core's table builder and extraction (angles wrapped about ``table``'s)."""
    t = robot.table
    C = np.asarray(robot.covariance, dtype=float)
    n = t.params.size
    theta0 = np.concatenate([np.asarray(t.params).ravel(), np.asarray(t.T_last_tool)[:3, 3], np.zeros(len(C) - n - 3)])
    p_ref = np.asarray(table.params)
    angle_cols = np.array(table.angle_columns)

    def converted(theta):
        P = theta[:n].reshape(t.params.shape)
        if t.convention == "poe":
            P = unit_screws(P, t.kinds)
        T = np.array(t.T_last_tool)
        T[:3, 3] = theta[n : n + 3]
        m = _core.Table(t.convention, P, t.kinds, t.T_world_base, T).to_model()
        new = _core.extract(_core.axes(m, np.zeros(m.nq)), table.convention, fidelity=False, **extract_options).table
        d = np.asarray(new.params) - p_ref
        d[:, angle_cols] = (d[:, angle_cols] + np.pi) % (2 * np.pi) - np.pi
        return np.concatenate([(p_ref + d).ravel(), np.asarray(new.T_last_tool)[:3, 3], theta[n + 3 :]])

    y0 = converted(theta0)
    J = np.zeros((len(y0), len(theta0)))
    for k in np.flatnonzero(np.diag(C) > 0):
        e = np.zeros_like(theta0)
        e[k] = 1e-7
        J[:, k] = (converted(theta0 + e) - converted(theta0 - e)) / 2e-7
    return J


def table_sigma(robot, q) -> np.ndarray:
    """(N,) predicted tool-position error (1 sigma, 3-D RMS, m) at configurations ``q`` (N, n) of a robot whose
    ``covariance`` (of its table's parameters, tool translation and, with ``reading_scale``, its reading scales,
    e.g. read from a robot file's ``[covariance]``) is known: ``sqrt(trace(J C J^T))``, ``J`` by central differences
    of the forward kinematics (a scale at the readings of ``q``: the commanded readings are fixed)."""
    return _sigma(*_table_propagation(robot, q))


def _table_propagation(robot, q, registration: bool = False, place=None) -> tuple[np.ndarray, np.ndarray]:
    """:func:`table_sigma`'s (J, C) (:func:`_propagation`; ``place`` as there)."""
    if registration:
        raise DenavitError(
            f"{robot.name}: registration: a robot file's [covariance] carries no base registration (calibrate leaves it"
            " out): predict with the Calibration itself for positions in its measurement frame"
        )
    C = np.asarray(robot.covariance, dtype=float)
    t = robot.table
    rscale = getattr(robot, "reading_scale", None)
    theta0 = np.concatenate(
        [np.asarray(t.params).ravel(), np.asarray(t.T_last_tool)[:3, 3]]
        + ([np.asarray(rscale, dtype=float)] if rscale is not None else [])
    )
    if C.shape != (len(theta0), len(theta0)):
        raise DenavitError(
            f"{robot.name}: covariance of shape {C.shape}, expected ({len(theta0)}, {len(theta0)}) (the table's"
            " parameters and the tool's x, y, z" + (", then the reading scales)" if rscale is not None else ")")
        )
    q = np.atleast_2d(np.asarray(q, dtype=float))
    n = t.params.size

    def tool_points(theta):
        T = np.array(t.T_last_tool)
        T[:3, 3] = theta[n : n + 3]
        qs = q if rscale is None else _scaled(q, rscale, robot.reading_reference, theta[n + 3 :])
        P = theta[:n].reshape(t.params.shape)
        if t.convention == "poe":  # back onto unit screws (first order: the covariance lies in their tangent space)
            P = unit_screws(P, t.kinds)
        m = _core.Table(t.convention, P, t.kinds, t.T_world_base, T).to_model()
        return _core.fk_batch(m if place is None else place(m), qs)[:, :3, 3]

    return _derivatives(tool_points, theta0, C, len(q)), C


def _axes_propagation(ident, q: np.ndarray, place=None) -> tuple[np.ndarray, np.ndarray]:
    ax = ident.axes
    n = ax.nq
    rscale = getattr(ident, "reading_scale", None)
    full = getattr(ident, "axis_scale_cov", None)
    C = np.asarray(ident.axis_cov if full is None or rscale is None else full)
    theta0 = np.concatenate(
        [np.concatenate([ax.points[i], ax.directions[i]]) for i in range(n)]
        + [ident.tool_point]
        + ([rscale] if len(C) > 6 * n + 3 else [])
    )

    def tool_points(theta):
        P = theta[: 6 * n].reshape(n, 6)
        T_tool = np.array(ax.T_world_tool)
        T_tool[:3, 3] = theta[6 * n : 6 * n + 3]
        a = _core.JointAxes(
            P[:, :3],
            P[:, 3:],
            kinds=list(ax.kinds),
            q_ref=ax.q_ref,
            T_world_base=ax.T_world_base,
            T_world_tool=T_tool,
            lower=ax.lower,
            upper=ax.upper,
        )
        qs = q if len(theta) == 6 * n + 3 else _scaled(q, rscale, ident.sweeps.home, theta[6 * n + 3 :])
        m = _core.extract(a, "edh", fidelity=False).table.to_model()
        return _core.fk_batch(m if place is None else place(m), qs)[:, :3, 3]

    return _derivatives(tool_points, theta0, C, len(q)), C


#: The step of the central differences a covariance is propagated through (m, rad; a reading scale's unitless): the
#: linearisation at the estimate. (A step of each parameter's sigma had taken the curvature in: a UR5's saved ED-H
#: calibration predicted up to 28 % above the calibration's own at a configuration, with joint offsets' sigmas of
#: 0.05-0.09 rad in the table, and 1000x where a reflector on the flange's axis left joint 6's geometry undetermined.)
FD_STEP = 1e-6


def _derivatives(points, theta0: np.ndarray, C: np.ndarray, n: int) -> np.ndarray:
    """(n, 3, P) the derivatives of ``points(theta)`` (n, 3) at ``theta0`` (P,) by central differences of
    :data:`FD_STEP`, in each parameter with a variance in ``C`` (zero for the others)."""
    J = np.zeros((n, 3, len(theta0)))
    for k in np.flatnonzero(np.diag(C) > 0):
        e = np.zeros_like(theta0)
        e[k] = FD_STEP
        J[:, :, k] = (points(theta0 + e) - points(theta0 - e)) / (2 * FD_STEP)
    return J
