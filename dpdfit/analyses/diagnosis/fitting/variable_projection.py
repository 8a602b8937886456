"""The calibration's error modes profiled out of a fit linearly (variable projection)."""

from __future__ import annotations

import numpy as np

__all__ = ['ModeProfile', 'PROFILE_STEP']


#: Jacobian step (sigma) of the modes
PROFILE_STEP = 0.1


class ModeProfile:
    """The calibration modes profiled out linearly around a point (variable projection).

    The tone model depends smoothly on the calibration's error modes
    (``cal_amp*``, ``cal_phase*``; N(0, 1) priors), so around a point
    ``p_lin`` (modes at ``d_lin``) the data residuals are
    ``z(x, d) ~ z(x, d_lin) + J (d - d_lin)``, with ``J`` their Jacobian in
    the modes (forward differences, one model evaluation per mode).  For any
    other parameters ``x`` the modes' optimum is then a ridge solution,
    ``d = -(J^T J + I)^-1 J^T r0`` with ``r0 = z(x, d_lin) - J d_lin``, and
    the profiled residual vector is ``[r0 + J d, d]`` (data, priors).  Its
    sum of squares is the marginal chi2 ``r0^T (I + J J^T)^-1 r0``, so the
    Gauss-Newton errors of ``x`` include the calibration uncertainty (all
    its modes) at the cost of one model evaluation per residual call instead
    of one more Jacobian column per mode.  The fit
    (:func:`~dpdfit.analyses.diagnosis.fitting.hypothesis_fit.fit_hypothesis`) re-linearises at its
    optimum until the modes settle.  Hand-written: a linear profile inside
    ``least_squares`` has no library routine.
    """

    def __init__(self, data_fun, p_lin: dict, modes: list, step: float = PROFILE_STEP):
        self.modes = modes
        self.d_lin = np.array([float(p_lin.get(k, 0.0)) for k in modes])
        z0 = data_fun(p_lin)
        J = np.empty((z0.size, len(modes)))
        for i, k in enumerate(modes):
            J[:, i] = (data_fun({**p_lin, k: self.d_lin[i] + step}) - z0) / step
        self.J = J
        self.M = np.linalg.solve(J.T @ J + np.eye(len(modes)), J.T)

    def point(self, p: dict) -> dict:
        """``p`` with the modes at the linearisation point (where the model is evaluated)."""
        return {**p, **dict(zip(self.modes, self.d_lin))}

    def solve(self, z: np.ndarray):
        """(profiled data residuals, modes) from the data residuals at :meth:`point`."""
        r0 = z - self.J @ self.d_lin
        d = -self.M @ r0
        return r0 + self.J @ d, d
