"""Universal Robots' kinematics-parameters file: the calibration YAML that ``ur_description`` reads.

Format (as written by ``ur_calibration``'s ``calibration_correction`` node and read by
``ur_description``'s ``ur_macro.xacro`` through ``kinematics_params_file``; e.g. ``config/ur30/
default_kinematics.yaml`` of Universal_Robots_ROS2_Description)::

    kinematics:
      shoulder:  {x, y, z, roll, pitch, yaw}     # shoulder_pan_joint origin in base_link_inertia
      upper_arm: ...                             # shoulder_lift_joint origin in shoulder_link
      forearm:   ...                             # elbow_joint origin in upper_arm_link
      wrist_1:   ...
      wrist_2:   ...
      wrist_3:   ...                             # wrist_3_joint origin in wrist_2_link
      hash: calib_<digits>

metres and radians; ``rpy`` is URDF's ``Rz(yaw) Ry(pitch) Rx(roll)``; each joint turns about the z axis of
its child link. ``base_link_inertia`` is the controller's base frame (DH frame 0), and ``tool0`` is
``wrist_3_link`` turned by the description's fixed ``wrist_3-flange`` and ``flange-tool0`` rotations
(together the identity), so ``T_base_tool0(q) = Π origin_i Rz(q_i)``.

The link frames follow ``ur_calibration``'s correction: frame i sits on axis i at the foot of its common
normal with axis i+1 (for the nominal robot: DH frame i-1 · Rz(theta_i) · Tz(d_i)), not metres away along a
near-parallel axis. For an identified model each frame is the nominal one carried onto the identified axis
(origin projected onto it, x axis made perpendicular to it), and the last is the flange (``tool0``) itself, so the file
reproduces the identified ``base -> tool0`` exactly while the meshes stay on their links.
"""

from __future__ import annotations

import hashlib
import os
import re

import numpy as np

from .. import _core
from ..errors import DenavitError
from ..geometry import inverse, matrix_rpy
from .delimited import NUMBER, as_number
from .output import write_text

#: The six blocks of the file, base to tip.
UR_JOINTS = ("shoulder", "upper_arm", "forearm", "wrist_1", "wrist_2", "wrist_3")


def _nominal_link_frames(nominal: _core.Table) -> np.ndarray:
    """(6, 4, 4) the nominal UR link frames at q = 0 in the base frame: DH frame i-1 · Rz(theta_i) Tz(d_i)."""
    if nominal.convention != "dh" or nominal.params.shape[0] != 6 or any(k != "revolute" for k in nominal.kinds):
        raise DenavitError(
            f"nominal: expected the standard DH table of a six-revolute UR arm, got a {nominal.params.shape[0]}-joint"
            f" {nominal.convention} table"
        )
    F = inverse(nominal.T_world_base) @ nominal.frames(np.zeros(6))
    out = np.empty((6, 4, 4))
    for i in range(6):
        d, theta = nominal.params[i, 0], nominal.params[i, 1]
        c, s = np.cos(theta), np.sin(theta)
        out[i] = F[i] @ np.array([[c, -s, 0, 0], [s, c, 0, 0], [0, 0, 1, d], [0, 0, 0, 1.0]])
    return out


def link_frames(model: _core.Model, nominal: _core.Table, tol: float = 1e-9) -> np.ndarray:
    """(6, 4, 4) the link frames of ``model`` at q = 0 in its base frame (module docstring): the nominal
    frames carried onto the model's axes; the last one is the model's flange (= ``tool0``; a tool attached
    to it is not part of the file), which must lie on axis 6 (within ``tol`` m)."""
    if model.nq != 6 or any(k != "revolute" for k in model.kinds):
        raise DenavitError(f"model: expected a six-revolute UR arm, got {model.nq} joints ({', '.join(model.kinds)})")
    B_inv = inverse(model.T_world_base)
    ax = _core.axes(model, np.zeros(6))
    points = (B_inv[:3, :3] @ ax.points.T).T + B_inv[:3, 3]
    dirs = (B_inv[:3, :3] @ ax.directions.T).T
    nominal_frames = _nominal_link_frames(nominal)
    out = np.empty((6, 4, 4))
    for i in range(6):
        Fn = nominal_frames[i]
        tilt = np.degrees(np.arccos(min(1.0, abs(float(dirs[i] @ Fn[:3, 2])))))
        off = float(np.linalg.norm(np.cross(Fn[:3, 3] - points[i], dirs[i])))
        if tilt > 5.0 or off > 0.05:
            raise DenavitError(
                f"model: axis {i + 1} is {tilt:.3g} deg and {off * 1e3:.4g} mm from the nominal's: expected a"
                " calibration of the nominal UR arm (within 5 deg and 50 mm per axis)"
            )
        z = dirs[i] if dirs[i] @ Fn[:3, 2] >= 0 else -dirs[i]
        x = Fn[:3, 0] - (Fn[:3, 0] @ z) * z
        x /= np.linalg.norm(x)
        o = points[i] + ((Fn[:3, 3] - points[i]) @ z) * z
        out[i] = np.eye(4)
        out[i][:3, :3] = np.column_stack([x, np.cross(z, x), z])
        out[i][:3, 3] = o
    tool0 = B_inv @ _core.fk(model.with_tool(np.eye(4)), np.zeros(6))  # the flange
    off = np.linalg.norm(np.cross(tool0[:3, 3] - points[5], dirs[5]))
    if off > tol or abs(abs(tool0[:3, 2] @ dirs[5]) - 1.0) > tol:
        raise DenavitError(
            f"model: its flange (tool0) must sit on axis 6 with z along it: it is {off * 1e3:.3g} mm off the axis and"
            f" {np.degrees(np.arccos(min(1.0, abs(tool0[:3, 2] @ dirs[5])))):.3g} deg off its direction: not a UR arm's"
            " flange"
        )
    out[5] = tool0
    return out


def kinematics(model: _core.Model, nominal: _core.Table) -> dict:
    """The ``kinematics`` mapping of the file: per joint block ``{x, y, z, roll, pitch, yaw}`` (m, rad)."""
    F = link_frames(model, nominal)
    out = {}
    prev = np.eye(4)
    for name, Fi in zip(UR_JOINTS, F):
        T = inverse(prev) @ Fi
        roll, pitch, yaw = matrix_rpy(T[:3, :3])
        out[name] = {
            "x": float(T[0, 3]),
            "y": float(T[1, 3]),
            "z": float(T[2, 3]),
            "roll": roll,
            "pitch": pitch,
            "yaw": yaw,
        }
        prev = Fi
    return out


def dumps(model: _core.Model, nominal: _core.Table) -> str:
    """The text of the kinematics-parameters file of ``model`` (numbers in the shortest form that round-trips)."""
    kin = kinematics(model, nominal)
    lines = ["kinematics:"]
    for name in UR_JOINTS:
        lines.append(f"  {name}:")
        lines += [f"    {k}: {float(v)!r}" for k, v in kin[name].items()]
    digest = hashlib.sha256(repr([list(kin[n].values()) for n in UR_JOINTS]).encode()).digest()
    lines.append(f"  hash: calib_{int.from_bytes(digest[:8], 'little') >> 1}")
    return "\n".join(lines) + "\n"


#: The largest kinematics-parameters file read (characters): the one ur_calibration writes is about 1 kB; PyYAML's
#: pure-Python loader is slow on fuzzed files of megabytes (docs/speed.md) and libyaml's overflows the C stack.
MAX_CHARS = 1_000_000


def loads(text: str, where: str = "kinematics file") -> np.ndarray:
    """(6, 4, 4) joint origins of a kinematics-parameters file's text (m); one-line errors naming the block."""
    try:
        import yaml  # noqa: PLC0415 (PyYAML: only this reader needs it)
    except ImportError:
        raise DenavitError(f"{where}: reading UR kinematics files needs PyYAML: pip install pyyaml") from None

    if len(text) > MAX_CHARS:  # PyYAML's pure-Python loader reads about 0.3 MB a second
        raise DenavitError(
            f"{where}: {len(text) / 1e6:.3g} MB: expected a UR kinematics-parameters file of a few kB (6 joints, 6"
            " numbers each)"
        )
    try:
        doc = yaml.load(text, Loader=_strict_loader(yaml, where))  # noqa: S506 (a SafeLoader, numbers narrowed)
    except yaml.YAMLError as e:
        raise DenavitError(f"{where}: not valid YAML: {str(e).splitlines()[0]}") from None
    except RecursionError:
        raise DenavitError(f"{where}: not readable YAML: mappings or lists nested too deeply") from None
    kin = doc.get("kinematics") if isinstance(doc, dict) else None
    if not isinstance(kin, dict):
        raise DenavitError(f"{where}: expected a top-level 'kinematics' mapping with {', '.join(UR_JOINTS)}")
    from ..geometry import xyz_rpy_pose  # noqa: PLC0415

    out = np.empty((6, 4, 4))
    keys = ("x", "y", "z", "roll", "pitch", "yaw")
    for i, name in enumerate(UR_JOINTS):
        block = kin.get(name)
        if not isinstance(block, dict) or any(k not in block for k in keys):
            raise DenavitError(f"{where}: kinematics.{name}: expected x, y, z, roll, pitch, yaw, got {block!r}")
        vals = [as_number(block[k], f"{where}: kinematics.{name}.{k}") for k in keys]
        out[i] = xyz_rpy_pose(vals[:3], vals[3:])
    return out


def _strict_loader(yaml, where: str):
    """PyYAML's SafeLoader with the one number rule of every reader (:data:`denavit.io.delimited.NUMBER`):
    YAML 1.1 would also read ``1_000``, ``0x10``, ``1:30`` (sexagesimal: 90) and ``.inf`` as numbers, which
    are then strings that :func:`~denavit.io.delimited.as_number` refuses; and a key given twice in one
    mapping is an error (PyYAML keeps the last)."""
    tags = ("tag:yaml.org,2002:int", "tag:yaml.org,2002:float")

    from collections import Counter  # noqa: PLC0415

    class Loader(
        yaml.SafeLoader
    ):  # not libyaml's CSafeLoader: its composer overflows the C stack (a segfault) on deep nesting
        yaml_implicit_resolvers = {
            c: [(t, r) for t, r in rs if t not in tags] for c, rs in yaml.SafeLoader.yaml_implicit_resolvers.items()
        }

        def construct_mapping(self, node, deep=False):
            counts = Counter(str(self.construct_object(k, deep=deep)) for k, _ in node.value)
            twice = sorted(k for k, c in counts.items() if c > 1)
            if twice:
                raise DenavitError(
                    f"{where}:{node.start_mark.line + 1}: key(s) {', '.join(twice)[:80]} given twice in one mapping:"
                    " expected each once"
                )
            return super().construct_mapping(node, deep=deep)

    Loader.add_implicit_resolver(tags[1], re.compile(f"^{NUMBER.pattern}$"), list("-+0123456789."))
    Loader.add_constructor(tags[1], lambda loader, node: float(loader.construct_scalar(node)))
    return Loader


def read(path: str | os.PathLike) -> np.ndarray:
    """(6, 4, 4) joint origins of the kinematics-parameters file at ``path`` (:func:`loads`)."""
    from .text import read_text  # noqa: PLC0415

    return loads(read_text(path, "kinematics file"), str(path))


def save(path: str | os.PathLike, model: _core.Model, nominal: _core.Table, *, force: bool = False) -> None:
    """Write the kinematics-parameters file of ``model`` (whole or not at all; ``force``: replace a read-only file,
    write through one with several hard links (:func:`denavit.io.output.write_text`))."""
    write_text(path, dumps(model, nominal), force=force)
