"""Reading a URDF: the checks before parsing, the chain between two links, the model, robot and tables."""

from __future__ import annotations

import math
import os
import re
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from ... import _core
from ...errors import DenavitError, DenavitWarning
from ...geometry import inverse, pose, rotvec_matrix
from ...robot import Robot, inertials_for_table
from ..delimited import NON_FINITE, NUMBER
from ..text import decode, read_bytes
from .common import SUPPORTED_JOINTS, UNSUPPORTED_JOINTS, _mat, _nums, combine_inertials, z_to

if TYPE_CHECKING:
    import yourdfpy


# --------------------------------------------------------------------------------------------------
# reading


@dataclass(frozen=True)
class UrdfChain:
    """The serial chain read from a URDF (SI; see the module docstring for the mapping).

    ``placements`` (n, 4, 4) are the model's ``T_{i-1}_i0``; ``axes_local`` (n, 3) the URDF axes (unit) in
    their joint's origin frame; ``extra`` is what :func:`load_urdf` stores in ``Robot.extra["urdf"]``.
    """

    name: str
    path: str
    base_link: str
    tip_link: str
    names: list[str]
    kinds: list[str]
    urdf_types: list[str]
    placements: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    T_world_base: np.ndarray
    T_last_flange: np.ndarray
    axes_local: np.ndarray
    extra: dict
    chosen: str = ""
    """How the tip link was chosen when none was given (empty when there was a single leaf)."""

    def model(self) -> _core.Model:
        """The exact model: ``T_world_joint[i] = L_i · R_a_i`` for every moving joint."""
        return _core.Model.from_placements(
            self.placements,
            self.kinds,
            lower=self.lower,
            upper=self.upper,
            names=self.names,
            T_world_base=self.T_world_base,
            T_last_flange=self.T_last_flange,
            name=self.name,
        )


class _Where:
    """Names an element of the file: ``robot.urdf: joint 'j2' (line 31)``."""

    def __init__(self, path: Path, root) -> None:
        self.path = path
        self.lines: dict[tuple[str, str], int] = {}
        for el in root:
            if isinstance(el.tag, str) and el.tag in ("link", "joint") and el.get("name") is not None:
                self.lines.setdefault((el.tag, el.get("name")), el.sourceline)

    def __call__(self, tag: str, name: str) -> str:
        line = self.lines.get((tag, name))
        return f"{self.path}: {tag} {name!r}" + (f" (line {line})" if line else "")


def _check_numbers(el, attr: str, n: int, what: str, finite: bool = True) -> None:
    """Attribute ``attr`` of ``el``, if given, holds ``n`` numbers by the one number rule of every reader
    (:data:`denavit.io.delimited.NUMBER`: yourdfpy's float() would read ``1_0`` or full-width digits), finite
    unless ``finite`` is False (limits and inertias: their own checks say so, naming the values)."""
    text = el.get(attr)
    if text is None:
        return
    parts = text.replace(",", " ").split()
    if not all(NUMBER.fullmatch(t) or NON_FINITE.fullmatch(t) for t in parts):
        raise DenavitError(
            f"{what}: {el.tag} {attr}={text[:60]!r}: expected {n} number{'s' if n > 1 else ''} (ASCII decimal)"
        )
    if len(parts) != n or (finite and not all(math.isfinite(float(t)) for t in parts)):
        raise DenavitError(
            f"{what}: {el.tag} {attr}={text[:60]!r}: expected {n} finite number{'s' if n > 1 else ''}, got {len(parts)}"
            " value(s)"
        )


#: The numeric attributes of URDF elements (element, attributes, numbers each, finite), checked wherever they appear.
_NUMBERS = (
    ("origin", ("xyz", "rpy"), 3, True),
    ("axis", ("xyz",), 3, True),
    ("mass", ("value",), 1, True),
    ("inertia", ("ixx", "ixy", "ixz", "iyy", "iyz", "izz"), 1, False),
    ("limit", ("lower", "upper"), 1, False),
    ("limit", ("effort", "velocity"), 1, True),
    ("dynamics", ("damping", "friction"), 1, True),
    ("safety_controller", ("soft_lower_limit", "soft_upper_limit", "k_position", "k_velocity"), 1, True),
    ("mimic", ("multiplier", "offset"), 1, True),
    ("calibration", ("rising", "falling"), 1, True),
    ("box", ("size",), 3, True),
    ("cylinder", ("radius", "length"), 1, True),
    ("sphere", ("radius",), 1, True),
    ("mesh", ("scale",), 3, True),
    ("color", ("rgba",), 4, True),
)


def _lengths(values, where: str) -> None:
    from ...limits import check_lengths  # noqa: PLC0415

    check_lengths(values, where, "m")


def _angles(values, where: str) -> None:
    from ...limits import check_angles  # noqa: PLC0415

    check_angles(values, where, "rad")


#: The URDF attributes held to physical plausibility (:mod:`denavit.limits`): lengths within 1 km, angles within
#: the turns allowed (a 1e308 m origin had been shown as inf mm).
_PLAUSIBLE = {
    ("origin", "xyz"): _lengths,
    ("origin", "rpy"): _angles,
    ("box", "size"): _lengths,
    ("cylinder", "radius"): _lengths,
    ("cylinder", "length"): _lengths,
    ("sphere", "radius"): _lengths,
}


def _precheck(path: Path, root) -> _Where:
    """Checks yourdfpy leaves to chance (it raises bare KeyError/AttributeError or ignores them), each
    naming the element and its line; the XML itself is already parsed by lxml."""
    if root.tag != "robot":
        raise DenavitError(f"{path}: expected a <robot> root element, got <{root.tag}> (line {root.sourceline})")
    if not root.get("name"):
        raise DenavitError(f"{path}: <robot> (line {root.sourceline}) has no name attribute")
    from ... import limits  # noqa: PLC0415

    for tag in ("link", "joint"):  # counted before yourdfpy builds its objects (slow on huge files: docs/speed.md)
        limits.check_size(sum(1 for _ in root.iterchildren(tag)), "urdf_links", str(path), f"<{tag}> elements")
    where = _Where(path, root)
    seen: dict[tuple[str, str], int] = {}
    for el in root:
        if not isinstance(el.tag, str) or el.tag not in ("link", "joint"):
            continue
        name = el.get("name")
        if not name:
            raise DenavitError(f"{path}: <{el.tag}> at line {el.sourceline} has no name attribute")
        key = (el.tag, name)
        if key in seen:
            raise DenavitError(f"{path}: {el.tag} {name!r} is defined twice (lines {seen[key]} and {el.sourceline})")
        seen[key] = el.sourceline
        w = where(el.tag, name)
        for tag, attrs, n, finite in _NUMBERS:
            for sub in el.iter(tag):
                for attr in attrs:
                    _check_numbers(sub, attr, n, w, finite)
                    if (tag, attr) in _PLAUSIBLE and sub.get(attr) is not None:
                        _PLAUSIBLE[tag, attr](
                            np.array(sub.get(attr).replace(",", " ").split(), dtype=float), f"{w}: <{tag}> {attr}"
                        )
        if el.tag == "joint":
            for tag in ("parent", "child"):
                sub = el.find(tag)
                if sub is None or not sub.get("link"):
                    raise DenavitError(f'{w}: expected a <{tag} link="..."/> element, got none')
            ax = el.find("axis")
            if ax is not None and ax.get("xyz") is None:  # urdfdom would take the default 1 0 0 for a mangled <axis>
                raise DenavitError(f'{w}: <axis> (line {ax.sourceline}) without xyz: expected e.g. <axis xyz="0 0 1"/>')
    return where


def _read(path: str | os.PathLike) -> tuple[yourdfpy.URDF, _Where, object]:
    import yourdfpy  # noqa: PLC0415 (yourdfpy and lxml load only for a URDF)
    from lxml import etree  # noqa: PLC0415

    path = Path(path)
    if not path.is_file():
        raise DenavitError(f"{path}: no such URDF file")
    data = read_bytes(path, "URDF file")
    if not re.match(rb"\s*<\?xml[^>]*encoding=", data.lstrip(b"\xef\xbb\xbf")):
        decode(data, str(path))  # no declared encoding: XML's default, UTF-8, with the byte offset of a bad byte
    # strict where urdfdom is strict: malformed XML is an error (yourdfpy's loader would recover from it), but an
    # undeclared namespace prefix on a vendor tag (drake:, gazebo extensions) is tolerated, as urdfdom does
    parser = etree.XMLParser(remove_blank_text=True, resolve_entities=False, recover=True)
    try:
        tree = etree.parse(str(path), parser)
    except etree.XMLSyntaxError as e:
        line, col = e.position if e.position else (e.lineno, 0)
        raise DenavitError(f"{path}: malformed XML at line {line}, column {col}: {' '.join(e.msg.split())}") from None
    fatal = [
        e for e in parser.error_log if e.level >= etree.ErrorLevels.ERROR and e.domain != etree.ErrorDomains.NAMESPACE
    ]
    if fatal or tree.getroot() is None:
        e = fatal[0] if fatal else None
        raise DenavitError(
            f"{path}: malformed XML at line {e.line if e else 1}, column {e.column if e else 0}:"
            f" {' '.join(e.message.split()) if e else 'no root element'}"
        )
    where = _precheck(path, tree.getroot())
    import logging  # noqa: PLC0415

    log = logging.getLogger("yourdfpy")
    level = log.level
    log.setLevel(logging.CRITICAL)  # its "Using different parsing approach" error log, for XML we have already checked
    try:
        urdf = yourdfpy.URDF.load(
            str(path),
            build_scene_graph=False,
            build_collision_scene_graph=False,
            load_meshes=False,
            load_collision_meshes=False,
        )
    except Exception as e:  # noqa: BLE001 (yourdfpy raises bare KeyError/ValueError/IndexError)
        raise DenavitError(f"{path}: not a readable URDF ({type(e).__name__}: {e})") from None
    finally:
        log.setLevel(level)
    return urdf, where, tree.getroot()


def _link_dict(link, T_world_link: np.ndarray, where=None) -> dict:
    d: dict = {"name": link.name, "T_world_link": _mat(T_world_link)}
    if link.inertial is not None and link.inertial.mass is not None:
        ine = link.inertial
        values = [
            float(ine.mass),
            *np.ravel(np.zeros(3) if ine.inertia is None else ine.inertia),
            *np.ravel(np.eye(4) if ine.origin is None else ine.origin),
        ]
        if not all(math.isfinite(v) for v in values):
            at = where("link", link.name) if where is not None else f"link {link.name!r}"
            raise DenavitError(
                f"{at}: <inertial> must hold finite numbers (mass, origin, inertia), got a non-finite one"
            )
        d["inertial"] = {
            "mass": float(ine.mass),
            "origin": _mat(np.eye(4) if ine.origin is None else ine.origin),
            "inertia": _mat(np.zeros((3, 3)) if ine.inertia is None else ine.inertia),
        }
    return d


def _select_chain(
    urdf: yourdfpy.URDF, where: _Where, base_link: str | None, tip_link: str | None
) -> tuple[list, str, str, str, dict, dict]:
    """The joints from ``base_link`` to ``tip_link`` (in order), with the tree checks; also how the tip was
    chosen, and the tree's joints by parent link (``children``) and by child link (``parent_of``)."""
    path = where.path
    robot = urdf.robot
    links = {l.name: l for l in robot.links}
    if not links:
        raise DenavitError(f"{path}: the URDF defines no <link>")
    parent_of: dict[str, object] = {}
    children: dict[str, list] = {name: [] for name in links}
    for j in robot.joints:
        for role, ln in (("parent", j.parent), ("child", j.child)):
            if ln not in links:
                raise DenavitError(
                    f"{where('joint', j.name)}: {role} link {ln!r} is not defined (links: {', '.join(sorted(links))})"
                )
        if j.child in parent_of:
            other = parent_of[j.child].name
            raise DenavitError(
                f"{where('link', j.child)} is the child of joint {other!r} and of joint {j.name!r}: kinematic loops are"
                " not supported"
            )
        parent_of[j.child] = j
        children[j.parent].append(j)
    roots = [n for n in links if n not in parent_of]
    if not roots:
        raise DenavitError(
            f"{path}: no root link (every link is some joint's child): the joints form a loop, which is not supported"
        )
    # a link no root reaches lies on a loop (following its parents never ends), e.g. a joint whose parent is its child
    reached, stack = set(), list(roots)
    while stack:
        ln = stack.pop()
        reached.add(ln)
        stack.extend(j.child for j in children[ln] if j.child not in reached)
    looped = [j for j in robot.joints if j.child not in reached]
    if looped:
        j = looped[0]
        raise DenavitError(
            f"{where('joint', j.name)}: its child link {j.child!r} (parent {j.parent!r}) is on a loop of joints:"
            " kinematic loops are not supported"
        )

    def names(ls):
        return ", ".join(repr(x) for x in ls)

    if base_link is None:
        if len(roots) > 1:
            raise DenavitError(f"{path}: several root links ({names(roots)}): give base_link")
        base_link = roots[0]
    elif base_link not in links:
        raise DenavitError(f"{path}: base link {base_link!r} is not defined (links: {', '.join(sorted(links))})")
    # every link below the base (a cycle without a root shows up as a revisit)
    below, stack = [], [base_link]
    seen = set()
    while stack:
        ln = stack.pop()
        if ln in seen:
            raise DenavitError(
                f"{where('link', ln)} is reached twice from {base_link!r}: kinematic loops are not supported"
            )
        seen.add(ln)
        below.append(ln)
        stack.extend(j.child for j in children[ln])
    chosen = ""
    if tip_link is None:
        tip_link, chosen = _default_tip(path, base_link, below, children, parent_of)
    elif tip_link not in links:
        raise DenavitError(f"{path}: tip link {tip_link!r} is not defined (links: {', '.join(sorted(links))})")
    elif tip_link not in seen:
        raise DenavitError(
            f"{path}: tip link {tip_link!r} is not below base link {base_link!r} (links below it:"
            f" {names(sorted(below))})"
        )
    chain = []
    ln = tip_link
    while ln != base_link:
        j = parent_of[ln]
        chain.append(j)
        ln = j.parent
    chain.reverse()
    return chain, base_link, tip_link, chosen, children, parent_of


#: Joint types that move (a chain's degrees of freedom).
MOVING = ("revolute", "continuous", "prismatic")


def _default_tip(path, base_link: str, below: list, children: dict, parent_of: dict) -> tuple[str, str]:
    """The tip link when none is given, and why (empty when there is a single leaf): REP-199's ``tool0`` when
    the tree has one (ROS-Industrial descriptions also hang a ``base`` frame, sensors and flanges off the
    arm), else the leaf reached through the most moving joints, mimic joints not counted (a camera or a
    ``base`` frame hangs off through fewer; a gripper's mimicking finger through one fewer than the other);
    a tie is an error listing the candidates."""
    leaves = [ln for ln in below if not children[ln]]
    if len(leaves) == 1:
        return leaves[0], ""
    if "tool0" in below:
        return (
            "tool0",
            f"tip link 'tool0' (REP-199) of {len(leaves)} leaves; choose another with tip_link (CLI: --tip-link)",
        )

    def moving(ln):
        count = 0
        while ln != base_link:
            j = parent_of[ln]
            count += (j.type or "").strip() in MOVING and j.mimic is None  # a mimic joint is no degree of freedom
            ln = j.parent
        return count

    counts = {ln: moving(ln) for ln in leaves}
    best = max(counts.values())
    top = [ln for ln in leaves if counts[ln] == best]
    if len(top) == 1:
        return (
            top[0],
            (
                f"tip link {top[0]!r}, the leaf reached through the most moving joints ({best}) of {len(leaves)}"
                " leaves; choose another with tip_link (CLI: --tip-link)"
            ),
        )
    listing = ", ".join(f"{ln!r} ({counts[ln]} moving joints)" for ln in sorted(leaves, key=lambda x: (-counts[x], x)))
    raise DenavitError(
        f"{path}: the tree below {base_link!r} has {len(leaves)} tip links ({listing}): "
        "a serial chain needs one; choose one with tip_link (CLI: --tip-link)"
    )


def _motion(j, value: float) -> np.ndarray:
    """The pose a URDF joint adds after its origin at joint value ``value`` (rad or m); fixed, floating and
    planar joints: none (held at their origin)."""
    jtype = (j.type or "").strip()
    if jtype not in MOVING or value == 0.0:
        return np.eye(4)
    a = np.asarray(j.axis if j.axis is not None else (1.0, 0.0, 0.0), dtype=float)
    a = a / np.linalg.norm(a)
    return pose(None, a * value) if jtype == "prismatic" else pose(rotvec_matrix(a * value))


def _attached(
    urdf, where: _Where, path_links: list, body_of: dict, T_path: dict, children: dict, locked: dict
) -> tuple[list, dict]:
    """The links off the chain, each with its pose at q = 0 (off-chain movable joints at their ``locked``
    value, 0 by default; a mimic joint at ``multiplier * value + offset`` of the joint it mimics), grouped by
    the chain body that carries them; and the value each off-chain movable joint was locked at."""
    links = {l.name: l for l in urdf.robot.links}
    movable = {j.name: j for js in children.values() for j in js if (j.type or "").strip() in MOVING}
    on_path = set(path_links)
    off = {name: j for name, j in movable.items() if j.child not in on_path}
    unknown = sorted(set(locked) - set(off))
    if unknown:
        raise DenavitError(
            f"{where.path}: locked joint{'s' if len(unknown) > 1 else ''} {', '.join(map(repr, unknown))}: expected"
            f" off-chain movable joints ({', '.join(map(repr, sorted(off))) or 'none'})"
        )

    def value(j) -> float:
        if j.name in locked:
            return float(locked[j.name])
        if j.mimic is not None:
            master = off.get(j.mimic.joint)
            v = value(master) if master is not None and master.mimic is None else float(locked.get(j.mimic.joint, 0.0))
            return (1.0 if j.mimic.multiplier is None else float(j.mimic.multiplier)) * v + (
                0.0 if j.mimic.offset is None else float(j.mimic.offset)
            )
        return 0.0

    out: list = [[] for _ in range(max(body_of.values()) + 1)]
    used: dict = {}
    stack = [(j, body_of[ln], T_path[ln]) for ln in path_links for j in children[ln] if j.child not in on_path]
    while stack:
        j, b, T_parent = stack.pop()
        v = value(j) if j.name in off else 0.0
        if j.name in off:
            used[j.name] = v
        T = T_parent @ (np.eye(4) if j.origin is None else np.asarray(j.origin, dtype=float)) @ _motion(j, v)
        out[b].append(_link_dict(links[j.child], T, where))
        stack.extend((c, b, T) for c in children[j.child])
    return out, used


def _joint_type(j, w: str) -> str:
    """The type of a chain's joint ``j`` (at ``w``), one the chain supports, else a one-line error."""
    jtype = (j.type or "").strip()
    if jtype in UNSUPPORTED_JOINTS:
        raise DenavitError(
            f"{w} is a {jtype} joint, which is not supported: expected revolute, continuous, prismatic or fixed "
            "(to import the arm alone, choose a base_link below it)"
        )
    if jtype not in SUPPORTED_JOINTS:
        raise DenavitError(f"{w}: unknown joint type {j.type!r}: expected one of {', '.join(SUPPORTED_JOINTS)}")
    if j.mimic is not None and jtype != "fixed":  # urdfdom ignores a fixed joint's <mimic>, and so do we
        raise DenavitError(f"{w} mimics joint {j.mimic.joint!r}: mimic joints (coupled joint values) are not supported")
    return jtype


def read_chain(
    path: str | os.PathLike, base_link: str | None = None, tip_link: str | None = None, *, locked: dict | None = None
) -> UrdfChain:
    """Read the serial chain ``base_link`` -> ``tip_link`` of a URDF (defaults: the root link and the single
    leaf below it). Every error names the file and the element (joint or link, with its line). ``locked``
    ({joint: value}, rad or m) sets off-chain movable joints (fingers, a head, another arm) for the bodies
    they are merged into (default 0; :func:`load_urdf`)."""
    from lxml import etree  # noqa: PLC0415

    urdf, where, xml_root = _read(path)
    path = where.path
    chain, base_link, tip_link, chosen, children, parent_of = _select_chain(urdf, where, base_link, tip_link)
    links = {l.name: l for l in urdf.robot.links}
    names, kinds, types, placements, lower, upper, axes_local = [], [], [], [], [], [], []
    joint_info, bodies, body_links = [], [[]], [base_link]
    acc = np.eye(4)  # the current link in the last joint frame (before the first joint: in world)
    T_world_link = np.eye(4)  # the current link at q = 0 in world
    T_world_base = None
    T_path = {base_link: T_world_link}
    body_of = {base_link: 0}
    bodies[0].append(_link_dict(links[base_link], T_world_link, where))
    from ... import limits  # noqa: PLC0415

    limits.check_size(
        sum((j.type or "").strip() != "fixed" for j in chain),
        "joints",
        f"{path}: the chain {base_link} -> {tip_link}",
        "moving joints",
    )
    for j in chain:
        w = where("joint", j.name)
        jtype = _joint_type(j, w)
        O = np.eye(4) if j.origin is None else np.asarray(j.origin, dtype=float)
        T_world_link = T_world_link @ O
        T_path[j.child] = T_world_link
        if jtype == "fixed":
            acc = acc @ O
            body_of[j.child] = len(bodies) - 1
            bodies[-1].append(_link_dict(links[j.child], T_world_link, where))
            continue
        a = np.asarray(j.axis, dtype=float)
        na = float(np.linalg.norm(a))
        if not (na > 1e-12 and np.all(np.isfinite(a))):
            raise DenavitError(
                f'{w}: axis xyz="{_nums(a)}" has zero length: expected a nonzero direction (e.g. "0 0 1")'
            )
        a = a / na
        Ra = pose(z_to(a))
        if T_world_base is None:
            T_world_base = acc
            body_links[0] = j.parent  # the base body's link the first moving joint hangs on
            placements.append(O @ Ra)
        else:
            placements.append(acc @ O @ Ra)
        acc = inverse(Ra)
        if jtype == "continuous":
            lo, hi = -math.inf, math.inf
        else:
            if j.limit is None:
                raise DenavitError(
                    f"{w}: a {jtype} joint needs a <limit lower=... upper=... effort=... velocity=.../> (use"
                    ' type="continuous" for an unlimited revolute joint)'
                )
            if j.limit.lower is None or j.limit.upper is None:
                # urdfdom would default a missing bound to 0, a joint that cannot move: say so instead
                raise DenavitError(
                    f"{w}: <limit> lacks {'lower' if j.limit.lower is None else 'upper'}: a {jtype} joint needs both"
                    " bounds (urdfdom reads a missing one as 0)"
                )
            lo, hi = float(j.limit.lower), float(j.limit.upper)
            if not (math.isfinite(lo) and math.isfinite(hi)):
                raise DenavitError(
                    f'{w}: limit lower={lo} upper={hi} must be finite (use type="continuous" for an unlimited revolute'
                    " joint)"
                )
            if lo > hi:
                raise DenavitError(f"{w}: limit lower={lo} is above upper={hi}")
        info: dict = {"name": j.name, "type": jtype, "axis": [float(v) for v in a]}
        if j.limit is not None:
            for k in ("effort", "velocity"):
                v = getattr(j.limit, k)
                if v is not None:
                    info[k] = float(v)
        if j.dynamics is not None:
            for k in ("damping", "friction"):
                v = getattr(j.dynamics, k)
                if v is not None:
                    info[k] = float(v)
        names.append(j.name)
        kinds.append("prismatic" if jtype == "prismatic" else "revolute")
        types.append(jtype)
        lower.append(lo)
        upper.append(hi)
        axes_local.append(a)
        joint_info.append(info)
        body_of[j.child] = len(bodies)
        bodies.append([_link_dict(links[j.child], T_world_link, where)])
        body_links.append(j.child)
    if not names:
        raise DenavitError(
            f"{path}: no revolute, continuous or prismatic joint between base link {base_link!r} and tip link"
            f" {tip_link!r}"
        )
    path_links = [base_link] + [j.child for j in chain]
    attached, used = _attached(urdf, where, path_links, body_of, T_path, children, dict(locked or {}))
    T_root_base, ln = np.eye(4), base_link  # the links above the base (a `world` root): fixed to the base body
    while ln in parent_of:
        j = parent_of[ln]
        T_root_base = (np.eye(4) if j.origin is None else np.asarray(j.origin, dtype=float)) @ T_root_base
        ln = j.parent
    xml = etree.tostring(xml_root, encoding="unicode")
    extra = {
        "note": (
            "kept from the URDF for export: SI units (m, rad, kg); T_world_link = each link at q = 0 in the base link's"
            " frame"
        ),
        "robot": urdf.robot.name,
        "file": str(path),
        "base_link": base_link,
        "tip_link": tip_link,
        "root_link": ln,
        "T_base_root": _mat(inverse(T_root_base)),
        "path_links": path_links,
        "body_links": body_links,
        "joints": joint_info,
        "bodies": [{"links": b, "attached": att} for b, att in zip(bodies, attached)],
        "locked": used,
        "xml": xml,
    }
    return UrdfChain(
        name=urdf.robot.name,
        path=str(path),
        base_link=base_link,
        tip_link=tip_link,
        names=names,
        kinds=kinds,
        urdf_types=types,
        placements=np.array(placements),
        lower=np.array(lower),
        upper=np.array(upper),
        T_world_base=T_world_base,
        T_last_flange=acc,
        axes_local=np.array(axes_local),
        extra=extra,
        chosen=chosen,
    )


def urdf_model(path: str | os.PathLike, base_link: str | None = None, tip_link: str | None = None) -> _core.Model:
    """The exact model of a URDF's serial chain ``base_link`` -> ``tip_link`` (docs/conventions.md).

    Joint frame *i* is URDF link frame *i* turned by ``R_a`` (:func:`z_to`), so every URDF link frame is
    ``T_world_joint[i] @ R_a^-1`` and the tool is the tip link; ``world`` is the base link's frame.
    Lengths in m, angles in rad; continuous joints have infinite limits.
    """
    return read_chain(path, base_link, tip_link).model()


def load_urdf(
    path: str | os.PathLike,
    base_link: str | None = None,
    tip_link: str | None = None,
    *,
    chain_only: bool = False,
    locked: dict | None = None,
) -> Robot:
    """Read a URDF's serial chain into a :class:`~denavit.Robot` (what ``denavit.load_robot("x.urdf")`` returns).

    The table is ED-H (Guo et al. eq. 1-2), extracted through the core's line geometry from the exact
    model's joint axes at ``q = 0`` with the frame origins at the URDF joint origins: exact for every
    geometry (same axes, tool pose to rounding error).

    Dynamics of the whole body: each chain body's inertial merges its links', the links fixed to them and
    every off-chain subtree it carries (fingers, a head, another arm; parallel-axis theorem, Featherstone
    2008 sec. 2.13), off-chain movable joints held at ``locked`` ({joint: value}, rad or m; default 0, a mimic
    joint following the joint it mimics) -- what pinocchio's ``buildReducedModel`` of the full tree gives
    with those joints locked. ``Robot.notes`` says the mass merged, in one line. ``chain_only`` leaves the
    off-chain links out, of the dynamics and of the export (:func:`dumps_urdf`).

    ``Robot.extra["urdf"]`` keeps, in SI: ``xml`` (the file's ``<robot>`` element, written back by
    :func:`dumps_urdf`), ``robot``, ``file``, ``base_link``, ``tip_link``, ``root_link`` and
    ``T_base_root`` (the tree's root in the base link), ``path_links`` (base to tip), ``body_links`` (the
    base link, then each moving joint's child link), ``joints`` (per moving joint ``name``, URDF ``type``,
    ``axis``, and when given ``effort``, ``velocity``, ``damping``, ``friction``), ``bodies`` (per body the
    path ``links`` and the off-chain links ``attached`` to it, each with ``T_world_link``, 4x4 at q = 0 in the
    base link's frame, and ``inertial``: ``mass``, ``origin``, ``inertia`` 3x3), ``locked`` (the off-chain
    joint values used) and ``chain_only``.
    ``Robot.inertials`` holds each moving body's inertial in the ED-H frames (None when the chain has no mass;
    an unphysical inertial leaves its body massless, with a warning).
    """
    ch = read_chain(path, base_link, tip_link, locked=locked)
    ch.extra["chain_only"] = bool(chain_only)
    m = ch.model()
    ex = _core.extract(_core.axes(m, np.zeros(m.nq)), "edh")
    names, lower, upper = list(ch.names), ch.lower.copy(), ch.upper.copy()
    inertials = None
    try:
        bodies = _body_inertials_in_world(ch, m, chain_only)
        if bodies is not None:
            inertials = inertials_for_table(m.with_inertias(*bodies, frame="world"), ex.table, names, lower, upper)
    except DenavitError as e:
        warnings.warn(
            f"{ch.path}: {e}; the robot is loaded without inertials (massless links)", DenavitWarning, stacklevel=2
        )
    notes = [f"{Path(ch.path).name}: {ch.chosen}"] if ch.chosen else []
    merged = [
        ld for b in ch.extra["bodies"][1:] for ld in b["attached"] if ld.get("inertial", {}).get("mass", 0.0) > 0.0
    ]
    if merged and not chain_only:
        kg = sum(ld["inertial"]["mass"] for ld in merged)
        shown = ", ".join(ld["name"] for ld in merged[:4]) + (", ..." if len(merged) > 4 else "")
        notes.append(
            f"{Path(ch.path).name}: merged {kg:.4g} kg of {len(merged)} off-chain link{'s' if len(merged) > 1 else ''}"
            f" ({shown}) into the chain's bodies, off-chain joints locked; chain_only (CLI: --chain-only) leaves"
            " them out"
        )
    return Robot(
        name=ch.name,
        table=ex.table,
        names=names,
        lower=lower,
        upper=upper,
        description=f"{ch.name} from URDF ({ch.base_link} -> {ch.tip_link}, {m.nq} joints), ED-H",
        source=f"URDF {Path(ch.path).name}",
        path=ch.path,
        extra={"urdf": ch.extra},
        inertials=inertials,
        notes=notes,
    )


def _body_inertials_in_world(
    ch: UrdfChain, model: _core.Model, chain_only: bool = False
) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
    """Per moving body (each joint's child with the links fixed to it and, unless ``chain_only``, the
    off-chain links it carries) its mass (kg), centre of mass and inertia about it (kg m^2), both in world at
    q = 0; None when no body of the chain has a mass. An unphysical inertial leaves its body massless with a
    warning naming the URDF link(s)."""
    n = len(ch.names)
    masses, coms, inertias = np.zeros(n), np.zeros((n, 3)), np.zeros((n, 3, 3))
    for i, body in enumerate(ch.extra["bodies"][1:]):
        lds = body["links"] + ([] if chain_only else body["attached"])
        links = [ld["name"] for ld in lds if "inertial" in ld]
        bad = [
            (ld["name"], m)
            for ld in lds
            if not (math.isfinite(m := ld.get("inertial", {}).get("mass", 0.0)) and m >= 0.0)
        ]
        if bad:  # as any unphysical inertial: that body alone is left massless (a negative mass had dropped them all)
            warnings.warn(
                f'{ch.path}: link {bad[0][0]!r}: <mass value="{bad[0][1]}"/>: expected a finite mass >= 0 kg (the body'
                f" moved by joint {ch.names[i]!r}); that body is loaded without mass, the others keep theirs",
                DenavitWarning,
                stacklevel=3,
            )
            continue
        parts = [
            (
                np.asarray(ld["T_world_link"], dtype=float) @ np.asarray(ld["inertial"]["origin"], dtype=float),
                float(ld["inertial"]["mass"]),
                np.asarray(ld["inertial"]["inertia"], dtype=float),
            )
            for ld in lds
            if "inertial" in ld
        ]
        comb = combine_inertials(parts)
        if comb is not None:
            T, masses[i], I = comb
            R = T[:3, :3]
            coms[i], inertias[i] = T[:3, 3], R @ I @ R.T
            one = np.zeros(n)
            one[i] = masses[i]
            try:  # the core's physical checks, one body at a time so that the message can name its links
                model.with_inertias(one, coms, inertias, frame="world")
            except DenavitError as e:
                # that body alone is left massless (pinocchio would keep it); the rest of the robot keeps its dynamics
                warnings.warn(
                    f"{ch.path}: the <inertial> of link{'s' if len(links) > 1 else ''} {', '.join(map(repr, links))}"
                    f" (the body moved by joint {ch.names[i]!r}) is not physical ({e}); that body is loaded without"
                    " mass, the others keep theirs",
                    DenavitWarning,
                    stacklevel=3,
                )
                masses[i], coms[i], inertias[i] = 0.0, 0.0, 0.0
        massless = [
            ld["name"]
            for ld in lds
            if "inertial" in ld and ld["inertial"]["mass"] == 0.0 and np.any(np.asarray(ld["inertial"]["inertia"]) != 0)
        ]
        if massless:
            warnings.warn(
                f"{ch.path}: link{'s' if len(massless) > 1 else ''} {', '.join(map(repr, massless))}"
                f' give{"" if len(massless) > 1 else "s"} an <inertia> but <mass value="0"/>: the inertia of a'
                " massless link is left out",
                DenavitWarning,
                stacklevel=3,
            )
    return (masses, coms, inertias) if masses.any() else None


def urdf_table(
    path: str | os.PathLike, convention: str, *, base_link: str | None = None, tip_link: str | None = None, **options
) -> _core.Extraction:
    """A URDF chain's parameters in ``convention`` (dh, mdh, edh, poe) through the core's line geometry.

    The :class:`~denavit.Extraction` carries the per-pair diagnostics (``relation``: parallel,
    intersecting, skew, coincident; ``angle``, ``distance``, Hayati ``beta`` where DH/MDH cannot represent a
    tilt) and the tool error the table carries (``max_position_error``, m; ``max_rotation_error``, rad).
    ``options`` are those of :func:`denavit.extract`.
    """
    m = urdf_model(path, base_link, tip_link)
    return _core.extract(_core.axes(m, np.zeros(m.nq)), convention, **options)
