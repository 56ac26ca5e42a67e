"""Payloads and joint compliances at the edge (issue 37): their units, a robot file's ``[compliance]`` section, the
CLI's ``--payload "5 kg @ 0,0,80 mm"`` and the ``payload_mass, payload_x, payload_y, payload_z`` columns of pose files.

Inside everything is SI: a payload is ``(mass kg, x, y, z m)``, its centre of mass in the flange frame; a compliance
is rad/(N m) for a revolute joint and m/N for a prismatic one (:mod:`denavit.calibration.compliance`).

A robot file's section (values in the units it declares; ``prismatic_unit`` only where a joint is prismatic)::

    [compliance]
    unit = "urad/(N m)"          # revolute joints: rad/(N m), mrad/(N m), urad/(N m), deg/(N m)
    prismatic_unit = "um/N"      # prismatic joints: m/N, mm/N, um/N
    values = [0, 1.5, 2.2, 4, 5, 5]
    covariance = [[...], ...]    # optional: n x n, in the units' products (written by calibrate --save)
    cross_covariance = [[...], ...]   # optional (calibrate --save): each [covariance] entry's (rows, in its order)
                                 # with each compliance (n columns), in the products of their units
    flange = {xyz = [0, 0, 82.3], rpy = [0, 0, 0]}   # optional: where a payload's centre of mass is given, in the
                                 # table's last frame (length / angle units; default that frame)
"""

from __future__ import annotations

import math
import re

import numpy as np

from ..errors import DenavitError
from .units import angle_scale, length_scale, mass_scale

#: The angle parts of a revolute compliance unit (per N m): :data:`denavit.io.units.ANGLE` and milli- / microradians.
REVOLUTE_UNITS = ("rad", "mrad", "urad", "deg")
#: The length parts of a prismatic compliance unit (per N): :data:`denavit.io.units.LENGTH`'s.
PRISMATIC_UNITS = ("m", "mm", "um")
#: The mass units of a payload (:data:`denavit.io.units.MASS`).
MASS_UNITS = ("kg", "g")
#: The payload columns of a pose file: the mass (kg, or the file's declared ``mass`` unit), the centre of mass in the
#: flange frame in the file's length unit. JSON files carry ``payload_mass`` and ``payload_com`` (``[x, y, z]``)
#: instead (:func:`denavit.io.sweeps.json_payload`).
PAYLOAD_COLUMNS = ("payload_mass", "payload_x", "payload_y", "payload_z")


def compliance_unit(text, kind: str, where: str) -> float:
    """SI per unit of a compliance unit: ``"rad/(N m)"`` (also ``rad/Nm``, ``rad/(N*m)``, ``rad/N/m``; ``mrad``,
    ``urad``, ``deg``) for a revolute joint, ``"m/N"`` (``mm/N``, ``um/N``) for a prismatic one."""
    if not isinstance(text, str):
        raise DenavitError(
            f'{where}: expected a compliance unit such as "rad/(N m)" (revolute) or "m/N" (prismatic), got {text!r}'
        )
    s = re.sub(r"[\s*·.()]", "", text).lower()
    if kind == "revolute":
        m = re.fullmatch(r"([a-z]+)/(?:nm|n/m)", s)
        if m and m.group(1) in REVOLUTE_UNITS:
            a = m.group(1)
            return {"m": 1e-3, "u": 1e-6}[a[0]] * angle_scale("rad") if a in ("mrad", "urad") else angle_scale(a)
        raise DenavitError(
            f"{where}: unknown compliance unit {text!r} for revolute joints: expected an angle per torque, one of "
            f"{', '.join(f'{u}/(N m)' for u in REVOLUTE_UNITS)}"
        )
    m = re.fullmatch(r"([a-z]+)/n", s)
    if m and m.group(1) in PRISMATIC_UNITS:
        return length_scale(m.group(1))
    raise DenavitError(
        f"{where}: unknown compliance unit {text!r} for prismatic joints: expected a length per force, one of "
        f"{', '.join(f'{u}/N' for u in PRISMATIC_UNITS)}"
    )


def _numbers(value, n: int, where: str) -> list[float]:
    from .delimited import as_number  # noqa: PLC0415

    if not isinstance(value, list) or len(value) != n:
        raise DenavitError(f"{where}: expected a list of {n} numbers (one per joint), got {value!r}"[:200])
    return [as_number(v, f"{where}[{i}]") for i, v in enumerate(value)]


def read_compliance(
    spec, kinds: list, names: list, has_inertials: bool, where: str, geometry=None
) -> tuple[np.ndarray, np.ndarray | None, np.ndarray | None]:
    """(compliances (n,) SI, covariance (n, n) SI or None, cross-covariance (P, n) SI or None) of a robot file's
    ``[compliance]`` table (module docstring). ``geometry``: (the file's ``[covariance]`` (P, P) SI, SI per file unit
    of each of its P entries), or None without one."""
    if not isinstance(spec, dict):
        raise DenavitError(f"{where}: expected a table with 'unit' and 'values', got {spec!r}"[:200])
    unknown = [k for k in spec if k not in ("unit", "prismatic_unit", "values", "covariance", "cross_covariance")]
    if unknown:
        raise DenavitError(
            f"{where}: unknown key(s) {', '.join(map(repr, unknown))}: expected unit, prismatic_unit, values,"
            " covariance, cross_covariance"
        )
    if not has_inertials:
        raise DenavitError(
            f"{where}: joint compliances need the links' inertial parameters ([joints.inertia]) to give the gravity"
            " torques the joints twist under; the file gives none"
        )
    n = len(kinds)
    scale = np.ones(n)
    for kind, key in (("revolute", "unit"), ("prismatic", "prismatic_unit")):
        if kind not in kinds:
            continue
        if key not in spec:
            example = 'unit = "rad/(N m)"' if kind == "revolute" else 'prismatic_unit = "m/N"'
            raise DenavitError(f"{where}: missing '{key}' (the unit of the {kind} joints' compliances, e.g. {example})")
        scale[[k == kind for k in kinds]] = compliance_unit(spec[key], kind, f"{where}: {key}")
    if "values" not in spec:
        raise DenavitError(f"{where}: missing 'values' (one compliance per joint, in 'unit')")
    raw = np.array(_numbers(spec["values"], n, f"{where}: values"))
    bad = np.flatnonzero(raw < 0)
    if bad.size:
        j = bad[0]
        raise DenavitError(
            f"{where}: values: joint {j + 1} ({names[j]}): expected a compliance >= 0 (a joint gives way under its"
            f" torque), got {raw[j]:g} {spec.get('unit' if kinds[j] == 'revolute' else 'prismatic_unit')}"
        )
    cov = None
    if "covariance" in spec:
        rows = spec["covariance"]
        if not isinstance(rows, list) or len(rows) != n:
            raise DenavitError(
                f"{where}: covariance: expected {n} rows of {n} numbers (in the units' products), got"
                f" {len(rows) if isinstance(rows, list) else rows!r}"
            )
        cov = np.array([_numbers(r, n, f"{where}: covariance row {i + 1}") for i, r in enumerate(rows)]) * np.outer(
            scale, scale
        )
        if not np.allclose(cov, cov.T, rtol=1e-9, atol=0) or np.linalg.eigvalsh((cov + cov.T) / 2).min() < -1e-9 * max(
            np.abs(np.diag(cov)).max(), 1e-300
        ):
            raise DenavitError(f"{where}: covariance: expected a symmetric positive semi-definite matrix")
    return raw * scale, cov, _cross(spec.get("cross_covariance"), cov, scale, geometry, where)


def _cross(rows, cov, scale: np.ndarray, geometry, where: str) -> np.ndarray | None:
    """The ``cross_covariance`` (P, n) SI of a ``[compliance]`` table (None: not given): each ``[covariance]`` entry's
    covariance with each compliance, in the products of their units; the joint matrix positive semi-definite."""
    if rows is None:
        return None
    if geometry is None or cov is None:
        missing = " and ".join(w for w, v in (("the [covariance]", geometry), ("the covariance", cov)) if v is None)
        raise DenavitError(
            f"{where}: cross_covariance: expected it beside the file's [covariance] and this table's covariance (it"
            f" holds their entries' covariances with each other), got it without {missing}"
        )
    C, s = geometry
    n = len(scale)
    if not isinstance(rows, list) or len(rows) != len(s):
        raise DenavitError(
            f"{where}: cross_covariance: expected {len(s)} rows (one per [covariance] entry) of {n} numbers (one per"
            f" joint), got {len(rows) if isinstance(rows, list) else rows!r}"
        )
    X = np.array([_numbers(r, n, f"{where}: cross_covariance row {i + 1}") for i, r in enumerate(rows)])
    X = X * np.outer(s, scale)
    full = np.block([[C, X], [X.T, cov]])
    d = np.sqrt(np.abs(np.diag(full)))
    d[d == 0] = 1.0
    # (as correlations: the entries' units differ by orders of magnitude, m^2 beside (rad/(N m))^2)
    if np.linalg.eigvalsh((full + full.T) / 2 / np.outer(d, d)).min() < -1e-8:
        raise DenavitError(
            f"{where}: cross_covariance: expected the covariance of [covariance]'s entries and the compliances"
            " together positive semi-definite (a correlation beyond 1)"
        )
    return X


def compliance_spec(
    values: np.ndarray,
    covariance: np.ndarray | None,
    kinds: list,
    unit: str = "urad/(N m)",
    prismatic_unit: str = "um/N",
    cross=None,
) -> dict:
    """The ``[compliance]`` table of compliances (SI) in ``unit`` / ``prismatic_unit``; ``cross``: (the cross-covariance
    (P, n) SI of the ``[covariance]`` entries with them, SI per file unit of each entry), or None."""
    scale = np.array([compliance_unit(unit if k == "revolute" else prismatic_unit, k, "compliance") for k in kinds])
    out: dict = {"unit": unit}
    if "prismatic" in kinds:
        out["prismatic_unit"] = prismatic_unit
    out["values"] = [float(f"{v:.15g}") for v in np.asarray(values, dtype=float) / scale]
    if covariance is not None:
        out["covariance"] = [
            [float(v) for v in row] for row in np.asarray(covariance, dtype=float) / np.outer(scale, scale)
        ]
    if cross is not None:
        X, s = cross
        if np.shape(X) != (len(s), len(kinds)):
            raise DenavitError(
                f"compliance_cross: expected shape ({len(s)}, {len(kinds)}) (one row per covariance entry, one column"
                f" per joint), got {np.shape(X)}"
            )
        out["cross_covariance"] = [[float(v) for v in row] for row in np.asarray(X, dtype=float) / np.outer(s, scale)]
    return out


_PAYLOAD = re.compile(r"\s*([-+0-9.eE]+)\s*([A-Za-z]*)\s*(?:@\s*(.+))?")


def parse_payload(text: str, length: str = "mm", where: str = "--payload") -> tuple[float, np.ndarray]:
    """``"5 kg @ 0,0,80 mm"`` as (mass kg, centre of mass (3,) m in the flange frame). The mass needs its unit (kg,
    g); the centre of mass defaults to the flange origin, its numbers in their own unit or ``length``."""
    m = _PAYLOAD.fullmatch(str(text))
    expected = (
        f'{where}: expected a mass with its unit and optionally its centre of mass in the flange frame, e.g. "5 kg @'
        ' 0,0,80 mm"'
    )
    if m is None:
        raise DenavitError(f"{expected}; got {text!r}")
    num, unit, com = m.groups()
    if not unit:
        raise DenavitError(
            f"{where}: the payload's mass {num} has no unit: expected one of {', '.join(MASS_UNITS)}, e.g. \"5 kg @"
            ' 0,0,80 mm"'
        )
    if unit not in MASS_UNITS:
        raise DenavitError(f"{where}: unknown mass unit {unit!r}: expected one of {', '.join(MASS_UNITS)}")
    try:
        mass = float(num) * mass_scale(unit, where)
    except ValueError:
        raise DenavitError(f"{expected}; got {text!r}") from None
    if not (math.isfinite(mass) and 0 <= mass <= 1e5):
        raise DenavitError(
            f"{where}: expected a payload mass >= 0 kg (and at most 100 t), got {text.split('@')[0].strip()!r}"
        )
    c = np.zeros(3)
    if com is not None:
        cm = re.fullmatch(r"\s*([-+0-9.eE]+)\s*,\s*([-+0-9.eE]+)\s*,\s*([-+0-9.eE]+)\s*([A-Za-z]*)\s*", com)
        if cm is None:
            raise DenavitError(
                f"{where}: expected the centre of mass as x,y,z with an optional length unit after '@', got"
                f" {com.strip()!r}"
            )
        ls = length_scale(cm.group(4) or length, where)
        try:
            c = np.array([float(cm.group(k)) for k in (1, 2, 3)]) * ls
        except ValueError:
            raise DenavitError(
                f"{where}: expected the centre of mass as three numbers x,y,z, got {com.strip()!r}"
            ) from None
        if not np.all(np.isfinite(c)) or np.any(np.abs(c) > 1e3):
            raise DenavitError(
                f"{where}: the centre of mass must be finite and within 1 km of the flange, got {com.strip()!r}"
            )
    return mass, c


def payload_rows(mass: float, com, n: int) -> np.ndarray:
    """(n, 4) rows ``[mass kg, x, y, z m]`` of one payload for every pose."""
    return np.tile(np.r_[float(mass), np.asarray(com, dtype=float).reshape(3)], (n, 1))


def payload_from_columns(table: np.ndarray, cols: dict, ls: float, where, mass_unit: str = "kg") -> np.ndarray:
    """(N, 4) SI payload rows from a numeric table and ``cols`` (a payload column name -> its index): the mass in
    ``mass_unit`` (the file's declared ``mass``, else kg), the centre of mass in the file's length unit (``ls`` m per
    unit; missing coordinates 0). A negative mass is an error naming its line (``where[i]``)."""
    ms = mass_scale(mass_unit, "units: mass")
    out = np.zeros((len(table), 4))
    out[:, 0] = table[:, cols["payload_mass"]] * ms
    for k, c in enumerate(PAYLOAD_COLUMNS[1:], 1):
        if c in cols:
            out[:, k] = table[:, cols[c]] * ls
    bad = np.flatnonzero(~(out[:, 0] >= 0) | ~np.all(np.isfinite(out), axis=1))
    if bad.size:
        i = bad[0]
        raise DenavitError(
            f"{where[i]}: payload_mass: expected a mass >= 0 {mass_unit} and a finite centre of mass, "
            f"got {out[i, 0] / ms:g} {mass_unit} at {(out[i, 1:] / ls).tolist()}"
        )
    return out
