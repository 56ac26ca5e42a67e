"""The joint fit's chain of joint motions (:mod:`denavit.fitting.joint`): the home point (and the orientation at home)
carried by every joint's motion from home, its Jacobian blocks, and the Jacobian of one turning joint as fixed
coefficients on (1, cos, sin) of its motion (:class:`_Basis`). Components first, points last, every function
linear in the points."""

from __future__ import annotations

import numpy as np

from ..geometry import perpendicular_basis, skew


def _trig(d: np.ndarray) -> tuple:
    """(cos, sin, 1 - cos) of the angles d (m,)."""
    co = np.cos(d)
    return co, np.sin(d), 1 - co


def _turn(n: np.ndarray, d: np.ndarray, trig: tuple | None = None) -> tuple:
    """A revolute joint's rotations R(n, d_k) for the angles d (m,): (n, K with K x = n x x, cos, sin, 1 - cos),
    for :func:`_rotate`; ``trig`` the angles' :func:`_trig` when known."""
    return (n, skew(n), *(_trig(d) if trig is None else trig))


def _rotate(turn: tuple, x: np.ndarray) -> np.ndarray:
    """R(n, d_k) x_k (Rodrigues) for vectors x (..., 3, m), or x (..., 3, 1) the same for every point; ``turn``
    from :func:`_turn`. Stacks of vectors (the leading axes) turn at once; components first, points last (the
    per-point factors then broadcast along whole rows: an (m, 3) layout had numpy loop over rows of three)."""
    n, K, co, sn, omc = turn
    return x * co + (K @ x) * sn + n[:, None] * ((n @ x) * omc)[..., None, :]


def _carried(turns: dict, active: list, i: int, x: np.ndarray) -> np.ndarray:
    """x (k, 3, m or 1) carried by the linear parts of g_1 ... g_(i-1) (the active revolute joints before i)."""
    for a in reversed(active):
        if a < i and a in turns:
            x = _rotate(turns[a], x)
    return x


def _chain(
    cs, ns, kinds, p, dq, active, jac: bool, moving: int | None = None, trig: dict | None = None, basis: bool = False
):
    """Predicted points (3, m), and with ``jac`` the Jacobian blocks and the motion of the swept joint.

    Returns ``pred``, ``blocks`` {joint: (4, 3, m) d pred / d [a, b, s, t]} (direction in its tangent basis,
    point across the axis), ``jp`` (3, 3, m) d pred / d p, and ``dpdq`` {joint: (3, m)} d pred / d q_joint (the
    parameter first, then the components, the points last, as in a chunk's Jacobian). Without ``jac`` but with
    ``moving`` (a joint), ``dpdq`` of that joint alone (the misfit's tangent), no blocks. Rotations act on
    vectors (Rodrigues), a vector the same for every point (the home point before the first joint turns it) as
    one column, so the cost is linear in the points and small per point. ``trig`` {joint: :func:`_trig` of its
    motion dq[:, joint]} when known (the fit keeps them between passes).

    ``basis`` (with ``jac``; the caller's word that one revolute joint alone moves, :func:`_one_turn`;
    :func:`_basis_chain`): the blocks (with d pred / d q
    fifth) and ``jp`` as their coefficients on (1, cos, sin) of that joint's motion, (..., 3) in place of (..., m);
    ``dpdq`` per point.
    """
    if jac and basis:
        return _basis_chain(cs, ns, p, dq, active[0], trig.get(active[0]) if trig else None)
    m = dq.shape[0]
    turns = {i: _turn(ns[i], dq[:, i], trig.get(i) if trig else None) for i in active if kinds[i] == "revolute"}
    y = np.asarray(p, dtype=float)[:, None]
    before, turned = {}, {}
    for i in reversed(active):
        before[i] = y
        if kinds[i] == "prismatic":
            y = y + ns[i][:, None] * dq[:, i]
        else:
            turned[i] = _rotate(turns[i], y - cs[i][:, None])
            y = cs[i][:, None] + turned[i]
    y = np.broadcast_to(y, (3, m))
    if not jac and moving is None:
        return y, None, None, None

    def move(i):
        """d pred / d q_i before the joints ahead of i carry it: n (prismatic), n x R (y - c) (revolute)."""
        return ns[i][None, :, None] if kinds[i] == "prismatic" else (turns[i][1] @ turned[i])[None]

    if not jac:
        return y, None, None, {moving: np.broadcast_to(_carried(turns, active, moving, move(moving))[0], (3, m))}
    blocks, dpdq = {}, {}
    for i in active:
        B = [b[:, None] for b in perpendicular_basis(ns[i])]
        n = ns[i][:, None]
        if kinds[i] == "prismatic":
            cols = [b * dq[:, i] for b in B] + [np.zeros((3, m)), np.zeros((3, m)), move(i)[0]]
        else:
            _, K, co, sn, omc = turns[i]
            v = before[i] - cs[i][:, None]
            nv = ns[i] @ v
            # d(R v)/dn b = -sin (v x b) + (1 - cos)((n.v) b + n (v.b)); (I - R) b, b across n:
            # R b = b cos + (n x b) sin
            cols = [sn * (skew(b[:, 0]) @ v) + omc * (b * nv + n * (b[:, 0] @ v)) for b in B]
            cols += [b - (b * co + (K @ b) * sn) for b in B]
            cols.append(move(i)[0])
        X = _carried(turns, active, i, np.stack([np.broadcast_to(c, (3, m)) for c in cols]))
        blocks[i], dpdq[i] = X[:4], X[4]
    jp = np.broadcast_to(_carried(turns, active, len(kinds), np.eye(3)[:, :, None]), (3, 3, m))
    return y, blocks, jp, dpdq


def _one_turn(kinds, active) -> bool:
    """Whether one revolute joint alone moves (the locked joints at home): the Jacobian is then linear in the
    cosine and sine of its motion (:func:`_basis_chain`)."""
    return len(active) == 1 and kinds[active[0]] == "revolute"


def _basis_chain(cs, ns, p, dq, i: int, trig: tuple | None = None):
    """:func:`_chain` with ``jac`` when joint ``i`` alone moves, revolute: ``pred`` (3, m), the Jacobian blocks
    {i: (5, 3, 3)} (the four parameters' columns, then d pred / d q_i) and ``jp`` (3, 3, 3) as their coefficients on
    (1, cos dq_k, sin dq_k) (the last axis), and ``dpdq`` {i: (3, m)} per point. A rotation R(n, d) x = n (n.x) +
    (x - n (n.x)) cos d + (n x x) sin d, so every column of the Jacobian is three fixed vectors combined by the
    point's cosine and sine: the normal equations
    take the points' weighted moments of (1, cos, sin) (:class:`_Basis`) instead of a (parameters, 3) Jacobian per
    point (the same sums, in another order)."""
    n, c = ns[i], cs[i]
    K, (co, sn, omc) = skew(n), (_trig(dq[:, i]) if trig is None else trig)
    v = np.asarray(p, dtype=float) - c
    turned = _rotate((n, K, co, sn, omc), v[:, None])
    y = c[:, None] + turned
    key = (n.tobytes(), v.tobytes())
    last = _BASIS_LAST[0]  # (one reference read: threads each keep the pair they read or made)
    if last is None or last[0] != key:  # the coefficients hold for every chunk of a sweep in a pass
        last = _BASIS_LAST[0] = (key, _basis_coefficients(n, K, v))
    cols, jp = last[1]
    return y, {i: cols}, jp, {i: K @ turned}


#: (the axis direction and the home point's lever of the last :func:`_basis_chain`, their coefficients), read-only
_BASIS_LAST: list = [None]


def _basis_coefficients(n: np.ndarray, K: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """:func:`_basis_chain`'s coefficients of the columns (5, 3, 3) and of ``jp`` (3, 3, 3) for the axis direction
    ``n`` (K = skew(n)) and the home point's lever ``v`` (from a point of the axis)."""
    nv = float(n @ v)
    cols = []
    for b in perpendicular_basis(n):
        q = b * nv + n * float(b @ v)  # the direction's column: sin (b x v) + (1 - cos) q
        cols.append(np.stack([q, -q, skew(b) @ v], axis=-1))
    for b in perpendicular_basis(n):  # the point's: b - R b
        cols.append(np.stack([b, -b, -(K @ b)], axis=-1))
    Kv = K @ v
    cols.append(np.stack([np.zeros(3), Kv, K @ Kv], axis=-1))  # the motion's: n x R v = (n x v) cos + n x (n x v) sin
    nn = np.outer(n, n)
    jp = np.stack([nn, np.eye(3) - nn, K], axis=-1).transpose(1, 0, 2)  # [l, :, a]: R e_l
    return np.array(cols), jp


class _Basis:
    """A chunk's Jacobian (parameters, 3, m) as ``F`` (b, m), the points' basis functions (1, cos, sin of the moving
    joint's motion, and with ``scaled`` those times the reading's motion ``F[3]`` for a scale's column, the last), and
    ``C`` (b, parameters, 3) their coefficients: J[:, :, k] = sum_a F[a, k] C[a] (:func:`_basis_chain`)."""

    __slots__ = ("F", "C", "Cf", "scaled")

    def __init__(self, F: np.ndarray, C: np.ndarray, scaled: bool = False):
        self.F, self.C, self.scaled = F, C, scaled
        # (parameters, 3 basis functions x 3 components); a scale's column on (1, cos, sin), times the reading after
        Cf = C[:3].copy()
        if scaled:
            Cf[:, -1] = C[3:, -1]
        self.Cf = np.ascontiguousarray(Cf.transpose(1, 0, 2)).reshape(C.shape[1], -1)

    def dot(self, x: np.ndarray) -> np.ndarray:
        """sum_i J[p, i, k] x[i, k] (parameters, m) for x (3, m)."""
        out = self.Cf @ (self.F[:3, None, :] * x[None]).reshape(-1, x.shape[1])
        if self.scaled:
            out[-1] *= self.F[3]
        return out

    def gram(self, w: np.ndarray) -> np.ndarray:
        """sum_k w_k J_k^T J_k (parameters, parameters)."""
        M = (self.F * w) @ self.F.T
        return np.einsum("ab,api,bqi->pq", M, self.C, self.C)

    def rdot(self, e: np.ndarray) -> np.ndarray:
        """sum_k J_k^T e_k (parameters,) for e (3, m)."""
        return np.einsum("api,ai->p", self.C, self.F @ e.T)


def _chain_rotation(ns, kinds, R0, dq, active, jac: bool, moving: int | None = None, trig: dict | None = None):
    """Predicted orientations ``R(n_1, dq_1) ... R(n_n, dq_n) R0`` (m, 3, 3), and with ``jac`` the Jacobian blocks
    of the orientation residual (a small rotation in ``world``): {joint: (4, 3, m) d r / d [a, b, s, t]} (the
    point across the axis does not turn anything: zeros), ``jr`` (3, 3, m) d r / d the rotation of ``R0`` (a
    rotation vector in ``world``), and {joint: (3, m)} d r / d q_joint (the joint's axis carried by the joints
    before it). Without ``jac`` but with ``moving``, that joint's d r / d q alone.

    Turning n by dq b (b across n) turns R(n, dq) by ``J_l(dq n) dq b = sin(dq) b + (1 - cos(dq)) n x b`` (the left
    Jacobian of SO(3)), then carried by the joints before. ``trig`` as for :func:`_chain`."""
    m = dq.shape[0]
    turns = {i: _turn(ns[i], dq[:, i], trig.get(i) if trig else None) for i in active if kinds[i] == "revolute"}
    # the columns of R0 (column, component, 1), turned by every joint; then (m, row, column)
    Y = np.transpose(
        np.broadcast_to(_carried(turns, active, len(kinds), np.asarray(R0, dtype=float).T[:, :, None]), (3, 3, m)),
        (2, 1, 0),
    )
    if not jac and moving is None:
        return Y, None, None, None

    def turn(i):
        return (
            np.zeros((3, m))
            if kinds[i] == "prismatic"
            else np.broadcast_to(_carried(turns, active, i, ns[i][None, :, None])[0], (3, m))
        )

    if not jac:
        return Y, None, None, {moving: turn(moving)}
    blocks, dpdq = {}, {}
    for i in active:
        if kinds[i] == "prismatic":
            blocks[i] = np.zeros((4, 3, m))
        else:
            _, K, co, sn, omc = turns[i]
            cols = _carried(
                turns,
                active,
                i,
                np.stack([b[:, None] * sn + (K @ b)[:, None] * omc for b in perpendicular_basis(ns[i])]),
            )
            blocks[i] = np.concatenate([cols, np.zeros((2, 3, m))])
        dpdq[i] = turn(i)
    jr = np.broadcast_to(_carried(turns, active, len(kinds), np.eye(3)[:, :, None]), (3, 3, m))
    return Y, blocks, jr, dpdq
