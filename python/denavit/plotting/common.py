"""What every figure shares: the install command of the plot extra, the colours of joints and frame axes, the joint
names, and a headless matplotlib Figure."""

from __future__ import annotations

from typing import TYPE_CHECKING

from ..errors import DenavitError

if TYPE_CHECKING:  # pragma: no cover
    from matplotlib.figure import Figure

    from ..identification import Identification


def install_hint(extra: str = "plot") -> str:
    """The command that installs an optional extra for the installation at hand (issue 40): from a checkout (the
    package's PEP 610 ``direct_url.json`` names a local folder), ``pip install "FOLDER[plot]"`` (``-e`` when it is an
    editable install); from the package index, ``pip install 'denavit[plot]'``."""
    import json  # noqa: PLC0415
    from importlib import metadata  # noqa: PLC0415
    from urllib.parse import unquote, urlparse  # noqa: PLC0415

    try:
        text = metadata.distribution("denavit").read_text("direct_url.json")
        info = json.loads(text) if text else {}
    except (metadata.PackageNotFoundError, ValueError, OSError):
        info = {}
    url = urlparse(str(info.get("url", "")))
    if url.scheme == "file":
        editable = bool(info.get("dir_info", {}).get("editable", False))
        return f'install the {extra} extra: pip install {"-e " if editable else ""}"{unquote(url.path)}[{extra}]"'
    return f"install the {extra} extra: pip install 'denavit[{extra}]'"


#: Colours of the frame axes x, y, z (the usual red, green, blue).
AXIS_COLOURS = ("#d62728", "#2ca02c", "#1f77b4")
#: Per-joint colours (matplotlib's tab10, repeated).
JOINT_COLOURS = (
    "#1f77b4",
    "#ff7f0e",
    "#2ca02c",
    "#d62728",
    "#9467bd",
    "#8c564b",
    "#e377c2",
    "#7f7f7f",
    "#bcbd22",
    "#17becf",
)


def joint_colour(j: int) -> str:
    """The colour of joint ``j`` (0-based) in every figure and in the report."""
    return JOINT_COLOURS[j % len(JOINT_COLOURS)]


def joint_names(result: Identification) -> list[str]:
    """The nominal model's joint names, else j1..jn."""
    return list(result.nominal.names) if result.nominal else [f"j{i + 1}" for i in range(result.axes.nq)]


def _figure(**kw) -> Figure:
    """A new headless Figure (no pyplot, so no GUI backend); 3-D projection registered."""
    try:
        from matplotlib.figure import Figure  # noqa: PLC0415
        from mpl_toolkits.mplot3d import Axes3D  # noqa: F401, PLC0415  (registers projection="3d")
    except ImportError as e:
        raise DenavitError(f"the figures need matplotlib, which is not installed ({e}): {install_hint()}") from None
    return Figure(**kw)
