"""Fleets on Dask (issue 39; docs/fleet.md): prints three tables.

1. ``fleet run`` throughput: a manifest of simulated KR5 calibrations run in this process and on a LocalCluster of 1
   and 2 worker processes: tasks per second, the job's own time on its worker and the per-task overhead (wall time
   x workers / tasks - the job's time: scheduling, pickling, the registry's writes, idle workers at the end).
2. The drift check's false alarms and power (must-show: <= 10 poses at 0.02 mm, a 0.01 deg change of one joint's
   offset): 1,000 runs each, every run a fresh calibration of the robot (40 poses at 0.02 mm) and its check at 10
   designed poses, on the unchanged robot and with 0.01 deg more on A1, A2 or A3; with exact binomial (Clopper-Pearson)
   95 % intervals.
3. A 10,000-run Monte Carlo of a measurement plan (``plan --monte-carlo``: 30 poses of a KR5, each run a calibration
   of simulated data), serial against the cluster: wall time, runs per second, the same estimates.

Usage: ``python benchmarks/bench_fleet.py [--robots 40] [--runs 1000] [--mc 10000] [--workers 2]`` (``--robots 0``,
``--runs 0``: skip that table).
"""

from __future__ import annotations

import argparse
import dataclasses
import statistics
import tempfile
import time
from pathlib import Path

import numpy as np
from scipy.stats import beta

import denavit as dv
from denavit.calibration import plan
from denavit.calibration.parametrization import configurations
from denavit.fleet import check
from denavit.fleet.montecarlo import CHUNK, study
from denavit.fleet.registry import Registry
from denavit.fleet.runner import connect, disconnect, run_manifest
from denavit.io.measurements import to_csv

NOISE = 2e-5
KR5 = dv.load_robot("kr5")


def true_robot(seed: int = 39, offsets=None):
    rng = np.random.default_rng(seed)
    t = KR5.table
    P = np.array(t.params) + rng.normal(0, 1, t.params.shape) * [3e-4, np.radians(0.03), 3e-4, np.radians(0.03)]
    return dataclasses.replace(KR5, table=dv.Table(t.convention, P, t.kinds, t.T_world_base, t.T_last_tool))


def calibrated(true, seed: int):
    meas = dv.simulate(true, configurations(KR5, 40, skip=7), noise=NOISE, seed=seed)
    return dv.calibrate(meas, KR5, model="full", convention="mdh").robot(convention="mdh")


def manifest(folder: Path, robots: int) -> Path:
    q = configurations(KR5, 30, skip=5)
    tables = []
    for i in range(robots):
        (folder / f"r{i}.csv").write_text(to_csv(dv.simulate(true_robot(i), q, noise=NOISE, seed=i)))
        tables.append(
            f'[[robot]]\nid = "R{i:03d}"\nnominal = "kr5"\njob = "calibrate"\ndata = "r{i}.csv"\n'
            'model = "full"\nconvention = "mdh"\n'
        )
    path = folder / "fleet.toml"
    path.write_text("\n".join(tables))
    return path


def throughput(robots: int, worker_counts) -> None:
    print(f"\n1. fleet run: {robots} calibrations (KR5, 30 poses each, the full model in modified DH)")
    print(f"{'workers':>10} {'wall s':>8} {'tasks/s':>8} {'job ms':>8} {'overhead ms/task':>17}")
    with tempfile.TemporaryDirectory() as tmp:
        path = manifest(Path(tmp), robots)
        for workers in [0, *worker_counts]:
            client = None if workers == 0 else connect(workers=workers)
            try:
                if client is not None:  # warm the workers (imports) outside the timing
                    client.run(lambda: __import__("denavit.fleet.jobs") and None)
                with Registry(Path(tmp) / f"r{workers}.sqlite") as reg:
                    t0 = time.perf_counter()
                    s = run_manifest(path, reg, client=client)
                    wall = time.perf_counter() - t0
            finally:
                if client is not None:
                    disconnect(client)
            job = statistics.median(s.job_seconds)
            overhead = wall * max(workers, 1) / s.added - statistics.mean(s.job_seconds)
            name = "in-process" if workers == 0 else str(workers)
            print(f"{name:>10} {wall:8.2f} {s.added / wall:8.2f} {job * 1e3:8.1f} {overhead * 1e3:17.1f}")


def check_runs(first: int, count: int, Q: np.ndarray) -> np.ndarray:
    """(count, 4): per run, the verdict on the unchanged robot and with 0.01 deg more on A1, A2, A3."""
    true = true_robot()
    out = np.zeros((count, 4), dtype=bool)
    for k in range(count):
        run = first + k
        reg = calibrated(true, 100_000 + run)
        out[k, 0] = check.test(reg, Q, dv.simulate(true, Q, noise=NOISE, seed=run).points, noise=NOISE).changed
        for j in range(3):
            Qj = Q.copy()
            Qj[:, j] += np.radians(0.01)
            pts = dv.simulate(true, Qj, noise=NOISE, seed=(j + 1) * 10_000_000 + run).points
            out[k, j + 1] = check.test(reg, Q, pts, noise=NOISE).changed
    return out


def interval(k: int, n: int) -> tuple[float, float]:
    lo = beta.ppf(0.025, k, n - k + 1) if k > 0 else 0.0
    hi = beta.ppf(0.975, k + 1, n - k) if k < n else 1.0
    return lo, hi


def drift(runs: int, client) -> np.ndarray:
    Q = check.design(calibrated(true_robot(), 0), 10)
    reg = calibrated(true_robot(), 1)
    sizes = np.linalg.norm(check.offset_changes(reg, Q, np.radians(0.01)), axis=2).mean(axis=1)
    chunk = 50
    t0 = time.perf_counter()
    futures = [client.submit(check_runs, s, min(chunk, runs - s), Q, pure=False) for s in range(0, runs, chunk)]
    verdicts = np.vstack(client.gather(futures))
    wall = time.perf_counter() - t0
    pred = np.median(check.residual_covariance(reg, Q, NOISE).diagonal().reshape(-1, 3).sum(axis=1) - 3 * NOISE**2)
    print(
        f"\n2. drift check: {runs} runs each, 10 designed poses, tracker noise {NOISE * 1e3:g} mm, stated false-alarm "
        f"rate {check.FALSE_ALARM:g}; the registered model's own predicted error at the poses (median, 1 sigma 3-D) "
        f"{np.sqrt(pred) * 1e3:.3f} mm; {wall:.0f} s on the cluster"
    )
    print(f"{'robot':>24} {'tool change mm':>15} {'declared changed':>17} {'95 % interval':>17}")
    for col, what in enumerate(["unchanged", "A1 offset +0.01 deg", "A2 offset +0.01 deg", "A3 offset +0.01 deg"]):
        k = int(verdicts[:, col].sum())
        lo, hi = interval(k, runs)
        size = "-" if col == 0 else f"{sizes[col - 1] * 1e3:.3f}"
        print(f"{what:>24} {size:>15} {k / runs:17.3f} {f'{lo:.3f}-{hi:.3f}':>17}")
    return Q


def monte_carlo(runs: int, client, workers: int) -> None:
    """``plan --monte-carlo``'s study (denavit.fleet.montecarlo) of a 30-pose plan: serial, then on the cluster."""
    tool = np.array([0.05, 0.03, 0.10])
    p = plan(KR5, q=configurations(KR5, 30, skip=3), noise=NOISE, tool=tool)
    client.run(lambda: __import__("denavit.fleet.montecarlo") and None)  # the workers' imports outside the timing
    times = {}
    t0 = time.perf_counter()
    serial = study(KR5, p, runs, tool=tool)
    times["serial"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    clustered = study(KR5, p, runs, tool=tool, client=client)
    times[f"cluster ({workers} workers)"] = time.perf_counter() - t0
    assert np.array_equal(serial.estimates, clustered.estimates, equal_nan=True)  # run for run the same
    ratio = serial.ratio[np.isfinite(serial.ratio)]
    print(
        f"\n3. Monte Carlo of a measurement plan (plan --monte-carlo): {runs} calibrations of 30 poses in tasks of "
        f"{CHUNK} runs; {serial.failed} failed; spread / planned sigma median {np.median(ratio):.3f} "
        f"({ratio.min():.3f}-{ratio.max():.3f} over {len(ratio)} parameters); the same estimates serial and clustered"
    )
    print(f"{'':>22} {'wall s':>9} {'runs/s':>9}")
    for name, t in times.items():
        print(f"{name:>22} {t:9.2f} {runs / t:9.0f}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--robots", type=int, default=40)
    ap.add_argument("--runs", type=int, default=1000)
    ap.add_argument("--mc", type=int, default=10_000)
    ap.add_argument("--workers", type=int, default=2)
    a = ap.parse_args()
    if a.robots:
        throughput(a.robots, sorted({1, a.workers}))
    client = connect(workers=a.workers)
    try:
        if a.runs:
            drift(a.runs, client)
        monte_carlo(a.mc, client, a.workers)
    finally:
        disconnect(client)


if __name__ == "__main__":
    main()
