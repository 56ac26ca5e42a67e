"""URDF in and out: the identified robot goes where users work.

Import (:func:`load_urdf`, :func:`urdf_model`) reads a URDF with `yourdfpy` (lxml underneath; the XML is
first parsed strictly, so a malformed file is an error, never a silent recovery), picks the serial chain
between a base and a tip link and builds the one :class:`~denavit.Model` of docs/conventions.md from it.
Export (:func:`dumps_urdf`, :func:`save_urdf`) writes any model, identified ones included, as URDF
(XML built with lxml, floats printed with ``repr`` so export -> import is exact to about 1e-15).

Mapping (docs/conventions.md, "The model")
------------------------------------------
A URDF joint with origin ``T`` (``xyz``, ``rpy``; ``R = Rz(y) Ry(p) Rx(r)``) and unit axis ``a`` moves its
child link by ``L_child(q) = L_parent · T · Rot(a, q)`` (``Trans(q a)`` for a prismatic joint). The model's
joints move about their own z axis, so joint frame *i* is the URDF link frame turned by ``R_a``, a fixed
rotation taking z to ``a`` (:func:`z_to`, deterministic: the smallest rotation, or a half turn about x first
when ``a`` points down)::

    T_world_joint[i] = L_i · R_a_i                      (q identical in the URDF and in the model)
    placement_i      = R_a_{i-1}^-1 · F_i · T_i · R_a_i (F_i: the fixed joints between the two, in order)
    T_world_base     = the fixed joints from the base link to the first moving joint's parent
    T_last_flange    = R_a_n^-1 · (trailing fixed joints) = the tip link (the flange) in the last joint frame

``world`` is the base link's frame. Axes are normalised (as urdfdom does); offsets are zero.

:func:`urdf_model` returns that exact model. :func:`load_urdf` returns a :class:`~denavit.Robot`, whose
table is the ED-H table (Guo et al. eq. 1-2) extracted from the model's axes with the frame origins at
the URDF joint origins: exact for every geometry (same axes, same tool pose; the ED-H x axes follow the
extraction rules instead of the URDF's arbitrary link x axes). Continuous joints get infinite limits.

Export writes the model's joint frames as URDF links (joint ``axis`` = z, ``origin`` = the placement with
the zero offset folded in, so the URDF's joint values equal the model's ``q``), ``T_world_base`` as a fixed
joint from a ``world`` root link when it is not the identity, and ``T_last_tool`` (flange and tool) as a fixed
joint to a tool link. For ED-H and URDF-derived models the link frames lie on the body (their origins are on the
joint axes, at the URDF joint origins); DH frames can lie off the body, which is why ED-H is the default
route for identified robots.

What a URDF carries beyond kinematics (visuals, collisions, inertials, materials, effort and velocity
limits, damping and friction) is kept in ``Robot.extra["urdf"]`` (plain dicts and lists, SI, see
:func:`load_urdf`) and written back on export when the model has the same number of joints. Links off
the chosen chain are not carried.

Meshes and inertials of an identified robot
-------------------------------------------
The kept link poses are in the nominal URDF's base link frame; an identified model is in the measurement
frame (a laser tracker's, anywhere), and its joint frames, even where the axes are the nominal's, are a
convention's: ED-H puts the UR shoulder frame 0.36 m along the axis from the URDF joint origin, DH turns
frames about their axes. So neither ``T_world_link`` as it stands (2.3 m off for a tracker 2 m away) nor
its pose relative to the nominal URDF joint frame ``F_n`` (``inv(F_n) · T_world_link``) can be written on
the model's frame directly. Export (:func:`_carry`):

1. registers the nominal joint axis lines at ``q = 0`` onto the model's (``X``, :func:`_register_lines`;
   lines only, so neither the frames' origins along their axes nor their turn about them matter);
2. anchors each body on the axis it turns about (the base body: the first axis, which it carries):
   ``A = X · F_n`` moved by the smallest rotation and shift that put its z axis on the model's axis line;
3. writes each element at ``inv(E) · A · inv(F_n) · T_world_link`` in its exported link, ``E`` the link's
   frame at ``q = 0``: the model's joint frame, or for the base body the model's base (the exported base
   link is where the model's base is, e.g. the tracker frame; the base meshes sit on the first axis).

The element then rides on the model's joint frame (at ``q`` it is moved by ``E(q) · inv(E)``), with the
same joint zero (identify works with the robot's readings). For the
nominal's own model, any convention, in any frame, the meshes land exactly where the nominal URDF has
them (moved with the base); for a noise-free identification to ~1e-14, for a noisy one each body turns on
its identified axis and the registration's error places it along and about it. Measured on the UR-style arm
(tests): the identified ED-H frames' turn about their own axes equals the nominal's to 1e-15 (offsets
included), but their origins slide along the axes, which the registration absorbs.

Dynamics: :func:`load_urdf` also merges each moving body's inertials (its link and the links fixed to it,
parallel-axis theorem) into ``Robot.inertials``, so the robot's model has the URDF's dynamics; an
unphysical inertial (negative mass, inertia not positive semi-definite or breaking the triangle
inequality) gives a :class:`~denavit.errors.DenavitWarning` naming the link, and massless links. A model
exported without URDF information writes its own link inertias (link *i* = joint frame *i*).
"""

from __future__ import annotations

import math
import os
import re
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from .. import _core
from ..errors import DenavitError, DenavitWarning
from ..geometry import inverse, matrix_rpy, pose, rotation_between, rotvec_matrix, skew
from ..robot import Robot, inertials_for_table
from .delimited import NON_FINITE, NUMBER
from .output import write_text
from .text import decode, read_bytes

if TYPE_CHECKING:
    import yourdfpy

SUPPORTED_JOINTS = ("revolute", "continuous", "prismatic", "fixed")
UNSUPPORTED_JOINTS = ("floating", "planar")



def z_to(a) -> np.ndarray:
    """The rotation ``R_a`` (3, 3) that takes the z axis to the unit vector ``a``, deterministically.

    The smallest rotation (Rodrigues, about ``z × a``); when ``a`` points into the lower half-space a half
    turn about x comes first (``R_a = Rx(pi) · R_min``), which keeps the formula well conditioned.
    ``z_to([0, 0, 1])`` is exactly the identity.
    """
    a = np.asarray(a, dtype=float)
    a = a / np.linalg.norm(a)
    flip = a[2] < 0.0
    if flip:  # Rx(pi)^T a, now in the upper half-space
        a = np.array([a[0], -a[1], -a[2]])
    R = rotation_between(np.array([0.0, 0.0, 1.0]), a)
    if flip:
        R = np.diag([1.0, -1.0, -1.0]) @ R
    return R


def _num(v: float) -> str:
    """A float as URDF text: repr (the shortest form that reads back to the same double, <= 17
    significant digits); rounding residue below 1e-15 (e.g. cos(pi/2) = 6e-17) is written as 0."""
    v = float(v)
    return "0" if abs(v) < 1e-15 else repr(v)


def _nums(vs) -> str:
    return " ".join(_num(v) for v in vs)


def _mat(T) -> list[list[float]]:
    return [[float(x) for x in row] for row in np.asarray(T, dtype=float)]


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
            self.placements, self.kinds, lower=self.lower, upper=self.upper, names=self.names,
            T_world_base=self.T_world_base, T_last_flange=self.T_last_flange, name=self.name,
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
        raise DenavitError(f"{what}: {el.tag} {attr}={text[:60]!r}: expected {n} number{'s' if n > 1 else ''} (ASCII decimal)")
    if len(parts) != n or (finite and not all(math.isfinite(float(t)) for t in parts)):
        raise DenavitError(f"{what}: {el.tag} {attr}={text[:60]!r}: expected {n} finite number{'s' if n > 1 else ''}, got {len(parts)} value(s)")


#: The numeric attributes of URDF elements (element, attributes, numbers each, finite), checked wherever they appear.
_NUMBERS = (
    ("origin", ("xyz", "rpy"), 3, True), ("axis", ("xyz",), 3, True), ("mass", ("value",), 1, True),
    ("inertia", ("ixx", "ixy", "ixz", "iyy", "iyz", "izz"), 1, False), ("limit", ("lower", "upper"), 1, False),
    ("limit", ("effort", "velocity"), 1, True), ("dynamics", ("damping", "friction"), 1, True),
    ("safety_controller", ("soft_lower_limit", "soft_upper_limit", "k_position", "k_velocity"), 1, True),
    ("mimic", ("multiplier", "offset"), 1, True), ("calibration", ("rising", "falling"), 1, True),
    ("box", ("size",), 3, True), ("cylinder", ("radius", "length"), 1, True), ("sphere", ("radius",), 1, True),
    ("mesh", ("scale",), 3, True), ("color", ("rgba",), 4, True),
)


def _precheck(path: Path, root) -> _Where:
    """Checks yourdfpy leaves to chance (it raises bare KeyError/AttributeError or ignores them), each
    naming the element and its line; the XML itself is already parsed by lxml."""
    if root.tag != "robot":
        raise DenavitError(f"{path}: expected a <robot> root element, got <{root.tag}> (line {root.sourceline})")
    if not root.get("name"):
        raise DenavitError(f"{path}: <robot> (line {root.sourceline}) has no name attribute")
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
        if el.tag == "joint":
            for tag in ("parent", "child"):
                sub = el.find(tag)
                if sub is None or not sub.get("link"):
                    raise DenavitError(f"{w}: expected a <{tag} link=\"...\"/> element, got none")
            ax = el.find("axis")
            if ax is not None and ax.get("xyz") is None:  # urdfdom would take the default 1 0 0 for a mangled <axis>
                raise DenavitError(f"{w}: <axis> (line {ax.sourceline}) without xyz: expected e.g. <axis xyz=\"0 0 1\"/>")
    return where


def _read(path: str | os.PathLike) -> tuple[yourdfpy.URDF, _Where]:
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
        line, col = (e.position if e.position else (e.lineno, 0))
        raise DenavitError(f"{path}: malformed XML at line {line}, column {col}: {' '.join(e.msg.split())}") from None
    fatal = [e for e in parser.error_log if e.level >= etree.ErrorLevels.ERROR and e.domain != etree.ErrorDomains.NAMESPACE]
    if fatal or tree.getroot() is None:
        e = fatal[0] if fatal else None
        raise DenavitError(f"{path}: malformed XML at line {e.line if e else 1}, column {e.column if e else 0}: {' '.join(e.message.split()) if e else 'no root element'}")
    where = _precheck(path, tree.getroot())
    import logging  # noqa: PLC0415

    log = logging.getLogger("yourdfpy")
    level = log.level
    log.setLevel(logging.CRITICAL)  # its "Using different parsing approach" error log, for XML we have already checked
    try:
        urdf = yourdfpy.URDF.load(str(path), build_scene_graph=False, build_collision_scene_graph=False, load_meshes=False, load_collision_meshes=False)
    except Exception as e:  # noqa: BLE001 (yourdfpy raises bare KeyError/ValueError/IndexError)
        raise DenavitError(f"{path}: not a readable URDF ({type(e).__name__}: {e})") from None
    finally:
        log.setLevel(level)
    return urdf, where


def _geometry_dict(g) -> dict:
    if g is None:
        return {}
    if g.mesh is not None:
        d = {"filename": str(g.mesh.filename)}
        if g.mesh.scale is not None:
            s = np.broadcast_to(np.asarray(g.mesh.scale, dtype=float), (3,))
            d["scale"] = [float(v) for v in s]
        return {"mesh": d}
    if g.box is not None:
        return {"box": {"size": [float(v) for v in g.box.size]}}
    if g.cylinder is not None:
        return {"cylinder": {"radius": float(g.cylinder.radius), "length": float(g.cylinder.length)}}
    if g.sphere is not None:
        return {"sphere": {"radius": float(g.sphere.radius)}}
    return {}


def _material_dict(m) -> dict:
    d: dict = {}
    if m is None:
        return d
    if m.name:
        d["name"] = str(m.name)
    if m.color is not None:
        d["rgba"] = [float(v) for v in m.color.rgba]
    if m.texture is not None and m.texture.filename:
        d["texture"] = str(m.texture.filename)
    return d


def _link_dict(link, T_world_link: np.ndarray, where=None) -> dict:
    d: dict = {"name": link.name, "T_world_link": _mat(T_world_link)}
    if link.inertial is not None and link.inertial.mass is not None:
        ine = link.inertial
        values = [float(ine.mass), *np.ravel(np.zeros(3) if ine.inertia is None else ine.inertia), *np.ravel(np.eye(4) if ine.origin is None else ine.origin)]
        if not all(math.isfinite(v) for v in values):
            at = where("link", link.name) if where is not None else f"link {link.name!r}"
            raise DenavitError(f"{at}: <inertial> must hold finite numbers (mass, origin, inertia), got a non-finite one")
        d["inertial"] = {
            "mass": float(ine.mass),
            "origin": _mat(np.eye(4) if ine.origin is None else ine.origin),
            "inertia": _mat(np.zeros((3, 3)) if ine.inertia is None else ine.inertia),
        }
    for key, items in (("visuals", link.visuals), ("collisions", link.collisions)):
        out = []
        for v in items:
            e: dict = {"origin": _mat(np.eye(4) if v.origin is None else v.origin), "geometry": _geometry_dict(v.geometry)}
            if v.name:
                e["name"] = str(v.name)
            if key == "visuals":
                mat = _material_dict(v.material)
                if mat:
                    e["material"] = mat
            out.append(e)
        if out:
            d[key] = out
    return d


def _select_chain(urdf: yourdfpy.URDF, where: _Where, base_link: str | None, tip_link: str | None) -> tuple[list, str, str]:
    """The joints from ``base_link`` to ``tip_link`` (in order), with the tree checks."""
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
                raise DenavitError(f"{where('joint', j.name)}: {role} link {ln!r} is not defined (links: {', '.join(sorted(links))})")
        if j.child in parent_of:
            other = parent_of[j.child].name
            raise DenavitError(f"{where('link', j.child)} is the child of joint {other!r} and of joint {j.name!r}: kinematic loops are not supported")
        parent_of[j.child] = j
        children[j.parent].append(j)
    roots = [n for n in links if n not in parent_of]
    if not roots:
        raise DenavitError(f"{path}: no root link (every link is some joint's child): the joints form a loop, which is not supported")

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
            raise DenavitError(f"{where('link', ln)} is reached twice from {base_link!r}: kinematic loops are not supported")
        seen.add(ln)
        below.append(ln)
        stack.extend(j.child for j in children[ln])
    chosen = ""
    if tip_link is None:
        tip_link, chosen = _default_tip(path, base_link, below, children, parent_of)
    elif tip_link not in links:
        raise DenavitError(f"{path}: tip link {tip_link!r} is not defined (links: {', '.join(sorted(links))})")
    elif tip_link not in seen:
        raise DenavitError(f"{path}: tip link {tip_link!r} is not below base link {base_link!r} (links below it: {names(sorted(below))})")
    chain = []
    ln = tip_link
    while ln != base_link:
        j = parent_of[ln]
        chain.append(j)
        ln = j.parent
    chain.reverse()
    return chain, base_link, tip_link, chosen


#: Joint types that move (a chain's degrees of freedom).
MOVING = ("revolute", "continuous", "prismatic")


def _default_tip(path, base_link: str, below: list, children: dict, parent_of: dict) -> tuple[str, str]:
    """The tip link when none is given, and why (empty when there is a single leaf): REP-199's ``tool0`` when
    the tree has one (ROS-Industrial descriptions also hang a ``base`` frame, sensors and flanges off the
    arm), else the leaf reached through the most moving joints (a camera or a ``base`` frame hangs off
    through fewer); a tie is an error listing the candidates."""
    leaves = [ln for ln in below if not children[ln]]
    if len(leaves) == 1:
        return leaves[0], ""
    if "tool0" in below:
        return "tool0", f"tip link 'tool0' (REP-199) of {len(leaves)} leaves; choose another with tip_link (CLI: --tip-link)"

    def moving(ln):
        count = 0
        while ln != base_link:
            j = parent_of[ln]
            count += (j.type or "").strip() in MOVING
            ln = j.parent
        return count

    counts = {ln: moving(ln) for ln in leaves}
    best = max(counts.values())
    top = [ln for ln in leaves if counts[ln] == best]
    if len(top) == 1:
        return top[0], f"tip link {top[0]!r}, the leaf reached through the most moving joints ({best}) of {len(leaves)} leaves; choose another with tip_link (CLI: --tip-link)"
    listing = ", ".join(f"{ln!r} ({counts[ln]} moving joints)" for ln in sorted(leaves, key=lambda x: (-counts[x], x)))
    raise DenavitError(f"{path}: the tree below {base_link!r} has {len(leaves)} tip links ({listing}): "
                       "a serial chain needs one; choose one with tip_link (CLI: --tip-link)")


def read_chain(path: str | os.PathLike, base_link: str | None = None, tip_link: str | None = None) -> UrdfChain:
    """Read the serial chain ``base_link`` -> ``tip_link`` of a URDF (defaults: the root link and the single
    leaf below it). Every error names the file and the element (joint or link, with its line)."""
    urdf, where = _read(path)
    path = where.path
    chain, base_link, tip_link, chosen = _select_chain(urdf, where, base_link, tip_link)
    links = {l.name: l for l in urdf.robot.links}
    names, kinds, types, placements, lower, upper, axes_local = [], [], [], [], [], [], []
    joint_info, bodies, body_links = [], [[]], [base_link]
    acc = np.eye(4)  # the current link in the last joint frame (before the first joint: in world)
    T_world_link = np.eye(4)  # the current link at q = 0 in world
    T_world_base = None
    bodies[0].append(_link_dict(links[base_link], T_world_link, where))
    for j in chain:
        w = where("joint", j.name)
        jtype = (j.type or "").strip()
        if jtype in UNSUPPORTED_JOINTS:
            raise DenavitError(f"{w} is a {jtype} joint, which is not supported: expected revolute, continuous, prismatic or fixed "
                               "(to import the arm alone, choose a base_link below it)")
        if jtype not in SUPPORTED_JOINTS:
            raise DenavitError(f"{w}: unknown joint type {j.type!r}: expected one of {', '.join(SUPPORTED_JOINTS)}")
        if j.mimic is not None and jtype != "fixed":  # urdfdom ignores a fixed joint's <mimic>, and so do we
            raise DenavitError(f"{w} mimics joint {j.mimic.joint!r}: mimic joints (coupled joint values) are not supported")
        O = np.eye(4) if j.origin is None else np.asarray(j.origin, dtype=float)
        T_world_link = T_world_link @ O
        if jtype == "fixed":
            acc = acc @ O
            bodies[-1].append(_link_dict(links[j.child], T_world_link, where))
            continue
        a = np.asarray(j.axis, dtype=float)
        na = float(np.linalg.norm(a))
        if not (na > 1e-12 and np.all(np.isfinite(a))):
            raise DenavitError(f"{w}: axis xyz=\"{_nums(a)}\" has zero length: expected a nonzero direction (e.g. \"0 0 1\")")
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
                raise DenavitError(f"{w}: a {jtype} joint needs a <limit lower=... upper=... effort=... velocity=.../> (use type=\"continuous\" for an unlimited revolute joint)")
            if j.limit.lower is None or j.limit.upper is None:
                # urdfdom would default a missing bound to 0, a joint that cannot move: say so instead
                raise DenavitError(f"{w}: <limit> lacks {'lower' if j.limit.lower is None else 'upper'}: a {jtype} joint needs both bounds (urdfdom reads a missing one as 0)")
            lo, hi = float(j.limit.lower), float(j.limit.upper)
            if not (math.isfinite(lo) and math.isfinite(hi)):
                raise DenavitError(f"{w}: limit lower={lo} upper={hi} must be finite (use type=\"continuous\" for an unlimited revolute joint)")
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
        bodies.append([_link_dict(links[j.child], T_world_link, where)])
        body_links.append(j.child)
    if not names:
        raise DenavitError(f"{path}: no revolute, continuous or prismatic joint between base link {base_link!r} and tip link {tip_link!r}")
    extra = {
        "note": "kept from the URDF for export: SI units (m, rad, kg); T_world_link = each link at q = 0 in the base link's frame",
        "robot": urdf.robot.name,
        "file": str(path),
        "base_link": base_link,
        "tip_link": tip_link,
        "body_links": body_links,
        "joints": joint_info,
        "bodies": [{"links": b} for b in bodies],
    }
    mats = [_material_dict(m) for m in urdf.robot.materials]
    mats = [m for m in mats if m.get("name")]
    if mats:
        extra["materials"] = mats
    return UrdfChain(
        name=urdf.robot.name, path=str(path), base_link=base_link, tip_link=tip_link, names=names, kinds=kinds, urdf_types=types,
        placements=np.array(placements), lower=np.array(lower), upper=np.array(upper), T_world_base=T_world_base, T_last_flange=acc,
        axes_local=np.array(axes_local), extra=extra, chosen=chosen,
    )


def urdf_model(path: str | os.PathLike, base_link: str | None = None, tip_link: str | None = None) -> _core.Model:
    """The exact model of a URDF's serial chain ``base_link`` -> ``tip_link`` (docs/conventions.md).

    Joint frame *i* is URDF link frame *i* turned by ``R_a`` (:func:`z_to`), so every URDF link frame is
    ``T_world_joint[i] @ R_a^-1`` and the tool is the tip link; ``world`` is the base link's frame.
    Lengths in m, angles in rad; continuous joints have infinite limits.
    """
    return read_chain(path, base_link, tip_link).model()


def load_urdf(path: str | os.PathLike, base_link: str | None = None, tip_link: str | None = None) -> Robot:
    """Read a URDF's serial chain into a :class:`~denavit.Robot` (what ``denavit.load_robot("x.urdf")`` returns).

    The table is ED-H (Guo et al. eq. 1-2), extracted through the core's line geometry from the exact
    model's joint axes at ``q = 0`` with the frame origins at the URDF joint origins: exact for every
    geometry (same axes, tool pose to rounding error). ``Robot.extra["urdf"]`` keeps, in SI:

    * ``robot``, ``file``, ``base_link``, ``tip_link``, ``body_links`` (the base link, then each moving
      joint's child link);
    * ``joints``: per moving joint ``name``, URDF ``type``, ``axis`` (unit, in the child link) and, when
      given, ``effort``, ``velocity``, ``damping``, ``friction``;
    * ``bodies``: per body (the base, then each moving joint's child with the links fixed to it) the
      links with ``T_world_link`` (4x4, at q = 0 in the base link's frame), ``inertial`` (``mass``,
      ``origin``, ``inertia`` 3x3), ``visuals`` and ``collisions`` (``origin``, ``geometry``: mesh
      filename/scale, box, cylinder or sphere, ``material``);
    * ``materials``: the robot-level named materials.

    :func:`dumps_urdf` writes them back. ``Robot.inertials`` holds each moving body's merged inertial in
    the ED-H frames (None when the chain has no mass, or, with a warning, an unphysical inertial).
    """
    ch = read_chain(path, base_link, tip_link)
    m = ch.model()
    ex = _core.extract(_core.axes(m, np.zeros(m.nq)), "edh")
    names, lower, upper = list(ch.names), ch.lower.copy(), ch.upper.copy()
    inertials = None
    try:
        bodies = _body_inertials_in_world(ch, m)
        if bodies is not None:
            inertials = inertials_for_table(m.with_inertias(*bodies, frame="world"), ex.table, names, lower, upper)
    except DenavitError as e:
        warnings.warn(f"{ch.path}: {e}; the robot is loaded without inertials (massless links)", DenavitWarning, stacklevel=2)
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
        notes=[f"{Path(ch.path).name}: {ch.chosen}"] if ch.chosen else [],
    )


def _body_inertials_in_world(ch: UrdfChain, model: _core.Model) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
    """Per moving body (each joint's child with the links fixed to it) its mass (kg), centre of mass and
    inertia about it (kg m^2), both in world at q = 0; None when no body of the chain has a mass. An
    unphysical inertial is an error naming the URDF link(s) of its body."""
    n = len(ch.names)
    masses, coms, inertias = np.zeros(n), np.zeros((n, 3)), np.zeros((n, 3, 3))
    for i, body in enumerate(ch.extra["bodies"][1:]):
        links = [ld["name"] for ld in body["links"] if "inertial" in ld]
        for ld in body["links"]:
            mass = ld.get("inertial", {}).get("mass", 0.0)
            if not (math.isfinite(mass) and mass >= 0.0):
                raise DenavitError(f"link {ld['name']!r}: <mass value=\"{mass}\"/>: expected a finite mass >= 0 kg")
        parts = [
            (np.asarray(ld["T_world_link"], dtype=float) @ np.asarray(ld["inertial"]["origin"], dtype=float),
             float(ld["inertial"]["mass"]), np.asarray(ld["inertial"]["inertia"], dtype=float))
            for ld in body["links"] if "inertial" in ld
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
                warnings.warn(f"{ch.path}: the <inertial> of link{'s' if len(links) > 1 else ''} {', '.join(map(repr, links))} (the body moved by joint "
                              f"{ch.names[i]!r}) is not physical ({e}); that body is loaded without mass, the others keep theirs", DenavitWarning, stacklevel=3)
                masses[i], coms[i], inertias[i] = 0.0, 0.0, 0.0
        massless = [ld["name"] for ld in body["links"] if "inertial" in ld and ld["inertial"]["mass"] == 0.0 and np.any(np.asarray(ld["inertial"]["inertia"]) != 0)]
        if massless:
            warnings.warn(f"{ch.path}: link{'s' if len(massless) > 1 else ''} {', '.join(map(repr, massless))} give{'' if len(massless) > 1 else 's'} an <inertia> "
                          "but <mass value=\"0\"/>: the inertia of a massless link is left out", DenavitWarning, stacklevel=3)
    return (masses, coms, inertias) if masses.any() else None


def urdf_table(path: str | os.PathLike, convention: str, *, base_link: str | None = None, tip_link: str | None = None, **options) -> _core.Extraction:
    """A URDF chain's parameters in ``convention`` (dh, mdh, edh, poe) through the core's line geometry.

    The :class:`~denavit.Extraction` carries the per-pair diagnostics (``relation``: parallel,
    intersecting, skew, coincident; ``angle``, ``distance``, Hayati ``beta`` where DH/MDH cannot represent a
    tilt) and the tool error the table carries (``max_position_error``, m; ``max_rotation_error``, rad).
    ``options`` are those of :func:`denavit.extract`.
    """
    m = urdf_model(path, base_link, tip_link)
    return _core.extract(_core.axes(m, np.zeros(m.nq)), convention, **options)


# --------------------------------------------------------------------------------------------------
# writing


def _unique(name: str, taken: set) -> str:
    out, k = name, 1
    while out in taken:
        k += 1
        out = f"{name}_{k}"
    taken.add(out)
    return out


def _origin(parent, T, tag: str = "origin") -> None:
    from lxml import etree  # noqa: PLC0415

    r, p, y = matrix_rpy(np.asarray(T)[:3, :3])
    etree.SubElement(parent, tag, xyz=_nums(np.asarray(T)[:3, 3]), rpy=_nums((r, p, y)))


def _geometry(parent, g: dict) -> None:
    from lxml import etree  # noqa: PLC0415

    ge = etree.SubElement(parent, "geometry")
    if "mesh" in g:
        m = etree.SubElement(ge, "mesh", filename=g["mesh"]["filename"])
        if "scale" in g["mesh"]:
            m.set("scale", _nums(g["mesh"]["scale"]))
    elif "box" in g:
        etree.SubElement(ge, "box", size=_nums(g["box"]["size"]))
    elif "cylinder" in g:
        etree.SubElement(ge, "cylinder", radius=_num(g["cylinder"]["radius"]), length=_num(g["cylinder"]["length"]))
    elif "sphere" in g:
        etree.SubElement(ge, "sphere", radius=_num(g["sphere"]["radius"]))


def _material(parent, m: dict) -> None:
    from lxml import etree  # noqa: PLC0415

    me = etree.SubElement(parent, "material", name=m.get("name", ""))
    if "rgba" in m:
        etree.SubElement(me, "color", rgba=_nums(m["rgba"]))
    if "texture" in m:
        etree.SubElement(me, "texture", filename=m["texture"])


def _inertial(parent, T, mass: float, I) -> None:
    from lxml import etree  # noqa: PLC0415

    ie = etree.SubElement(parent, "inertial")
    _origin(ie, T)
    etree.SubElement(ie, "mass", value=_num(mass))
    etree.SubElement(ie, "inertia", ixx=_num(I[0, 0]), ixy=_num(I[0, 1]), ixz=_num(I[0, 2]), iyy=_num(I[1, 1]), iyz=_num(I[1, 2]), izz=_num(I[2, 2]))


def combine_inertials(parts: list[tuple[np.ndarray, float, np.ndarray]]) -> tuple[np.ndarray, float, np.ndarray] | None:
    """One rigid body's inertial from several: ``parts`` = (pose of each inertial frame in the body frame
    (4, 4), mass kg, inertia (3, 3) kg m^2 about the centre of mass in that frame). Returns the pose (at the
    common centre of mass, body orientation), the total mass and the inertia there (parallel-axis theorem,
    Featherstone 2008 sec. 2.13); a single part is returned unchanged; None without mass."""
    parts = [p for p in parts if p[1] > 0.0]
    if not parts:
        return None
    if len(parts) == 1:
        return parts[0]
    M = sum(m for _, m, _ in parts)
    c = sum(m * T[:3, 3] for T, m, _ in parts) / M
    I = np.zeros((3, 3))
    for T, m, Ic in parts:
        R, d = T[:3, :3], T[:3, 3] - c
        I += R @ Ic @ R.T + m * (d @ d * np.eye(3) - np.outer(d, d))
    return pose(None, c), M, I


def _matches(info: dict | None, model: _core.Model) -> bool:
    try:
        return info is not None and len(info["bodies"]) == model.nq + 1 and len(info["body_links"]) == model.nq + 1
    except (KeyError, TypeError):
        return False


def _register_lines(Fn: np.ndarray, Fi: np.ndarray, kinds) -> np.ndarray:
    """The rigid motion ``X`` (4, 4) that best puts the nominal joint axes on the identified ones.

    ``Fn``, ``Fi`` (n, 4, 4): joint frames at q = 0 (z = the axis), of the nominal and of the identified
    model in their own world frames. Only the axis lines are compared (directions, and for revolute joints
    the distance of the line from the identified one), never the frames' origins along the axes nor their
    turn about them: those are convention choices (an ED-H frame may lie 0.36 m along the UR shoulder axis
    from the URDF joint origin). Gauss-Newton from the Kabsch rotation of the directions; dofs the lines do
    not fix (e.g. a slide along parallel axes) keep their minimal-norm value."""
    dn, pn, d, p = Fn[:, :3, 2], Fn[:, :3, 3], Fi[:, :3, 2], Fi[:, :3, 3]
    U_, _, Vt = np.linalg.svd(dn.T @ d)
    R = Vt.T @ np.diag([1.0, 1.0, np.linalg.det(Vt.T @ U_.T)]) @ U_.T
    t = np.zeros(3)
    for _ in range(30):
        rows, res = [], []
        for i, kind in enumerate(kinds):
            e, y = R @ dn[i], R @ pn[i] + t
            rows.append(np.hstack([-skew(e), np.zeros((3, 3))]))
            res.append(e - d[i])
            if kind == "revolute":
                P = np.eye(3) - np.outer(d[i], d[i])
                rows.append(np.hstack([-P @ skew(y), P]))
                res.append(P @ (y - p[i]))
        step = np.linalg.lstsq(np.vstack(rows), -np.concatenate(res), rcond=1e-9)[0]
        w, v = step[:3], step[3:]
        ang = float(np.linalg.norm(w))
        dR = rotvec_matrix(w)
        R, t = dR @ R, dR @ t + v
        if ang < 1e-15 and np.linalg.norm(v) < 1e-15:
            break
    return pose(R, t)


def _carry(info: dict, robot: Robot, model: _core.Model, frames: np.ndarray) -> list[np.ndarray]:
    """Per body *b*, the matrix taking a kept link pose ``T_world_link`` (q = 0, the nominal URDF's base
    link frame) to its pose in exported link *b* (the model's joint frame *b* - 1; the model's base for
    the base body). Module docstring, "Meshes and inertials of an identified robot"."""
    n = model.nq
    joints = info["joints"]
    if all("axis" in j for j in joints):  # the nominal URDF's joint frames: child link @ R_a
        Fn = np.array([np.asarray(info["bodies"][i + 1]["links"][0]["T_world_link"], dtype=float) @ pose(z_to(j["axis"]))
                       for i, j in enumerate(joints)])
    else:  # kept by an older version without the axes: the robot's own model is the nominal
        Fn = np.asarray(_core.joint_frames(robot.model(), np.zeros(n)))
    X = _register_lines(Fn, frames, list(model.kinds))
    out = []
    for b in range(n + 1):
        j = max(b - 1, 0)  # the axis the body turns about (the base body: the stator of joint 1)
        G, F = X @ Fn[j], frames[j]
        A = pose(rotation_between(G[:3, 2], F[:3, 2]) @ G[:3, :3], G[:3, 3])
        if model.kinds[j] == "revolute":  # the body's bearing on the identified axis line
            A[:3, 3] = F[:3, 3] + F[:3, 2] * (F[:3, 2] @ (G[:3, 3] - F[:3, 3]))
        E = np.asarray(model.T_world_base) if b == 0 else frames[b - 1]
        out.append(inverse(E) @ A @ inverse(Fn[j]))
    return out


def dumps_urdf(model: _core.Model, robot: Robot | None = None) -> str:
    """The URDF text of ``model`` (any convention's model, identified ones included).

    Link *i* is the model's joint frame *i*: ``<axis xyz="0 0 1"/>`` and ``origin`` = ``placement_i ·
    Rz(offset_i)`` (``Tz`` for prismatic joints), so URDF joint values are the model's ``q`` and
    ``urdf_model`` of the text reproduces every joint frame and the tool. Revolute joints with infinite
    limits are written ``continuous``. ``robot`` (optional) gives the robot name and, when it was read
    from a URDF (``robot.extra["urdf"]``) and has as many joints as ``model``, the link names, meshes,
    inertials, effort/velocity limits and dynamics, each body's elements riding on the model's joint frame
    (module docstring, "Meshes and inertials of an identified robot": ``model`` may be in another frame than
    the URDF's base link, e.g. identified in a tracker's frame).
    Lengths in m, angles in rad, masses in kg.
    """
    from lxml import etree  # noqa: PLC0415

    n = model.nq
    info = robot.extra.get("urdf") if robot is not None and isinstance(robot.extra, dict) else None
    if not _matches(info, model):
        info = None
    name = robot.name if robot is not None else model.name
    P = np.asarray(model.placements)
    offsets, kinds = list(model.offsets), list(model.kinds)
    lower, upper, names = list(model.lower), list(model.upper), list(model.names)
    B, Tt = np.asarray(model.T_world_base), np.asarray(model.T_last_tool)
    frames = np.asarray(_core.joint_frames(model, np.zeros(n)))

    root = etree.Element("robot", name=name)
    what = f"{robot.description} ({robot.source})" if robot is not None and robot.source else (robot.description if robot is not None else model.name)
    root.append(etree.Comment(
        f" Written by denavit {_core.__version__} from {what.replace('--', '- -')}. "
        "Link i is the model's joint frame i (docs/conventions.md): every joint moves about the z axis of its link; "
        "joint values equal the model's q; metres, radians, kilograms. "))

    link_names: set = set()
    joint_names: set = set()
    names = [_unique(nm, joint_names) for nm in names]
    body_names = [_unique(info["body_links"][b] if info else ("base_link" if b == 0 else f"link_{b}"), link_names) for b in range(n + 1)]
    identity_base = np.allclose(B, np.eye(4), rtol=0.0, atol=1e-15)
    identity_tool = np.allclose(Tt, np.eye(4), rtol=0.0, atol=1e-15)
    link_el = {}

    def add_link(lname: str):
        el = etree.SubElement(root, "link", name=lname)
        link_el[lname] = el
        return el

    if not identity_base:
        base_root = info["base_link"] if info and info["base_link"] != info["body_links"][0] else "world"
        world = _unique(base_root, link_names)
        add_link(world)
    for b in range(n + 1):
        add_link(body_names[b])
    if not identity_tool:
        tip = info["tip_link"] if info and info["tip_link"] != info["body_links"][n] else "tool0"
        tool = _unique(tip, link_names)
        add_link(tool)

    # meshes and inertials, per body, riding on the model's joint frames (module docstring)
    if info is not None:
        carry = _carry(info, robot, model, frames)
        for b in range(n + 1):
            el = link_el[body_names[b]]
            parts, vis, col = [], [], []
            for ld in info["bodies"][b]["links"]:
                C = carry[b] @ np.asarray(ld["T_world_link"], dtype=float)
                if "inertial" in ld:
                    ine = ld["inertial"]
                    parts.append((C @ np.asarray(ine["origin"], dtype=float), float(ine["mass"]), np.asarray(ine["inertia"], dtype=float)))
                vis += [(C, v) for v in ld.get("visuals", [])]
                col += [(C, v) for v in ld.get("collisions", [])]
            comb = combine_inertials(parts)
            if comb is not None:
                _inertial(el, *comb)
            for tag, items in (("visual", vis), ("collision", col)):
                for C, v in items:
                    ve = etree.SubElement(el, tag, **({"name": v["name"]} if v.get("name") else {}))
                    _origin(ve, C @ np.asarray(v["origin"], dtype=float))
                    _geometry(ve, v.get("geometry", {}))
                    if tag == "visual" and v.get("material"):
                        _material(ve, v["material"])
        for m in info.get("materials", []):
            _material(root, m)
    else:  # the model's own link inertias (link i = joint frame i, about the centre of mass)
        ins = model.inertias
        for i in range(n):
            if ins["masses"][i] > 0.0:
                _inertial(link_el[body_names[i + 1]], pose(None, ins["coms"][i]), float(ins["masses"][i]), ins["inertias"][i])

    def add_fixed(jname: str, parent: str, child: str, T) -> None:
        je = etree.SubElement(root, "joint", name=_unique(jname, joint_names), type="fixed")
        etree.SubElement(je, "parent", link=parent)
        etree.SubElement(je, "child", link=child)
        _origin(je, T)

    if not identity_base:
        add_fixed(f"{world}_to_{body_names[0]}", world, body_names[0], B)
    jinfo = {j["name"]: j for j in info["joints"]} if info else {}
    for i in range(n):
        prismatic = kinds[i] == "prismatic"
        M = np.eye(4)
        if prismatic:
            M[2, 3] = offsets[i]
        else:
            c, s = math.cos(offsets[i]), math.sin(offsets[i])
            M[:2, :2] = [[c, -s], [s, c]]
        lo, hi = lower[i], upper[i]
        jtype = "prismatic" if prismatic else ("continuous" if math.isinf(lo) and math.isinf(hi) else "revolute")
        je = etree.SubElement(root, "joint", name=names[i], type=jtype)
        etree.SubElement(je, "parent", link=body_names[i])
        etree.SubElement(je, "child", link=body_names[i + 1])
        _origin(je, P[i] @ M)
        etree.SubElement(je, "axis", xyz="0 0 1")
        ji = jinfo.get(names[i], {})
        lim = {"effort": _num(ji.get("effort", 0.0)), "velocity": _num(ji.get("velocity", 0.0))}
        if jtype != "continuous":
            lim = {"lower": _num(lo), "upper": _num(hi), **lim}
        etree.SubElement(je, "limit", **lim)
        dyn = {k: _num(ji[k]) for k in ("damping", "friction") if k in ji}
        if dyn:
            etree.SubElement(je, "dynamics", **dyn)
    if not identity_tool:
        add_fixed(f"{body_names[n]}_to_{tool}", body_names[n], tool, Tt)
    text = etree.tostring(root, pretty_print=True, xml_declaration=True, encoding="UTF-8").decode("utf-8")
    return text


def save_urdf(model: _core.Model, path: str | os.PathLike, robot: Robot | None = None) -> None:
    """Write :func:`dumps_urdf` to ``path`` (whole or not at all)."""
    write_text(path, dumps_urdf(model, robot))


__all__ = ["UrdfChain", "combine_inertials", "dumps_urdf", "load_urdf", "read_chain", "save_urdf", "urdf_model", "urdf_table", "z_to"]
