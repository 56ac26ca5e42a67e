"""The readers' contract under mutated input (issue 16), shared by tests/test_fuzz.py (a derandomized CI-sized
run) and benchmarks/fuzz_readers.py (the long run that prints the counts per reader).

Every reader, given any bytes, either raises a :class:`denavit.DenavitError` subclass (one line, a clear message)
or returns; it never raises another exception, panics or hangs. Mutations that cannot change a file's meaning
(a byte-order mark, CRLF line ends, a comment line, a trailing blank line) must give the same numbers.
"""

from __future__ import annotations

import json
import os
import random
import signal
import tempfile
import warnings
from collections.abc import Callable
from pathlib import Path

import numpy as np

import denavit as dv
from denavit.errors import MAX_MESSAGE

DATA = Path(__file__).parent / "data"


def _kr5_sweeps_csv() -> str:
    from denavit import sweeps as sw
    from denavit.io import sweeps as swio

    s = sw.simulate(
        dv.load_model("kr5"),
        home=np.radians(sw.PAPER_HOME_DEG),
        ranges=np.radians(sw.PAPER_RANGES_DEG[30]),
        points_per_sweep=6,
        noise=2e-5,
        seed=1,
    )
    return swio.to_long_csv(s, "mm", "deg")


def _measurements_csv() -> str:
    from denavit import calibration as cal
    from denavit.io.measurements import to_csv

    kr5 = dv.load_robot("kr5")
    return to_csv(cal.simulate(kr5, cal.configurations(kr5, 12), tool=(0.05, 0.03, 0.1)), "mm", "deg")


def _sweeps_json() -> str:
    from denavit import sweeps as sw

    s = sw.simulate(
        dv.load_model("kr5"),
        home=np.radians(sw.PAPER_HOME_DEG),
        ranges=np.radians(sw.PAPER_RANGES_DEG[30]),
        points_per_sweep=5,
    )
    return json.dumps(
        {
            "units": {"length": "m", "angle": "rad"},
            "home": s.home.tolist(),
            "sweeps": [{"joint": x.joint, "points": x.points.tolist(), "q": x.q.tolist()} for x in s.sweeps],
        }
    )


def _sweeps_json_targets_poses() -> str:
    """A sweep JSON with three targets per pose, their nest and 6-DoF orientations (io.sweeps.to_json)."""
    from denavit import sweeps as sw
    from denavit.io import sweeps as swio

    s = sw.simulate(
        dv.load_model("kr5"),
        home=np.radians(sw.PAPER_HOME_DEG),
        ranges=np.radians(sw.PAPER_RANGES_DEG[30]),
        points_per_sweep=5,
        targets=[(0.05, 0.03, 0.1), (-0.04, 0.06, 0.08), (0.03, -0.07, 0.13)],
        poses=True,
    )
    return json.dumps(swio.to_json(s, "mm", "deg"))


def _positions_csv() -> str:
    Q = np.radians(np.array([[10, -80, 90, 0, 45, 0], [20, -70, 80, 10, 40, 5], [30, -60, 70, 20, 35, 10]]))
    return "# units: length=mm angle=deg\nq1,q2,q3,q4,q5,q6\n" + "".join(
        ",".join(f"{v:.6f}" for v in np.degrees(q)) + "\n" for q in Q
    )


def _measurements_json() -> str:
    from denavit import calibration as cal

    kr5 = dv.load_robot("kr5")
    m = cal.simulate(kr5, cal.configurations(kr5, 8), tool=(0.05, 0.03, 0.1))
    return json.dumps({"units": {"length": "m", "angle": "rad"}, "q": m.q.tolist(), "points": m.points.tolist()})


def _joint_file(path: Path):
    """A folder holding the mutated file as j1.csv, read as a one-joint set of per-joint files."""
    import shutil

    from denavit.io import sweeps as swio

    folder = path.parent / "joints"
    folder.mkdir(exist_ok=True)
    shutil.copyfile(path, folder / "j1.csv")
    return swio.read_joint_files(folder, home=[0.0], length="mm").sweeps[0].points


def _ur_yaml() -> str:
    from denavit.io import ur_calibration

    r = dv.load_robot("ur5")
    return ur_calibration.dumps(r.model(), r.table)


def seeds() -> dict[str, tuple[str, str, Callable[[Path], object]]]:
    """reader name -> (file suffix, valid text, read(path) -> a value whose numbers are compared)."""
    from denavit.io import robotfile, ur_calibration
    from denavit.io import sweeps as swio
    from denavit.io.configurations import read_configurations
    from denavit.io.measurements import read_measurements
    from denavit.io.positions import read_positions
    from denavit.io.recordings import read_recording
    from denavit.io.urdf import load_urdf

    kr5_toml = (Path(dv.__file__).parent / "models" / "kr5.toml").read_text()
    six = ["revolute"] * 6

    def nums(*arrays):
        return np.concatenate([np.ravel(np.asarray(a, dtype=float)) for a in arrays if a is not None])

    return {
        "robot file": (".toml", kr5_toml, lambda p: nums(robotfile.read(p).table.params)),
        "urdf": (".urdf", (DATA / "urdf" / "ur_style.urdf").read_text(), lambda p: nums(load_urdf(p).table.params)),
        "sweep csv": (".csv", _kr5_sweeps_csv(), lambda p: nums(*[s.points for s in swio.read_long_csv(p).sweeps])),
        "sweep json": (".json", _sweeps_json(), lambda p: nums(*[s.points for s in swio.read_json(p).sweeps])),
        "sweep json, targets and poses": (
            ".json",
            _sweeps_json_targets_poses(),
            lambda p: nums(
                *[x for s in swio.read_json(p).sweeps for x in (s.targets, s.rotations)], swio.read_json(p).nest
            ),
        ),
        "measurements": (".csv", _measurements_csv(), lambda p: nums(read_measurements(p).points)),
        "measurements json": (".json", _measurements_json(), lambda p: nums(read_measurements(p).points)),
        "joint file": (
            ".csv",
            "# units: length=mm\ntime;x;y;z\n"
            + "".join(
                f"{k * 0.1:.1f};{100 * np.cos(t):.6f};{100 * np.sin(t):.6f};5\n"
                for k, t in enumerate(np.linspace(0, 1, 8))
            ),
            lambda p: nums(_joint_file(p)),
        ),
        "candidates": (".csv", _positions_csv(), lambda p: nums(read_configurations(p, six))),
        "positions": (".csv", _positions_csv(), lambda p: nums(read_positions(p, six).q)),
        "ur kinematics": (".yaml", _ur_yaml(), lambda p: nums(ur_calibration.read(p))),
        "rtde": (".csv", (DATA / "recordings" / "rtde.csv").read_text(), lambda p: nums(read_recording(p, "rtde").q)),
        "rsi": (".xml", (DATA / "recordings" / "rsi.xml").read_text(), lambda p: nums(read_recording(p, "rsi").q)),
        "tracker": (
            ".csv",
            (DATA / "recordings" / "tracker.csv").read_text(),
            lambda p: nums(read_recording(p, "tracker").points),
        ),
    }


WEIRD = [
    "nan",
    "inf",
    "-inf",
    "1e309",
    "-1e309",
    "",
    " ",
    "１２",
    "١٢",
    "1_000",
    "true",
    "0x10",
    "--1",
    "1e",
    ".",
    "+",
    "1,5",
    "NaN",
    "9" * 400,
    "\x00",
    "\ufeff",
    "é",
    "°",
    "\\",
    '"',
    "'",
    "[",
    "]",
    "{",
    "}",
    "<",
    ">",
    "=",
    ";",
    ",",
    "#",
    "# units: length=m",
    "# units: length=furlong",
]


def mutate(text: str, rng: random.Random) -> tuple[bytes, bool]:
    """(mutated bytes, meaning kept): one random mutation of bytes, tokens, structure, encoding or size."""
    kind = rng.randrange(9)
    data = text.encode()
    if kind == 0:  # bytes: flip, insert or delete a few
        b = bytearray(data)
        for _ in range(rng.randint(1, 4)):
            i = rng.randrange(max(1, len(b)))
            op = rng.randrange(3)
            if op == 0 and b:
                b[i] = rng.randrange(256)
            elif op == 1:
                b.insert(i, rng.randrange(256))
            elif b:
                del b[i]
        return bytes(b), False
    if kind == 1:  # a token replaced by a weird one
        import re

        toks = list(re.finditer(r"[-+]?\d+(\.\d+)?([eE][-+]?\d+)?|[A-Za-z_]+", text))
        if not toks:
            return data, True
        m = rng.choice(toks)
        return (text[: m.start()] + rng.choice(WEIRD) + text[m.end() :]).encode(), False
    lines = text.splitlines(keepends=True)
    if kind == 2 and lines:  # structure: drop, duplicate or swap lines
        i, j = rng.randrange(len(lines)), rng.randrange(len(lines))
        op = rng.randrange(3)
        if op == 0:
            del lines[i]
        elif op == 1:
            lines.insert(i, lines[j])
        else:
            lines[i], lines[j] = lines[j], lines[i]
        return "".join(lines).encode(), False
    if kind == 3:  # encodings
        enc = rng.choice(["latin-1", "utf-16", "cp1252"])
        return (text + "# 90°\n").encode(enc, errors="replace"), False
    if kind == 4:  # size: cut short, the body repeated many times, or the last line up to 10^5 rows
        r = rng.random()
        if r < 0.5:
            return data[: rng.randrange(len(data) + 1)], False
        if r < 0.9 or not lines:
            return data + data[data.find(b"\n") + 1 :] * rng.randint(2, 50), False
        last = next((ln for ln in reversed(lines) if ln.strip()), "\n")
        return (
            data + (last if last.endswith("\n") else last + "\n").encode() * rng.choice([1_000, 10_000, 100_000]),
            False,
        )
    if kind == 5:  # meaning kept: a byte-order mark
        return b"\xef\xbb\xbf" + data, True
    if kind == 6:  # meaning kept: CRLF line ends
        return text.replace("\n", "\r\n").encode(), True
    if kind == 7:  # meaning kept: a trailing blank line
        return data + b"\n", True
    # a very long line
    return data + b"x" * rng.choice([10, 10_000, 300_000]) + b"\n", False


class Hang(Exception):
    pass


def _alarm(signum, frame):
    raise Hang()


def run_case(name: str, suffix: str, reader, data: bytes, reference, keeps_meaning: bool, timeout: int = 10) -> str:
    """'error' (a DenavitError), 'accepted', 'other' (another exception: a failure) or 'hang' (over ``timeout``
    seconds of the process's CPU time: on a machine shared with other jobs wall time measures them, not the reader;
    a reader stuck in a loop spends CPU time and is caught)."""
    with tempfile.TemporaryDirectory() as d:
        p = Path(d) / f"f{suffix}"
        p.write_bytes(data)
        old = signal.signal(signal.SIGPROF, _alarm)
        signal.setitimer(signal.ITIMER_PROF, timeout)
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("error")  # a RuntimeWarning (numpy overflow...) is a failure, as under pytest
                warnings.simplefilter("ignore", dv.DenavitWarning)  # the documented "usable in part" outcome
                got = reader(p)
        except dv.DenavitError as e:
            msg = str(e)
            if keeps_meaning:  # a meaning-keeping mutation must still read
                return f"other: meaning-keeping mutation refused: {msg[:200]}"
            return (
                "error"
                if "\n" not in msg and len(msg) <= MAX_MESSAGE
                else f"other: message of {len(msg)} chars / {msg.count(chr(10)) + 1} lines"
            )
        except Hang:
            return "hang"
        except BaseException as e:  # noqa: BLE001 - the contract is what is being checked
            return f"other: {type(e).__name__}: {str(e)[:200]}"
        finally:
            try:
                signal.setitimer(signal.ITIMER_PROF, 0)
            except Hang:  # the timer fired as the reader returned: it finished in time
                pass
            signal.signal(signal.SIGPROF, old)
        if keeps_meaning and not np.array_equal(np.asarray(got), np.asarray(reference)):
            return "other: a meaning-keeping mutation changed the numbers"
        return "accepted"


def campaign(cases_per_reader: int, seed: int = 0, readers=None) -> dict[str, dict[str, int]]:
    """Run ``cases_per_reader`` mutated files through each reader; counts per outcome, and the failures."""
    out = {}
    rng = random.Random(seed)
    for name, (suffix, text, reader) in seeds().items():
        if readers and name not in readers:
            continue
        with tempfile.TemporaryDirectory() as d:
            p = Path(d) / f"ref{suffix}"
            p.write_text(text)
            reference = reader(p)
        counts = {"cases": 0, "clean errors": 0, "accepted": 0, "other exceptions": 0, "hangs": 0, "failures": []}
        for _ in range(cases_per_reader):
            data, keeps = mutate(text, rng)
            r = run_case(name, suffix, reader, data, reference, keeps)
            counts["cases"] += 1
            if r == "error":
                counts["clean errors"] += 1
            elif r == "accepted":
                counts["accepted"] += 1
            elif r == "hang":
                counts["hangs"] += 1
                counts["failures"].append("hang")
            else:
                counts["other exceptions"] += 1
                counts["failures"].append(r)
        out[name] = counts
    return out


if os.environ.get("DENAVIT_FUZZ_DEBUG"):
    print(campaign(20))
