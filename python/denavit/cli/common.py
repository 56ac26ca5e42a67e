"""What every command shares: the typer app, the consoles, option types, errors, and the parsers of numbers,
joint values and poses from the command line.

Units are declared at this edge and applied by :mod:`denavit.io.units` only: a joint value (``--q``,
``--home``, ``--ranges``, rates) is in the angle unit for a revolute joint and in the length unit for a
prismatic one (:func:`~denavit.io.units.joint_scale`); table cells follow
:func:`~denavit.io.units.cell_scale` (a POE ``w``, and a prismatic joint's ``v``, are unitless).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Annotated

import typer
from rich.console import Console
from rich.table import Table as RichTable
from rich.text import Text

from ..io.units import cell_scale, column_scale, joint_scale

if TYPE_CHECKING:
    import numpy as np

    from .. import _core
    from ..robot import Robot

app = typer.Typer(
    add_completion=False,
    no_args_is_help=True,
    help="Find the true kinematic geometry of serial robots and compute with it.",
    pretty_exceptions_enable=False,
)
def _version(value: bool) -> None:
    if value:
        from .._core import __version__  # noqa: PLC0415

        print(f"denavit {__version__}")
        raise typer.Exit()


@app.callback()
def _root(version: Annotated[bool, typer.Option("--version", callback=_version, is_eager=True, help="Print the version and exit.")] = False) -> None:
    """Find the true kinematic geometry of serial robots and compute with it."""


# markup off: units in headers ("a [mm]"), file paths and messages are printed as written; style only through say()
console = Console(markup=False)
err_console = Console(stderr=True, markup=False)

ModelArg = Annotated[str, typer.Argument(help="A built-in name (see `denavit models`), a robot file (.toml) or a URDF.")]
JsonOpt = Annotated[bool, typer.Option("--json", help="Print JSON instead of tables.")]
BaseLinkOpt = Annotated[str | None, typer.Option("--base-link", help="URDF model: the chain's base link (default: the root link).")]
TipLinkOpt = Annotated[str | None, typer.Option("--tip-link", help="URDF model: the chain's tip link (default: the single leaf, REP-199's tool0, or the leaf through the most moving joints; echoed).")]
ChainOnlyOpt = Annotated[bool, typer.Option("--chain-only", help="URDF model: the chain alone, without the links off it (in the dynamics and in a URDF written).")]


def load_robot(model: str, base_link: str | None = None, tip_link: str | None = None, what: str = "MODEL", chain_only: bool = False) -> Robot:
    """The robot of a MODEL argument (built-in name, robot file or URDF; ``base_link``/``tip_link`` pick a URDF's
    chain), with what the reader chose on the user's behalf said in one line each."""
    from ..robot import load  # noqa: PLC0415

    if (base_link is not None or tip_link is not None) and not str(model).lower().endswith(".urdf"):
        fail(f"--base-link/--tip-link apply to a URDF {what}, got {model!r}")
    if chain_only and not str(model).lower().endswith(".urdf"):
        chain_only = False  # a robot file or built-in is a chain already
    robot = load(model, base_link=base_link, tip_link=tip_link, chain_only=chain_only)
    for note in robot.notes:
        say("dim", "note:", f" {note}", err=True)
    return robot


def say(style: str, head: str, rest: str = "", err: bool = False) -> None:
    """Print `head` in a rich `style` followed by plain `rest`."""
    (err_console if err else console).print(Text.assemble((head, style), rest), soft_wrap=True)  # one line, whatever the width


def fail(msg: str) -> None:
    """A one-line error on stderr and exit code 2."""
    say("bold red", "error:", f" {msg}", err=True)
    raise typer.Exit(2)


def wrote(path, detail: str = "") -> None:
    """Say where an output went (on stderr when it went to standard output, so the output stays clean)."""
    say("", f"wrote {path}{detail}", err=str(path) == "-")


def parse_numbers(text: str | None, what: str) -> list[float]:
    """Numbers separated by commas and/or spaces ("90,-90,90" or "90 -90 90")."""
    if not text:
        return []
    try:
        return [float(t) for t in text.replace(",", " ").split()]
    except ValueError:
        fail(f"{what}: expected numbers separated by commas or spaces, got {text!r}")
        raise


def parse_joint_values(text: str | None, what: str, robot: Robot, length: str, angle: str, default=None) -> np.ndarray:
    """One value per joint from the command line (``--q``, ``--qd``, ``--home``, ...), SI out: revolute values
    in ``angle``, prismatic ones in ``length`` (rates per s, per s^2). Without ``text``: ``default`` (SI),
    else zeros."""
    import numpy as np  # noqa: PLC0415

    n = len(robot.names)
    values = parse_numbers(text, what)
    if not values:
        return np.zeros(n) if default is None else np.asarray(default, dtype=float)
    if len(values) != n:
        fail(f"{what}: expected {n} joint values for {robot.name}, got {len(values)}")
    return np.array(values) * joint_scale(robot.table.kinds, length, angle, what)


def joint_values_out(values, robot: Robot, length: str, angle: str) -> list[float]:
    """SI joint values in the display units (revolute: ``angle``, prismatic: ``length``)."""
    return (values / joint_scale(robot.table.kinds, length, angle)).tolist()


def parse_ranges(text: str | None, robot: Robot, length: str, angle: str, default: str) -> np.ndarray:
    """--ranges: 'paper90' / 'paper30' (Hayat Table II, a 6-joint revolute arm) or start,end pairs per joint
    (revolute: ``angle``, prismatic: ``length``); SI out, shape (n, 2)."""
    import numpy as np  # noqa: PLC0415

    from ..sweeps import PAPER_RANGES_DEG  # noqa: PLC0415

    n = len(robot.names)
    key = (text or default).lower()
    if key in ("paper90", "paper30"):
        if n != 6 or "prismatic" in robot.table.kinds:
            fail("--ranges paper90/paper30 are Hayat Table II for a 6-joint revolute robot; give start,end pairs for this one")
        return np.radians(np.array(PAPER_RANGES_DEG[int(key[-2:])]))
    vals = parse_numbers(text, "--ranges")
    if len(vals) != 2 * n:
        fail(f"--ranges: expected {2 * n} values (start,end per joint), got {len(vals)}")
    return np.array(vals).reshape(n, 2) * joint_scale(robot.table.kinds, length, angle, "--ranges")[:, None]


def parse_pose(text: str, angle: str, ls: float, what: str = "--pose") -> np.ndarray:
    """A pose from the command line: 16 (or 12) numbers, the rows of the 4x4 matrix, or 6 numbers
    x,y,z,roll,pitch,yaw with R = Rz(yaw) Ry(pitch) Rx(roll) (URDF's rpy); positions scaled by ``ls``
    (metres per unit), angles in ``angle``."""
    import numpy as np  # noqa: PLC0415

    from ..geometry import xyz_rpy_pose  # noqa: PLC0415
    from ..io.units import angle_scale  # noqa: PLC0415

    v = parse_numbers(text, what)
    if len(v) in (12, 16):
        T = np.eye(4)
        T[: len(v) // 4] = np.reshape(v, (len(v) // 4, 4))
        T[:3, 3] *= ls
        return T
    if len(v) == 6:
        return xyz_rpy_pose(np.array(v[:3]) * ls, np.array(v[3:]) * angle_scale(angle))
    fail(f"{what}: expected 16 or 12 numbers (rows of the 4x4 pose) or 6 (x,y,z,roll,pitch,yaw), got {len(v)}")
    raise AssertionError


def pose_rows(T: np.ndarray, ls: float) -> list[list[float]]:
    import numpy as np  # noqa: PLC0415

    M = np.array(T, dtype=float)
    M[:3, 3] /= ls
    return M.tolist()


def fmt(v: float, nd: int = 6) -> str:
    """A table cell: ``nd`` decimals, "nan" for NaN (never 0.000000), -0 shown as 0."""
    if v != v:
        return "nan"
    return f"{v:.{nd}f}" if abs(v) >= 1e-12 else f"{0.0:.{nd}f}"


def table_rows(table: _core.Table, length: str, angle: str) -> list[dict]:
    """The table's rows in display units (:func:`denavit.io.units.cell_scale`), keyed by column name."""
    return [{c: float(v / cell_scale(table, i, k, length, angle)[0]) for k, (c, v) in enumerate(zip(table.columns, row))}
            for i, row in enumerate(table.params)]


def print_table(table: _core.Table, names: list[str], length: str, angle: str, title: str) -> None:
    prismatic_poe = table.convention == "poe" and "prismatic" in table.kinds
    t = RichTable(title=title, caption="v of a prismatic joint: its unit direction [1]" if prismatic_poe else None)
    t.add_column("joint")
    for k, c in enumerate(table.columns):
        t.add_column(f"{c} [{column_scale(table, k, length, angle)[1]}]", justify="right")
    for n, row in zip(names, table_rows(table, length, angle)):
        t.add_row(n, *(fmt(v, 4) for v in row.values()))
    console.print(t)


def calib_unit(unit: str, length: str, angle: str) -> tuple[str, float]:
    """Display unit and scale (SI per display unit) of a calibration parameter ("length" | "angle" | "ratio")."""
    from ..io.units import angle_scale, length_scale  # noqa: PLC0415

    if unit == "length":
        return length, length_scale(length)
    if unit == "angle":
        return angle, angle_scale(angle)
    return "1", 1.0


def convention_name(name: str) -> str:
    """The canonical name of a convention (the core's one parser: dh, sdh, mdh, craig, modified-dh, edh, poe)."""
    from .. import _core  # noqa: PLC0415

    return _core.convention_info(name)["name"]
