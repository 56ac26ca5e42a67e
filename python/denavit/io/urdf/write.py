"""Writing a URDF: the model alone, or the nominal's tree with the chain's joints moved onto the model's axes."""

from __future__ import annotations

import math
import os
from typing import TYPE_CHECKING

import numpy as np

from ... import _core
from ...geometry import inverse, matrix_rotvec, matrix_rpy, pose, rotation_between, rotvec_matrix, skew, xyz_rpy_pose
from ...robot import Robot
from ..output import write_text
from .common import _num, _nums, z_to

if TYPE_CHECKING:
    pass


# --------------------------------------------------------------------------------------------------
# writing


def _unique(name: str, taken: set) -> str:
    out, k = name, 1
    while out in taken:
        k += 1
        out = f"{name}_{k}"
    taken.add(out)
    return out


#: Below this (m, and rotation-matrix entries), a joint origin, axis or limit equals the URDF's and its text is
#: kept as it was (so that export -> import -> export is byte-identical).
SAME = 1e-12


def _set_origin(parent, T, tag: str = "origin") -> None:
    """Write ``T`` (4, 4) as ``<origin xyz rpy>`` into ``parent`` (replacing one already there), shortest
    round-trip numbers, rpy by :func:`denavit.geometry.matrix_rpy` (gimbal-safe)."""
    from lxml import etree  # noqa: PLC0415

    el = parent.find(tag)
    if el is None:
        el = etree.Element(tag)
        parent.insert(0, el)
    el.attrib.clear()
    el.set("xyz", _nums(np.asarray(T)[:3, 3]))
    el.set("rpy", _nums(matrix_rpy(np.asarray(T)[:3, :3])))


def _origin_of(el) -> np.ndarray:
    """The pose (4, 4) of a URDF element's ``<origin>`` (identity without one), as urdfdom reads it."""
    o = el.find("origin")
    if o is None:
        return np.eye(4)
    xyz = [float(v) for v in (o.get("xyz") or "0 0 0").replace(",", " ").split()]
    rpy = [float(v) for v in (o.get("rpy") or "0 0 0").replace(",", " ").split()]
    return xyz_rpy_pose(xyz, rpy)


def _axis_of(el) -> np.ndarray:
    ax = el.find("axis")
    a = (
        np.array([float(v) for v in ax.get("xyz").replace(",", " ").split()])
        if ax is not None and ax.get("xyz")
        else np.array([1.0, 0.0, 0.0])
    )
    return a / np.linalg.norm(a)


def _inertial(parent, T, mass: float, I) -> None:
    from lxml import etree  # noqa: PLC0415

    ie = etree.SubElement(parent, "inertial")
    _set_origin(ie, T)
    etree.SubElement(ie, "mass", value=_num(mass))
    etree.SubElement(
        ie,
        "inertia",
        ixx=_num(I[0, 0]),
        ixy=_num(I[0, 1]),
        ixz=_num(I[0, 2]),
        iyy=_num(I[1, 1]),
        iyz=_num(I[1, 2]),
        izz=_num(I[2, 2]),
    )


def _matches(info: dict | None, model: _core.Model) -> bool:
    try:
        return (
            info is not None
            and "xml" in info
            and len(info["joints"]) == model.nq
            and len(info["bodies"]) == model.nq + 1
        )
    except (KeyError, TypeError):
        return False


def _register_lines(Fn: np.ndarray, Fi: np.ndarray, kinds, tool_n: np.ndarray, tool_i: np.ndarray) -> np.ndarray:
    """The rigid motion ``X`` (4, 4) that best puts the nominal joint axes on the identified ones.

    ``Fn``, ``Fi`` (n, 4, 4): joint frames at q = 0 (z = the axis), of the nominal and of the identified
    model in their own world frames. Only the axis lines are compared (directions, and for revolute joints
    the distance of the line from the identified one), never the frames' origins along the axes nor their
    turn about them: those are convention choices (an ED-H frame may lie 0.36 m along the UR shoulder axis
    from the URDF joint origin). Gauss-Newton from the Kabsch rotation of the directions. What the lines do
    not fix (the slide along the axes of an all-parallel chain, a SCARA's or a planar arm's; the turn and slide
    of a single axis) is fixed by the tools, ``tool_n`` (the nominal's tip link) onto ``tool_i`` (the model's
    tool), both (4, 4) at q = 0: exact for the nominal's own model in any convention and frame."""
    dn, pn, d, p = Fn[:, :3, 2], Fn[:, :3, 3], Fi[:, :3, 2], Fi[:, :3, 3]
    # (the Kabsch start from the directions, and with a small weight the tools' axes: parallel directions leave the
    # turn about them to the SVD's round-off, and a start half a turn off is a stationary point of the line fit:
    # an all-parallel chain's links had come out turned by 180 degrees on one CPU and not on another)
    U_, _, Vt = np.linalg.svd(dn.T @ d + 1e-3 * tool_n[:3, :3] @ tool_i[:3, :3].T)
    R = Vt.T @ np.diag([1.0, 1.0, np.linalg.det(Vt.T @ U_.T)]) @ U_.T
    t = np.zeros(3)

    def lines(R, t):
        rows, res = [], []
        for i, kind in enumerate(kinds):
            e, y = R @ dn[i], R @ pn[i] + t
            rows.append(np.hstack([-skew(e), np.zeros((3, 3))]))
            res.append(e - d[i])
            if kind == "revolute":
                P = np.eye(3) - np.outer(d[i], d[i])
                rows.append(np.hstack([-P @ skew(y), P]))
                res.append(P @ (y - p[i]))
        return np.vstack(rows), np.concatenate(res)

    def update(R, t, step):
        dR = rotvec_matrix(step[:3])
        return dR @ R, dR @ t + step[3:]

    for _ in range(30):
        J, r = lines(R, t)
        step = np.linalg.lstsq(J, -r, rcond=1e-9)[0]
        R, t = update(R, t, step)
        if np.linalg.norm(step) < 1e-15:
            break
    J, _ = lines(R, t)
    _, sv, V = np.linalg.svd(
        J, full_matrices=False
    )  # (the thin SVD: the full one's U is 6n x 6n, 29 GB at 10^4 joints)
    N = V[np.concatenate([sv, np.zeros(6 - len(sv))]) <= 1e-9 * sv[0]].T  # (6, k): the motions the lines leave free
    if N.size:
        for _ in range(30):
            Rt, pt = R @ tool_n[:3, :3], R @ tool_n[:3, 3] + t
            Jt = np.vstack([np.hstack([-skew(pt), np.eye(3)]), np.hstack([np.eye(3), np.zeros((3, 3))])])
            rt = np.concatenate([pt - tool_i[:3, 3], matrix_rotvec(Rt @ tool_i[:3, :3].T)])
            step = N @ np.linalg.lstsq(Jt @ N, -rt, rcond=1e-9)[0]
            R, t = update(R, t, step)
            if np.linalg.norm(step) < 1e-15:
                break
    return pose(R, t)


def _body_maps(info: dict, model: _core.Model, frames: np.ndarray) -> list[np.ndarray]:
    """Per body *b* (0: the base, *i*: the child of joint *i*), the rigid motion ``M_b`` (4, 4) taking the
    body from the nominal URDF (its base link's frame, q = 0) to the model (its world, q = 0). Module
    docstring, "Identified robots": the nominal axis lines are registered onto the model's
    (:func:`_register_lines`), and each body is anchored on the axis it turns about (the base on the first)."""
    n = model.nq
    Fn = np.array(
        [
            np.asarray(info["bodies"][i + 1]["links"][0]["T_world_link"], dtype=float) @ pose(z_to(j["axis"]))
            for i, j in enumerate(info["joints"])
        ]
    )
    tool_n = np.asarray(info["bodies"][n]["links"][-1]["T_world_link"], dtype=float)  # the tip link
    X = _register_lines(Fn, frames, list(model.kinds), tool_n, frames[n - 1] @ np.asarray(model.T_last_tool))
    out = []
    for b in range(n + 1):
        j = max(b - 1, 0)
        G, F = X @ Fn[j], frames[j]
        A = pose(rotation_between(G[:3, 2], F[:3, 2]) @ G[:3, :3], G[:3, 3])
        if model.kinds[j] == "revolute":  # the body's bearing on the model's axis line
            A[:3, 3] = F[:3, 3] + F[:3, 2] * (F[:3, 2] @ (G[:3, 3] - F[:3, 3]))
        out.append(A @ inverse(Fn[j]))
    return out


def _comment(root, what: str) -> None:
    """The one header comment, replacing an earlier export's (so that a re-export is byte-identical)."""
    from lxml import etree  # noqa: PLC0415

    for c in [c for c in root if isinstance(c, etree._Comment) and (c.text or "").startswith(" Written by denavit")]:
        root.remove(c)
    root.insert(0, etree.Comment(f" Written by denavit {_core.__version__}: {what}; metres, radians, kilograms. "))


def _add_fixed(root, name: str, parent: str, child: str, T, at: int | None = None) -> None:
    from lxml import etree  # noqa: PLC0415

    je = etree.Element("joint", name=name, type="fixed")
    etree.SubElement(je, "parent", link=parent)
    etree.SubElement(je, "child", link=child)
    _set_origin(je, T)
    if at is None:
        root.append(je)
    else:
        root.insert(at, je)


def _dumps_tree(model: _core.Model, info: dict) -> str:
    """The URDF the model was read from, with its names, links and frames (module docstring, "Export")."""
    from lxml import etree  # noqa: PLC0415

    n = model.nq
    root = etree.fromstring(
        info["xml"].encode("utf-8"), etree.XMLParser(remove_blank_text=True, resolve_entities=False, recover=True)
    )
    joints = {el.get("name"): el for el in root if el.tag == "joint"}
    by_child = {el.find("child").get("link"): el for el in joints.values()}
    path = list(info["path_links"])
    frames = np.asarray(_core.joint_frames(model, np.zeros(n)))
    maps = _body_maps(info, model, frames)
    L_nom = {ld["name"]: np.asarray(ld["T_world_link"], dtype=float) for b in info["bodies"] for ld in b["links"]}
    body_of = {ld["name"]: b for b, body in enumerate(info["bodies"]) for ld in body["links"]}
    L = {ln: maps[body_of[ln]] @ L_nom[ln] for ln in path}  # each link rides rigidly on its body
    moving = {j["name"]: i for i, j in enumerate(info["joints"])}
    for ln in path[1:]:
        el = by_child[ln]
        O = inverse(L[el.find("parent").get("link")]) @ L[ln]
        if np.abs(O - _origin_of(el)).max() > SAME:
            _set_origin(el, O)
        i = moving.get(el.get("name"))
        if i is None:
            continue
        a = L[ln][:3, :3].T @ frames[i][:3, 2]  # the model's axis in the child link
        if np.abs(a - _axis_of(el)).max() > SAME:
            ax = el.find("axis")
            if ax is None:
                ax = etree.SubElement(el, "axis")
            ax.set("xyz", _nums(a))
        lim = el.find("limit")
        for attr, v in (("lower", model.lower[i]), ("upper", model.upper[i])):
            if (
                lim is not None
                and math.isfinite(v)
                and lim.get(attr) is not None
                and abs(float(lim.get(attr)) - v) > SAME
            ):
                lim.set(attr, _num(v))
    if info.get("chain_only"):
        keep = set(path)
        for el in list(root):
            if (el.tag == "link" and el.get("name") not in keep) or (
                el.tag == "joint" and el.find("child").get("link") not in keep
            ):
                root.remove(el)
            elif el.tag == "joint" and el.find("child").get("link") == path[0]:
                root.remove(el)  # the joint above the base link
        top, T_top = path[0], maps[0]
    else:
        top, T_top = info["root_link"], maps[0] @ np.asarray(info["T_base_root"], dtype=float)
    links = {el.get("name") for el in root if el.tag == "link"}
    names = {el.get("name") for el in root if el.tag == "joint"}
    if np.abs(T_top - np.eye(4)).max() > SAME:  # the model's world is not the URDF's root (a tracker frame)
        world = _unique("world", links)
        k = next(i for i, el in enumerate(root) if el.tag == "link")
        root.insert(k, etree.Element("link", name=world))
        _add_fixed(root, _unique(f"{world}-{top}", names), world, top, T_top, at=k + 1)
    tip = info["tip_link"]
    T_tool = frames[n - 1] @ np.asarray(model.T_last_tool)
    if np.abs(T_tool - L[tip]).max() > SAME:  # the model's tool is not the tip link: a frame of its own
        tool = _unique("tcp", links)
        root.append(etree.Element("link", name=tool))
        _add_fixed(root, _unique(f"{tip}-{tool}", names), tip, tool, inverse(L[tip]) @ T_tool)
    _comment(
        root,
        "the links and joints of the URDF read (docs/urdf.md); only the chain's joint origins, axes and limits follow"
        " the model",
    )
    return etree.tostring(root, pretty_print=True, xml_declaration=True, encoding="UTF-8").decode("utf-8")


def _dumps_model(model: _core.Model, name: str) -> str:
    """A model without a URDF of its own: ``base_link``, ``link_1`` ... ``link_n`` (link *i* is the model's
    joint frame *i*), ``flange`` and ``tool0`` (REP-199), a ``world`` root when the base is not the identity."""
    from lxml import etree  # noqa: PLC0415

    n = model.nq
    P = np.asarray(model.placements)
    offsets, kinds, names = list(model.offsets), list(model.kinds), list(model.names)
    B = np.asarray(model.T_world_base)
    root = etree.Element("robot", name=name)
    link_names: set = set()
    joint_names: set = set()
    names = [_unique(nm, joint_names) for nm in names]
    body = [_unique("base_link" if b == 0 else f"link_{b}", link_names) for b in range(n + 1)]
    flange, tool = _unique("flange", link_names), _unique("tool0", link_names)
    world = _unique("world", link_names) if np.abs(B - np.eye(4)).max() > SAME else None
    for ln in ([world] if world else []) + body + [flange, tool]:
        etree.SubElement(root, "link", name=ln)
    link_el = {el.get("name"): el for el in root}
    ins = model.inertias
    for i in range(n):  # the model's own link inertias (link i = joint frame i, about the centre of mass)
        if ins["masses"][i] > 0.0 or np.any(
            ins["inertias"][i] != 0
        ):  # an inertia without mass too (the Puma 560's link 1)
            _inertial(link_el[body[i + 1]], pose(None, ins["coms"][i]), float(ins["masses"][i]), ins["inertias"][i])
    if world:
        _add_fixed(root, _unique(f"{world}-{body[0]}", joint_names), world, body[0], B)
    for i in range(n):
        prismatic = kinds[i] == "prismatic"
        M = np.eye(4)
        if prismatic:
            M[2, 3] = offsets[i]
        else:
            c, s = math.cos(offsets[i]), math.sin(offsets[i])
            M[:2, :2] = [[c, -s], [s, c]]
        lo, hi = model.lower[i], model.upper[i]
        jtype = "prismatic" if prismatic else ("continuous" if math.isinf(lo) and math.isinf(hi) else "revolute")
        je = etree.SubElement(root, "joint", name=names[i], type=jtype)
        etree.SubElement(je, "parent", link=body[i])
        etree.SubElement(je, "child", link=body[i + 1])
        _set_origin(je, P[i] @ M)
        etree.SubElement(je, "axis", xyz="0 0 1")
        if jtype != "continuous":  # no <limit> is invented for a continuous joint (docs/urdf.md, "Limits")
            etree.SubElement(je, "limit", lower=_num(lo), upper=_num(hi), effort="0", velocity="0")
    _add_fixed(root, _unique(f"{body[n]}-{flange}", joint_names), body[n], flange, model.T_last_flange)
    _add_fixed(root, _unique(f"{flange}-{tool}", joint_names), flange, tool, model.T_flange_tool)
    _comment(
        root,
        "link i is the model's joint frame i (docs/urdf.md): every joint moves about the z axis of its link, joint"
        " values equal the model's q; effort and velocity limits unknown (0, urdfdom's unset value)",
    )
    return etree.tostring(root, pretty_print=True, xml_declaration=True, encoding="UTF-8").decode("utf-8")


def dumps_urdf(model: _core.Model, robot: Robot | None = None) -> str:
    """The URDF text of ``model`` (any convention's model, identified ones included); docs/urdf.md.

    When ``robot`` was read from a URDF (``robot.extra["urdf"]``) with as many joints as ``model``, the text
    is that URDF: every link and joint keeps its name, its elements (visuals, collisions, inertials, sensors,
    vendor tags) and its frame; off the chain nothing changes (unless the robot was loaded ``chain_only``:
    then only the links from base to tip are written). Each chain link rides rigidly on its body, the body
    moved from the nominal onto the model's axes (module docstring, "Identified robots"), so only the chain
    joints' origins, axes and limits change, and only where they differ from the URDF's by more than
    :data:`SAME`: for the unchanged model the text is the URDF's own. A ``world`` root is added when the
    model's world is not the URDF's root (a model identified in a tracker's frame), a ``tcp`` frame (fixed to the tip
    link)
    when the model's tool is not the tip link (an identified tool point).

    Otherwise link *i* is the model's joint frame *i* (``base_link``, ``link_1`` ... ``link_n``, then
    ``flange`` and ``tool0``): ``<axis xyz="0 0 1"/>`` and ``origin`` = ``placement_i · Rz(offset_i)``
    (``Tz`` for prismatic joints), so URDF joint values are the model's ``q``. Revolute joints with infinite
    limits are written ``continuous``. Lengths in m, angles in rad, masses in kg.
    """
    info = robot.extra.get("urdf") if robot is not None and isinstance(robot.extra, dict) else None
    if _matches(info, model):
        return _dumps_tree(model, info)
    return _dumps_model(model, robot.name if robot is not None else model.name)


def save_urdf(model: _core.Model, path: str | os.PathLike, robot: Robot | None = None, *, force: bool = False) -> None:
    """Write :func:`dumps_urdf` to ``path`` (whole or not at all; ``force``: replace a read-only file, write through one
    with several hard links (:func:`denavit.io.output.write_text`))."""
    write_text(path, dumps_urdf(model, robot), force=force)
