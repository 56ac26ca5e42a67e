"""Joint sweeps: the measurements of circle-point identification (Hayat et al. sec. III.A).

A sweep moves one joint with the others locked at the home configuration and records a point on the
end-effector in the measurement frame. This module holds the data model, the readers (long-form CSV, one
file per joint, JSON), the long-form CSV writer and the simulator used to plan measurements and to test.
Everything is SI inside (m, rad); files declare their units.
"""

from __future__ import annotations

import csv
import io
import json
import math
import os
import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from . import _core
from .errors import DenavitError
from .io.units import angle_scale, length_scale

# Hayat et al. Table II: range of motion given to each joint (deg), the paper's two protocols.
PAPER_RANGES_DEG = {
    90: [(-45.0, 45.0), (-60.0, -130.0), (120.0, 30.0), (90.0, 0.0), (90.0, 0.0), (0.0, 90.0)],
    30: [(-15.0, 15.0), (-60.0, -90.0), (120.0, 90.0), (90.0, 60.0), (90.0, 60.0), (0.0, 30.0)],
}
# Hayat et al. sec. III.A: the home configuration A1 90, A2 -90, A3 90, A4 0, A5 90, A6 0 (deg).
PAPER_HOME_DEG = [90.0, -90.0, 90.0, 0.0, 90.0, 0.0]


@dataclass(frozen=True)
class Sweep:
    """One joint moved with the others locked.

    joint : 1-based index of the moving joint.
    points : (m, 3) measured points in the measurement frame (m).
    q : (m, n) joint readings at each point (rad / m), or None when not recorded.
    where : (m,) where each point came from ("file:line"), for error messages.
    """

    joint: int
    points: np.ndarray
    q: np.ndarray | None
    where: list[str] = field(default_factory=list)

    @property
    def moving(self) -> np.ndarray | None:
        """(m,) readings of the moving joint, or None."""
        return None if self.q is None else self.q[:, self.joint - 1]


@dataclass(frozen=True)
class SweepSet:
    """All sweeps of one measurement: n joints, the home configuration, the sources."""

    sweeps: list[Sweep]
    n_joints: int
    home: np.ndarray
    kinds: list[str]
    source: str = ""
    units: dict = field(default_factory=lambda: {"length": "m", "angle": "rad"})

    def sweep(self, joint: int) -> Sweep:
        for s in self.sweeps:
            if s.joint == joint:
                return s
        raise DenavitError(f"{self.source}: no sweep of joint {joint}")

    @property
    def all_points(self) -> np.ndarray:
        return np.vstack([s.points for s in self.sweeps])

    @property
    def has_readings(self) -> bool:
        return all(s.q is not None for s in self.sweeps)


_UNITS_RE = re.compile(r"#\s*units\s*:\s*(.*)", re.IGNORECASE)


def _units_comment(lines: list[str]) -> dict:
    out = {}
    for line in lines:
        m = _UNITS_RE.match(line.strip())
        if m:
            for part in m.group(1).replace(",", " ").split():
                if "=" in part:
                    k, v = part.split("=", 1)
                    out[k.strip().lower()] = v.strip()
    return out


def _scales(units: dict, where: str) -> tuple[float, float]:
    if "length" not in units or "angle" not in units:
        raise DenavitError(f"{where}: units not declared: add a line '# units: length=mm angle=deg' or pass --length/--angle (got {units or 'none'})")
    return length_scale(units["length"], where), angle_scale(units["angle"], where)


def _float(text: str, where: str, column: str) -> float:
    try:
        v = float(text)
    except ValueError:
        hint = " (a decimal comma? write numbers with a decimal point)" if re.fullmatch(r"[-+]?\d+,\d+", text) else ""
        raise DenavitError(f"{where}: column {column!r} must be a number, got {text!r}{hint}") from None
    if not math.isfinite(v):
        raise DenavitError(f"{where}: column {column!r} must be finite, got {text!r}")
    return v


def _check_complete(sweeps: dict[int, list], n: int, where: str) -> None:
    missing = [j for j in range(1, n + 1) if j not in sweeps]
    if missing:
        raise DenavitError(f"{where}: missing sweeps of joint(s) {', '.join(map(str, missing))}: every joint 1..{n} needs one (got joints {sorted(sweeps)})")


def read_long_csv(path: str | os.PathLike, *, length: str | None = None, angle: str | None = None, kinds: list[str] | None = None, home=None) -> SweepSet:
    """Read the long-form CSV: header ``joint,q1,...,qn,x,y,z`` (optional ``time``), one row per point.

    ``joint`` is the moving joint's 1-based index; q1..qn every joint reading at that instant; x, y, z the
    point. Units come from a ``# units: length=mm angle=deg`` comment line, or from ``length`` / ``angle``
    (which win). ``home`` (rad / m, SI) defaults to the readings of the locked joints.
    """
    path = Path(path)
    text = path.read_text(encoding="utf-8")
    lines = text.splitlines()
    units = _units_comment(lines)
    if length:
        units["length"] = length
    if angle:
        units["angle"] = angle
    ls, as_ = _scales(units, str(path))
    data_lines = [(i + 1, line) for i, line in enumerate(lines) if line.strip() and not line.lstrip().startswith("#")]
    if not data_lines:
        raise DenavitError(f"{path}: no header and no data: expected a header 'joint,q1,...,qn,x,y,z'")
    hline, header = data_lines[0]
    delim = ";" if header.count(";") > header.count(",") else ","
    cols = [c.strip().lower() for c in header.split(delim)]
    qcols = sorted((c for c in cols if re.fullmatch(r"q\d+", c)), key=lambda c: int(c[1:]))
    n = len(qcols)
    need = ["joint", *[f"q{i}" for i in range(1, n + 1)], "x", "y", "z"]
    missing = [c for c in need if c not in cols]
    if missing or n == 0:
        raise DenavitError(f"{path}:{hline}: header must be 'joint,q1,...,qn,x,y,z' (optional 'time'); missing {', '.join(missing) or 'q columns'}, got {header.strip()!r}")
    kinds = kinds or ["revolute"] * n
    if len(kinds) != n:
        raise DenavitError(f"{path}: {n} joints in the header but {len(kinds)} joint kinds given")
    qscale = np.array([as_ if k == "revolute" else ls for k in kinds])
    idx = {c: cols.index(c) for c in need}
    rows: dict[int, list] = {}
    for ln, line in data_lines[1:]:
        where = f"{path}:{ln}"
        cells = [c.strip() for c in line.split(delim)]
        if len(cells) != len(cols):
            raise DenavitError(f"{where}: expected {len(cols)} values, got {len(cells)}")
        jtext = cells[idx["joint"]]
        try:
            jv = float(jtext)
        except ValueError:
            raise DenavitError(f"{where}: column 'joint' must be a joint index 1..{n}, got {jtext!r}") from None
        if not (math.isfinite(jv) and jv == round(jv) and 1 <= jv <= n):
            raise DenavitError(f"{where}: joint index out of range: expected 1..{n}, got {jtext}")
        j = int(jv)
        q = np.array([_float(cells[idx[f'q{i}']], where, f"q{i}") for i in range(1, n + 1)]) * qscale
        p = np.array([_float(cells[idx[c]], where, c) for c in "xyz"]) * ls
        rows.setdefault(j, []).append((q, p, where))
    _check_complete(rows, n, str(path))
    sweeps = []
    for j in sorted(rows):
        qs = np.array([r[0] for r in rows[j]])
        sweeps.append(Sweep(j, np.array([r[1] for r in rows[j]]), qs, [r[2] for r in rows[j]]))
    if home is None:
        # the locked joints' readings: the median over the sweeps in which each joint does not move
        home = np.array([np.median(np.concatenate([s.q[:, i] for s in sweeps if s.joint != i + 1])) if n > 1 else 0.0 for i in range(n)])
    return SweepSet(sweeps, n, np.asarray(home, dtype=float), kinds, str(path), units)


_JOINT_FILE = re.compile(r"j(\d+)\.csv", re.IGNORECASE)


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def read_joint_files(folder: str | os.PathLike, *, home, length: str, angle: str = "deg", direction=1, kinds: list[str] | None = None) -> SweepSet:
    """Read one file per joint (``j1.csv`` ... ``jN.csv``): x,y,z per row, optionally a leading time column.

    Only files named exactly ``j<N>.csv`` count (``j1_old.csv`` is not a sweep). Comma or semicolon separated
    (the first line that is not a ``#`` comment decides), optional header (a line of names: none of its cells
    a number). Without joint readings, the sweep direction gives the axis orientation: ``direction`` (+1 or
    -1, or one per joint) says whether the joint value increased over the recording. ``home`` is in ``angle``
    units (revolute) / ``length`` (prismatic).
    """
    folder = Path(folder)
    files: dict[int, Path] = {}
    for f in sorted(folder.iterdir()):
        m = _JOINT_FILE.fullmatch(f.name)
        if m and f.is_file():
            j = int(m.group(1))
            if j in files:
                raise DenavitError(f"{folder}: two files for joint {j}: {files[j].name} and {f.name}: expected one j{j}.csv")
            files[j] = f
    if not files:
        raise DenavitError(f"{folder}: no per-joint files j1.csv ... jN.csv found")
    ls, as_ = length_scale(length, "--length"), angle_scale(angle, "--angle")
    try:
        home = np.atleast_1d(np.asarray(home, dtype=float))
    except (TypeError, ValueError):
        raise DenavitError(f"--home: expected one number per joint, got {home!r}") from None
    if home.ndim != 1 or not np.all(np.isfinite(home)):
        raise DenavitError(f"--home: expected one finite number per joint, got {home.tolist()}")
    n = len(home)
    kinds = kinds or ["revolute"] * n
    if len(kinds) != n:
        raise DenavitError(f"{folder}: {n} joints in --home but {len(kinds)} joint kinds given")
    try:
        dirs = np.atleast_1d(np.asarray(direction, dtype=float))
    except (TypeError, ValueError):
        raise DenavitError(f"--direction: expected +1 or -1, one for all joints or one per joint, got {direction!r}") from None
    if dirs.ndim != 1 or dirs.size not in (1, n) or not np.all(np.abs(dirs) == 1):
        raise DenavitError(f"--direction: expected +1 or -1, one for all joints or {n} (one per joint, from --home), got {dirs.tolist()}")
    dirs = np.broadcast_to(dirs, (n,))
    rows: dict[int, list] = {}
    for j, f in sorted(files.items()):
        if not 1 <= j <= n:
            raise DenavitError(f"{f}: joint index out of range: expected 1..{n} (from --home), got {j}")
        pts, where, delim = [], [], None
        for ln, line in enumerate(f.read_text(encoding="utf-8").splitlines(), 1):
            s = line.strip()
            if not s or s.startswith("#"):
                continue
            first = delim is None
            if first:
                delim = ";" if ";" in s else ","
            cells = [c.strip() for c in s.split(delim)]
            if cells and cells[-1] == "":
                cells.pop()  # a trailing separator
            if first and not any(_is_number(c) for c in cells):
                continue  # header: a line of names
            if len(cells) not in (3, 4):
                raise DenavitError(f"{f}:{ln}: expected 3 values (x,y,z) or 4 (time,x,y,z) separated by {delim!r}, got {len(cells)}: {s!r}")
            names = ["x", "y", "z"] if len(cells) == 3 else ["time", "x", "y", "z"]
            vals = [_float(c, f"{f}:{ln}", name) for c, name in zip(cells, names)]
            pts.append(np.array(vals[-3:]) * ls)
            where.append(f"{f}:{ln}")
        pts_arr = np.array(pts).reshape(-1, 3)
        if dirs[j - 1] < 0:
            pts_arr, where = pts_arr[::-1], where[::-1]
        rows[j] = (pts_arr, where)
    _check_complete(rows, n, str(folder))
    homes = np.array([h * (as_ if k == "revolute" else ls) for h, k in zip(home, kinds)])
    sweeps = [Sweep(j, rows[j][0], None, rows[j][1]) for j in sorted(rows)]
    return SweepSet(sweeps, n, homes, kinds, str(folder), {"length": length, "angle": angle})


def _show(value) -> str:
    """A short JSON rendering of a value for messages."""
    text = json.dumps(value)
    return text if len(text) <= 60 else text[:57] + "..."


def _json_numbers(value, n: int | None, where: str) -> np.ndarray:
    """A JSON list of finite numbers (``n`` of them, or any number >= 1) as a float array."""
    if not isinstance(value, list) or not value or (n is not None and len(value) != n):
        raise DenavitError(f"{where}: expected a list of {n if n is not None else 'one or more'} numbers, got {_show(value)}")
    out = []
    for i, v in enumerate(value):
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            raise DenavitError(f"{where}[{i}]: expected a number, got {_show(v)}")
        try:
            v = float(v)
        except OverflowError:
            v = math.inf
        if not math.isfinite(v):
            raise DenavitError(f"{where}[{i}]: expected a finite number, got {_show(value[i])}")
        out.append(v)
    return np.array(out)


def _json_rows(value, n: int, where: str) -> np.ndarray:
    """A JSON list of rows of ``n`` finite numbers as an (m, n) float array."""
    if not isinstance(value, list) or not value:
        raise DenavitError(f"{where}: expected a list of rows of {n} numbers, got {_show(value)}")
    return np.array([_json_numbers(row, n, f"{where}[{i}]") for i, row in enumerate(value)])


def read_json(path: str | os.PathLike) -> SweepSet:
    """Read sweeps from JSON: ``{"units": {"length": "mm", "angle": "deg"}, "home": [...],
    "kinds": [...] (optional), "sweeps": [{"joint": 1, "points": [[x, y, z], ...], "q": [[q1..qn], ...] (optional)}]}``.

    One sweep per joint; every number finite; errors name the file and the place (e.g. ``sweeps[2].q[3][1]``).
    """
    path = Path(path)
    try:
        doc = json.loads(path.read_text(encoding="utf-8"))
    except json.JSONDecodeError as e:
        raise DenavitError(f"{path}:{e.lineno}: not valid JSON: {e.msg}") from None
    if not isinstance(doc, dict):
        raise DenavitError(f'{path}: expected a JSON object {{"units": ..., "home": [...], "sweeps": [...]}}, got {_show(doc)}')
    units = doc.get("units") or {}
    if not isinstance(units, dict) or not all(isinstance(v, str) for v in units.values()):
        raise DenavitError(f'{path}: units: expected an object such as {{"length": "mm", "angle": "deg"}}, got {_show(units)}')
    ls, as_ = _scales(units, str(path))
    if doc.get("home") is None:
        raise DenavitError(f"{path}: 'home' (the locked configuration) is required")
    home = _json_numbers(doc["home"], None, f"{path}: home")
    n = len(home)
    kinds = doc.get("kinds") or ["revolute"] * n
    if not isinstance(kinds, list) or len(kinds) != n or any(k not in ("revolute", "prismatic") for k in kinds):
        raise DenavitError(f"{path}: kinds: expected {n} of 'revolute' / 'prismatic' (one per joint of home), got {_show(kinds)}")
    qscale = np.array([as_ if k == "revolute" else ls for k in kinds])
    sweeps = doc.get("sweeps")
    if not isinstance(sweeps, list) or not sweeps:
        raise DenavitError(f"{path}: sweeps: expected a list of sweeps {{\"joint\": 1, \"points\": [[x, y, z], ...]}}, got {_show(sweeps)}")
    rows: dict[int, Sweep] = {}
    first: dict[int, int] = {}
    for k, s in enumerate(sweeps):
        where = f"{path}: sweeps[{k}]"
        if not isinstance(s, dict):
            raise DenavitError(f"{where}: expected an object {{\"joint\": ..., \"points\": ...}}, got {_show(s)}")
        j = s.get("joint")
        if isinstance(j, bool) or not isinstance(j, int) or not 1 <= j <= n:
            raise DenavitError(f"{where}: joint index out of range: expected an integer 1..{n}, got {_show(j)}")
        if j in rows:
            raise DenavitError(f"{where}: a second sweep of joint {j} (the first is sweeps[{first[j]}]): expected one sweep per joint")
        pts = _json_rows(s.get("points"), 3, f"{where}.points")
        q = s.get("q")
        if q is not None:
            q = _json_rows(q, n, f"{where}.q")
            if len(q) != len(pts):
                raise DenavitError(f"{where}: q must have one row per point: expected {len(pts)} rows, got {len(q)}")
            q = q * qscale
        rows[j], first[j] = Sweep(j, pts * ls, q, [f"{where}.points[{i}]" for i in range(len(pts))]), k
    _check_complete(rows, n, str(path))
    homes = home * qscale
    return SweepSet([rows[j] for j in sorted(rows)], n, homes, kinds, str(path), units)


def read(path: str | os.PathLike, **kw) -> SweepSet:
    """Read sweeps from a long-form CSV, a JSON file, or a folder of per-joint files (by what ``path`` is)."""
    p = Path(path)
    if not p.exists():
        raise DenavitError(f"{p}: no such file or folder")
    if p.is_dir():
        return read_joint_files(p, **kw)
    if p.suffix.lower() == ".json":
        return read_json(p)
    return read_long_csv(p, **kw)


def to_long_csv(sweeps: SweepSet, length: str = "mm", angle: str = "deg", header_comment: str = "") -> str:
    """The long-form CSV text of a sweep set (units declared in a comment line)."""
    ls, as_ = length_scale(length), angle_scale(angle)
    qscale = np.array([as_ if k == "revolute" else ls for k in sweeps.kinds])
    out = io.StringIO()
    for line in header_comment.splitlines():
        out.write(f"# {line}\n")
    out.write(f"# units: length={length} angle={angle}\n")
    w = csv.writer(out, lineterminator="\n")
    w.writerow(["joint", *[f"q{i}" for i in range(1, sweeps.n_joints + 1)], "x", "y", "z"])
    for s in sweeps.sweeps:
        if s.q is None:
            raise DenavitError("long-form CSV needs joint readings; this sweep set has none")
        for q, p in zip(s.q, s.points):
            w.writerow([s.joint, *(f"{v:.10g}" for v in q / qscale), *(f"{v:.10g}" for v in p / ls)])
    return out.getvalue()


def simulate(
    model: _core.Model,
    *,
    home,
    ranges,
    points_per_sweep: int = 30,
    tool_point=(0.05, 0.03, 0.10),
    noise: float = 0.0,
    noise_q: float = 0.0,
    seed: int = 0,
) -> SweepSet:
    """Simulate sweeps of ``model``: joint j runs from ``ranges[j][0]`` to ``ranges[j][1]`` (rad / m,
    absolute joint values, as in Hayat Table II) with the others at ``home``; the tool point (m, in the
    flange frame, i.e. in ``T_flange_tool``'s parent frame: the flange, DH frame n for a DH robot) is recorded with Gaussian
    noise ``noise`` (m, per coordinate) and the readings with noise ``noise_q`` (rad / m).
    """
    n = model.nq
    home = np.asarray(home, dtype=float)
    ranges = np.asarray(ranges, dtype=float)
    if home.shape != (n,) or ranges.shape != (n, 2):
        raise DenavitError(f"simulate: expected home ({n},) and ranges ({n}, 2), got {home.shape} and {ranges.shape}")
    if points_per_sweep < 3:
        raise DenavitError(f"simulate: points_per_sweep must be >= 3, got {points_per_sweep}")
    rng = np.random.default_rng(seed)
    tool = np.asarray(tool_point, dtype=float)
    flange = model.with_tool(np.eye(4))
    sweeps = []
    for j in range(n):
        qs = np.tile(home, (points_per_sweep, 1))
        qs[:, j] = np.linspace(ranges[j, 0], ranges[j, 1], points_per_sweep)
        T = _core.fk_batch(flange, qs)
        pts = T[:, :3, :3] @ tool + T[:, :3, 3]
        pts = pts + rng.normal(0.0, noise, pts.shape) if noise > 0 else pts
        readings = qs + rng.normal(0.0, noise_q, qs.shape) if noise_q > 0 else qs
        sweeps.append(Sweep(j + 1, pts, readings, [f"simulated sweep {j + 1}, point {k}" for k in range(points_per_sweep)]))
    return SweepSet(sweeps, n, home, list(model.kinds), f"simulated {model.name}", {"length": "m", "angle": "rad"})
