"""The harness's reduced campaign: the configuration every harness campaign starts from.

Harness campaigns (:mod:`dpdfit.simulation.harness`, and the further recordings of its
closed loop, :mod:`dpdfit.simulation.closed_loop`) use :func:`harness_config`: the
campaign simulator with the tone powers taken directly from the field (with the noise
the heterodyne extraction would leave, :func:`dpdfit.simulation.campaign.direct_tones`),
three gate amplitudes x two flags x three scans, two time scans, and calibration runs
before and after the recordings.
"""

from __future__ import annotations

from dpdfit.simulation.campaign import CampaignConfig

__all__ = ["harness_config"]


def harness_config(seed: int) -> CampaignConfig:
    """The reduced campaign of the harness (see module doc)."""
    return CampaignConfig(seed=seed, spectra_mode="direct", n_amp_runs=9, amp_span_days=14.0,
                          runs_after_recordings=3, n_phase_runs=2, phase_span_hours=1.0,
                          gate_amplitudes=(0.4, 0.6, 0.8),
                          scan_shots=((625, 625), (625, 625), (625, 625)),
                          time_scan_A=0.6, time_scan_points=13, bundled_traces=())
