"""The model checksum: one short hex string that says which kinematic model a file or a controller holds, whatever
its convention (docs/fleet.md, "Model checksum").

The canonical parameters are the model's product-of-exponentials form at the zero configuration (Lynch & Park,
Modern Robotics, sec. 4.1): every joint's axis line in the world frame and the tool pose ``T_world_tool`` at q = 0.
These fix the forward kinematics completely, so two files of one robot in DH, modified DH, ED-H or POE (or a URDF)
get one checksum, and any change of the geometry above the resolution changes it.

Bytes hashed by SHA-256, in this order:

1. ``b"denavit-model-v1\\n"``;
2. the joint count and the kinds, as ASCII ``"6:RRRRRR\\n"`` (``R`` revolute, ``P`` prismatic);
3. per joint, base to tip: the axis direction ``w`` (unit vector, 3 values), then for a revolute joint the point of
   its axis line nearest the world origin ``p - (p . w) w`` (m, 3 values); a prismatic joint's line carries no point;
4. ``T_world_tool`` at q = 0: its rotation row by row (9 values), then its translation (m, 3 values).

Every value is in SI (m; directions and rotation entries unitless), divided by :data:`RESOLUTION` (1e-8: 10 nm,
1e-8 rad) and rounded half to even to an integer, written as a signed 64-bit big-endian integer (``-0`` is ``0``).
Two models whose values differ by less than the resolution get the same checksum unless a value sits on a rounding
boundary (floating-point noise of a unit conversion, ~1e-16 relative, moves it across with odds ~1e-8 per value).
"""

from __future__ import annotations

import hashlib
import struct

import numpy as np

from .. import _core

#: The rounding step of every canonical value (m for lengths, unitless for directions and rotation entries).
RESOLUTION = 1e-8
#: The checksum's length in hex digits (the first 16 of the SHA-256: 64 bits).
DIGITS = 16


def canonical_bytes(model: _core.Model) -> bytes:
    """The bytes :func:`model_checksum` hashes (module docstring), of a kinematic ``model``."""
    q0 = np.zeros(model.nq)
    ax = _core.axes(model, q0)
    kinds = list(model.kinds)
    values: list[np.ndarray] = []
    for i, kind in enumerate(kinds):
        w = np.asarray(ax.directions[i], dtype=float)
        values.append(w)
        if kind == "revolute":
            p = np.asarray(ax.points[i], dtype=float)
            values.append(p - (p @ w) * w)
    T = np.asarray(_core.fk(model, q0), dtype=float)
    values += [T[:3, :3].ravel(), T[:3, 3]]
    ints = np.rint(np.concatenate(values) / RESOLUTION).astype(np.int64) + 0  # (+ 0: -0 is 0)
    head = f"{len(kinds)}:{''.join('P' if k == 'prismatic' else 'R' for k in kinds)}\n".encode("ascii")
    return b"denavit-model-v1\n" + head + struct.pack(f">{len(ints)}q", *ints.tolist())


def model_checksum(model) -> str:
    """The model checksum (:data:`DIGITS` hex digits of SHA-256 over :func:`canonical_bytes`) of a Model or of
    anything with ``.model()`` (a Robot, a Calibration, an Identification)."""
    m = model if isinstance(model, _core.Model) else model.model()
    return hashlib.sha256(canonical_bytes(m)).hexdigest()[:DIGITS]


def saved_checksum(path, robot=None) -> str:
    """The model checksum of a model just written to ``path`` (a robot file or URDF), read back: that of the digits
    the file holds. ``robot`` (a Robot or Model): the model written when ``path`` is ``-`` (standard output)."""
    if str(path) == "-":
        return model_checksum(robot)
    from ..io.robots import load  # noqa: PLC0415

    return model_checksum(load(path))
