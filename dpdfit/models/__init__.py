"""Physics models: AOM transfer and its inverse, gate waveforms, spectra of simulated fields,
the phase-space fidelity estimate and the exact two-ion gate dynamics."""

__all__: list[str] = []
