"""The small campaign the stand-in tests record further measurements of."""

from dpdfit.simulation.campaign import CampaignConfig, parse_effects

#: a harness-like campaign, smaller: direct spectra, two gate amplitudes, two scans, an
#: injected effect, a calibration run after the recordings and a further item already
SMALL = CampaignConfig(seed=11, spectra_mode="direct", n_amp_runs=5, amp_span_days=6.0,
                       runs_after_recordings=1, n_phase_runs=2, phase_span_hours=1.0,
                       cal_points=51, trace_amplitudes=(0.2, 0.4, 0.6, 0.8), bundled_traces=(),
                       gate_amplitudes=(0.4, 0.6), scan_shots=((300, 300), (300, 200)),
                       time_scan_A=0.6, time_scan_points=7,
                       further=(("phase_run",),)).with_effects(parse_effects("spam_offset=0.002"))
