"""The command line's frame: the typer app, its commands' classes (help reflowed, ``--json [PATH]``, ``--force``,
outputs and units checked before the work starts), and :data:`COMMANDS`, the registry each command module is
imported from when that command runs or shows its help. What the commands share lives by concern beside it:
:mod:`.options` (the options declared once), :mod:`.console` (printing), :mod:`.outputs` (JSON and files
written), :mod:`.values` (numbers, joint values, poses and robots from the command line).

The grammar every command follows (units, physical defaults, ``--json [PATH]`` in SI, exit codes, terminal output)
is docs/cli.md.
"""

from __future__ import annotations

import os
import sys
from typing import Annotated

import typer
from typer.core import TyperCommand, TyperGroup

try:
    from typer._coercion import PassThroughRuntimeParam  # typer >= 0.2x coerces values with pydantic (see _flags)
except ImportError:
    PassThroughRuntimeParam = None

from ..errors import DenavitError
from ..io.output import check_writable
from ..io.units import angle_scale, length_scale
from .console import console
from .options import ForceOpt
from .outputs import STDOUT, json_argv
from .values import say_deprecated


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
        from ..io.units import typed_units  # noqa: PLC0415

        with (
            forcing(bool(ctx.params.pop("force", False))),  # --force reaches every write of the command
            typed_units(_typed(ctx)),  # a file declaring other units than --length / --angle typed: a warning
        ):
            _check_units(ctx)
            _check_outputs(ctx)
            say_deprecated(done=False)
            done = False
            try:
                result = super().invoke(ctx)
                done = True
            except typer.Exit as e:
                done = e.exit_code in (0, 1)  # done (1: the goal not met): the deprecated spellings used, said last
                raise
            finally:
                console.file = (
                    None  # back to standard output after a --json - run (json_target), for the next in-process call
                )
                say_deprecated(done)
            return result


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


def _typed(ctx) -> dict[str, str]:  # noqa: ANN001 (click's context)
    """The ``--length`` / ``--angle`` the user typed (not their defaults): ``{"angle": "rad"}``. (The source by its
    name: typer may run its own copy of click, whose ParameterSource is not click's.)"""
    return {
        name: value
        for name in ("length", "angle")
        if isinstance(value := ctx.params.get(name), str)
        and getattr(ctx.get_parameter_source(name), "name", None) == "COMMANDLINE"
    }


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
                    f"{opt} {out}: is the input file {inp} ({name}): an output never replaces an input; name another"
                    " file"
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
    "check": (
        "check",
        (
            "Check a robot against its registered model with a few measured poses: a chi-square test of the residuals"
            " against the model's own covariance and the tracker noise, at a stated false-alarm rate. Exit code 1 when"
            " the robot has changed. A registered robot's check is recorded in the registry."
        ),
    ),
    "compensate": (
        "compensate",
        (
            'Compensate a program (RoboDK\'s "filtering"): for each position, the joint values that reach it on'
            " the identified robot (on the program's branch) and the pose T' = FK_nominal(q) to send to a controller"
            " that keeps its nominal model. Flagged rows (unreachable, branch changed, path jump) are marked, never"
            " silently kept; exit code 1 when any row is flagged."
        ),
    ),
    "convert": ("convert", "Express a robot in another convention through its joint axes, with the FK-parity check."),
    "dynamics": (
        "dynamics",
        "Inverse dynamics (recursive Newton-Euler): the joint torques (N m) / forces (N) for q, qd, qdd.",
    ),
    "fleet": (
        "fleet",
        "Every robot's calibrations in one registry: fleet add | run | status | diff | export (fleet --help).",
    ),
    "fk": ("fk", "Forward kinematics: the tool pose and every joint frame (T_world_joint)."),
    "identify": (
        "identify",
        "Identify the joint axes and parameters from joint sweeps (Hayat et al.), beside the nominal values.",
    ),
    "ik": (
        "ik",
        (
            "Inverse kinematics: joint values that put the tool at --pose, judged from the measured final error against"
            " the tolerances."
        ),
    ),
    "inspect": (
        "inspect",
        (
            "Print what a recording holds: the reader used, joints, targets, rates and units, and the sweeps the"
            " segmentation finds (joint, rows, start and end, dwell left out), for checking before `identify`."
        ),
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
        (
            "Print a robot file (TOML) in --length / --angle units (or, with --json, the robot as JSON in SI), or write"
            " a UR kinematics-parameters file."
        ),
    ),
    "simulate": (
        "simulate",
        "Simulate joint sweeps of a model (for planning a measurement and for tests); writes the long-form CSV.",
    ),
    "validate": (
        "validate",
        (
            "Score a saved model on another measurement session: per-pose tool-position errors, RMS, max and"
            " percentiles, extrapolation flags (outside the training joint ranges, large predicted sigma), ISO 9283"
            " pose accuracy and repeatability of repeated poses."
        ),
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
    help=(
        "Find the true kinematic geometry of serial robots and compute with it. Lengths in mm and angles in degrees "
        "unless --length/--angle say otherwise; JSON always in SI (docs/cli.md)."
    ),
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
