"""Regenerate the KR5 example shipped in python/denavit/data: a simulated "true" KR5 and its measured sweeps.

The paper's measurements (Hayat et al., RSI controller readings) are not public, so the example simulates them,
from a robot that is NOT the nominal: ``kr5_true.toml`` is the built-in kr5 (standard DH) with every DH parameter
off by a realistic manufacturing error, drawn once with a fixed seed (:data:`SEED`):

- link lengths and offsets (d, a): 0.3 to 1 mm, either sign;
- twists and joint offsets (alpha, theta): 0.02 to 0.1 deg, either sign;
- the tool point: 0.2 to 0.6 mm off its design position 50, 30, 100 mm in the flange frame, per coordinate,

each rounded (0.01 mm, 0.001 deg) so the file reads as a table. The robot's base frame is the measurement frame (a
tracker registered to the base). The sweeps follow Hayat et al.'s protocols (Table II: the 90 and 30 deg ranges)
about the paper's home A1 90, A2 -90, A3 90, A4 0, A5 90, A6 0 deg, 40 points per sweep, the tool point recorded with
0.02 mm Gaussian noise per coordinate (a laser tracker's level) and the swept joint's reading with 0.001 deg noise
(the locked joints read their home exactly: the servo holds them to the encoder's count).

Run ``python examples/make_kr5_example.py`` to rewrite the three files; ``tests/test_first_hour.py`` checks that the
shipped files are what :func:`make` gives.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np

import denavit as dv
from denavit import _core
from denavit import sweeps as sw
from denavit.io import robotfile
from denavit.io.output import write_text
from denavit.io.sweeps import to_long_csv
from denavit.io.units import angle_scale, length_scale

SEED = 2017  # the year Hayat et al. was published
NOMINAL_TOOL_MM = (50.0, 30.0, 100.0)
TRACKER_NOISE_MM = 0.02
READING_NOISE_DEG = 0.001
POINTS_PER_SWEEP = 40
PROTOCOLS = {90: 90, 30: 30}  # Hayat Table II's protocol (deg) -> the seed of its noise
DATA = Path(__file__).resolve().parents[1] / "python" / "denavit" / "data"


def true_robot():
    """The "true" KR5: the built-in kr5 with its DH parameters and tool off by the errors of the module's docstring,
    as a :class:`denavit.Robot` (SI), its simulation's settings under ``extra["simulation"]``."""
    nominal = dv.load_robot("kr5")
    rng = np.random.default_rng(SEED)
    t = nominal.table
    # in the file's units (mm, deg), rounded, then in SI as the file reader scales them: the file reads as written
    scale = np.where(t.angle_columns, angle_scale("deg"), length_scale("mm"))
    sign = rng.choice([-1.0, 1.0], size=t.params.shape)
    lengths = np.round(rng.uniform(0.3, 1.0, t.params.shape), 2)  # mm
    angles = np.round(rng.uniform(0.02, 0.1, t.params.shape), 3)  # deg
    params = np.round(t.params / scale + sign * np.where(t.angle_columns, angles, lengths), 3) * scale
    tool = np.array(NOMINAL_TOOL_MM) + rng.choice([-1.0, 1.0], 3) * np.round(rng.uniform(0.2, 0.6, 3), 2)
    T_tool = np.eye(4)
    T_tool[:3, 3] = np.round(tool, 2) * length_scale("mm")
    table = _core.Table(t.convention, params, list(t.kinds), t.T_world_base, T_tool)
    simulation = {
        "nominal": "kr5",
        "errors": "0.3-1 mm (d, a) and 0.02-0.1 deg (alpha, theta)",
        "nominal_tool_mm": list(NOMINAL_TOOL_MM),
        "tracker_noise_mm": TRACKER_NOISE_MM,
        "reading_noise_deg": READING_NOISE_DEG,
        "points_per_sweep": POINTS_PER_SWEEP,
        "protocols_deg": sorted(PROTOCOLS, reverse=True),
        "seed": SEED,
        "script": "examples/make_kr5_example.py",
    }
    return type(nominal)(
        **{
            **nominal.__dict__,
            "name": "kr5_true",
            "table": table,
            "description": 'KUKA KR5 arc, the simulated "true" robot of the example sweeps: the built-in kr5 with '
            "errors of 0.3-1 mm (d, a), 0.02-0.1 deg (alpha, theta) and 0.2-0.6 mm on the tool point",
            "source": f"examples/make_kr5_example.py, seed {SEED} (not a measured robot)",
            "path": "",
            "extra": {"simulation": simulation},
        }
    )


def make() -> dict[str, str]:
    """The example's files: ``kr5_true.toml`` and ``kr5_{90,30}deg.csv``, name -> text."""
    robot = true_robot()
    comment = (
        '# This is NOT a measured robot: it is the simulated "true" KR5 that the example sweeps kr5_90deg.csv\n'
        "# and kr5_30deg.csv were measured from. It is the built-in kr5 with each DH parameter off by an error\n"
        f"# drawn with seed {SEED} (d, a: 0.3-1 mm; alpha, theta: 0.02-0.1 deg, either sign) and the tool point\n"
        "# 0.2-0.6 mm off its design 50, 30, 100 mm per coordinate. Its base frame is the measurement frame.\n"
        "# Made by examples/make_kr5_example.py; `denavit identify --example kr5` compares the nominal and the\n"
        "# identified models with it.\n"
    )
    files = {"kr5_true.toml": comment + robotfile.dumps(robot, "mm", "deg")}
    model = robot.model()
    for protocol, seed in PROTOCOLS.items():
        s = sw.simulate(
            model,
            home=np.radians(sw.PAPER_HOME_DEG),
            ranges=np.radians(sw.PAPER_RANGES_DEG[protocol]),
            points_per_sweep=POINTS_PER_SWEEP,
            tool_point=robot.table.T_last_tool[:3, 3],
            noise=TRACKER_NOISE_MM * 1e-3,
            noise_q=np.radians(READING_NOISE_DEG),
            seed=seed,
        )
        # the locked joints read their home exactly (held by the servo to the encoder's count); the swept one is noisy
        held = [replace(w, q=np.where(np.arange(6) == w.joint - 1, w.q, s.home)) for w in s.sweeps]
        files[f"kr5_{protocol}deg.csv"] = to_long_csv(
            replace(s, sweeps=held),
            "mm",
            "deg",
            'KUKA KR5 joint sweeps, SIMULATED (not measured) from the "true" robot kr5_true.toml (the nominal kr5\n'
            f"with errors of 0.3-1 mm and 0.02-0.1 deg): Hayat et al. protocol, {protocol} deg ranges (Table II),\n"
            f"home 90,-90,90,0,90,0 deg, {POINTS_PER_SWEEP} points per sweep, the tool point (design 50,30,100 mm in\n"
            f"the flange frame) with {TRACKER_NOISE_MM} mm tracker noise, the swept joint's reading with\n"
            f"{READING_NOISE_DEG} deg noise (the locked joints' exact), seed {seed}.\n"
            "Regenerate with examples/make_kr5_example.py.",
        )
    return files


if __name__ == "__main__":
    for name, text in make().items():
        write_text(DATA / name, text)
        print("wrote", DATA / name)
