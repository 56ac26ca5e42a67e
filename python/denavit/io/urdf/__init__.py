"""URDF in and out: the identified robot goes where users work (docs/urdf.md).

Import (:func:`load_urdf`, :func:`urdf_model`) reads a URDF with `yourdfpy` (lxml underneath; the XML is
first parsed strictly, so a malformed file is an error, never a silent recovery; an undeclared namespace
prefix is tolerated as urdfdom tolerates it), picks the serial chain between a base and a tip link and builds
the one :class:`~denavit.Model` of docs/conventions.md from it. Export (:func:`dumps_urdf`,
:func:`save_urdf`) writes any model, identified ones included, as URDF.

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
the URDF joint origins: exact for every geometry (same axes, same tool pose). Continuous joints get
infinite limits. Its inertials are the whole body's: the links off the chain merged into the chain body that
carries them, their movable joints locked (:func:`load_urdf`).

Export
------
A robot read from a URDF is written back as that URDF (its ``<robot>`` element is kept in
``Robot.extra["urdf"]["xml"]``): every link and joint keeps its name, elements and frame, the links off the
chain included (unless loaded ``chain_only``). Each chain link rides rigidly on its body; the body is moved
from the nominal onto the model's joint axes, so only the chain joints' origins, axes and limits change, and
only where they differ by more than :data:`SAME` (the unchanged model's text is the URDF's own, and
export -> import -> export is byte-identical). Numbers are written with ``repr`` (the shortest text that
reads back to the same double), rpy by :func:`denavit.geometry.matrix_rpy`.

Identified robots
-----------------
An identified model is in the measurement frame (a laser tracker's, anywhere), and its joint frames, even
where the axes are the nominal's, are a convention's: ED-H puts the UR shoulder frame 0.36 m along the axis
from the URDF joint origin, DH turns frames about their axes. So neither the nominal link poses as they stand
(2.3 m off for a tracker 2 m away) nor their poses relative to the model's joint frames can be written
directly. Export (:func:`_body_maps`):

1. registers the nominal joint axis lines at ``q = 0`` onto the model's (``X``, :func:`_register_lines`;
   lines only, so neither the frames' origins along their axes nor their turn about them matter; what the
   lines leave free, the slide along an all-parallel chain's axes, is fixed by the tool);
2. anchors each body on the axis it turns about (the base body: the first axis, which it carries):
   ``A = X · F_n`` moved by the smallest rotation and shift that put its z axis on the model's axis line;
3. places each chain link of the body at ``A · inv(F_n) · T_world_link``; a joint's origin is its child's pose
   in its parent's, its axis the model's axis in the child link.

For the nominal's own model, any convention, in any frame, every link lands exactly where the nominal URDF has
it (moved with the base); for a noise-free identification to ~1e-14, for a noisy one each body turns on its
identified axis and the registration's error places it along and about it. The URDF's root is the model's
world (a ``world`` root is added when that is not the file's root) and its tool a ``tcp`` frame on the tip link
when the model's tool is not the tip link (an identified tool point).

A model without a URDF is written with link *i* = its joint frame *i* (``base_link``, ``link_1`` ...,
``flange``, ``tool0``; :func:`dumps_urdf`).
"""

from .common import SUPPORTED_JOINTS, UNSUPPORTED_JOINTS, combine_inertials, z_to
from .read import UrdfChain, load_urdf, read_chain, urdf_model, urdf_table
from .write import dumps_urdf, save_urdf

__all__ = [
    "SUPPORTED_JOINTS",
    "UNSUPPORTED_JOINTS",
    "UrdfChain",
    "combine_inertials",
    "dumps_urdf",
    "load_urdf",
    "read_chain",
    "save_urdf",
    "urdf_model",
    "urdf_table",
    "z_to",
]
