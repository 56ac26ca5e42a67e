"""The calibration model: a chain of elementary factors generated from a nominal robot in one convention.

The factors are ``Rx, Ry, Rz`` (rad) and ``Tx, Ty, Tz`` (m) with named parameters; the identification Jacobian
of every parameter is computed analytically in the Rust core (``denavit_core::calibration``) in one forward
pass per pose.

Parametrisations (chain order, base to tool; joint numbers 1-based, subscripts as in the papers)
--------------------------------------------------------------------------------------------------
* base: ``Tx(base_tx) Ty(base_ty) Tz(base_tz) · R0 · Rx(base_rx) Ry(base_ry) Rz(base_rz)``: the convention's
  frame 0 in ``world``; ``R0`` is the nominal (or registered) base rotation, the three angles small
  corrections about the base axes (0 at the start), so no Euler singularity is ever met.
* ``edh`` (Guo et al. eq. 1-2), link *i*: ``Rx(alpha_{i-1}) Tx(a_{i-1}) Ty(b_{i-1}) Tz(c_{i-1}) [Ry(beta_{i-1})]
  Rz(offset_i + q_i)``; prismatic: ``... Tz(c_{i-1}) [Ry(beta_{i-1})] Rz(theta_i) Tz(offset_i + q_i)``. Where axes
  *i-1*, *i* are near-parallel, ED-H's common-normal direction ``x_{i-1}`` cannot turn smoothly with the axes (a
  tilt of axis *i* about ``y_{i-1}`` would turn it by 90 degrees), so a tilt ``beta_{i-1}`` about ``y`` at frame
  *i*'s origin is added (after Hayati & Mirmirani 1985); the direction of ``x_{i-1}`` then becomes a free choice
  (a joint offset is reported redundant).
* ``mdh`` (Craig) with Hayati's angle (Hayati & Mirmirani 1985) where axes *i-1*, *i* are near-parallel
  (``|sin| < NEAR_PARALLEL_SIN``, as in docs/conventions.md): ``Rx(alpha_{i-1}) Tx(a_{i-1}) [Ry(beta_{i-1})]
  Tz(d_i) Rz(offset_i + q_i)`` (``Tz`` commutes with ``Rz``); where ``beta_{i-1}`` is used, ``d_{i-1}`` (the
  position of frame *i-1* along its axis, undefined for parallel axes) is fixed at its nominal value.
* ``dh`` (Denavit & Hartenberg), link *i*: ``Rz(offset_i + q_i) Tz(d_i) Tx(a_i) Rx(alpha_i)``. Refused (with the
  reason) when consecutive axes are near-parallel: a DH table has no parameter for a tilt about ``y`` there
  and its ``d`` diverges (Hayati & Mirmirani 1985).
* tool point: ``Tx(tool_x) Ty(tool_y) Tz(tool_z)``, the measured point in the convention's last frame (the
  flange frame for ``edh``/``mdh``; DH frame *n* for ``dh``); tool frame (pose data): ``Tx Ty Tz · R0 ·
  Rx(tool_rx) Ry(tool_ry) Rz(tool_rz)``.
* joint scale (optional): ``q_i -> q_i (1 + scale_i)``.

"""

from __future__ import annotations

import fnmatch
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .. import _core
from ..errors import DegenerateError, DenavitError
from ..geometry import orthonormalize, pose, rotvec_matrix
from ..robotfile import Robot, load
from .identifiability import analyze
from .least_squares import fit_parameters
from .measurements import Measurements

#: The conventions a calibration chain is built in (the core's conventions but POE).
CONVENTIONS = ("edh", "mdh", "dh")


def as_robot(nominal) -> Robot:
    """``nominal`` (a Robot, a Model, a built-in name or a robot file) as a :class:`Robot`."""
    if isinstance(nominal, Robot):
        return nominal
    if isinstance(nominal, (str, Path)):
        return load(nominal)
    if isinstance(nominal, _core.Model):
        ex = _core.extract(_core.axes(nominal, np.zeros(nominal.nq)), "edh")
        return Robot(nominal.name, ex.table, list(nominal.names), np.array(nominal.lower), np.array(nominal.upper))
    raise DenavitError(f"nominal: expected a Robot, a Model, a built-in name or a robot file, got {type(nominal).__name__}")


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
    tool_start: int  # factors[tool_start:] form T_flange_tool (after the last joint)
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

    def evaluate(self, x, q, jacobian: bool = True):
        """Tool poses (N, 4, 4) and identification Jacobians (N, 6, P) (rows [v; w], world) at x for q (N, n)."""
        return self.chain.evaluate(np.asarray(x, dtype=float), np.atleast_2d(np.asarray(q, dtype=float)), jacobian)

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
        # DH: the factors between the last joint and the tool belong to T_flange_tool
        tool = self._product(x, prev, len(self.factors))
        return _core.Model.from_placements(np.array(placements), self.robot.table.kinds, offsets=offsets, lower=self.robot.lower, upper=self.robot.upper,
                                           names=self.robot.names, T_world_base=orthonormalize(self.base_pose(x)), T_flange_tool=orthonormalize(tool), name=name)

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
    return _core.CalibrationChain([a for a, _, _, _ in factors], [max(p, 0) for _, p, _, _ in factors], [j for _, _, j, _ in factors],
                                  np.array(fixed).reshape(-1, 4, 4), n_params, nq, scales)


def _replace_factors(pz: Parametrization, factors) -> Parametrization:
    scales = [pz.names.index(f"scale_{j + 1}") if f"scale_{j + 1}" in pz.names else -1 for j in range(pz.nq)]
    chain = make_chain(factors, pz.n_params, pz.nq, scales)
    return Parametrization(pz.convention, pz.measure, pz.names, pz.x0, pz.units, pz.order, pz.rules, factors, chain, pz.robot, pz.joint_factor, pz.tool_start, pz.base_end)


def _pairs_near_parallel(model: _core.Model) -> list[tuple[int, float]]:
    """(i, angle) of consecutive axes i, i+1 (1-based) within _core.NEAR_PARALLEL_SIN of parallel (or anti-parallel)."""
    ax = _core.axes(model, np.zeros(model.nq))
    out = []
    for i in range(model.nq - 1):
        s = np.linalg.norm(np.cross(ax.directions[i], ax.directions[i + 1]))
        if s < _core.NEAR_PARALLEL_SIN:
            out.append((i + 1, math.asin(min(s, 1.0))))
    return out


def parametrize(nominal, convention: str = "edh", *, measure: str = "point", tool=None, scale: bool = False) -> Parametrization:
    """The calibration model of ``nominal`` in ``convention`` (see the module docstring for the factors).

    Parameters
    ----------
    nominal : Robot, Model, built-in name or robot file
    convention : {"edh", "mdh", "dh"}
        ``mdh`` uses Hayati's angle ``beta`` where consecutive axes are near-parallel; ``dh`` is refused there.
    measure : {"point", "pose"}
        Measured tool points (tool = 3 translations) or full tool poses (tool = 6 parameters).
    tool : array_like, optional
        Point: the tool point (3,) in the flange frame (the last joint frame), metres; pose: ``T_flange_tool``
        (4, 4). Default: the nominal model's tool.
    scale : bool
        Add a scale parameter per joint (``q -> q (1 + scale)``).
    """
    conv = _core.convention_info(convention)["name"]
    if conv not in CONVENTIONS:
        hint = " (product-of-exponentials calibration is not available yet: use edh)" if conv == "poe" else ""
        raise DenavitError(f"calibration convention {convention!r}: expected one of {', '.join(CONVENTIONS)}{hint}")
    if measure not in ("point", "pose"):
        raise DenavitError(f"measure: expected 'point' or 'pose', got {measure!r}")
    robot = as_robot(nominal)
    m = robot.model()
    n = m.nq
    kinds = list(m.kinds)
    near = _pairs_near_parallel(m)
    near_set = {i for i, _ in near}
    if conv == "dh" and near:
        lst = ", ".join(f"{i}-{i + 1} ({math.degrees(a):.3g} deg)" for i, a in near)
        raise DegenerateError(
            f"standard DH cannot calibrate {robot.name}: axes {lst} are parallel within {math.degrees(math.asin(_core.NEAR_PARALLEL_SIN)):.2g} deg; "
            "a DH link can tilt the next axis only about their common normal (alpha); a tilt about the other perpendicular direction "
            "(Hayati's beta) sends the common normal, hence d, to infinity, so the fit cannot represent the robot or diverges "
            "(Hayati & Mirmirani 1985): use convention 'mdh' (Hayati angle beta) or 'edh'")
    ref = robot.table if robot.table.convention == conv else None
    ex = _core.extract(_core.axes(m, np.zeros(n)), conv, nominal=ref)
    table = ex.table
    P = table.params
    # tool in the convention's last frame
    F_flange = _core.joint_frames(m, np.zeros(n))[-1] if n else m.T_world_base
    C_last = table.frames(np.zeros(n))[-1]
    T_tool_flange = np.asarray(m.T_flange_tool) if tool is None or measure == "point" else np.asarray(tool, dtype=float)
    if measure == "point" and tool is not None:
        tp = np.asarray(tool, dtype=float)
        if tp.shape != (3,) or not np.all(np.isfinite(tp)):
            raise DenavitError(f"tool: expected the tool point (3,) in the flange frame (m), got {np.asarray(tool).tolist()}")
        T_tool_flange = np.array(m.T_flange_tool)
        T_tool_flange[:3, 3] = tp
    if measure == "pose" and tool is not None and T_tool_flange.shape != (4, 4):
        raise DenavitError(f"tool: expected T_flange_tool (4, 4) for pose measurements, got shape {T_tool_flange.shape}")
    T_last_tool = np.linalg.inv(C_last) @ F_flange @ T_tool_flange

    names, x0, units, factors, groups, along = [], [], [], [], [], []
    rules = {}

    def add(axis, name, value, unit, group, joint=-1, is_along=False):
        factors.append((axis, len(names), joint, None))
        names.append(name)
        x0.append(float(value))
        units.append(unit)
        groups.append(group)
        along.append(is_along)

    def fixed(T):
        factors.append(("fixed", -1, -1, orthonormalize(np.asarray(T, dtype=float))))

    B = np.asarray(table.T_world_base)
    for a in "xyz":
        add(f"t{a}", f"base_t{a}", B["xyz".index(a), 3], "length", "base")
    R0 = np.eye(4)
    R0[:3, :3] = B[:3, :3]
    fixed(R0)
    for a in "xyz":
        add(f"r{a}", f"base_r{a}", 0.0, "angle", "base")
    base_end = len(factors)
    joint_factor = []
    for k in range(n):
        i = k + 1
        r = P[k]
        rev = kinds[k] == "revolute"
        if conv == "edh":  # alpha, a, b, c, theta
            add("rx", f"alpha_{k}", r[0], "angle", "link")
            add("tx", f"a_{k}", r[1], "length", "link")
            add("ty", f"b_{k}", r[2], "length", "link")
            if rev:
                add("tz", f"c_{k}", r[3], "length", "link", is_along=True)
                if k in near_set:  # axes k, k+1 (1-based) near-parallel: tilt about y at frame k+1's origin
                    add("ry", f"beta_{k}", 0.0, "angle", "link")
                joint_factor.append(len(factors))
                add("rz", f"offset_{i}", r[4], "angle", "offset", k)
            else:
                if k in near_set:
                    add("ry", f"beta_{k}", 0.0, "angle", "link")
                add("rz", f"theta_{i}", r[4], "angle", "link")
                joint_factor.append(len(factors))
                add("tz", f"offset_{i}", r[3], "length", "offset", k)
        elif conv == "mdh":  # alpha, a, theta, d
            add("rx", f"alpha_{k}", r[0], "angle", "link")
            add("tx", f"a_{k}", r[1], "length", "link")
            if k in near_set:  # axes k, k+1 (1-based) near-parallel: Hayati angle
                add("ry", f"beta_{k}", 0.0, "angle", "link")
            if rev:
                add("tz", f"d_{i}", r[3], "length", "link", is_along=True)
                if i in near_set:
                    rules[f"d_{i}"] = (f"axes {i} and {i + 1} are near-parallel: their common normal, hence the position of frame {i} along axis {i}, "
                                       f"is undefined; Hayati's beta_{i} is used instead and d_{i} is fixed (Hayati & Mirmirani 1985)")
                joint_factor.append(len(factors))
                add("rz", f"offset_{i}", r[2], "angle", "offset", k)
            else:
                add("rz", f"theta_{i}", r[2], "angle", "link")
                joint_factor.append(len(factors))
                add("tz", f"offset_{i}", r[3], "length", "offset", k)
        else:  # dh: d, theta, a, alpha; link i = Rz(theta + q) Tz(d) Tx(a) Rx(alpha)
            if rev:
                joint_factor.append(len(factors))
                add("rz", f"offset_{i}", r[1], "angle", "offset", k)
                add("tz", f"d_{i}", r[0], "length", "link", is_along=True)
            else:
                add("rz", f"theta_{i}", r[1], "angle", "link")
                joint_factor.append(len(factors))
                add("tz", f"offset_{i}", r[0], "length", "offset", k)
            add("tx", f"a_{i}", r[2], "length", "link")
            add("rx", f"alpha_{i}", r[3], "angle", "link")
    tool_start = joint_factor[-1] + 1 if joint_factor else base_end
    for a in "xyz":
        add(f"t{a}", f"tool_{a}", T_last_tool["xyz".index(a), 3], "length", "tool")
    Rt = np.eye(4)
    Rt[:3, :3] = T_last_tool[:3, :3]
    fixed(Rt)
    if measure == "pose":
        for a in "xyz":
            add(f"r{a}", f"tool_r{a}", 0.0, "angle", "tool")
    scales = [-1] * n
    if scale:
        for k in range(n):
            scales[k] = len(names)
            names.append(f"scale_{k + 1}")
            x0.append(0.0)
            units.append("ratio")
            groups.append("scale")
            along.append(False)
    P_ = len(names)
    rank_of = {"base": 0, "tool": 1, "link": 2, "offset": 3, "scale": 4}
    order = sorted(range(P_), key=lambda c: (5, -c) if along[c] else (rank_of[groups[c]], c))
    chain = make_chain(factors, P_, n, scales)
    pz = Parametrization(conv, measure, names, np.array(x0), units, order, rules, factors, chain, robot, joint_factor, tool_start, base_end)
    # the chain must reproduce the nominal model (with the tool); where the convention's table lost something
    # (an MDH table has no tilt about y), the parameters are fitted to the nominal model's kinematics.
    Q = configurations(robot, max(3 * P_, 60))
    truth = _core.fk_batch(m.with_tool(T_tool_flange), Q)
    pred, _ = pz.evaluate(pz.x0, Q, False)
    err = np.abs(pred[:, :3, 3] - truth[:, :3, 3]).max() + (np.abs(pred[:, :3, :3] - truth[:, :3, :3]).max() if measure == "pose" else 0.0)
    if err > 1e-10:
        target = Measurements(Q, None, truth, "nominal model") if measure == "pose" else Measurements(Q, truth[:, :3, 3], None, "nominal model")
        free = [c for c in range(P_) if names[c] not in rules and not names[c].startswith("scale_")]
        ana = analyze(pz, pz.x0, target, free, np.ones(6), explain=False)
        x, _ = fit_parameters(pz, pz.x0, ana.kept_idx, target, np.ones(6), "linear", None)
        pz = Parametrization(conv, measure, names, x, units, order, rules, factors, chain, robot, joint_factor, tool_start, base_end)
        pred, _ = pz.evaluate(pz.x0, Q, False)
        err = np.abs(pred[:, :3, 3] - truth[:, :3, 3]).max()
        if err > 1e-8:
            raise DegenerateError(f"the {conv} calibration chain cannot reproduce the nominal model {robot.name}: tool error {err * 1e3:.3g} mm after fitting it; use convention 'edh'")
    return pz


def configurations(nominal, count: int, *, skip: int = 1) -> np.ndarray:
    """``count`` deterministic configurations spread over the joint limits, shape (count, n): the unscrambled
    Halton sequence from index ``skip`` (``scipy.stats.qmc.Halton``, bases the first n primes), revolute limits
    clipped to +-pi."""
    from scipy.stats import qmc  # noqa: PLC0415 (scipy is loaded when first needed)

    robot = as_robot(nominal)
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
            raise DenavitError(f"fix: {pat!r} matches no parameter of the {pz.convention} model of {pz.robot.name}: expected names or patterns of {', '.join(pz.names)}")
        for c in hits:
            out[c] = None if value is None else float(value)
    return out
