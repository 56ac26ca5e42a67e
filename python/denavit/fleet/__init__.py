"""Fleets (docs/fleet.md): every robot's calibrations in one registry (:mod:`.registry`), the model checksum
(:mod:`.checksum`), manifests of jobs run as Dask tasks (:mod:`.runner`, the tasks in :mod:`.jobs`), the Monte Carlo
study of a measurement plan as Dask tasks (:mod:`.montecarlo`) and the quick drift check (:mod:`.check`).

Layering: above :mod:`denavit.api` (the tasks call it), below :mod:`denavit.cli`. Dask (``denavit[fleet]``) is
imported only when a cluster is used.
"""

from __future__ import annotations
