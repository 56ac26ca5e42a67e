"""The joints' compliances in the joint fit (:func:`denavit.fitting.joint.fit_sweeps`' ``torques``; issue 37): which
compliances are parameters, their bound ``k >= 0`` and their Jacobian columns, as a part of
:class:`~denavit.fitting.joint._JointFit`."""

from __future__ import annotations

import numpy as np


class _Compliances:
    """The compliance steps of :class:`~denavit.fitting.joint._JointFit` (its attributes: ``n`` joints, ``dqs`` the
    motions, ``tq`` the torques per sweep or None, ``sc`` the scales then the compliances, ``i_k`` the first
    compliance's index, ``held`` and ``negative``; its ``solve``)."""

    def free_compliances(self, kj: list) -> None:
        """The compliances of joints ``kj`` (0-based) are parameters (the others stay at their values): the layout."""
        self.kj, self.npar = list(kj), self.i_k + len(kj)
        self.active = [
            [i for i in range(self.n) if np.any(dq[:, i] != 0) or (i in kj and np.any(self.tq[k][:, i] != 0))]
            for k, dq in enumerate(self.dqs)
        ]
        # a pose one point, isotropic: the Jacobian of one turning joint by moments
        self.simple = self.tracker is None and not self.rot and self.K == 1 and not kj

    def bound_compliances(self) -> None:
        """k >= 0 (a joint gives way under its torque), as calibrate (:mod:`denavit.calibration.compliance`): those
        fitted negative are held at 0 and the fit repeated until none is (an active set). Held, they are parameters
        again for the covariance (their sigmas, the others' too, the data's: not zero); ``negative``: their values."""
        n = self.n
        while neg := [i for i in self.kj if self.sc[n + i] < 0]:
            self.negative[neg] = self.sc[[n + i for i in neg]]
            self.sc[[n + i for i in neg]] = 0.0
            self.held += neg
            self.free_compliances([i for i in self.kj if i not in neg])
            self.solve()
        if self.held:
            self.free_compliances(sorted(self.kj + self.held))

    def k_columns(self, k, rows, sc_, dpdq) -> list:
        """The compliances' Jacobian columns (1, 3, m) each: d pred / d k_i = -dtau_i (1 + s_i) d pred / d q_i."""
        if not self.kj:
            return []
        zero = np.zeros((1, 3, len(self.tq[k][rows])))
        return [-(self.tq[k][rows, i] * (1 + sc_[i]))[None, None] * dpdq[i] if i in dpdq else zero for i in self.kj]
