"""Tests of dpdfit.models: transfer function, waveforms, the fidelity estimate, the gate engine."""
