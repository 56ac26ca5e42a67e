"""What every command shares: the typer app, the consoles, option types, errors, and the parsers of numbers,
joint values and poses from the command line.

Units are declared at this edge and applied by :mod:`denavit.io.units` only: a joint value (``--q``,
``--home``, ``--ranges``, rates) is in the angle unit for a revolute joint and in the length unit for a
prismatic one (:func:`~denavit.io.units.joint_scale`); table cells follow
:func:`~denavit.io.units.cell_scale` (a POE ``w``, and a prismatic joint's ``v``, are unitless). The grammar
every command follows (units, physical defaults, ``--json [PATH]`` in SI, exit codes, terminal output) is
docs/cli.md.
"""

from __future__ import annotations

import math
import os
import sys
from contextlib import contextmanager
from typing import TYPE_CHECKING, Annotated

import typer
from rich.console import Console
from rich.table import Table as RichTable
from rich.text import Text
from typer.core import TyperCommand, TyperGroup

try:
    from typer._coercion import PassThroughRuntimeParam  # typer >= 0.2x coerces values with pydantic (see _flags)
except ImportError:
    PassThroughRuntimeParam = None

from ..errors import DenavitError
from ..io.output import check_writable
from ..io.units import ANGLE, LENGTH, angle_scale, cell_scale, column_scale, joint_scale, joint_unit, length_scale

if TYPE_CHECKING:
    from collections.abc import Iterator, Sequence

    import numpy as np

    from .. import _core
    from ..robot import Robot


def _reflow(text: str | None) -> str | None:
    """A docstring's paragraphs each on one line, so the help wraps them at the terminal's width (rich markup
    mode keeps single newlines, which broke sentences mid-way in the command list)."""
    if not text:
        return text
    import inspect  # noqa: PLC0415

    return "\n\n".join(" ".join(p.split()) for p in inspect.cleandoc(text).split("\n\n"))


def _flags(params: list) -> list:
    """Flags take no value: no ``<bool>`` placeholder after them in the help, and no coercion of the bool (or
    None, when absent) they yield: typer would build a pydantic TypeAdapter for it, importing pydantic (a
    tenth of a second) on every ``--help``."""
    for p in params:
        if getattr(p, "is_flag", False):
            if p.metavar is None:
                p.metavar = ""
            if (
                PassThroughRuntimeParam is not None
                and getattr(p, "_runtime_param", False) is None
                and p.type_descriptor.annotation is bool
            ):
                p._runtime_param = PassThroughRuntimeParam(
                    annotation=bool, parameter_info=p.type_descriptor.parameter_info
                )
    return params


class Command(TyperCommand):
    """Every command: help paragraphs reflowed, flags without a type placeholder, a bare ``--json`` meaning
    standard output (:func:`json_argv`)."""

    def __init__(self, *args, **kwargs) -> None:
        super().__init__(*args, **kwargs)
        self.help = _reflow(self.help)
        if any(OUTPUT_OPTIONS.intersection(p.opts) or "--plot" in p.opts for p in self.params):
            self.params.append(force_option())

    def get_params(self, ctx):  # noqa: ANN001, ANN201 (click's signature)
        return _flags(super().get_params(ctx))

    def format_help(self, ctx, formatter) -> None:  # noqa: ANN001 (click's signature)
        import_rich_utils()
        super().format_help(ctx, formatter)

    def parse_args(self, ctx, args):  # noqa: ANN001, ANN201 (click's signature)
        return super().parse_args(ctx, json_argv(args))

    def invoke(self, ctx):  # noqa: ANN001, ANN201 (click's signature)
        from ..io.output import forcing  # noqa: PLC0415

        with forcing(bool(ctx.params.pop("force", False))):  # --force reaches every write of the command
            _check_units(ctx)
            _check_outputs(ctx)
            try:
                return super().invoke(ctx)
            finally:
                console.file = (
                    None  # back to standard output after a --json - run (json_target), for the next in-process call
                )


ForceOpt = Annotated[
    bool,
    typer.Option(
        "--force",
        help="Replace an output file that is read-only, and write through one with several hard links (in place: every name "
        "gets the new content); without it both are refused. A replaced file keeps its owner and mode.",
    ),
]


def force_option():  # noqa: ANN201 (typer's click option)
    """``--force``, added to every command that writes a file (docs/cli.md, "How outputs are written"); the
    command's function does not take it: :meth:`Command.invoke` applies it to every write of the command
    (:func:`denavit.io.output.forcing`). Built by typer from :data:`ForceOpt`, once."""
    global _force_param  # noqa: PLW0603 (built on first use)
    if _force_param is None:
        one = typer.Typer()

        @one.command()
        def _force(force: ForceOpt = False) -> None:
            """The --force option."""

        _force_param = next(p for p in typer.main.get_command(one).params if p.name == "force")
    return _force_param


_force_param = None


#: the options that name a file the command writes (``--plot`` names a folder, made when it is written)
OUTPUT_OPTIONS = frozenset({"-o", "--output", "--json", "--save", "--urdf", "--report", "--ur-kinematics"})


def _check_units(ctx) -> None:  # noqa: ANN001 (click's context)
    """``--length`` and ``--angle`` are checked before the work starts, whether or not the command reads a value in
    them (``fk --angle grad`` without ``--q`` had printed its tables, exit 0)."""
    for name, check in (("length", length_scale), ("angle", angle_scale)):
        value = ctx.params.get(name)
        if isinstance(value, str):
            check(value)


def _check_outputs(ctx) -> None:  # noqa: ANN001 (click's context)
    """Every output the command line names is checked before the work starts: a missing or read-only directory
    is an error in the first second, not after a minute of fitting; an output that is one of the command's input
    files (the same path, or a link to it) is refused, as is a ``--plot`` folder that is an existing file."""
    inputs, outputs = [], []
    for param in ctx.command.params:
        value = ctx.params.get(param.name)
        if value is None:
            continue
        if OUTPUT_OPTIONS.intersection(param.opts):
            if value != STDOUT:
                check_writable(value)
                outputs.append((param.opts[-1], value))
        elif "--plot" in param.opts:
            if os.path.exists(value) and not os.path.isdir(value):
                raise DenavitError(f"--plot {value}: expected a folder (made when missing), got an existing file")
            outputs.append(("--plot", value))
        else:
            inputs += [
                (param, v)
                for v in (value if isinstance(value, list | tuple) else [value])
                if isinstance(v, str | os.PathLike) and _is_file(v)
            ]
    for opt, out in outputs:
        for param, inp in inputs:
            if _is_file(out) and os.path.samefile(out, inp):
                name = param.opts[-1] if param.opts[-1].startswith("-") else param.name.upper()
                raise DenavitError(
                    f"{opt} {out}: is the input file {inp} ({name}): an output never replaces an input; name another file"
                )


def _is_file(path) -> bool:  # noqa: ANN001 (any path-like)
    try:
        return os.path.isfile(path)
    except (OSError, ValueError):
        return False


#: Every command, in the order of ``denavit --help``: its module (imported when the command runs or shows its
#: help) and its summary, the first paragraph of its docstring, listed by ``denavit --help`` without importing
#: the module (tests/test_cli.py checks the two agree).
COMMANDS = {
    "calibrate": (
        "calibrate",
        "Calibrate the whole model from measured points or poses at known joint readings (one least-squares fit).",
    ),
    "compensate": (
        "compensate",
        'Compensate a program (RoboDK\'s "filtering"): for each target, the joint values that reach it on the '
        "identified robot (on the program's branch) and the pose T' = FK_nominal(q) to send to a controller that keeps "
        "its nominal model. Flagged rows (unreachable, branch changed, path jump) are marked, never silently kept; exit "
        "code 1 when any row is flagged.",
    ),
    "convert": ("convert", "Express a robot in another convention through its joint axes, with the FK-parity check."),
    "dynamics": (
        "dynamics",
        "Inverse dynamics (recursive Newton-Euler): the joint torques (N m) / forces (N) for q, qd, qdd.",
    ),
    "fk": ("fk", "Forward kinematics: the tool pose and every joint frame (T_world_joint)."),
    "identify": (
        "identify",
        "Identify the joint axes and parameters from joint sweeps (Hayat et al.), beside the nominal values.",
    ),
    "ik": (
        "ik",
        "Inverse kinematics: joint values that put the tool at --pose, judged from the measured final error against the tolerances.",
    ),
    "inspect": (
        "inspect",
        "Print what a recording holds: the reader used, joints, targets, rates and units, and the sweeps the segmentation "
        "finds (joint, rows, start and end, dwell left out), for checking before `identify`.",
    ),
    "plan": (
        "plan",
        "Predict every parameter's sigma (Cramer-Rao bound) and the measuring volume of a protocol, before measuring.",
    ),
    "models": ("show", "List the built-in robots (names and descriptions: no units)."),
    "show": (
        "show",
        "Print a robot file's table as read (with units); optionally draw its frames beside another convention's.",
    ),
    "export": (
        "show",
        "Print a robot file (TOML) in --length / --angle units (or, with --json, the robot as JSON in SI), or write a UR "
        "kinematics-parameters file.",
    ),
    "simulate": (
        "simulate",
        "Simulate joint sweeps of a model (for planning a measurement and for tests); writes the long-form CSV.",
    ),
    "validate": (
        "validate",
        "Score a saved model on another measurement session: per-pose tool-position errors, RMS, max and percentiles, "
        "extrapolation flags (outside the training joint ranges, large predicted sigma), ISO 9283 pose accuracy and repeatability "
        "of repeated poses.",
    ),
}


class Group(TyperGroup):
    """The root: its own options (--version, --help) without placeholders; each command built from its module
    (:data:`COMMANDS`) when it is run or shows its help, so a command's start-up pays for that command only."""

    listing = False  # while the root's help is formatted: commands are their summaries, nothing is imported

    def get_params(self, ctx):  # noqa: ANN001, ANN201 (click's signature)
        return _flags(super().get_params(ctx))

    def list_commands(self, ctx) -> list[str]:  # noqa: ANN001 (click's context)
        return list(COMMANDS)

    def get_command(self, ctx, cmd_name: str):  # noqa: ANN001, ANN201 (click's signature)
        if cmd_name not in COMMANDS:
            return None
        if cmd_name not in self.commands:
            if self.listing:
                return TyperCommand(cmd_name, help=COMMANDS[cmd_name][1])
            self.commands[cmd_name] = build_command(cmd_name)
        return self.commands[cmd_name]

    def resolve_command(self, ctx, args):  # noqa: ANN001, ANN201 (click's signature)
        if (
            args and args[0] not in COMMANDS and not args[0].startswith("-")
        ):  # a typo: typer's "Did you mean" picks from the commands built
            for name in COMMANDS:
                self.get_command(ctx, name)
        return super().resolve_command(ctx, args)

    def format_help(self, ctx, formatter) -> None:  # noqa: ANN001 (click's signature)
        import_rich_utils()
        self.listing = True
        try:
            super().format_help(ctx, formatter)
        finally:
            self.listing = False


def build_command(name: str) -> TyperCommand:
    """The click command ``name``: its module imported (which registers it on :data:`commands`), then built by typer."""
    __import__(f"{__package__}.{COMMANDS[name][0]}")  # not importlib.import_module, which -X importtime does not see
    info = next(
        i for i in commands.registered_commands if (i.name or typer.main.get_command_name(i.callback.__name__)) == name
    )
    return typer.main.get_command_from_info(
        info, pretty_exceptions_short=app.pretty_exceptions_short, rich_markup_mode=app.rich_markup_mode
    )


def import_rich_utils() -> None:
    """Import typer's help formatter (typer.rich_utils) without the modules it imports for markdown help and rich
    tracebacks, rich.markdown and rich.traceback (markdown-it and pygments behind them: 0.1-0.2 s CPU of
    ``--help``), which this command line never uses (rich markup, pretty exceptions off): while it loads, stand-ins
    that import the real class on first use."""
    if "typer.rich_utils" in sys.modules:
        return
    from importlib import import_module  # noqa: PLC0415
    from types import ModuleType  # noqa: PLC0415

    class Deferred(type):
        def __getattr__(cls, attr: str):  # noqa: ANN204 (the real class's attribute)
            return getattr(cls.real(), attr)

    def deferred(module: str, name: str) -> type:
        def real() -> type:
            return getattr(import_module(module), name)

        return Deferred(name, (), {"__new__": lambda _cls, *a, **k: real()(*a, **k), "real": staticmethod(real)})

    stand_ins = {}
    for module, name in (("rich.markdown", "Markdown"), ("rich.traceback", "Traceback")):
        if module not in sys.modules:
            stand_ins[module] = sys.modules[module] = ModuleType(module)
            setattr(stand_ins[module], name, deferred(module, name))
    try:
        import typer.rich_utils  # noqa: F401, PLC0415
    finally:
        for module in stand_ins:
            del sys.modules[module]


class App(typer.Typer):
    """The typer app whose commands are :class:`Command` s."""

    def command(self, *args, cls=None, **kwargs):  # noqa: ANN001, ANN201 (typer's signature)
        return super().command(*args, cls=cls or Command, **kwargs)


#: Where each command module registers its command (``@commands.command()``); :class:`Group` builds it from here.
commands = App()

app = App(
    cls=Group,
    add_completion=False,
    no_args_is_help=True,
    help="Find the true kinematic geometry of serial robots and compute with it. Lengths in mm and angles in degrees "
    "unless --length/--angle say otherwise; JSON always in SI (docs/cli.md).",
    pretty_exceptions_enable=False,
)


def _version(value: bool) -> None:
    if value:
        from .._core import __version__  # noqa: PLC0415

        print(f"denavit {__version__}")
        raise typer.Exit()


@app.callback()
def _root(
    version: Annotated[
        bool, typer.Option("--version", callback=_version, is_eager=True, help="Print the version and exit.")
    ] = False,
) -> None:
    """Find the true kinematic geometry of serial robots and compute with it."""


# markup off: units in headers ("a [mm]"), file paths and messages are printed as written; style only through say()
console = Console(markup=False)
err_console = Console(stderr=True, markup=False)

ModelArg = Annotated[
    str, typer.Argument(help="A built-in name (see `denavit models`), a robot file (.toml) or a URDF.")
]
LengthOpt = Annotated[
    str,
    typer.Option(
        "--length", help="Length unit of what is typed and printed: mm (default) | m | cm | um | in. JSON stays SI."
    ),
]
AngleOpt = Annotated[
    str, typer.Option("--angle", help="Angle unit of what is typed and printed: deg (default) | rad. JSON stays SI.")
]
JsonOpt = Annotated[
    str | None,
    typer.Option(
        "--json",
        metavar="[PATH]",
        help="Write the result as JSON (SI: m, rad) to PATH; '-' or no PATH: standard output, instead of the tables.",
    ),
]
BaseLinkOpt = Annotated[
    str | None, typer.Option("--base-link", help="URDF model: the chain's base link (default: the root link).")
]
TipLinkOpt = Annotated[
    str | None,
    typer.Option(
        "--tip-link",
        help="URDF model: the chain's tip link (default: the single leaf, REP-199's tool0, or the leaf through the most moving joints; echoed).",
    ),
]
ChainOnlyOpt = Annotated[
    bool,
    typer.Option(
        "--chain-only",
        help="URDF model: the chain alone, without the links off it (in the dynamics and in a URDF written).",
    ),
]

#: What a bare ``--json`` (no PATH after it) means: standard output.
STDOUT = "-"


def json_argv(argv: Sequence[str]) -> list[str]:
    """``--json`` with no value (last, or followed by another option) becomes ``--json -``: ``--json [PATH]``
    on every command (click has no optional option values)."""
    out: list[str] = []
    for k, a in enumerate(argv):
        out.append(a)
        if a == "--":
            return out + list(argv[k + 1 :])
        if a == "--json":
            nxt = argv[k + 1] if k + 1 < len(argv) else None
            if nxt is None or (nxt.startswith("-") and nxt != STDOUT):
                out.append(STDOUT)
    return out


def check_outputs(**paths) -> None:
    """The files a command writes, by option name (``check_outputs(**{"--save": save, "--json": json})``): at most
    one on standard output ('-'), which then holds that document only (tables, notes and ``wrote`` lines go to
    stderr; two had been written one after the other into one stream), and no file named twice (the second
    write had replaced the first without a word)."""
    given = {opt: str(p) for opt, p in paths.items() if p is not None}
    std = [opt for opt, p in given.items() if p == STDOUT]
    if len(std) > 1:
        fail(f"{' and '.join(std)}: both write to standard output ('-'): give a file to all but one")
    if std:
        console.file = sys.stderr
    seen: dict[str, str] = {}
    for opt, p in given.items():
        key = os.path.realpath(p) if p != STDOUT else None
        if key is not None and key in seen:
            fail(f"{seen[key]} and {opt} both write {p}: give each its own file")
        if key is not None:
            seen[key] = opt


def json_target(path) -> str | None:
    """Where ``--json`` goes (None: nowhere). To standard output, it replaces the tables and everything else
    printed (notes, warnings, ``wrote``) goes to stderr, so standard output holds the JSON document only."""
    if path is None:
        return None
    path = str(path)
    if path == STDOUT:
        console.file = sys.stderr
    return path


def emit_json(doc, path: str | None) -> None:
    """Write ``doc`` (SI, ``units`` stated) as strict JSON to ``path`` ('-': standard output)."""
    from ..io.output import json_text, write_text  # noqa: PLC0415

    if path is None:
        return
    text = json_text(doc)
    if path == STDOUT:
        sys.stdout.write(text)
        sys.stdout.flush()
    else:
        write_text(path, text)
        wrote(path)


SI_UNITS = {"length": "m", "angle": "rad"}


#: A step that lasts longer than this (s) says what it is doing.
PATIENCE = 1.0


@contextmanager
def status(message: str) -> Iterator:
    """Say what a step that takes more than :data:`PATIENCE` is doing, on stderr: a spinner on a terminal (its
    ``update(text)`` shows progress), else one line once the step has lasted that long (a quick step, or an
    error found at once, prints nothing but its result)."""
    if err_console.is_terminal:
        with err_console.status(message) as s:
            yield s
        return
    import threading  # noqa: PLC0415

    class _Line:
        def __init__(self) -> None:
            self.text = message
            self.timer = threading.Timer(PATIENCE, lambda: err_console.print(self.text, soft_wrap=True))
            self.timer.daemon = True

        def update(self, text, *_a, **_k) -> None:
            self.text = f"{message} {text}" if text else message

    line = _Line()
    line.timer.start()
    try:
        yield line
    finally:
        line.timer.cancel()


def load_robot(
    model: str, base_link: str | None = None, tip_link: str | None = None, what: str = "MODEL", chain_only: bool = False
) -> Robot:
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
    (err_console if err else console).print(
        Text.assemble((head, style), rest), soft_wrap=True
    )  # one line, whatever the width


def fail(msg: str) -> None:
    """A one-line error on stderr and exit code 2."""
    say("bold red", "error:", f" {msg}", err=True)
    raise typer.Exit(2)


def wrote(path, detail: str = "") -> None:
    """Say where an output went (on stderr when it went to standard output, so the output stays clean)."""
    say("", f"wrote {path}{detail}", err=str(path) == "-")


def parse_numbers(text: str | None, what: str) -> list[float]:
    """Numbers separated by commas and/or spaces ("90,-90,90" or "90 -90 90")."""
    from ..io.delimited import NUMBER  # noqa: PLC0415 (the one number rule of every reader)

    if not text:
        return []
    tokens = text.replace(",", " ").split()
    bad = next((t for t in tokens if not NUMBER.fullmatch(t)), None)
    if bad is not None:
        fail(
            f"{what}: expected numbers (ASCII decimal, e.g. -90 or 1.5e-3) separated by commas or spaces, got {bad[:40]!r}"
        )
    values = [float(t) for t in tokens]
    if not all(math.isfinite(v) for v in values):
        fail(f"{what}: expected finite numbers, got {text[:80]!r}")
    return values


def parse_joint_values(
    text: str | None, what: str, robot: Robot, length: str, angle: str, default=None, limits: bool = True
) -> np.ndarray:
    """One value per joint from the command line (``--q``, ``--qd``, ``--home``, ...), SI out: revolute values
    in ``angle``, prismatic ones in ``length`` (rates per s, per s^2). Without ``text``: ``default`` (SI),
    else zeros; an empty ``text`` (``--q ""``) is an error, not zeros. With ``limits``, values beyond the robot's
    joint limits are warned about (:func:`warn_limits`)."""
    import numpy as np  # noqa: PLC0415

    n = len(robot.names)
    if text is None:
        return np.zeros(n) if default is None else np.asarray(default, dtype=float)
    values = parse_numbers(text, what)
    if len(values) != n:
        fail(f"{what}: expected {n} joint values for {robot.name}, got {len(values) or 'none'}")
    q = np.array(values) * joint_scale(robot.table.kinds, length, angle, what)
    if limits:
        check_joint_values(q, robot.table.kinds, what, length, angle)
        warn_limits(q, robot, what, length, angle)
    return q


def check_joint_values(q, kinds, what: str, length: str, angle: str) -> None:
    """Joint values (SI, (..., n)) within the plausible (:mod:`denavit.limits`: revolute within the turns allowed,
    prismatic within 1 km), else the one-line error in the units typed."""
    import numpy as np  # noqa: PLC0415

    from .. import limits  # noqa: PLC0415

    q2 = np.asarray(q, dtype=float).reshape(-1, len(kinds))
    for j, kind in enumerate(kinds):
        if kind == "revolute":
            limits.check_angles(q2[:, j], f"{what}: joint {j + 1}", angle, angle_scale(angle), joint=True)
        else:
            limits.check_lengths(q2[:, j], f"{what}: joint {j + 1}", length, length_scale(length))


def warn_limits(q, robot: Robot, what: str, length: str, angle: str) -> None:
    """A warning on stderr for each joint value (SI) beyond the robot's limits, in the units typed; in degrees
    the hint that radians were meant is rarely right, in radians that degrees were meant almost always is."""
    import numpy as np  # noqa: PLC0415

    lo, hi = np.asarray(robot.lower, dtype=float), np.asarray(robot.upper, dtype=float)
    sc = joint_scale(robot.table.kinds, length, angle)
    bad = [j for j in range(len(q)) if not lo[j] - 1e-12 <= q[j] <= hi[j] + 1e-12]
    for j in bad:
        u = joint_unit(robot.table.kinds[j], length, angle)
        say(
            "bold yellow",
            "warning:",
            f" {what}: joint {robot.names[j]} = {q[j] / sc[j]:.6g} {u} is beyond its limits [{lo[j] / sc[j]:.6g}, {hi[j] / sc[j]:.6g}] {u}",
            err=True,
        )
    if bad and angle == "rad" and all(k == "revolute" for k in robot.table.kinds):
        say("bold yellow", "warning:", f" {what} is read in rad (--angle rad): were degrees meant?", err=True)


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
            fail(
                "--ranges paper90/paper30 are Hayat Table II for a 6-joint revolute robot; give start,end pairs for this one"
            )
        return np.radians(np.array(PAPER_RANGES_DEG[int(key[-2:])]))
    vals = parse_numbers(text, "--ranges")
    if len(vals) != 2 * n:
        fail(f"--ranges: expected {2 * n} values (start,end per joint), got {len(vals)}")
    r = np.array(vals).reshape(n, 2) * joint_scale(robot.table.kinds, length, angle, "--ranges")[:, None]
    check_joint_values(r.T, robot.table.kinds, "--ranges", length, angle)
    return r


def parse_pose(text: str, angle: str, ls: float, what: str = "--pose") -> np.ndarray:
    """A pose from the command line: 16 (or 12) numbers, the rows of the 4x4 matrix, or 6 numbers
    x,y,z,roll,pitch,yaw with R = Rz(yaw) Ry(pitch) Rx(roll) (URDF's rpy); positions scaled by ``ls``
    (metres per unit), angles in ``angle``."""
    import numpy as np  # noqa: PLC0415

    from .. import limits  # noqa: PLC0415
    from ..geometry import xyz_rpy_pose  # noqa: PLC0415
    from ..io.units import angle_scale  # noqa: PLC0415

    v = parse_numbers(text, what)
    unit = _length_unit(ls)
    if len(v) in (12, 16):
        T = np.eye(4)
        T[: len(v) // 4] = np.reshape(v, (len(v) // 4, 4))
        T[:3, 3] *= ls
        limits.check_lengths(T[:3, 3], f"{what}: position", unit, ls)
        return T
    if len(v) == 6:
        limits.check_lengths(np.array(v[:3]) * ls, f"{what}: position", unit, ls)
        limits.check_angles(
            np.array(v[3:]) * angle_scale(angle), f"{what}: roll, pitch, yaw", angle, angle_scale(angle)
        )
        return xyz_rpy_pose(np.array(v[:3]) * ls, np.array(v[3:]) * angle_scale(angle))
    fail(f"{what}: expected 16 or 12 numbers (rows of the 4x4 pose) or 6 (x,y,z,roll,pitch,yaw), got {len(v)}")
    raise AssertionError


def parse_point(text: str | None, what: str, ls: float, default_si: Sequence[float]) -> np.ndarray:
    """A point x,y,z typed in the length unit (``ls`` metres per unit), SI out; ``default_si`` (metres, a
    physical default that keeps its size whatever the unit) without ``text``."""
    import numpy as np  # noqa: PLC0415

    from .. import limits  # noqa: PLC0415

    if text is None:
        return np.asarray(default_si, dtype=float)
    p = np.array(parse_numbers(text, what)) * ls
    if p.shape != (3,):
        fail(f"{what}: expected 3 values (x, y, z), got {p.size}")
    limits.check_lengths(p, what, _length_unit(ls), ls)
    return p


def _length_unit(ls: float) -> str:
    """The name of the length unit of ``ls`` metres (for a message)."""
    return next((u for u in ("mm", "m", "cm", "um", "in") if u in LENGTH and LENGTH[u] == ls), f"x {ls:g} m")


def count(value: int, what: str, limit: str, least: int = 1, counted: str | None = None) -> int:
    """A count typed (``--points``, ``--random``): an integer >= ``least`` within the size limit ``limit``
    (:mod:`denavit.limits`), checked before anything is allocated."""
    from .. import limits  # noqa: PLC0415

    return limits.check_count(value, what, limit, least, counted)


def positive(value: float | None, what: str, scale: float, default_si: float | None, unit: str) -> float | None:
    """A non-negative quantity typed in ``unit`` (``scale`` SI per unit), SI out; ``default_si`` without a value."""
    if value is None:
        return default_si
    if not (math.isfinite(value) and value >= 0):
        fail(f"{what}: expected a finite value >= 0 in {unit}, got {value}")
    return value * scale


def check_noises(model: _core.Model, tool, length: str, angle: str, *noises: tuple[str, float | None, str]) -> None:
    """Noises (SI, one sigma) as physically plausible (:mod:`denavit.limits`): ``(option, value, kind)`` with kind
    "length" (below the robot's size, with the tool point ``tool``), "angle" (below half a turn) or "joint" (a
    joint reading: by the joints' kinds); errors in the units typed."""
    from .. import limits  # noqa: PLC0415

    ls, as_ = length_scale(length), angle_scale(angle)
    for what, value, kind in noises:
        if value is None:
            continue
        if kind == "angle" or (kind == "joint" and "revolute" in model.kinds):
            limits.check_angle_noise(value, what + (" (revolute joints)" if kind == "joint" else ""), angle, as_)
        if kind == "length" or (kind == "joint" and "prismatic" in model.kinds):
            limits.check_noise(
                value, what + (" (prismatic joints)" if kind == "joint" else ""), model, tool, length, ls
            )


def pose_rows(T: np.ndarray, ls: float) -> list[list[float]]:
    import numpy as np  # noqa: PLC0415

    M = np.array(T, dtype=float)
    M[:3, 3] /= ls
    return M.tolist()


def fmt(v: float, nd: int = 6) -> str:
    """A table cell: ``nd`` decimals, "nan" for NaN (never 0.000000), -0 shown as 0; from 1e15 on in exponent
    form (beyond a double's 16 digits the decimals are noise, and 1e300 had printed 300 digits)."""
    if v != v:
        return "nan"
    if abs(v) >= 1e15:
        return f"{v:.{max(nd, 6)}e}"
    return f"{v:.{nd}f}" if abs(v) >= 0.5 * 10.0**-nd else f"{0.0:.{nd}f}"


#: The resolution printed: 1 um for lengths, 0.001 deg for angles, 1e-6 for unitless numbers.
RESOLUTION = {"length": 1e-6, "angle": math.radians(1e-3), "1": 1e-6}


def decimals(unit: str) -> int:
    """Decimals that show :data:`RESOLUTION` in ``unit`` (3 in mm, 6 in m, 3 in deg, 5 in rad, 6 unitless)."""
    u = str(unit).strip().lower()
    if u in LENGTH:
        r = RESOLUTION["length"] / length_scale(u)
    elif u in ANGLE:
        r = RESOLUTION["angle"] / angle_scale(u)
    else:
        r = RESOLUTION["1"]
    return max(0, math.ceil(-math.log10(r) - 1e-9))


def num(v: float, unit: str) -> str:
    """A value in ``unit`` with the digits of its resolution (:func:`decimals`)."""
    return fmt(v, decimals(unit))


def spread(v: float) -> str:
    """A sigma, rms or other small positive spread: 3 significant figures (never ``0.000`` in metres); "-"
    where it is not finite (not identifiable)."""
    if not math.isfinite(v):
        return "-"
    return f"{v:.3g}"


def print_rows(
    title: str | None,
    headers: Sequence[str],
    rows: Sequence[Sequence[str]],
    *,
    caption: str | None = None,
    labels: int = 1,
    left: Sequence[int] = (),
    group: bool = False,
    prose: Sequence[int] = (),
) -> None:
    """A table that never cuts a number or a name: a rich table when every column fits the console at its
    widest cell (headers may wrap between words), else a long layout, each row's ``labels`` first cells as a
    heading and one ``header  value`` line per other cell. ``left``: columns justified left (labels are);
    ``group``: a rich table shows the first cell only where it changes, with a line between groups; ``prose``:
    columns of text that may wrap between words (descriptions)."""
    headers = list(headers)
    rows = [list(r) for r in rows]

    def longest_word(text: str) -> int:
        return max((len(w) for w in text.split()), default=0)

    ks = range(len(headers))
    least = [
        max([longest_word(r[k]) if k in prose else len(r[k]) for r in rows] + [longest_word(headers[k]), 1]) for k in ks
    ]
    width = [
        max([len(r[k]) for r in rows] + [len(headers[k]), 1]) for k in ks
    ]  # headers (and prose) on one line if the console allows
    for k in sorted(ks, key=lambda k: least[k] - width[k]):  # else wrap the widest-for-its-content first
        excess = sum(width) + 3 * len(headers) + 1 - console.width
        if excess <= 0:
            break
        width[k] = max(least[k], width[k] - excess)
    if sum(width) + 3 * len(headers) + 1 <= console.width:
        import textwrap  # noqa: PLC0415

        # the widths are decided here (rich would shrink columns by cutting them): headers wrapped between
        # words to their column's width, cells never wrapped but prose
        t = RichTable(title=title, caption=caption)
        for k, h in enumerate(headers):
            t.add_column(
                textwrap.fill(h, width[k], break_long_words=False),
                justify="left" if k < labels or k in left else "right",
                width=width[k] if k in prose else None,
                no_wrap=k not in prose,
                overflow="fold",
            )
        for i, r in enumerate(rows):
            last = i + 1 == len(rows) or rows[i + 1][0] != r[0]
            first = i == 0 or rows[i - 1][0] != r[0]
            t.add_row(
                *([r[0] if first else "", *r[1:]] if group else r), end_section=group and last and i + 1 < len(rows)
            )
        console.print(t)
        return
    if title:
        say("bold", title)
    hw = max((len(h) for h in headers[labels:]), default=0)
    for r in rows:
        say("bold", " ".join(c for c in r[:labels] if c))
        for h, c in zip(headers[labels:], r[labels:]):
            console.print(f"  {h:<{hw}}  {c}", soft_wrap=True)
    if caption:
        console.print(caption)


def table_rows(table: _core.Table, length: str, angle: str) -> list[dict]:
    """The table's rows in display units (:func:`denavit.io.units.cell_scale`), keyed by column name."""
    return [
        {c: float(v / cell_scale(table, i, k, length, angle)[0]) for k, (c, v) in enumerate(zip(table.columns, row))}
        for i, row in enumerate(table.params)
    ]


def print_table(table: _core.Table, names: list[str], length: str, angle: str, title: str) -> None:
    """A parameter table with each column's unit in its header and the digits of that unit."""
    prismatic_poe = table.convention == "poe" and "prismatic" in table.kinds
    units = [column_scale(table, k, length, angle)[1] for k in range(len(table.columns))]
    rows = [
        [n, *(num(v, cell_scale(table, i, k, length, angle)[1]) for k, v in enumerate(row.values()))]
        for i, (n, row) in enumerate(zip(names, table_rows(table, length, angle)))
    ]
    print_rows(
        title,
        ["joint", *(f"{c} [{u}]" for c, u in zip(table.columns, units))],
        rows,
        caption="v of a prismatic joint: its unit direction [1]" if prismatic_poe else None,
    )


def calib_unit(unit: str, length: str, angle: str) -> tuple[str, float]:
    """Display unit and scale (SI per display unit) of a calibration parameter ("length" | "angle" | "ratio")."""
    from ..io.units import angle_scale, length_scale  # noqa: PLC0415

    if unit == "length":
        return length, length_scale(length)
    if unit == "angle":
        return angle, angle_scale(angle)
    if unit in ("rad/(N m)", "m/N"):  # a joint compliance (calibration/compliance.py)
        return ("urad/(N m)" if unit == "rad/(N m)" else "um/N"), 1e-6
    return "1", 1.0


def convention_name(name: str) -> str:
    """The canonical name of a convention (the core's one parser: dh, sdh, mdh, craig, modified-dh, edh, poe)."""
    from .. import _core  # noqa: PLC0415

    return _core.convention_info(name)["name"]


def require_plot_extra(report=None, plot=None) -> None:
    """Before any work: ``--report`` needs plotly and ``--plot`` matplotlib (the ``plot`` extra); a missing one is a
    one-line error with the command that installs it for this installation (:func:`denavit.plotting.install_hint`),
    not a failure after the fit (issue 40)."""
    import importlib.util  # noqa: PLC0415

    need = [(opt, mod) for opt, given, mod in (("--report", report, "plotly"), ("--plot", plot, "matplotlib")) if given]

    def absent(mod: str) -> bool:
        try:
            return importlib.util.find_spec(mod) is None
        except (ImportError, ValueError):  # a broken or blocked installation is no installation
            return True

    missing = [(opt, mod) for opt, mod in need if absent(mod)]
    if missing:
        from ..plotting import install_hint  # noqa: PLC0415

        what = ", ".join(f"{opt} needs {mod}" for opt, mod in missing)
        raise DenavitError(f"{what}, which is not installed: {install_hint()}")
