"""The experiment's default constants, defined once (the paper's values).

Every default a function signature, a command-line option or a campaign folder
falls back to is taken from here, so that a lab changes it in one place.
"""

from __future__ import annotations

__all__ = ["NU_HZ", "XI0_SPECTRA_HZ", "NBAR", "ETA_REF", "ETA_LD", "AMPLITUDE_ORDER",
           "PHASE_ORDER", "PHASE_MIN_A", "FORMULA"]

#: sideband detuning nu of the gate tones from the carrier, Hz (S4)
NU_HZ = 1.84e6
#: gate detuning xi0 of the recorded spectra, Hz (S4)
XI0_SPECTRA_HZ = 20e3
#: thermal mean phonon number of the gate mode assumed by the estimates
NBAR = 0.1
#: peak diffraction efficiency of the AOM (normalises eta_bar)
ETA_REF = 0.80
#: Lamb-Dicke parameter of the gate mode
ETA_LD = 0.026
#: polynomial order K of the amplitude transfer function
AMPLITUDE_ORDER = 8
#: polynomial order of the phase transfer function
PHASE_ORDER = 5
#: lowest drive amplitude used in the phase fit
PHASE_MIN_A = 0.1
#: the fidelity-estimate formula used by default ("exact" or "paper")
FORMULA = "exact"
