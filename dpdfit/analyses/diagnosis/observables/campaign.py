"""Recorded observables of a campaign, standardised for the discrepancy diagnosis.

Reads a campaign folder (layout of :mod:`dpdfit.simulation.campaign`) into the
quantities that the forward model predicts, each with a 1-sigma error that
contains every known noise source and nothing else:

* **tone features** per trace (``spectra.csv``): ``R10 = P1 - P0``,
  ``R23 = P2 - P3``, ``R5lo = P1 - P(-1)`` and ``R5hi = P2 - P4`` (IM5),
  ``gate_balance = P2 - P1`` per sideband, ``red_blue`` (mean red minus mean
  blue gate tone) and ``gate_power`` (mean gate tone minus ``20 log10 A``, up
  to a constant).  Ratios within one trace cancel its laser-power jitter;
  ``gate_power`` carries it (``power_jitter_db`` of the lab's error model).
  Tone powers are debiased for the noise in their bin: the extraction's
  floor is the *median* noise power, the mean is ``floor / ln 2``
  (:mod:`dpdfit.fits.tones`), so ``P = |c|^2 + N0`` and the error of a
  tone at SNR ``s`` is ``(10/ln 10) sqrt(2 N0 / P)`` dB.  Tones below
  ``MIN_SNR_DB`` are not used (their reading is an upper limit).  A tone
  recorded ``k`` times (repeated rows of ``spectra.csv``) is the mean of its
  linear readings (:func:`dpdfit.recordings.spectra.pool_spectra`), which keeps
  ``E P = |c|^2 + N0``; its noise error is ``1/sqrt(k)`` of one reading's, and
  ``Campaign.n_repeats`` carries ``k`` to the null model.
* **gate observables** per setting ``(A, dpd)``, pooled over the scans:
  population fidelity ``F_pop = P00 + P11``, imbalance ``P00 - P11`` and the
  mean of the scans' parity contrasts (binomial MLE per scan, :mod:`dpdfit.fits.counts`;
  not the count-level merge, whose contrast the scans' power jitter washes out).
* **time scans**: ``P00`` and ``P11`` at each scan time (binomial; a point
  recorded again has its counts summed).
* **calibration residuals** of the model's own amplitude and phase runs.
* **phase runs after the recordings** (optional: recording times and such runs), each
  whitened for its noise and the run-to-run drift of ``phi``
  (:mod:`~dpdfit.analyses.diagnosis.observables.phase_runs_after`).
* **SPAM characterisation** (``spam.csv``, optional): the detected counts of each
  prepared basis state, pooled per state (:func:`dpdfit.recordings.spam.read_spam`).
* **AOM pulse response** (``pulse_response.csv``, optional): the photodiode trace of each
  RF step with each sample's noise (``power_err``, else the trace's own sample-to-sample
  scatter, :func:`pulse_response_noise`).
* **Ramsey and spin-echo characterisation** (``ramsey.csv``, optional): the detected
  counts of each sequence at each wait, pooled per point
  (:func:`dpdfit.recordings.ramsey.read_ramsey`).
* **detector linearity** (``detector_linearity.csv``, optional): the photodiode's
  reading pairs with and without a calibrated attenuator, with each reading's noise
  (:mod:`~dpdfit.analyses.diagnosis.observables.detector_linearity`).
* **sideband thermometry** (``thermometry.csv``, optional): the bright counts of the
  probed ion after each wait and sideband, pooled per point
  (:func:`dpdfit.recordings.thermometry.read_thermometry`).

Everything here is measured; predictions live in :mod:`dpdfit.analyses.diagnosis.model.tones.tone_model`
and :mod:`dpdfit.analyses.diagnosis.model.gates.gate_model`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

from dpdfit.analyses.diagnosis.observables.calibration_drift import (RunsAfter, drift_modes,
                                                                     runs_after_recordings)
from dpdfit.analyses.diagnosis.observables.detector_linearity import (LinearityData,
                                                                      linearity_data)
from dpdfit.analyses.diagnosis.observables.phase_runs_after import (PhaseRunsAfter,
                                                                    model_run_points,
                                                                    phase_runs_after)
from dpdfit.analyses.diagnosis.observables.tone_features import TONE_HARMONICS, debias_tones
from dpdfit.analyses.diagnosis.observables.tone_grid import tone_grid
from dpdfit.core.defaults import ERROR_MODEL, ErrorModel
from dpdfit.errors import FitError, InputError
from dpdfit.fits.calibration import calibrate_amplitude, calibrate_phase
from dpdfit.fits.counts import fit_parity
from dpdfit.fits.photodiode import (model_run_with_noise, phase_run_with_noise,
                                    with_phase_noise, with_power_noise)
from dpdfit.recordings.campaign_folder import CampaignFolder

__all__ = ['DEFAULT_ERROR_MODEL', 'Campaign', 'load_campaign', 'pulse_response_noise']


#: the lab's error model when campaign.json has none (``ERROR_MODEL``'s error_model keys)
DEFAULT_ERROR_MODEL = ERROR_MODEL.campaign_dict()


@dataclass(frozen=True)
class Campaign:
    """A campaign's recordings and the lab's own model inputs.

    Attributes
    ----------
    folder : Path
    meta : dict
        ``campaign.json``.
    amplitude, phase : calibration results of the model's runs (phase may be None)
    amp_residuals, phase_residuals : pandas.DataFrame
        ``A, z`` standardised fit residuals of those runs.
    A_tones : ndarray
        Amplitudes of the spectra grid.
    P_dB, sd_dB : ndarray, shape (nA, 2 dpd, 2 sideband, len(TONE_HARMONICS))
        Debiased tone powers and their errors (NaN where unusable); a tone recorded
        several times (repeated rows of ``spectra.csv``) is their pooled reading, one
        row per distinct A, with ``n_repeats`` readings.
    gates : pandas.DataFrame
        Per setting: ``A, dpd, xi0_hz, xi0_rel_err`` (of one calibration), ``n_rates``
        (repeated calibrations pooled into ``xi0_hz``), ``n_scans`` and the measured
        ``F_pop, imb, C`` with shot-noise errors ``*_shot``.
    time_scans : pandas.DataFrame
        ``A, dpd, t_s, n00, n11, shots``.
    error_model : dict
        The lab's error model (``campaign.json`` ``error_model``, else defaults).
    warnings : tuple of str
        One line each, e.g. a non-monotone model calibration.
    """

    folder: Path
    meta: dict
    amplitude: object
    phase: object
    amp_residuals: pd.DataFrame
    phase_residuals: pd.DataFrame | None
    A_tones: np.ndarray
    P_dB: np.ndarray
    sd_dB: np.ndarray
    gates: pd.DataFrame | None
    time_scans: pd.DataFrame | None
    error_model: dict = field(default_factory=dict)
    warnings: tuple = ()
    #: recorded tone powers (dB, before debiasing), same shape as ``P_dB``
    P_raw: np.ndarray | None = None
    #: recorded SNR over the median noise power (NaN without ``snr_db``)
    snr_raw: np.ndarray | None = None
    #: readings pooled into each tone of ``P_raw`` (repeated recordings of a setting; 0
    #: where the tone has none), same shape; None: one each
    n_repeats: np.ndarray | None = None
    #: every reading (dB) before pooling, shape (nA, repeats, 2 dpd, 2 sideband,
    #: len(TONE_HARMONICS)), NaN where a tone has fewer repeats; None: ``P_raw`` itself
    P_readings: np.ndarray | None = None
    #: spectra.csv carries snr_db (else the noise floor is estimated by the diagnosis)
    has_snr: bool = True
    #: campaign.json carries the lab's error_model
    has_error_model: bool = True
    #: what the folder lacks and what that leaves out of the analysis, one line each
    left_out: tuple = ()
    #: run-to-run drift of the amplitude calibration: coefficient directions (k = 2..K) of
    #: its principal components, each scaled to its run-to-run sd (m x (K-1)), the
    #: ``drift_significant`` first of them above the runs' fit errors
    drift_modes: np.ndarray | None = None
    drift_significant: int = 0
    #: noise models learnt from the calibration runs when the files give no errors
    #: (``photodiode``: sigma(P) = sqrt(a^2 + (b P)^2); ``phase``: sqrt(c^2 + (d/A)^2))
    calibration_noise: dict = field(default_factory=dict)
    #: when the spectra and the gates were recorded (``campaign.json``
    #: ``spectra_recorded``, ``gates_recorded``; pandas Timestamps in UTC, or None)
    recorded: dict = field(default_factory=dict)
    #: the amplitude runs taken after the recordings, in the drift modes (None: no
    #: recording times, or no run after them)
    runs_after: "RunsAfter | None" = None
    #: the SPAM characterisation: ``prepared, n00, n01_10, n11, shots``, one row per
    #: prepared basis state (None without ``spam.csv``)
    spam: pd.DataFrame | None = None
    #: the AOM pulse response: ``step, A, t_us, power, sigma``, one row per sample (None
    #: without ``pulse_response.csv``)
    pulse_response: pd.DataFrame | None = None
    #: the Ramsey and spin-echo characterisation: ``sequence, wait_s, n00, n01_10, n11,
    #: shots``, one row per point (None without ``ramsey.csv``)
    ramsey: pd.DataFrame | None = None
    #: the detector linearity characterisation: the reading pairs with each reading's
    #: noise (:class:`~.detector_linearity.LinearityData`; None without
    #: ``detector_linearity.csv``)
    detector_linearity: LinearityData | None = None
    #: the sideband thermometry: ``wait_us, wait_s, sideband, n_bright, shots``, one row
    #: per point (None without ``thermometry.csv``)
    thermometry: pd.DataFrame | None = None
    #: the phase runs taken after the recordings, whitened for their noise and the
    #: run-to-run drift of ``phi`` (None: no phase file, recording times or such run)
    phase_runs_after: "PhaseRunsAfter | None" = None
    #: the model's phase run's amplitudes (``A >= PHASE_MIN_A``) and their errors (rad;
    #: None without errors), the points a further phase run repeats (None: no phase file)
    phase_points: tuple | None = None

    @property
    def nu(self) -> float:
        """Sideband detuning ``nu`` of the gate tones from the carrier (Hz), ``nu_hz``."""
        return float(self.meta["nu_hz"])

    @property
    def xi0_spectra(self) -> float:
        """Gate detuning ``xi0`` of the recorded spectra (Hz), ``xi0_spectra_hz``."""
        return float(self.meta["xi0_spectra_hz"])

    @property
    def has_imbalance(self) -> bool:
        """The gate recordings carry the population imbalance ``P00 - P11`` (``imb``)."""
        return self.gates is not None and bool(np.isfinite(self.gates["imb"]).any())


def _residual_frame(cal, A, value, err) -> pd.DataFrame:
    pred = cal.power(A) if hasattr(cal, "power") else cal.phi(A)
    if err is None:
        err = np.full_like(value, np.std(value - pred))
    return pd.DataFrame({"A": A, "z": (value - pred) / err})


#: what the diagnosis does without an optional column (CampaignFolder.left_out)
_CONSEQUENCES = {
    ("spectra", ("snr_db",)): "the noise floor is estimated from the recordings "
                              "(IM tones at low A)",
    ("populations", ("n00", "n11")): "the imbalance P00 - P11 is not used",
}


def _model_runs(cf: CampaignFolder, learnt, fits: dict | None = None):
    """The model amplitude and phase runs with their errors, and the noise models:
    :func:`~dpdfit.fits.photodiode.model_run_with_noise` and ``phase_run_with_noise``
    (which learn the noise from every run; ``fits`` receives the amplitude runs' fits),
    or with ``learnt`` = ``(power noise, phase noise)`` already learnt so by the caller
    (the same errors, no run refitted).
    Returns ``(data, power noise, phase data or None, phase noise)``."""
    if learnt is None:
        return (*model_run_with_noise(cf, fits), *phase_run_with_noise(cf))
    power, phase = learnt
    data, pdata = cf.amplitude_model, cf.phase_model
    if power is not None:
        data = with_power_noise(data, power, int(cf.meta["order"]))
    if pdata is not None and phase is not None:
        pdata = with_phase_noise(pdata, phase)
    return data, power, pdata, (None if pdata is None else phase)


def _calibrations(cf: CampaignFolder, noise: dict, given=None, learnt=None,
                  fits: dict | None = None):
    """The model runs' fits and residuals; ``given`` (a Calibration of the same runs at
    the campaign's order, made by the caller) is used instead of fitting again, and
    ``learnt`` (the runs' noise models, :func:`_model_runs`) instead of learning them
    (``fits`` receives the amplitude runs' fits made in learning them)."""
    data, noise["photodiode"], pdata, noise["phase"] = _model_runs(cf, learnt, fits)
    order = int(cf.meta["order"])
    if given is not None and given.amplitude.order == order:
        amp = given.amplitude
    else:
        amp, given = calibrate_amplitude(data, order), None
    amp_res = _residual_frame(amp, data.A, data.value, data.error)
    ph, ph_res = None, None
    if pdata is not None:
        ph = given.phase if given is not None and given.phase is not None \
            else calibrate_phase(pdata)
        use = pdata.A >= 0.1
        ph_res = _residual_frame(ph, pdata.A[use], pdata.value[use],
                                 None if pdata.error is None else pdata.error[use])
    return amp, amp_res, ph, ph_res


def _gates(cf: CampaignFolder):
    pop, par, rates = cf.populations, cf.parity, cf.gate_rates
    if pop is None or par is None or rates is None:
        return None
    rate_path = str(cf.file("gate_rates.csv"))
    has_imb = {"n00", "n11"} <= set(pop.columns)
    rows = []
    for (A, d), g in pop.groupby(["A", "dpd"]):
        r = rates[(np.isclose(rates.A, A)) & (rates.dpd == d)]
        if r.empty:
            raise InputError(f"no gate rate for A={A:g}, dpd={int(d)}", file=rate_path,
                             column="xi0_khz")
        sel = par[(np.isclose(par.A, A)) & (par.dpd == d)]
        if sel.empty:
            raise InputError(f"setting A={A:g}, dpd={int(d)} has populations but no parity "
                             "scans", file=str(cf.file("parity.csv")), column="A")
        N = float(g["shots"].sum())
        F = float(g["n_even"].sum()) / N
        # contrast per scan, averaged: each scan's power error also moves its
        # fringe phase, so a count-level merge would wash the contrast out
        cs, es = [], []
        for label, sc in sel.groupby("scan"):
            try:
                f = fit_parity(sc["phase_rad"].to_numpy(), sc["n_even"].to_numpy(),
                               sc["shots"].to_numpy())
            except (InputError, FitError) as exc:   # one scan's design, named where written
                raise InputError(f"setting A={A:g}, dpd={int(d)}, scan {label}: {exc}",
                                 file=str(cf.file("parity.csv")), column="scan",
                                 row=int(sc.index[0]) + 1) from None
            cs.append(f.A)
            es.append(f.A_err)
        xi = float(r["xi0_khz"].iloc[0]) * 1e3
        # a rate pooled from repeated calibrations: its error is 1/sqrt(n) of one's, and
        # xi0_rel_err states one calibration's (the scatter the null model learns)
        n_rates = int(r["n_repeats"].iloc[0]) if "n_repeats" in r.columns else 1
        rel = (float(r["xi0_err_khz"].iloc[0]) * 1e3 / xi * np.sqrt(n_rates)
               if "xi0_err_khz" in r.columns else np.nan)
        pe = max(min(F, 1 - 0.5 / N), 0.5 / N)
        row = {"A": float(A), "dpd": int(d), "xi0_hz": xi, "xi0_rel_err": rel,
               "n_rates": n_rates,
               "n_scans": int(g["scan"].nunique()), "shots": N,
               "F_pop": F, "F_pop_shot": np.sqrt(pe * (1 - pe) / N),
               "imb": np.nan, "imb_shot": np.nan,
               "C": float(np.mean(cs)), "C_shot": float(np.sqrt(np.sum(np.square(es))) / len(es))}
        if has_imb:
            p00, p11 = g["n00"].sum() / N, g["n11"].sum() / N
            row["imb"] = p00 - p11
            row["imb_shot"] = np.sqrt(max(p00 + p11 - (p00 - p11) ** 2, 1.0 / N) / N)
        rows.append(row)
    return pd.DataFrame(rows).sort_values(["dpd", "A"], ignore_index=True)


def _time_scans(cf: CampaignFolder):
    ts = cf.time_scans
    if ts is None:
        return None
    # n_repeats: the time scans pooled into each point (their shots summed)
    keep = ["A", "dpd", "t_s", "n00", "n11", "shots"] + (
        ["n_repeats"] if "n_repeats" in ts.columns else [])
    return ts[keep].reset_index(drop=True)


def _spam(cf: CampaignFolder):
    spam = cf.spam
    if spam is None:
        return None
    return spam[["prepared", "n00", "n01_10", "n11", "shots"]].reset_index(drop=True)


def pulse_response_noise(steps, power) -> np.ndarray:
    """Each sample's noise from its step's own trace, for a table without ``power_err``:
    the median absolute deviation of successive differences (1.4826 MAD / sqrt 2: the
    rise and any ringing are a few samples among thousands, so they do not enter)."""
    steps, power = np.asarray(steps), np.asarray(power, dtype=float)
    sigma = np.empty(power.size)
    for s in np.unique(steps):
        idx = np.flatnonzero(steps == s)
        d = np.diff(power[idx])
        mad = np.median(np.abs(d - np.median(d))) if d.size else 0.0
        floor = 1e-9 * max(float(np.max(np.abs(power[idx]))), 1e-300)
        sigma[idx] = max(1.4826 * mad / np.sqrt(2.0), floor)
    return sigma


def _pulse_response(cf: CampaignFolder):
    pulse = cf.pulse_response
    if pulse is None:
        return None
    out = pulse[["step", "A", "t_us", "power"]].reset_index(drop=True)
    out["sigma"] = (pulse["power_err"].to_numpy(dtype=float) if "power_err" in pulse.columns
                    else pulse_response_noise(out["step"], out["power"]))
    return out


def _ramsey(cf: CampaignFolder):
    df = cf.ramsey
    if df is None:
        return None
    return df[["sequence", "wait_s", "n00", "n01_10", "n11", "shots"]].reset_index(drop=True)


def _linearity(cf: CampaignFolder, amp, cal_noise: dict):
    """The detector linearity pairs with their noise (None without the table)."""
    table = cf.detector_linearity
    if table is None:
        return None
    return linearity_data(table, cf.amplitude_model, cal_noise.get("photodiode"), amp)


def _thermometry(cf: CampaignFolder):
    th = cf.thermometry
    if th is None:
        return None
    return th[["wait_us", "wait_s", "sideband", "n_bright", "shots"]].reset_index(drop=True)


def _unfitted_characterisations(cf: CampaignFolder) -> list:
    """The ``left_out`` lines of the characterisations of the gate model a campaign
    without gate recordings has (their tables are read, not fitted)."""
    left = []
    if cf.ramsey is not None:
        left.append("ramsey.csv without gate recordings: not fitted (the coherence time it "
                    "measures is the gate model's)")
    if cf.spam is not None:
        left.append("spam.csv without gate recordings: not fitted (the preparation and "
                    "detection errors it measures are the gate model's)")
    if cf.thermometry is not None:
        left.append("thermometry.csv without gate recordings: not fitted (the motional "
                    "state it measures is the gate model's)")
    return left


def load_campaign(folder, run_fits: dict | None = None, calibration=None,
                  noise=None) -> Campaign:
    """Read and validate a campaign folder for the diagnosis.

    ``folder`` is a path or a :class:`~dpdfit.recordings.campaign_folder.CampaignFolder`
    (the reader ``dpdfit analyze`` shares).  Required: ``campaign.json``,
    ``calibration_amplitude.csv``, ``spectra.csv``; everything else is
    optional and what is absent is listed in :attr:`Campaign.left_out`.
    ``run_fits``: the amplitude runs' fits at the campaign's order, and
    ``calibration``: the model runs' fits (a Calibration), and ``noise``: the runs'
    noise models ``(power noise, phase noise)``, if the caller has them (not refitted).
    """
    cf = folder if isinstance(folder, CampaignFolder) else CampaignFolder(folder)
    cf.check_plausible()                 # a unit slip anywhere refuses the campaign
    cal_noise = {}
    noise_fits = {}
    amp, amp_res, ph, ph_res = _calibrations(cf, cal_noise, calibration, noise, noise_fits)
    warnings = []
    if not amp.monotone:
        iv = ", ".join(f"[{a:.3g}, {b:.3g}]" for a, b in amp.nonmonotone_intervals)
        warnings.append(f"{cf.file('calibration_amplitude.csv')}, run "
                        f"{amp.source.get('run', '?')}: amplitude calibration decreases on "
                        f"A in {iv}; the predistortion table clamps there")
    cf.require("spectra.csv", "the diagnosis")
    A, P_raw, snr, has_snr, n_rep, P_each = tone_grid(cf, TONE_HARMONICS)
    if has_snr:
        # the recorded SNR is over the median noise power: mean power = floor / ln 2
        # (pooled: over the mean of the repeats' floors)
        N0 = 10 ** ((P_raw - snr) / 10) / np.log(2)
        P, sd = debias_tones(P_raw, np.where(np.isfinite(N0), N0, np.inf), n_rep)
    else:
        P, sd = np.full_like(P_raw, np.nan), np.full_like(P_raw, np.nan)
    try:        # the campaign's error_model over the defaults (an unknown key refused)
        em = ErrorModel.from_dict(cf.raw_meta.get("error_model") or {}).campaign_dict()
    except InputError as exc:
        raise InputError(str(exc), file=str(cf.file("campaign.json"))) from None
    gates = _gates(cf)
    left = cf.left_out(_CONSEQUENCES)
    if ph is None:
        left.append("no phase calibration: the model has no AM-to-PM")
    if gates is None:
        left += _unfitted_characterisations(cf)
    recorded = cf.recording_times
    if run_fits is None and "power_err" not in cf.amplitude_runs.columns:
        # the drift modes fit every run without errors at the campaign's order, as the
        # power noise's learning did: the same fits, not made twice
        run_fits = noise_fits
    modes, coords, labels, starts, n_sig = drift_modes(cf, int(cf.meta["order"]), run_fits)
    after = runs_after_recordings(coords, labels, starts, recorded, cf.table_run)
    if not recorded:
        left.append("campaign.json has no spectra_recorded/gates_recorded: the calibration "
                    "runs cannot be placed relative to the recordings, so a stale "
                    "calibration (a drifted AOM moves the runs taken after them) and a "
                    "detector nonlinearity (it bends every run alike) are told apart by the "
                    "spectra alone")
    elif after is None:
        left.append("no amplitude calibration run after the recordings (or fewer than 3 "
                    "before them): a stale calibration is judged by the spectra alone")
    return Campaign(folder=cf.path, meta=cf.meta, amplitude=amp, phase=ph,
                    amp_residuals=amp_res, phase_residuals=ph_res, A_tones=A, P_dB=P,
                    sd_dB=sd, gates=gates, time_scans=_time_scans(cf), error_model=em,
                    warnings=tuple(warnings), P_raw=P_raw, snr_raw=snr, has_snr=has_snr,
                    n_repeats=n_rep, P_readings=P_each,
                    has_error_model="error_model" in cf.raw_meta, left_out=tuple(left),
                    drift_modes=modes, drift_significant=n_sig,
                    calibration_noise={k: None if v is None else v.to_dict()
                                       for k, v in cal_noise.items()},
                    recorded=recorded, runs_after=after, spam=_spam(cf),
                    pulse_response=_pulse_response(cf), ramsey=_ramsey(cf),
                    detector_linearity=_linearity(cf, amp, cal_noise),
                    thermometry=_thermometry(cf),
                    phase_runs_after=phase_runs_after(cf, ph, cal_noise.get("phase"),
                                                      recorded),
                    phase_points=model_run_points(cf, cal_noise.get("phase")))
