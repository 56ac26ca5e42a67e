"""JSON values of denavit's data files (sweeps and poses, :mod:`denavit.io.sweeps`, :mod:`denavit.io.measurements`):
the document parsed with duplicate keys refused, arrays of a given depth and length checked, lengths scaled, the
payload read and written, unknown keys named, in one-line errors that say where."""

from __future__ import annotations

import json

import numpy as np

from ..errors import DenavitError
from . import delimited as dl
from .units import mass_scale


def show_value(value) -> str:
    """A short JSON rendering of a value for messages."""
    if isinstance(value, list) and len(value) > 6:
        return f"a list of {len(value)}"
    try:
        text = json.dumps(value)
    except (ValueError, RecursionError):
        text = type(value).__name__
    return text if len(text) <= 60 else text[:57] + "..."


def load_json(text: str, where: str):
    """The document of a JSON text, strictly: NaN and Infinity (not JSON, RFC 8259) and an integer beyond the
    float range are read as non-finite numbers, which every reader refuses at their place; a key given twice
    in one object, nesting deeper than Python's recursion limit and malformed JSON are one-line errors."""

    def unique(pairs):
        keys = [k for k, _ in pairs]
        dup = sorted({k for k in keys if keys.count(k) > 1})
        if dup:
            raise DenavitError(
                f"{where}: key(s) {', '.join(map(repr, dup))[:80]} given twice in one object: expected each once"
            )
        return dict(pairs)

    try:
        return json.loads(
            text,
            parse_constant=float,
            parse_int=lambda t: int(t) if len(t) < 19 else float(t),
            object_pairs_hook=unique,
        )
    except json.JSONDecodeError as e:
        raise DenavitError(f"{where}:{e.lineno}: not valid JSON: {e.msg} (column {e.colno})") from None
    except RecursionError:
        raise DenavitError(f"{where}: not readable JSON: lists or objects nested too deeply") from None


def json_array(value, n: int | None, depth: int, where: str) -> np.ndarray:
    """A JSON value of ``depth`` nested lists of finite numbers (the innermost of ``n`` numbers, or any number
    >= 1 when ``n`` is None) as a float array; each number through :func:`denavit.io.delimited.as_number`, and
    errors name the place (``points[3][1]``)."""
    if depth == 1:
        if not isinstance(value, list) or not value or (n is not None and len(value) != n):
            raise DenavitError(
                f"{where}: expected a list of {n if n is not None else 'one or more'} numbers, got {show_value(value)}"
            )
        return np.array([dl.as_number(v, f"{where}[{i}]") for i, v in enumerate(value)])
    if not isinstance(value, list) or not value:
        raise DenavitError(
            f"{where}: expected a list of rows{f' of {n} numbers' if n is not None and depth == 2 else ''}, got"
            f" {show_value(value)}"
        )
    rows = [json_array(v, n, depth - 1, f"{where}[{i}]") for i, v in enumerate(value)]
    bad = next((i for i, r in enumerate(rows) if r.shape != rows[0].shape), None)
    if bad is not None:
        a, b = rows[bad].shape, rows[0].shape
        a, b = (a[0], b[0]) if a[0] != b[0] else (a, b)
        raise DenavitError(
            f"{where}[{bad}]: rows of different lengths ({a} here, {b} in the first row): expected a rectangular array"
        )
    return np.array(rows)


def json_lengths(values: np.ndarray, scale: float, where: str) -> np.ndarray:
    """(m, 3) coordinates in metres (``scale`` m per file unit), each within :data:`denavit.io.delimited.MAX_LENGTH`;
    an error names the first one beyond (``points[4][2]``)."""
    out = np.asarray(values, dtype=float) * scale
    bad = np.argwhere(np.abs(out) > dl.MAX_LENGTH)
    if bad.size:
        i, j = bad[0]
        dl.far(out[i, j], f"{where}[{i}][{j}]")
    return out


def json_payload(obj: dict, m: int, units: dict, ls: float, at: str, rows: str = "pose") -> np.ndarray | None:
    """(m, 4) SI payload rows ``[mass kg, x, y, z m]`` of a JSON object's ``payload_mass`` and ``payload_com``
    (issue 37), or None without them. ``payload_mass``: one number for all ``m`` rows or a list of one per row, in
    the declared ``units["mass"]`` (required with a payload: a JSON number has no unit); ``payload_com``: the centre
    of mass in the flange frame in the length unit (``ls`` m per unit), one ``[x, y, z]`` for all rows or a list of
    one per row; default the flange origin. ``at`` prefixes the keys in errors (``"s.json: "``, ``"s.json:
    sweeps[2]."``).
    """
    if "payload_mass" not in obj:
        if "payload_com" in obj:
            raise DenavitError(f"{at}payload_com without payload_mass: give the payload's mass with its centre of mass")
        return None
    if "mass" not in units:
        raise DenavitError(
            f'{at}payload_mass: the mass unit is not declared: expected "units": {{"mass": "kg"}} (kg or g) '
            "with a payload"
        )
    unit = units["mass"]
    ms = mass_scale(unit, f"{at}payload_mass: units")
    value = obj["payload_mass"]
    if isinstance(value, list):
        if len(value) != m:
            raise DenavitError(
                f"{at}payload_mass: expected one number for every {rows} or a list of {m} (one per {rows}), "
                f"got {show_value(value)}"
            )
        mass = np.array([dl.as_number(v, f"{at}payload_mass[{i}]") for i, v in enumerate(value)])
    else:
        mass = np.full(m, dl.as_number(value, f"{at}payload_mass"))
    bad = np.flatnonzero(~(mass >= 0))
    if bad.size:
        place = f"payload_mass[{bad[0]}]" if isinstance(value, list) else "payload_mass"
        raise DenavitError(f"{at}{place}: expected a mass >= 0 {unit}, got {mass[bad[0]]:g} {unit}")
    out = np.zeros((m, 4))
    out[:, 0] = mass * ms
    com = obj.get("payload_com")
    if com is not None:
        per_row = isinstance(com, list) and bool(com) and isinstance(com[0], list)
        if per_row and len(com) != m:
            raise DenavitError(
                f"{at}payload_com: expected one [x, y, z] for every {rows} or a list of {m} (one per {rows}), "
                f"got {show_value(com)}"
            )
        c = json_array(com, 3, 2 if per_row else 1, f"{at}payload_com")
        out[:, 1:] = json_lengths(c.reshape(-1, 3), ls, f"{at}payload_com")
    return out


def json_payload_doc(payload: np.ndarray, ls: float) -> dict:
    """The ``payload_mass`` (kg) and ``payload_com`` (length unit, ``ls`` m per unit) keys of (m, 4) SI payload rows
    (:func:`json_payload`): each one value for all rows when it is the same in all, else one per row; no
    ``payload_com`` at the flange origin."""
    pl = np.asarray(payload, dtype=float)
    mass, com = pl[:, 0], pl[:, 1:] / ls
    d: dict = {"payload_mass": float(mass[0]) if np.all(mass == mass[0]) else mass.tolist()}
    if np.any(com != 0):
        d["payload_com"] = com[0].tolist() if np.all(com == com[0]) else com.tolist()
    return d


#: The payload's keys of a JSON pose or sweep object (:func:`json_payload`).
PAYLOAD_KEYS = ("payload_mass", "payload_com")


def about_payload(obj: dict, unknown: list) -> bool:
    """Whether an unknown-key message should name :data:`PAYLOAD_KEYS` too: the object gives a payload, or an unknown
    key is about one (``"payload_mas"``); other objects' messages list only the keys they use."""
    return any(k in obj for k in PAYLOAD_KEYS) or any("payload" in str(k).lower() for k in unknown)


def check_keys(obj: dict, expected: tuple, where: str, optional: tuple = ()) -> None:
    """An object's keys must be expected ones (or ``optional``, named where :func:`about_payload`): a misspelt key
    ("Q" for "q") must not be skipped."""
    unknown = [k for k in obj if k not in expected + optional]
    if unknown:
        named = expected + (optional if about_payload(obj, unknown) else ())
        raise DenavitError(f"{where}: unknown key(s) {', '.join(map(repr, unknown))[:80]}: expected {', '.join(named)}")
