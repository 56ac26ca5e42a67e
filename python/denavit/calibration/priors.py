"""Plausible-size priors of a calibration (issue 36): every geometric parameter is a Gaussian about its nominal
value, one sigma wide by kind (manufacturing tolerances), and the fit is maximum a posteriori: the prior rows
``(x_c - nominal_c) / width_c`` are appended to the whitened least-squares problem (Tikhonov / ridge about the
nominal), so a parameter the data barely determine stays near its nominal value instead of swinging.

Kinds (defaults in :data:`DEFAULT_WIDTHS`, SI):

* ``length``: link lengths and offsets of the convention (``a``, ``b``, ``c``, ``d``), and the zero offset of a
  prismatic joint: 1 mm, a machined part's and an assembly's tolerance;
* ``angle``: link twists and Hayati tilts (``alpha``, ``beta``, a prismatic joint's ``theta``): 0.1 deg, i.e.
  1.7 mm over a metre;
* ``offset``: a revolute joint's zero offset: 0.1 deg, the size of a mastering error (the makers' reference
  marks and dial gauges repeat to about 0.01 deg; a careless mastering is off by tenths);
* ``scale``: joint-reading scales (``scale_i``): 100 ppm (a gear ratio's tolerance);
* ``compliance``: a joint's compliance ``k_i`` (:mod:`~denavit.calibration.compliance`), about the nominal's (0 without
  one): the deflection it allows under the largest gravity torque the joint holds in the data, 1 mrad (1 mm for a
  prismatic joint; a width typed for ``compliance`` is that deflection, in ``--angle``), so ``k_i``'s width is
  ``1 mrad / max |tau_i|``: the size of the published joint deflections of industrial arms and cobots at full load
  (0.1-2 mrad); a width typed for a parameter ``k_i`` by name is the compliance itself, SI;
* the base and tool registration (``base_*``, ``tool_*``) are uninformative (no prior): where the tracker stands
  and what is mounted on the flange are not the robot's geometry.

A width can be overridden per kind or per parameter name or shell pattern (``"a_5"``, ``"alpha_*"``):
:func:`as_prior` (Python) and :func:`parse_prior` (the CLI's ``--prior "length=1mm, angle=0.1deg, scale=100ppm"``).
"""

from __future__ import annotations

import fnmatch
import math
import re
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from ..errors import DenavitError

if TYPE_CHECKING:
    from .parametrization import Parametrization

#: The kinds of parameter that take a prior, and their default one-sigma widths (SI: m, rad, rad, ratio).
DEFAULT_WIDTHS = {"length": 1e-3, "angle": math.radians(0.1), "offset": math.radians(0.1), "scale": 1e-4}
#: The compliances' default width: the deflection (rad; m for a prismatic joint) under the largest torque in the data.
COMPLIANCE_WIDTH = 1e-3
#: A parameter whose posterior sigma is above this fraction of its prior width is "not determined beyond its
#: prior": the data alone would give it a sigma above 2.1 prior widths (``1 / sqrt(1 / 0.9^2 - 1)``). It is fixed at
#: its nominal value and listed.
PRIOR_DOMINATED = 0.9
#: The units a width may be typed in: SI per unit, and the dimension it belongs to.
WIDTH_UNITS = {
    "m": (1.0, "length"),
    "cm": (1e-2, "length"),
    "mm": (1e-3, "length"),
    "um": (1e-6, "length"),
    "in": (0.0254, "length"),
    "rad": (1.0, "angle"),
    "mrad": (1e-3, "angle"),
    "urad": (1e-6, "angle"),
    "deg": (math.pi / 180, "angle"),
    "arcmin": (math.pi / 180 / 60, "angle"),
    "arcsec": (math.pi / 180 / 3600, "angle"),
    "ppm": (1e-6, "ratio"),
    "%": (1e-2, "ratio"),
}
_KIND_DIMENSION = {"length": "length", "angle": "angle", "offset": "angle", "scale": "ratio", "compliance": "angle"}
_UNIT_DIMENSION = {
    "length": "length",
    "angle": "angle",
    "ratio": "ratio",
    "rad/(N m)": "compliance",
    "m/N": "compliance",
}


@dataclass(frozen=True)
class Prior:
    """Prior widths (one sigma, SI) per kind of parameter (:data:`DEFAULT_WIDTHS` keys) and per parameter name or
    pattern (``overrides``: pattern -> (width, dimension or None)); later overrides win over earlier ones and over
    the kinds."""

    widths: dict = field(default_factory=lambda: dict(DEFAULT_WIDTHS))
    overrides: tuple = ()
    #: SI per unit of an override given as a bare number, (length, angle) (the CLI's --length / --angle; SI in Python)
    bare: tuple = (1.0, 1.0)
    #: the compliances' width: the joint's deflection (rad, or m) under the largest gravity torque it holds in the data
    compliance: float = COMPLIANCE_WIDTH

    def sigma(self, pz: Parametrization) -> np.ndarray:
        """The prior width of every parameter of ``pz`` (SI; ``inf``: no prior, the base and tool registration)."""
        out = np.array(
            [
                self.compliance if k == "compliance" else self.widths[k] if k is not None else math.inf
                for k in (kind_of(pz, c) for c in range(pz.n_params))
            ],
            dtype=float,
        )
        for c, f in getattr(
            pz, "prior_factors", {}
        ).items():  # a compliance: the deflection's width per unit of the largest torque
            out[c] *= f
        for pat, (v, dim) in self.overrides:
            hits = [c for c, nm in enumerate(pz.names) if fnmatch.fnmatchcase(nm, pat)]
            if not hits:
                raise DenavitError(
                    f"prior: {pat!r} matches no parameter of the {pz.convention} model of {pz.robot.name}: expected a"
                    f" kind ({', '.join(DEFAULT_WIDTHS)}) or names or patterns of {', '.join(pz.names)}"
                )
            for c in hits:
                want = _UNIT_DIMENSION[pz.units[c]]
                if dim is not None and dim != want:
                    raise DenavitError(
                        f"prior: {pz.names[c]} is a{'n' if want == 'angle' else ''} {want}, got a width in {dim} units"
                        f" for {pat!r}"
                    )
                out[c] = (
                    v
                    if dim is not None
                    else v * (self.bare[0] if want == "length" else self.bare[1] if want == "angle" else 1.0)
                )
        return out


def kind_of(pz: Parametrization, c: int) -> str | None:
    """The prior kind of parameter ``c`` of ``pz`` (None: the registration, no prior)."""
    name = pz.names[c]
    if name.startswith(("base_", "tool_")):
        return None
    if name.startswith("scale_"):
        return "scale"
    if name.startswith("k_"):
        return "compliance"
    if name.startswith("offset_"):
        return "offset" if pz.units[c] == "angle" else "length"
    return "length" if pz.units[c] == "length" else "angle" if pz.units[c] == "angle" else "scale"


def _width(value, what: str) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise DenavitError(f"prior: expected a width (one sigma, SI) > 0 for {what}, got {value!r}") from None
    if not (math.isfinite(v) and v > 0):
        raise DenavitError(f"prior: expected a finite width (one sigma, SI) > 0 for {what}, got {value!r}")
    return v


def as_prior(prior) -> Prior | None:
    """``prior`` as a :class:`Prior`: None or True the defaults; False or ``"none"`` no prior (least squares); a
    :class:`Prior`; a dict of kind or parameter name / pattern -> width (SI: m, rad, or a ratio for scales), the
    kinds not given keeping their defaults; or a string in the CLI's grammar (:func:`parse_prior`; bare numbers SI)."""
    if prior is None or prior is True:
        return Prior()
    if prior is False:
        return None
    if isinstance(prior, Prior):
        return prior
    if isinstance(prior, str):
        return parse_prior(prior, 1.0, 1.0, "prior")
    if isinstance(prior, dict):
        widths = dict(DEFAULT_WIDTHS)
        over = []
        comp = COMPLIANCE_WIDTH
        for k, v in prior.items():
            key = str(k).strip()
            if key == "compliance":
                comp = _width(v, key)
            elif key in widths:
                widths[key] = _width(v, key)
            else:
                over.append((key, (_width(v, key), None)))
        return Prior(widths, tuple(over), compliance=comp)
    raise DenavitError(
        f"prior: expected None, True, False, a dict of kind or parameter -> width (SI) or a string such as "
        f'"length=1mm, angle=0.1deg", got {type(prior).__name__}'
    )


_ITEM = re.compile(r"\s*([A-Za-z_*?\[\]0-9]+)\s*=\s*([-+0-9.eE]+)\s*([A-Za-z%]*)\s*")


def parse_prior(text: str, length: float = 1e-3, angle: float = math.pi / 180, where: str = "--prior") -> Prior | None:
    """``"length=1mm, angle=0.1deg, offset=0.05deg, scale=100ppm, a_5=2mm"`` as a :class:`Prior` (kinds not given
    keep their defaults), ``"none"`` as None (no prior: least squares). A value's unit is one of
    :data:`WIDTH_UNITS`; a bare number is in the unit of ``length`` metres / ``angle`` radians (default mm and deg,
    the command line's: its ``--length`` / ``--angle`` scales, :func:`denavit.io.units.length_scale`) for a length /
    angle kind and a ratio for ``scale``, and so for a parameter name by the parameter's unit."""

    s = text.strip()
    if s.lower() in ("none", "off", "no"):
        return None
    widths = dict(DEFAULT_WIDTHS)
    over = []
    comp = COMPLIANCE_WIDTH
    expected = (
        f"{where}: expected KIND=WIDTH pairs separated by commas, KIND one of {', '.join(DEFAULT_WIDTHS)} or a"
        " parameter name "
        f'or pattern, WIDTH a number > 0 with a unit ({", ".join(WIDTH_UNITS)}), e.g. "length=1mm, angle=0.1deg,'
        ' scale=100ppm", or "none"'
    )
    for item in s.split(","):
        if not item.strip():
            continue
        m = _ITEM.fullmatch(item)
        if m is None:
            raise DenavitError(f"{expected}; got {item.strip()[:40]!r}")
        key, num, unit = m.group(1), m.group(2), m.group(3)
        try:
            v = float(num)
        except ValueError:
            raise DenavitError(f"{expected}; got {item.strip()[:40]!r}") from None
        if not (math.isfinite(v) and v > 0):
            raise DenavitError(f"{where}: expected a finite width > 0 for {key}, got {num}")
        dim = None
        if unit:
            if unit.lower() not in WIDTH_UNITS and unit not in WIDTH_UNITS:
                raise DenavitError(
                    f"{where}: unknown unit {unit!r} for {key}: expected one of {', '.join(WIDTH_UNITS)}"
                )
            f, dim = WIDTH_UNITS.get(unit, WIDTH_UNITS.get(unit.lower()))
            v *= f
        if key == "compliance":  # the deflection under the largest torque: an angle (bare in --angle)
            if dim not in (None, "angle"):
                raise DenavitError(
                    f"{where}: compliance is the joints' deflection under their largest torque, an angle, got a width"
                    f" in {unit}"
                )
            comp = v * (angle if dim is None else 1.0)
        elif key in widths:
            want = _KIND_DIMENSION[key]
            if dim is None:
                v *= length if want == "length" else angle if want == "angle" else 1.0
            elif dim != want:
                raise DenavitError(f"{where}: {key} is a{'n' if want == 'angle' else ''} {want}, got a width in {unit}")
            widths[key] = v
        else:
            over.append((key, (v, dim)))
    return Prior(widths, tuple(over), (length, angle), comp)


def prior_weights(sigma: np.ndarray, s2: float) -> np.ndarray:
    """The weights of the prior rows in the whitened problem: ``sqrt(s2) / sigma`` (0 where there is no prior), so
    that ``|r|^2 + |w (x - nominal)|^2`` is ``s2`` times the negative log posterior (``s2``: the noise variance in
    the whitened units of the residuals ``r``, 1 when the noise is known)."""
    with np.errstate(divide="ignore"):
        return np.where(np.isfinite(sigma), math.sqrt(s2) / sigma, 0.0)
