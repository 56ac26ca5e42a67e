"""Where robots are found and read: built-in names (the package's ``denavit/models/*.toml``), robot files (TOML,
:mod:`denavit.io.robotfile`) and URDFs (:mod:`denavit.io.urdf`), as :class:`denavit.robot.Robot` records."""

from __future__ import annotations

import os
from importlib import resources
from pathlib import Path

from .. import _core
from ..errors import DenavitError
from ..robot import Robot, robot_of


def builtin_names() -> list[str]:
    """Names of the built-in robot files."""
    return sorted(p.name[:-5] for p in resources.files("denavit.models").iterdir() if p.name.endswith(".toml"))


def resolve(name_or_path: str | os.PathLike) -> Path:
    """The file of a built-in name or a path; a clear error listing the built-ins otherwise."""
    p = Path(name_or_path)
    if p.suffix and p.exists():
        return p
    if p.exists() and p.is_file():
        return p
    key = str(name_or_path).lower().replace("-", "_")
    if key in builtin_names():
        return Path(str(resources.files("denavit.models").joinpath(key + ".toml")))
    raise DenavitError(
        f"unknown model {str(name_or_path)!r}: expected a built-in name ({', '.join(builtin_names())}) or an existing"
        " robot file (.toml) or URDF (.urdf)"
    )


def load(
    name_or_path: str | os.PathLike,
    *,
    base_link: str | None = None,
    tip_link: str | None = None,
    chain_only: bool = False,
    locked: dict | None = None,
) -> Robot:
    """The :class:`Robot` of a built-in name, a robot file (.toml, :mod:`denavit.io.robotfile`) or a URDF
    (.urdf, :mod:`denavit.io.urdf`; ``base_link`` / ``tip_link`` pick its chain; the links off it are merged
    into the chain's dynamics, their movable joints at ``locked`` ({joint: value}, default 0), unless
    ``chain_only``). SI inside."""
    path = resolve(name_or_path)
    if path.suffix.lower() == ".urdf":
        from .urdf import load_urdf  # noqa: PLC0415 (yourdfpy and lxml load only for a URDF)

        return load_urdf(path, base_link=base_link, tip_link=tip_link, chain_only=chain_only, locked=locked)
    if base_link is not None or tip_link is not None or chain_only or locked:
        raise DenavitError(f"{path}: base_link/tip_link/chain_only/locked apply to a URDF, got a robot file")
    if path.suffix.lower() == ".json":  # (a robot file is TOML: read as one, it had been 'Invalid statement')
        raise DenavitError(
            f"{path}: a JSON file is not a robot model (calibrate's and identify's --json is their report): expected a"
            " robot file (.toml, e.g. from --save) or a URDF"
        )
    if path.suffix.lower() in (".yaml", ".yml"):
        raise DenavitError(
            f"{path}: a YAML file is not a robot model here (a UR kinematics file, export --ur-kinematics, is a bare"
            " chain: denavit.io.ur_calibration.read in Python, with its nominal): expected a robot file (.toml) or a"
            " URDF"
        )
    from .robotfile import read  # noqa: PLC0415

    return read(path)


def as_robot(nominal) -> Robot:
    """``nominal`` (a Robot, a Model, a built-in name, or a robot file or URDF as ``str`` or ``os.PathLike``) as a
    :class:`Robot`."""
    if isinstance(nominal, (str, os.PathLike)):
        return load(nominal)
    if isinstance(nominal, (Robot, _core.Model)):
        return robot_of(nominal)
    raise DenavitError(
        f"nominal: expected a Robot, a Model, a built-in name or a robot file, got {type(nominal).__name__}"
    )
