"""Regenerate the KR5 example sweeps shipped in python/denavit/data (simulated, not measured).

The paper's measurements (Hayat et al., RSI controller readings) are not public, so the example is a
simulation of the paper's protocol on the built-in kr5 (Table III's magnitudes with KUKA's axis senses,
which stand the arm on its base; models/kr5.toml says why): home A1 90, A2 -90, A3 90,
A4 0, A5 90, A6 0 deg; ranges of Table II; 40 points per sweep; a tool point 50, 30, 100 mm off the flange;
0.02 mm Gaussian noise per coordinate on the points (a laser tracker's level) and exact joint readings.
"""

from pathlib import Path

import numpy as np

import denavit as dv
from denavit import sweeps as sw
from denavit.io.output import write_text
from denavit.io.sweeps import to_long_csv

out = Path(__file__).resolve().parents[1] / "python" / "denavit" / "data"
model = dv.load_model("kr5")
for protocol, seed in ((90, 90), (30, 30)):
    s = sw.simulate(
        model,
        home=np.radians(sw.PAPER_HOME_DEG),
        ranges=np.radians(sw.PAPER_RANGES_DEG[protocol]),
        points_per_sweep=40,
        tool_point=(0.05, 0.03, 0.10),
        noise=2e-5,
        seed=seed,
    )
    text = to_long_csv(
        s,
        "mm",
        "deg",
        f"KUKA KR5 joint sweeps, SIMULATED (not measured): Hayat et al. protocol, {protocol} deg ranges (Table II),\n"
        f"home 90,-90,90,0,90,0 deg, tool point 50,30,100 mm in the flange frame, 0.02 mm point noise, seed {seed}.\n"
        "Regenerate with examples/make_kr5_example.py.",
    )
    write_text(out / f"kr5_{protocol}deg.csv", text)
    print("wrote", out / f"kr5_{protocol}deg.csv")
