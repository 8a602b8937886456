"""Simulator of a complete, realistic measurement campaign (synthetic recordings).

The truth is physical, never the fit polynomials: a tanh-compressed RF
amplifier driving a Bragg-regime AOM with amplitude-to-phase conversion
(:mod:`dpdfit.simulation.aom_truth`), drifting from run to run; gate
experiments come from the exact two-ion spin-motion dynamics driven by the
optical spectrum that this AOM produces (:mod:`dpdfit.models.gate_sim`).  The
simulator writes the campaign layout that labs can also write their own
recordings in (see ``CAMPAIGN_FILES`` and the generated README.md):

``campaign.json``, ``calibration_amplitude.csv``, ``calibration_phase.csv``,
``spectra.csv``, ``traces.csv`` + ``traces/``, ``populations.csv``,
``parity.csv``, ``gate_rates.csv``, ``time_scans.csv``, ``README.md`` and
``truth.json`` (generating parameters; no analysis reads it).

Everything is derived from one seed through :class:`numpy.random.SeedSequence`
children keyed by purpose (and by amplitude/flag for traces), so the campaign
is regenerated bit for bit, and any single trace can be regenerated from the
seed recorded in ``traces.csv``.

Concealed effects (a memory of the modulator, a nonlinear photodiode, ...) are
injected only through the diagnosis's effect registry
(:mod:`dpdfit.analyses.diagnosis.effects`), by the ``inject_*`` hooks of each
effect's injection (:mod:`dpdfit.simulation.injections`);
:data:`SIMULATOR_EFFECTS` is a read-only view of that registry.

Modules: ``config`` (generating parameters, :data:`SIMULATOR_EFFECTS`, random
streams), ``calibration_runs`` (drifting AOM, calibration recordings, DPD
table), ``optics`` (RF envelope, AOM and injected effects, gate tones), ``spectra``
(heterodyne traces and their tone powers), ``gate_runs`` (gate experiments),
``simulate`` (the driver, ``campaign.json``, ``truth.json``), ``readme``
(the README.md template), ``folder`` (writing the folder, hashes).
"""

from .config import DEFAULT_SEED, SIMULATOR_EFFECTS, CampaignConfig, parse_effects
from .folder import CAMPAIGN_FILES, campaign_hashes
from .optics import drive_envelope
from .simulate import simulate_campaign
from .spectra import direct_tones, generate_trace, regenerate_trace, tone_readout

__all__ = ["CampaignConfig", "simulate_campaign", "parse_effects", "SIMULATOR_EFFECTS",
           "DEFAULT_SEED", "drive_envelope", "direct_tones", "tone_readout", "generate_trace",
           "regenerate_trace", "campaign_hashes", "CAMPAIGN_FILES"]
