"""The phase calibration runs taken after the recordings, as data of every hypothesis.

The model's phase run (``phase_run_for_model``) is in the diagnosis's likelihood already:
its fit's covariance gives the calibration's phase error modes (``cal_phase*``) their
N(0, 1) priors, which are that run's own likelihood, linearised; its residuals are not
added again.  A run taken *after* the recordings measures the AOM's phase transfer as
it is now: under the baseline it is the model's curve, moved by the run-to-run drift of
``phi`` (learnt from the runs taken before the recordings) and its own noise (the
``phase_err`` column, else the noise model learnt from every run,
:func:`~dpdfit.fits.photodiode.phase_run_with_noise`); an effect that changes the AOM's
phase transfer (its coefficients, e.g. the modulator's own AM-to-PM left out of the
model) moves it (:mod:`~dpdfit.analyses.diagnosis.model.phase_runs_block`).

The run-to-run drift is a Gaussian nuisance of each run along the model's curve
``phi(A) / phi(1)`` (the AOM's phase scales as a whole with the drive it sees), its sd the
rms of the runs before the recordings about the model's run (without another such run:
:data:`~dpdfit.core.defaults.PHASE_RUN_NOISE_RAD`); it is marginalised, so each run is
whitened once (:attr:`PhaseRunsAfter.whiteners`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

from dpdfit.core.defaults import PHASE_MIN_A, PHASE_RUN_NOISE_RAD

__all__ = ["PhaseRunsAfter", "phase_runs_after", "phase_whitener", "drift_shape",
           "model_run_points"]


@dataclass(frozen=True)
class PhaseRunsAfter:
    """The phase runs taken after the recordings (points at ``A >= PHASE_MIN_A``).

    ``runs``: labels; ``hours``: hours after the recordings; ``A``, ``phase``: one array
    per run (rad, as recorded); ``whiteners``: one matrix per run, ``W Cov W^T = I`` for
    its noise and drift; ``drift_sd``: the run-to-run sd of ``phi(1)`` (rad) used.
    """

    runs: tuple
    hours: np.ndarray
    A: tuple
    phase: tuple
    whiteners: tuple
    drift_sd: float

    def standardised(self, predicted) -> np.ndarray:
        """Whitened residuals of every run against ``predicted`` (a callable of the
        amplitudes: the recorded phase the hypothesis predicts), concatenated."""
        return np.concatenate([W @ (y - predicted(A)) for A, y, W in
                               zip(self.A, self.phase, self.whiteners)])


def drift_shape(phase_cal, A) -> np.ndarray:
    """The run-to-run drift's shape at ``A``: the model's curve over its ``phi(1)``
    (``A^2``, the AOM's own form, when ``phi(1)`` is not measured above its error)."""
    A = np.asarray(A, dtype=float)
    p1 = float(phase_cal.phi_at_1)
    if abs(p1) > 3 * float(phase_cal.phi_at_1_stderr) and p1 != 0:
        return np.asarray(phase_cal.phi(A), dtype=float) / p1
    return A ** 2


def phase_whitener(sd_points, shape, drift_sd: float) -> np.ndarray:
    """Whitening ``W`` (``W C W^T = I``) of ``C = diag(sd_points^2) + drift_sd^2 s s^T``."""
    s = np.asarray(shape, dtype=float)
    C = np.diag(np.asarray(sd_points, dtype=float) ** 2) + drift_sd ** 2 * np.outer(s, s)
    return np.linalg.inv(np.linalg.cholesky(C))


def _run_starts(df: pd.DataFrame) -> dict:
    if "run" not in df.columns or "timestamp" not in df.columns:
        return {}
    t = pd.to_datetime(df["timestamp"], utc=True, errors="coerce")
    return {str(r): t[df["run"] == r].min() for r in dict.fromkeys(df["run"].tolist())}


def _sd_points(data, noise) -> np.ndarray | None:
    if data.error is not None:
        return np.asarray(data.error, dtype=float)
    return None if noise is None else np.asarray(noise.sigma(data.A), dtype=float)


def model_run_points(cf, noise) -> tuple | None:
    """``(A, sd)``: the amplitudes ``A >= PHASE_MIN_A`` of the model's phase run and their
    errors (rad; as recorded, else the learnt ``noise``; None without either), the points
    a further run repeats (the schedule writes the latest run's amplitudes); None without
    a phase file."""
    data = cf.phase_model
    if data is None:
        return None
    use = data.A >= PHASE_MIN_A
    sd = _sd_points(data, noise)
    return np.asarray(data.A[use], dtype=float), None if sd is None else sd[use]


def phase_runs_after(cf, phase_cal, noise, recorded: dict) -> PhaseRunsAfter | None:
    """The phase runs of the folder ``cf`` taken after every recording (``recorded``:
    :attr:`~dpdfit.recordings.campaign_folder.CampaignFolder.recording_times`), against
    the model's phase calibration ``phase_cal`` with the learnt phase ``noise``; None
    without a phase file, recording times, run timestamps, errors or such a run."""
    df = cf.phase_runs
    if phase_cal is None or df is None or not recorded:
        return None
    t_rec = max(recorded.values())
    starts = _run_starts(df)
    if not starts or any(pd.isna(t) for t in starts.values()):
        return None
    data = cf.phase_run_data
    model = str(cf.phase_model.run)
    before = [r for r, t in starts.items() if t <= t_rec and r != model]
    # the model's run is in the likelihood already (module doc), wherever it lies
    after = [r for r, t in starts.items() if t > t_rec and r != model]
    if not after:
        return None
    drift = []
    for r in before:
        use = data[r].A >= PHASE_MIN_A
        s = drift_shape(phase_cal, data[r].A[use])
        dev = data[r].value[use] - phase_cal.phi(data[r].A[use])
        drift.append(float(s @ dev / (s @ s)))
    drift_sd = float(np.sqrt(np.mean(np.square(drift)))) if len(drift) >= 2 \
        else PHASE_RUN_NOISE_RAD
    A, y, W = [], [], []
    for r in after:
        use = data[r].A >= PHASE_MIN_A
        sd = _sd_points(data[r], noise)
        if sd is None:
            return None
        A.append(data[r].A[use])
        y.append(data[r].value[use])
        W.append(phase_whitener(sd[use], drift_shape(phase_cal, A[-1]), drift_sd))
    hours = np.array([(starts[r] - t_rec) / pd.Timedelta(hours=1) for r in after], float)
    return PhaseRunsAfter(tuple(after), hours, tuple(A), tuple(y), tuple(W), drift_sd)
