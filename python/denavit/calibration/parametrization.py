"""The calibration model: a chain of elementary factors generated from a nominal robot in one convention.

The factors are ``Rx, Ry, Rz`` (rad) and ``Tx, Ty, Tz`` (m) with named parameters; the identification Jacobian
of every parameter is computed analytically in the Rust core (``denavit_core::calibration``) in one forward
pass per pose.

The parametrisation of each convention (factor orders, parameter names, Hayati's beta on near-parallel axes,
the refusal of standard DH there) is built by the core, ``Table::parametrize`` (``_core.parametrize``), and
documented once in docs/conventions.md, "Calibration parametrisations". This module names the parameters'
roles, fits the chain to the nominal model where the convention's table lost something, and turns a
parameter vector back into a :class:`denavit.Model`.

"""

from __future__ import annotations

import dataclasses
import fnmatch
import math
from contextlib import contextmanager
from contextvars import ContextVar
from dataclasses import dataclass

import numpy as np

from .. import _core
from ..errors import DegenerateError, DenavitError
from ..geometry import orthonormalize, pose, rotvec_matrix
from ..robot import Robot, robot_of
from .identifiability import analyze
from .least_squares import fit_parameters
from .measurements import Measurements


class _Memo:
    """The last evaluations of calibration chains (see :func:`remembered`): the poses of the last
    :attr:`POSES` and the Jacobians of the last :attr:`JACOBIANS`, each keyed by its chain, x and the readings'
    values (compared whole). A Jacobian whose rows and weights match and whose columns include those asked for serves
    them.
    """

    POSES, JACOBIANS = 4, 1

    def __init__(self):
        self.poses: list = []  # (chain, key, poses), newest first
        self.jacobians: list = []  # (chain, key, rows, weights, columns, J)
        self.built = 0  # Jacobian evaluations made by the core
        self.readings: list = []  # ((shape, hash), a copy) of each set of readings seen: keys compare them whole

    def _readings(self, q) -> int:
        h = (q.shape, hash(q.tobytes()))
        for i, (hq, kept) in enumerate(self.readings):
            if hq == h and np.array_equal(kept, q):
                return i
        self.readings.append((h, q.copy()))
        return len(self.readings) - 1

    def evaluate(self, chain, x, q, jacobian, rows, cols, w):
        # the chain itself is kept in the entries, so no other chain can take its id while they live
        key = (x.tobytes(), self._readings(q))
        wkey = None if w is None else w.tobytes()
        poses = next((p for c, k, p in self.poses if c is chain and k == key), None)
        J = None
        if jacobian:
            for c, k, jrows, jw, jcols, Jc in self.jacobians:
                if c is chain and k == key and jrows == rows and jw == wkey and set(cols) <= set(jcols):
                    at = {v: i for i, v in enumerate(jcols)}
                    J = np.take(Jc, [at[v] for v in cols], axis=2)  # a copy
                    break
        if poses is None or (jacobian and J is None):
            poses, J = chain.evaluate(x, q, jacobian, rows=rows, columns=cols, weights=w)
            poses.flags.writeable = False
            if J is not None:
                self.built += 1
                self.jacobians = [(chain, key, rows, wkey, cols, J.copy())] + self.jacobians[: self.JACOBIANS - 1]
        self.poses = [(chain, key, poses)] + [e for e in self.poses if not (e[0] is chain and e[1] == key)][
            : self.POSES - 1
        ]
        return poses, J


_MEMO: ContextVar[_Memo | None] = ContextVar("denavit_calibration_memo", default=None)


@contextmanager
def remembered():
    """Within this context, :meth:`Parametrization.evaluate` serves an evaluation it has just made from memory
    (a calibration asks again for what it has seen: the analysis' Jacobian at the start of the fit, the solver's
    last residuals and Jacobian at the solution; it keeps the last Jacobian only). The values are the same; the
    memory is freed on exit. Within another such context, the outer memory serves."""
    outer = _MEMO.get()
    if outer is not None:
        yield outer
        return
    memo = _Memo()
    token = _MEMO.set(memo)
    try:
        yield memo
    finally:
        _MEMO.reset(token)


@dataclass(frozen=True, eq=False)
class Parametrization:
    """A calibration model: the chain of elementary factors of a nominal robot in one convention.

    ``x0`` are the nominal values; :meth:`evaluate` gives tool poses and identification Jacobians (Rust);
    :meth:`model` the kinematic :class:`denavit.Model` of any parameter vector (joint scales aside).
    """

    convention: str
    measure: str
    names: list
    x0: np.ndarray
    units: list  # per parameter: "length" | "angle" | "ratio"
    order: list  # preference order of the rank-revealing analysis (indices)
    rules: dict  # parameters fixed by the parametrisation itself -> why
    factors: list  # (axis, param, joint, T or None)
    chain: _core.CalibrationChain
    robot: Robot
    joint_factor: list  # factor index of each joint
    tool_start: (
        int  # factors[tool_start:] form T_flange_tool (before it, after the last joint: dh's link n and the flange)
    )
    base_end: int  # factors[:base_end] form the base

    @property
    def n_params(self) -> int:
        return len(self.names)

    @property
    def nq(self) -> int:
        return len(self.joint_factor)

    def index(self, name: str) -> int:
        try:
            return self.names.index(name)
        except ValueError:
            raise DenavitError(f"unknown parameter {name!r}: expected one of {', '.join(self.names)}") from None

    def evaluate(self, x, q, jacobian: bool = True, *, rows: int = 6, columns=None, weights=None):
        """Tool poses (N, 4, 4) and identification Jacobians (N, rows, P) (rows [v; w], world) at x for q (N, n);
        of the parameters ``columns`` (indices; default all) only, each row times its ``weights`` entry if given
        (``CalibrationChain.evaluate``: only that part is computed and written). Within :func:`remembered`, an
        evaluation seen before is served from memory. The poses may be read-only; the Jacobian is the caller's
        own array (a solver may write into it)."""
        x = np.asarray(x, dtype=float)
        q = np.atleast_2d(np.asarray(q, dtype=float))
        cols = list(range(self.n_params)) if columns is None else [int(c) for c in columns]
        w = None if weights is None else np.asarray(weights, dtype=float)
        memo = _MEMO.get()
        if memo is None:
            return self.chain.evaluate(x, q, jacobian, rows=rows, columns=cols, weights=w)
        return memo.evaluate(self.chain, x, q, jacobian, rows, cols, w)

    def inputs(self, meas: Measurements) -> np.ndarray:
        """What :meth:`evaluate` takes as the readings of ``meas``: its ``q`` (a compliant chain appends each pose's
        gravity torques: :mod:`denavit.calibration.compliance`)."""
        return meas.q

    def _product(self, x, lo: int, hi: int) -> np.ndarray:
        T = np.eye(4)
        for axis, p, _, F in self.factors[lo:hi]:
            T = T @ (F if axis == "fixed" else _elementary(axis, x[p]))
        return T

    def base_pose(self, x) -> np.ndarray:
        """``T_world_frame0`` (the convention's frame 0 in world) of parameters x."""
        return self._product(x, 0, self.base_end)

    def model(self, x, name: str = "calibrated") -> _core.Model:
        """The kinematic model of parameters x (joint names and limits of the nominal robot; joint scales are
        not part of a model: see :attr:`Calibration.scales`)."""
        x = np.asarray(x, dtype=float)
        placements, offsets = [], []
        prev = self.base_end
        for jf in self.joint_factor:
            placements.append(self._product(x, prev, jf))
            offsets.append(x[self.factors[jf][1]])
            prev = jf + 1
        # the flange (docs/conventions.md "Frames"): dh's link n after the last joint and the fixed nominal flange
        flange = self._product(x, prev, self.tool_start)
        tool = self._product(x, self.tool_start, len(self.factors))
        return _core.Model.from_placements(
            np.array(placements),
            self.robot.table.kinds,
            offsets=offsets,
            lower=self.robot.lower,
            upper=self.robot.upper,
            names=self.robot.names,
            T_world_base=orthonormalize(self.base_pose(x)),
            T_last_flange=orthonormalize(flange),
            T_flange_tool=orthonormalize(tool),
            name=name,
        )

    def rebased(self, x, T_world_new_old) -> tuple[Parametrization, np.ndarray]:
        """The same parametrisation with the base moved by ``T_world_new_old`` (a change of measurement frame),
        and x with base translations updated and base angles reset to 0."""
        B = T_world_new_old @ self.base_pose(x)
        x = np.array(x, dtype=float)
        factors = list(self.factors)
        for k in range(self.base_end):
            axis, p, j, F = factors[k]
            if axis == "fixed":
                R = np.eye(4)
                R[:3, :3] = B[:3, :3]
                factors[k] = ("fixed", -1, -1, orthonormalize(R))
            elif axis.startswith("t"):
                x[p] = B["xyz".index(axis[1]), 3]
            else:
                x[p] = 0.0
        return _replace_factors(self, factors), x


def _elementary(axis: str, s: float) -> np.ndarray:
    """The elementary factor ``Tx/Ty/Tz(s)`` (m) or ``Rx/Ry/Rz(s)`` (rad) as a (4, 4) transform."""
    e = np.eye(3)["xyz".index(axis[1])] * s
    return pose(p=e) if axis[0] == "t" else pose(rotvec_matrix(e))


def make_chain(factors, n_params, nq, scales) -> _core.CalibrationChain:
    """The core's calibration chain of ``factors`` ((axis, param, joint, T or None) each; Rust evaluates it)."""
    fixed = [F for a, _, _, F in factors if a == "fixed"]
    return _core.CalibrationChain(
        [a for a, _, _, _ in factors],
        [max(p, 0) for _, p, _, _ in factors],
        [j for _, _, j, _ in factors],
        np.array(fixed).reshape(-1, 4, 4),
        n_params,
        nq,
        scales,
    )


def _replace_factors(pz: Parametrization, factors) -> Parametrization:
    scales = [pz.names.index(f"scale_{j + 1}") if f"scale_{j + 1}" in pz.names else -1 for j in range(pz.nq)]
    chain = make_chain(factors, pz.n_params, pz.nq, scales)
    return dataclasses.replace(pz, factors=factors, chain=chain)  # (a subclass, compliance.py's, stays one)


def parametrize(
    nominal, convention: str = "edh", *, measure: str = "point", tool=None, scale: bool = False
) -> Parametrization:
    """The calibration model of ``nominal`` in ``convention`` (see the module docstring for the factors).

    Parameters
    ----------
    nominal : Robot, Model, built-in name or robot file
    convention : {"edh", "mdh", "dh"}
        ``mdh`` uses Hayati's angle ``beta`` where consecutive axes are near-parallel; ``dh`` is refused there.
    measure : {"point", "pose"}
        Measured tool points (tool = 3 translations) or full tool poses (tool = 6 parameters).
    tool : array_like, optional
        Point: the tool point (3,) in the flange frame (docs/conventions.md "Frames": DH frame n for a DH robot),
        metres; pose: ``T_flange_tool``
        (4, 4). Default: the nominal model's tool.
    scale : bool
        Add a scale parameter per joint (``q -> q (1 + scale)``).
    """
    conv = _core.convention_info(convention)["name"]
    if measure not in ("point", "pose"):
        raise DenavitError(f"measure: expected 'point' or 'pose', got {measure!r}")
    robot = robot_of(nominal)
    m = robot.model()
    n = m.nq
    ref = robot.table if robot.table.convention == conv else None
    table = _core.extract(_core.axes(m, np.zeros(n)), conv, nominal=ref).table
    # the nominal flange in world and in the convention's last frame; the tool is in the flange
    F_flange = (_core.joint_frames(m, np.zeros(n))[-1] if n else np.asarray(m.T_world_base)) @ np.asarray(
        m.T_last_flange
    )
    C_last = table.frames(np.zeros(n))[-1]
    T_tool_flange = np.asarray(m.T_flange_tool) if tool is None or measure == "point" else np.asarray(tool, dtype=float)
    if measure == "point" and tool is not None:
        tp = np.asarray(tool, dtype=float)
        if tp.shape != (3,) or not np.all(np.isfinite(tp)):
            raise DenavitError(
                f"tool: expected the tool point (3,) in the flange frame (m), got {np.asarray(tool).tolist()}"
            )
        T_tool_flange = np.array(m.T_flange_tool)
        T_tool_flange[:3, 3] = tp
    if measure == "pose" and tool is not None and T_tool_flange.shape != (4, 4):
        raise DenavitError(
            f"tool: expected T_flange_tool (4, 4) for pose measurements, got shape {T_tool_flange.shape}"
        )
    T_last_flange = orthonormalize(np.linalg.inv(C_last) @ F_flange)
    # the factors and parameters of the convention (the core: Table::parametrize, docs/conventions.md)
    core = _core.parametrize(table, T_last_flange, orthonormalize(T_tool_flange), measure, scale, robot.name)
    fixed = iter(core["fixed"])
    factors = [
        (a, p, j, next(fixed) if a == "fixed" else None)
        for a, p, j in zip(core["axes"], core["params"], core["joints"])
    ]
    names, x0, units, groups, along, rules = (
        core["names"],
        core["x0"],
        core["units"],
        core["groups"],
        core["along"],
        dict(core["rules"]),
    )
    joint_factor, tool_start, base_end = list(core["joint_factors"]), core["tool_start"], core["base_end"]
    P_ = len(names)
    rank_of = {"base": 0, "tool": 1, "link": 2, "offset": 3, "scale": 4}
    order = sorted(range(P_), key=lambda c: (5, -c) if along[c] else (rank_of[groups[c]], c))
    chain = core["chain"]
    pz = Parametrization(
        conv,
        measure,
        names,
        np.array(x0),
        units,
        order,
        rules,
        factors,
        chain,
        robot,
        joint_factor,
        tool_start,
        base_end,
    )
    # the chain must reproduce the nominal model (with the tool); where the convention's table lost something
    # (an MDH table has no tilt about y), the parameters are fitted to the nominal model's kinematics.
    Q = configurations(robot, max(3 * P_, 60))
    truth = _core.fk_batch(m.with_tool(T_tool_flange), Q)
    pred, _ = pz.evaluate(pz.x0, Q, False)
    err = np.abs(pred[:, :3, 3] - truth[:, :3, 3]).max() + (
        np.abs(pred[:, :3, :3] - truth[:, :3, :3]).max() if measure == "pose" else 0.0
    )
    if err > 1e-10:
        target = (
            Measurements(Q, None, truth, "nominal model")
            if measure == "pose"
            else Measurements(Q, truth[:, :3, 3], None, "nominal model")
        )
        free = [c for c in range(P_) if names[c] not in rules and not names[c].startswith("scale_")]
        ana = analyze(pz, pz.x0, target, free, np.ones(6), explain=False)
        x, _ = fit_parameters(pz, pz.x0, ana.kept_idx, target, np.ones(6), "linear", None)
        pz = Parametrization(
            conv, measure, names, x, units, order, rules, factors, chain, robot, joint_factor, tool_start, base_end
        )
        pred, _ = pz.evaluate(pz.x0, Q, False)
        err = np.abs(pred[:, :3, 3] - truth[:, :3, 3]).max()
        if err > 1e-8:
            raise DegenerateError(
                f"the {conv} calibration chain cannot reproduce the nominal model {robot.name}: tool error"
                f" {err * 1e3:.3g} mm after fitting it; use convention 'edh'"
            )
    return pz


def configurations(nominal, count: int, *, skip: int = 1) -> np.ndarray:
    """``count`` deterministic configurations spread over the joint limits, shape (count, n): the unscrambled
    Halton sequence from index ``skip`` (``scipy.stats.qmc.Halton``, bases the first n primes), revolute limits
    clipped to +-pi."""
    from scipy.stats import qmc  # noqa: PLC0415 (scipy is loaded when first needed)

    from .. import limits  # noqa: PLC0415

    count = limits.check_count(count, "configurations: count", "poses", what="configurations")
    robot = robot_of(nominal)
    lo = np.array(robot.lower, dtype=float)
    hi = np.array(robot.upper, dtype=float)
    rev = np.array([k == "revolute" for k in robot.table.kinds])
    lo = np.where(rev, np.maximum(lo, -math.pi), lo)
    hi = np.where(rev, np.minimum(hi, math.pi), hi)
    halton = qmc.Halton(d=len(lo), scramble=False)
    halton.fast_forward(skip)
    return lo + (hi - lo) * halton.random(count)


def resolve_fix(pz: Parametrization, fix) -> dict:
    """``fix`` (names or shell patterns, or a dict of name -> value in SI) as {parameter index: value or None}."""
    out = {}
    items = fix.items() if isinstance(fix, dict) else ((f, None) for f in ([fix] if isinstance(fix, str) else fix))
    for pat, value in items:
        pat = str(pat).strip()
        if not pat:
            continue
        hits = [c for c, nm in enumerate(pz.names) if fnmatch.fnmatchcase(nm, pat)]
        if not hits:
            raise DenavitError(
                f"fix: {pat!r} matches no parameter of the {pz.convention} model of {pz.robot.name}: expected names or"
                f" patterns of {', '.join(pz.names)}"
            )
        for c in hits:
            out[c] = None if value is None else float(value)
    return out
