"""Run-to-run drift of the amplitude calibration: its principal modes, and the runs
taken after the recordings in those modes (what a stale calibration is tested against)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

from dpdfit.errors import DpdfitError
from dpdfit.fits.calibration import fit_amplitude
from dpdfit.recordings.calibration_runs import list_runs
from dpdfit.recordings.campaign_folder import CampaignFolder

__all__ = ["RunsAfter", "MAX_DRIFT_MODES", "DRIFT_MODE_SIGNIFICANCE", "drift_modes",
           "runs_after_recordings"]

#: this many run-to-run drift modes (principal components); a mode is significant if its
#: run-to-run sd exceeds DRIFT_MODE_SIGNIFICANCE times the runs' median fit error (both rms
#: over 0 <= A <= 1)
MAX_DRIFT_MODES = 3
DRIFT_MODE_SIGNIFICANCE = 2.0


def drift_modes(cf: CampaignFolder, order: int, run_fits: dict | None = None):
    """Principal components of the amplitude runs' normalised curves (see Campaign), and
    each run's coordinates along them with its start time: ``(modes, coords, labels,
    starts, n_significant)`` or ``(None, None, (), (), 0)``.

    ``run_fits``: the runs' fits at ``order`` already made by the caller
    (``{run label: fit}``, as ``dpdfit analyze``'s calibration step makes them);
    a run not in it is fitted here.
    """
    df = cf.amplitude_runs
    runs = list_runs(df)
    if len(runs) < 3:
        return None, None, (), (), 0
    C, err, labels, starts = [], [], [], []
    A = np.linspace(0.0, 1.0, 101)
    for r in runs:
        sub = df[df["run"] == r]
        f = (run_fits or {}).get(r)
        try:
            f = f if f is not None else fit_amplitude(sub["A"].to_numpy(), sub["power"].to_numpy(),
                              sub["power_err"].to_numpy() if "power_err" in sub.columns else None,
                              order)
        except DpdfitError:
            continue
        C.append(np.asarray(f.coefficients)[1:])
        err.append(np.sqrt(np.mean(f.y_stderr(A) ** 2)))
        labels.append(r)
        starts.append(sub["timestamp"].min() if "timestamp" in sub.columns else None)
    if len(C) < 3:
        return None, None, (), (), 0
    C = np.array(C)
    V = A[:, None] ** np.arange(2, order + 1)[None, :]
    U, sv, Vt = np.linalg.svd((C - C.mean(0)) @ V.T, full_matrices=False)
    sd = sv / np.sqrt((len(C) - 1) * A.size)                  # rms over A of each mode
    keep = [i for i in range(min(MAX_DRIFT_MODES, sd.size)) if sd[i] > 0]
    n_sig = max(1, sum(sd[i] > DRIFT_MODE_SIGNIFICANCE * np.median(err) for i in keep))
    # function-space direction -> coefficients (least squares on the grid), scaled to 1 sd
    coef = np.linalg.lstsq(V, Vt[keep].T * sd[keep] * np.sqrt(A.size), rcond=None)[0]
    # each run's coordinate along a mode, in units of the mode (zero mean, unit sd)
    coords = U[:, keep] * np.sqrt(len(C) - 1)
    return coef.T, coords, tuple(labels), tuple(starts), int(n_sig)


def runs_after_recordings(coords, labels, starts, recorded: dict, table_run) -> RunsAfter | None:
    """The runs started after the recordings (:class:`RunsAfter`), or None."""
    t_rec = recorded.get("spectra_recorded") or recorded.get("gates_recorded")
    if t_rec is None or coords is None or any(s is None for s in starts):
        return None
    starts = pd.to_datetime(list(starts), utc=True)
    after = np.asarray(starts > t_rec)
    before = ~after
    if not after.any() or before.sum() < 3:
        return None
    mu = coords[before].mean(axis=0)
    sd = np.maximum(coords[before].std(axis=0, ddof=1), 1e-3)
    days = np.asarray((starts[after] - t_rec) / pd.Timedelta(days=1), dtype=float)
    return RunsAfter(tuple(np.asarray(labels)[after]), days, coords[after], mu, sd)


@dataclass(frozen=True)
class RunsAfter:
    """The amplitude calibration runs taken after the recordings, in the run-to-run drift
    modes (each mode scaled to the runs' sd, :func:`drift_modes`).

    ``coords`` (n runs, n modes): their coordinates; ``mu``, ``sd``: mean and sd of
    the runs taken before the recordings (the table's run among them), the null
    expectation; ``days``: days after the recordings; ``runs``: their labels.
    """

    runs: tuple
    days: np.ndarray
    coords: np.ndarray
    mu: np.ndarray
    sd: np.ndarray

    def standardised(self, shift=None) -> np.ndarray:
        """Standardised residuals (n runs, n modes) against the null plus ``shift``."""
        c = self.coords - self.mu[None, :] - (0.0 if shift is None else shift)
        return c / self.sd[None, :]
