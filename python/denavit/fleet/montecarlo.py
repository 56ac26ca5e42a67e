"""The Monte Carlo study of a measurement plan (``denavit plan --monte-carlo N``), as Dask tasks or in this process.

A plan predicts every parameter's sigma before measuring (the Cramer-Rao bound of the least-squares fit,
:func:`denavit.plan`). The study checks that prediction by doing the calibration ``N`` times: each run simulates the
plan's configurations on the model itself with fresh tracker noise (:func:`denavit.simulate`) and calibrates them
(:func:`denavit.calibrate`, the whole model by least squares: the estimator the bound is of, from the model as
nominal). The spread of the ``N`` estimates of a parameter is its sigma in fact; its ratio to the planned sigma is 1
for an efficient fit on an honest plan.

Run ``k`` (0-based) draws its noise from seed ``seed + k``, whichever task runs it, so the study is the same serial
or on a cluster, in any chunking. The tasks are :func:`run_chunk` on pickled inputs (the robot, the configurations
and the fit's options), :data:`CHUNK` runs each; the client gathers them (nothing is written by a worker).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ..errors import DenavitError

#: Runs per Dask task (a calibration takes tens of milliseconds: a task of this many outweighs its scheduling).
CHUNK = 20
#: Dask's retries of a task whose run raised for other reasons than the job's data (a worker lost).
RETRIES = 2


@dataclass(frozen=True)
class Study:
    """The study of a plan: per parameter (``names``, as the plan's) its ``truth`` (the model's value, SI), the
    ``planned`` sigma (NaN: not estimated) and every run's estimate (``estimates`` (runs, P); a run that raised or did
    not converge is a row of NaN, counted in ``failed``)."""

    names: list
    truth: np.ndarray
    planned: np.ndarray
    estimates: np.ndarray
    seed: int
    failed: int

    @property
    def runs(self) -> int:
        return len(self.estimates)

    def _converged(self) -> np.ndarray:
        return self.estimates[np.isfinite(self.estimates).all(axis=1) if self.estimates.size else slice(0)]

    @property
    def spread(self) -> np.ndarray:
        """(P,) the sample standard deviation of each parameter's estimates over the converged runs (NaN where the
        parameter was not estimated or fewer than two runs converged)."""
        ok = self._converged()
        if len(ok) < 2:
            return np.full(len(self.names), np.nan)
        return np.where(np.isfinite(self.planned), ok.std(axis=0, ddof=1), np.nan)

    @property
    def bias(self) -> np.ndarray:
        """(P,) the mean error of the estimates (estimate - truth) over the converged runs."""
        ok = self._converged()
        if not len(ok):
            return np.full(len(self.names), np.nan)
        return np.where(np.isfinite(self.planned), (ok - self.truth).mean(axis=0), np.nan)

    @property
    def ratio(self) -> np.ndarray:
        """(P,) Monte Carlo spread / planned sigma (1: the plan's prediction holds)."""
        with np.errstate(invalid="ignore", divide="ignore"):
            return self.spread / self.planned


def run_chunk(robot, q: np.ndarray, first: int, count: int, seed: int, noise: float, tool, options: dict):
    """(count, P) the estimates of runs ``first .. first + count - 1`` (module docstring); a row of NaN for a run
    whose calibration raised for its data or did not converge. One Dask task."""
    from .. import api  # noqa: PLC0415

    out: list = []
    for k in range(first, first + count):
        meas = api.simulate(robot, q, tool_point=tool, noise=noise, seed=seed + k)
        try:
            res = api.calibrate(meas, robot, tool=tool, model="full", **options)
        except DenavitError:
            out.append(None)
            continue
        out.append(np.asarray(res.values, dtype=float) if res.converged else np.full(len(res.values), np.nan))
    size = next((len(v) for v in out if v is not None), 0)
    return np.vstack([np.full(size, np.nan) if v is None else v for v in out]) if size else np.full((count, 0), np.nan)


def study(
    robot,
    plan,
    count: int,
    *,
    tool,
    fix=(),
    seed: int = 0,
    client=None,
    progress: Callable[[int, int], None] | None = None,
) -> Study:
    """The Monte Carlo study of ``plan`` (a :class:`denavit.calibration.Plan` of ``robot``) in ``count`` runs, with
    the plan's noise and convention, the parameters ``fix`` held (as the plan's) and the tool point ``tool`` (m,
    flange frame): in this process without ``client``, else as Dask tasks on its cluster; ``progress(done, total)``
    after each task."""
    if count < 2:
        raise DenavitError(f"Monte Carlo runs: expected at least 2 (a spread needs two), got {count}")
    pz = plan.parametrization
    options = {"convention": pz.convention, "fix": list(fix)}
    q, noise, tool = np.asarray(plan.q, dtype=float), float(plan.noise), np.asarray(tool, dtype=float)
    starts = list(range(0, count, CHUNK))
    args = [(s, min(CHUNK, count - s)) for s in starts]
    done, parts = 0, {}
    if progress is not None:
        progress(0, len(args))
    if client is None:
        for first, n in args:
            parts[first] = run_chunk(robot, q, first, n, seed, noise, tool, options)
            done += 1
            if progress is not None:
                progress(done, len(args))
    else:
        from dask.distributed import as_completed  # noqa: PLC0415

        futures = {
            client.submit(run_chunk, robot, q, first, n, seed, noise, tool, options, pure=False, retries=RETRIES): first
            for first, n in args
        }
        for fut in as_completed(futures):
            parts[futures[fut]] = fut.result()
            done += 1
            if progress is not None:
                progress(done, len(args))
    estimates = np.vstack([parts[s] for s in starts])
    if estimates.shape[1] == 0:  # every run raised
        estimates = np.full((count, len(plan.names)), np.nan)
    failed = int((~np.isfinite(estimates).all(axis=1)).sum())
    return Study(
        list(plan.names), np.asarray(pz.x0, dtype=float), np.asarray(plan.sigma, dtype=float), estimates, seed, failed
    )
