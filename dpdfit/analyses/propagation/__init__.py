"""Propagation of the amplitude calibration's posterior and drift into the fidelity estimate.

The uncertainty of the calibration comes from :mod:`dpdfit.fits.posterior`
(emcee posterior of the calibration run) and :mod:`dpdfit.fits.drift`
(run-to-run drift of ``y(1)``, the predictive transfer function of a later
day); this package pushes it through the exact forward model of the sweep.

Propagation into the fidelity estimate
--------------------------------------
For the chosen amplitude ``A`` and DPD flag the RF waveform (Cardioid(1,2),
after DPD with the exact inverse of the *calibration's* point-estimate fit,
as the sweep does) is the same for every draw; only the true transfer
function differs.  The optical field ``y(|x|) exp(i[arg x + phi(|x|)])`` is
*linear in the coefficients* ``a_k``, so its Fourier amplitude at every tone
bin is ``c = a @ M`` with ``M_k = DFT_bin[|x|^k sign(x) exp(i phi(|x|))]``
(computed once per flag); likewise ``mean |y|^2 = a^T G a``.  This is the
exact forward model of :mod:`dpdfit.analyses.sweep` evaluated for all draws at once
(tested against :func:`dpdfit.analyses.sweep.run_sweep` to 1e-9 dB), followed by the
batched :func:`dpdfit.models.fidelity.estimate` on the tone powers.  Reported per flag:
``F_est`` (mean of the sidebands, as the sweep's ``mean`` row), ``R10`` (dB,
mean of sidebands) and ``eta_bar``: median, 16/84 % and 2.5/97.5 % quantiles.

Recalibration question
----------------------
:func:`recalibration` finds the smallest ``|delta y(1)|`` (either sign) of the
true transfer function, relative to the calibration used for the LUT, that
lowers ``F_est(A, DPD)`` by ``loss`` (default 1e-4), and with the drift model
the staleness ``d`` at which ``sigma_drift(d) = |delta|`` (``d = delta^2/q``;
``None`` when the saturated drift ``sqrt(2) sigma_drift`` never reaches it).

Modules: :mod:`.forward` (the draw-batched forward model), :mod:`.inputs`
(posterior, LUT fit and drift; predictive draws), :mod:`.result`
(:class:`PropagationResult`), :mod:`.amplitude` (:func:`propagate`),
:mod:`.thresholds` (:func:`threshold_distribution`), :mod:`.recalibration`.
"""

from .amplitude import propagate
from .forward import BatchedForwardModel
from .recalibration import recalibration
from .result import PropagationResult
from .thresholds import threshold_distribution

__all__ = ["PropagationResult", "propagate", "threshold_distribution", "recalibration",
           "BatchedForwardModel"]
