"""Static figures (matplotlib): fitted circles and axes, residuals, the bounding box, frames, origin paths, parameters.

Every function returns a :class:`matplotlib.figure.Figure` built with the object-oriented API (``Figure()``,
never ``pyplot``), so nothing depends on a display or on the user's backend: saving goes through Agg (PNG) or
the SVG backend, and the figure's artists can be counted by tests. Artists carry ``gid`` labels
(``circle-3``, ``axis-3``, ``frame-2``, ``path-4``, ``box-edge`` ...) that name what they show.

matplotlib is an optional extra (``pip install 'denavit[plot]'``): it is imported inside the functions, and a
missing install raises :class:`~denavit.errors.DenavitError` naming that command.

Modules, by concern: ``common`` (install command, colours, joint names, the headless Figure), ``scene`` (the
geometry drawn, pure numpy: circles, box edges, the 3-D view's camera, frame origins along a joint motion; shared
with the HTML report, :mod:`denavit.report`), ``parameters`` (which parameters the data determine, and their
chart), ``figures`` (the other figures). Every public name is importable from ``denavit.plotting``.

Frames and units: every input is SI in the measurement frame ``world`` (docs/conventions.md); figures show
lengths in ``length`` units (default mm, as in Hayat et al.) and angles in degrees.

Figures after the papers:

* :func:`plot_circles` -- Hayat et al. Fig. 7, "fitted circle for each joint motion": full circles (not the
  measured arcs), centres and normals.
* :func:`plot_bounding_box` -- Hayat et al. Fig. 8 / Table IV, the minimum-volume oriented bounding box.
* :func:`plot_frames` -- Guo et al. Figs. 6-7: the frames of two conventions side by side (MD-H frames off
  the body and overlapping, ED-H frames on the joint axes).
* :func:`plot_origin_paths` -- Guo et al. Fig. 3: the path of each frame origin while one joint moves.
"""

from .common import AXIS_COLOURS, JOINT_COLOURS, install_hint, joint_colour, joint_names
from .common import _figure as _figure  # the headless Figure, shared with denavit.report
from .figures import (
    figures_for,
    plot_accuracy,
    plot_bounding_box,
    plot_circles,
    plot_frames,
    plot_origin_paths,
    plot_residuals,
)
from .parameters import (
    UNDETERMINED_ANGLE,
    UNDETERMINED_LENGTH,
    UNDETERMINED_RATIO,
    ParameterErrors,
    clean_ticks,
    parameter_errors,
    plot_parameters,
    symmetric_limit,
)
from .scene import (
    box_edges,
    chain_path,
    circle_points,
    clusters,
    frame_labels,
    frames_along,
    line_span,
    motion_range,
    other_convention,
    scene_size,
    scene_view,
    sweep_range,
    triad_lengths,
)

__all__ = [
    "AXIS_COLOURS",
    "JOINT_COLOURS",
    "ParameterErrors",
    "UNDETERMINED_ANGLE",
    "UNDETERMINED_LENGTH",
    "UNDETERMINED_RATIO",
    "box_edges",
    "chain_path",
    "circle_points",
    "clean_ticks",
    "clusters",
    "figures_for",
    "frame_labels",
    "frames_along",
    "install_hint",
    "joint_colour",
    "joint_names",
    "line_span",
    "motion_range",
    "other_convention",
    "parameter_errors",
    "plot_accuracy",
    "plot_bounding_box",
    "plot_circles",
    "plot_frames",
    "plot_origin_paths",
    "plot_parameters",
    "plot_residuals",
    "scene_size",
    "scene_view",
    "sweep_range",
    "symmetric_limit",
    "triad_lengths",
]
