"""The sweep's forward model at one amplitude, evaluated for many transfer-function draws at once.

The RF waveform (Cardioid(1,2), predistorted with the LUT's fit for DPD) does
not depend on the draw, and the optical field is linear in the amplitude
coefficients ``a_k``: the tone amplitudes are ``c = a @ M`` and
``mean |y|^2 = a^T G a`` with ``M``, ``G`` computed once per DPD flag (see
:mod:`dpdfit.analyses.propagation`).
"""

from __future__ import annotations

import numpy as np

from dpdfit.analyses.sweep import SWEEP_HARMONICS
from dpdfit.core.defaults import ETA_REF, FORMULA, NBAR, NU_HZ, XI0_SPECTRA_HZ
from dpdfit.fits.calibration import AmplitudeCalibration, PhaseCalibration
from dpdfit.models.fidelity import estimate
from dpdfit.models.transfer import TransferFunction
from dpdfit.models.waveforms import cardioid, predistort, sample_grid, synthesize

__all__ = ["BatchedForwardModel"]


class BatchedForwardModel:
    """Exact, draw-batched forward model at one amplitude for both DPD flags."""

    def __init__(self, lut_fit: AmplitudeCalibration, phase: PhaseCalibration | None, A: float,
                 nu=NU_HZ, xi0=XI0_SPECTRA_HZ, nbar=NBAR, formula=FORMULA, eta_ref=ETA_REF):
        self.tones = cardioid()
        self.grid = sample_grid(nu, xi0, self.tones)
        self.tf = TransferFunction(lut_fit.powers, tuple(lut_fit.coefficients),
                                   () if phase is None else phase.powers,
                                   () if phase is None else tuple(phase.coefficients))
        self.powers = np.asarray(lut_fit.powers)
        self.nbar, self.formula, self.eta_ref = nbar, formula, eta_ref
        self.harmonics = SWEEP_HARMONICS
        w = synthesize(self.tones, self.grid, np.array([float(A)]))[0]
        self.M, self.G, self.M2 = {}, {}, {}
        self.pm_powers = None if phase is None else np.asarray(phase.powers)
        kb, kr = self.grid.tone_bins(self.harmonics)
        N = self.grid.n_samples
        for dpd in (0, 1):
            rf = predistort(w, self.tf) if dpd else w
            mag = np.minimum(np.abs(rf), 1.0)
            ph = np.angle(rf) + self.tf.f_pm(mag)
            basis = mag[None, :] ** self.powers[:, None]            # (K, N)
            spec = np.fft.fft(basis * np.exp(1j * ph)[None, :], axis=-1) / N
            self.M[dpd] = (spec[:, kb], spec[:, kr])                 # (K, 4) each
            self.G[dpd] = basis @ basis.T / N                        # mean y^2 = a G a
            if self.pm_powers is not None:
                # first-order response to a phase-coefficient perturbation db:
                # exp(i(phi + dphi)) = exp(i phi)(1 + i dphi), dphi = sum_l db_l |x|^l
                pb = mag[None, :] ** self.pm_powers[:, None]          # (P, N)
                s2 = np.fft.fft(basis[:, None, :] * pb[None, :, :] * np.exp(1j * ph), axis=-1) / N
                self.M2[dpd] = (1j * s2[..., kb], 1j * s2[..., kr])  # (K, P, 4) each
        self.gate_signs = tuple(np.sign([self.tones.r_blue[self.tones.n.index(k)]
                                         for k in (1, 2)]))

    def evaluate(self, a, dpd: int, db=None) -> dict:
        """Tone powers etc. for coefficient draws ``a`` (D, K); ``db`` (D, P) optional
        phase-coefficient perturbations, to first order (``|dphi| ~ 1e-3`` rad: the
        neglected second order is ~1e-6 of the tone amplitudes)."""
        a = np.atleast_2d(a)
        Mb, Mr = self.M[dpd]
        cb, cr = a @ Mb, a @ Mr
        if db is not None and dpd in self.M2:
            M2b, M2r = self.M2[dpd]
            cb = cb + np.einsum("dk,dl,klh->dh", a, db, M2b)
            cr = cr + np.einsum("dk,dl,klh->dh", a, db, M2r)
        Pb = 10 * np.log10(np.maximum(np.abs(cb) ** 2, 1e-300))
        Pr = 10 * np.log10(np.maximum(np.abs(cr) ** 2, 1e-300))
        F = 0.5 * sum(estimate(P, self.harmonics, gate_signs=self.gate_signs, nbar=self.nbar,
                               formula=self.formula).F_est for P in (Pr, Pb))
        R10 = 0.5 * ((Pr[:, 1] - Pr[:, 0]) + (Pb[:, 1] - Pb[:, 0]))
        y1 = a.sum(axis=1)
        eta = self.eta_ref * np.einsum("di,ij,dj->d", a, self.G[dpd], a) / y1 ** 2
        return {"F_est": F, "R10_dB": R10, "eta_bar": eta}
