"""A campaign's tone powers on the diagnosis's grid (amplitude, dpd, sideband, harmonic).

Repeated recordings of a tone (repeated rows of ``spectra.csv``) are pooled first
(:func:`dpdfit.recordings.spectra.pool_spectra`: the mean linear power); the number
of readings of each tone and every reading itself come with them, for the errors
that shrink with the repeats and for the noise floor's likelihood (one reading's).
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from dpdfit.recordings.campaign_folder import CampaignFolder

__all__ = ["tone_grid"]


def _grid(df: pd.DataFrame, A: np.ndarray, harmonics, columns, extra=()):
    """Values of ``columns`` of a tone table on the (A, [extra,] dpd, sideband, harmonic)
    grid, NaN where the table has none (``extra``: an index column and its size; rows of
    harmonics not in the sorted ``harmonics`` are left out)."""
    iA = np.searchsorted(A, df["A"].to_numpy(dtype=float))
    d = df["dpd"].to_numpy(dtype=int)
    s = (df["sideband"] == "blue").to_numpy(dtype=int)
    n = df["n"].to_numpy(dtype=int)
    keep = np.isin(n, harmonics)
    h = np.searchsorted(harmonics, n[keep])
    lead = (iA[keep],) + tuple(np.asarray(df[c].to_numpy())[keep] for c, _ in extra)
    shape = (A.size,) + tuple(size for _, size in extra) + (2, 2, len(harmonics))
    out = []
    for c in columns:
        x = np.full(shape, np.nan)
        x[lead + (d[keep], s[keep], h)] = df[c].to_numpy(dtype=float)[keep]
        out.append(x)
    return out


def tone_grid(cf: CampaignFolder, harmonics):
    """Recorded tone powers, their repeats pooled (mean linear power,
    :func:`~dpdfit.recordings.spectra.pool_spectra`), on the (A, dpd, sideband, harmonic)
    grid: ``A``, pooled powers, SNRs (NaN without ``snr_db``), the number of readings of
    each tone (0 where none), whether ``snr_db`` is recorded, and every reading on the
    grid (A, repeat, dpd, sideband, harmonic) -- the repeats in their order of a tone."""
    pooled, reads = cf.pooled_spectra, cf.spectra
    A = np.unique(pooled["A"].to_numpy(dtype=float))
    has_snr = "snr_db" in pooled.columns
    P, n = _grid(pooled, A, harmonics, ["P_dB", "n_repeats"])
    n = np.where(np.isfinite(n), n, 0.0)
    snr = _grid(pooled, A, harmonics, ["snr_db"])[0] if has_snr else np.full_like(P, np.nan)
    k = reads.groupby(["A", "dpd", "sideband", "n"], sort=False).cumcount().to_numpy()
    each = _grid(reads.assign(_k=k), A, harmonics, ["P_dB"],
                 extra=(("_k", int(k.max()) + 1),))[0]
    return A, P, snr, has_snr, n, each
