"""The amplitude sweep (Supplement S6): spectra, fidelity estimate, efficiency, gate rate.

For every normalised amplitude ``A`` of a grid and both DPD flags the
Cardioid(1,2) waveform (or any tone set) is synthesised, optionally
predistorted, pushed through the calibrated AM/PM forward model, and its tone
powers ``P_0..P_3`` are read exactly off the FFT grid for each sideband.  From
them follow ``R10``, ``R23``, ``dP_n`` (DPD minus no-DPD at matched ``A``), the
spectrum-based estimate ``F_est`` (S5), the time-averaged diffraction
efficiency ``eta_bar`` (Eqs. S15-S16) and the relative gate rate ``r_rel``
(Eq. S12).

Output is a long table with one row per ``(A, dpd, sideband)``, ``sideband``
in ``red``, ``blue``, ``mean``.  The ``mean`` row averages the dB values of
the two sidebands (``P_n``, ``R10``, ``R23``, ``dP_n``, as the paper averages
``R10``) and the fidelities (``F_est``, as S5.4); its ``r_rel`` uses the mean
``P1_dB``.  ``dP_n`` is the same on the ``dpd = 0`` and ``dpd = 1`` rows of an
amplitude.  ``eta_bar`` does not depend on the sideband.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import pandas as pd
from scipy.interpolate import CubicSpline

from dpdfit.core.defaults import ETA_REF, FORMULA, NBAR, NU_HZ, XI0_SPECTRA_HZ
from dpdfit.errors import InputError
from dpdfit.models.fidelity import FORMULAS, estimate
from dpdfit.models.spectrum import field_tone_powers, simulate_field
from dpdfit.models.transfer import TransferFunction
from dpdfit.models.waveforms import ToneSet, cardioid, sample_grid
from dpdfit.recordings.outputs import read_csv_header
from dpdfit.recordings.tables import read_table

__all__ = ["SweepConfig", "run_sweep", "check_sweep_size", "MAX_SWEEP_SAMPLES", "eta_bar",
           "efficiency_spline", "eta_corr", "thresholds", "read_sweep_table",
           "first_crossing", "first_crossing_rows", "parse_amplitudes", "COLUMNS",
           "THRESHOLD_LEVELS", "SWEEP_HARMONICS"]

COLUMNS = ["A", "dpd", "sideband", "P0_dB", "P1_dB", "P2_dB", "P3_dB", "R10_dB", "R23_dB",
           "dP1_dB", "dP2_dB", "eta_bar", "F_est", "eps_est", "r_rel"]
THRESHOLD_LEVELS = {"1e-2": 1e-2, "1e-3": 1e-3, "1e-4": 1e-4}
#: Harmonics n of the tones whose powers P0..P3 the sweep reads (carrier n = 0 first).
SWEEP_HARMONICS = (0, 1, 2, 3)

#: Largest sweep ``run_sweep`` will build: samples per record times (amplitudes + 1 anchor);
#: 2e7 complex samples are 320 MB per array (the default sweep uses 1.7e5).
MAX_SWEEP_SAMPLES = 20_000_000


def parse_amplitudes(spec: str) -> np.ndarray:
    """``"START:STOP:N"`` -> N amplitudes from START to STOP inclusive, within [0, 1]."""
    parts = str(spec).split(":")
    try:
        if len(parts) != 3:
            raise ValueError
        start, stop, n = float(parts[0]), float(parts[1]), int(parts[2])
    except ValueError:
        raise InputError(f"--amplitudes must be START:STOP:N (e.g. 0.05:1:100), got '{spec}'"
                         ) from None
    if n < 2:
        raise InputError(f"--amplitudes needs N >= 2 points, got {n}")
    if not (0 <= start < stop <= 1):
        raise InputError(f"--amplitudes grid must satisfy 0 <= START < STOP <= 1, got '{spec}'")
    return np.linspace(start, stop, n)


@dataclass(frozen=True)
class SweepConfig:
    """Settings of a sweep (defaults: the spectral-benchmarking values of S4).

    Attributes
    ----------
    amplitudes : ndarray
        Grid of normalised amplitudes (default 100 points on 0.05..1).
    nu, xi0 : float
        Sideband and gate detuning, Hz.
    nbar : float
        Thermal phonon number for ``F_est``.
    am_only : bool
        Forward model without the phase response.
    formula : {"exact", "paper"}
    eta_ref : float
        Peak diffraction efficiency at A = 1.
    anchor : (float, int)
        ``(A, dpd)`` of the ``r_rel = 1`` reference (paper: (0.4, 0)).
    tones : ToneSet
    """

    amplitudes: np.ndarray = field(default_factory=lambda: np.linspace(0.05, 1.0, 100))
    nu: float = NU_HZ
    xi0: float = XI0_SPECTRA_HZ
    nbar: float = NBAR
    am_only: bool = False
    formula: str = FORMULA
    eta_ref: float = ETA_REF
    anchor: tuple = (0.4, 0)
    tones: ToneSet = field(default_factory=cardioid)

    def __post_init__(self):
        A = np.asarray(self.amplitudes, dtype=float)
        if A.ndim != 1 or A.size < 2 or np.any((A < 0) | (A > 1)) or not np.all(np.isfinite(A)):
            raise InputError("sweep amplitudes must be >= 2 finite values in [0, 1]")
        if self.formula not in FORMULAS:
            raise InputError(f"formula must be one of {FORMULAS}, got {self.formula!r}")
        if not 0 < self.eta_ref <= 1:
            raise InputError(f"eta_ref must lie in (0, 1], got {self.eta_ref}")
        if not 0 <= self.anchor[0] <= 1 or self.anchor[1] not in (0, 1):
            raise InputError(f"anchor must be (A in [0,1], dpd 0/1), got {self.anchor}")
        if not (np.isfinite(self.nbar) and self.nbar >= 0):
            raise InputError(f"nbar must be a finite number >= 0, got {self.nbar}")
        object.__setattr__(self, "amplitudes", A)


def eta_bar(rf, transfer: TransferFunction, eta_ref: float = ETA_REF):
    """Time-averaged diffraction efficiency (Eqs. S15-S16).

    ``eta_bar = eta_ref * mean_i |f_AM(w_i)|^2 / |f_AM(1)|^2`` over the RF
    samples ``w_i`` (after optional DPD), along the last axis.
    """
    rf = np.asarray(rf)
    p = transfer.f_am(np.abs(rf)) ** 2
    return eta_ref * p.mean(axis=-1) / transfer.f_am(1.0) ** 2


def _spectra(transfer, cfg, grid, A, dpd):
    rf, fld = simulate_field(transfer, cfg.tones, grid, A, dpd, cfg.am_only)
    spec = field_tone_powers(fld, grid, SWEEP_HARMONICS)
    return spec.P_dB("red"), spec.P_dB("blue"), eta_bar(rf, transfer, cfg.eta_ref)


def check_sweep_size(cfg: SweepConfig, names=("nu", "xi0", "amplitudes")):
    """The sample grid of ``cfg``, refused before anything is allocated if it is too large.

    The sweep holds ``n_samples`` complex samples per amplitude; above
    :data:`MAX_SWEEP_SAMPLES` in total (``n_samples * len(amplitudes)``) an
    :class:`~dpdfit.errors.InputError` names ``names`` (the settings, or the
    command-line options) and the size.
    """
    nu, xi0, amps = names
    try:
        with np.errstate(over="ignore"):        # an overflow is refused below
            grid = sample_grid(cfg.nu, cfg.xi0, cfg.tones)
    except InputError as exc:
        raise InputError(f"{nu}, {xi0}: {exc}") from None
    except OverflowError:
        raise InputError(f"{nu}, {xi0}: nu = {cfg.nu:g} Hz, xi0 = {cfg.xi0:g} Hz need more "
                         f"samples than can be counted, above the limit of "
                         f"{MAX_SWEEP_SAMPLES:.3g} (MAX_SWEEP_SAMPLES)") from None
    total = int(grid.n_samples) * (len(cfg.amplitudes) + 1)
    if total > MAX_SWEEP_SAMPLES:
        raise InputError(
            f"{nu}, {xi0}: nu = {cfg.nu:g} Hz, xi0 = {cfg.xi0:g} Hz need {grid.n_samples} "
            f"samples per record x {len(cfg.amplitudes) + 1} records = {total:.3g} samples, "
            f"above the limit of {MAX_SWEEP_SAMPLES:.3g} (MAX_SWEEP_SAMPLES); lower {nu}, "
            f"raise {xi0} or give fewer {amps}")
    return grid


def run_sweep(transfer: TransferFunction, cfg: SweepConfig = SweepConfig()) -> pd.DataFrame:
    """Run the amplitude sweep; returns the long table (columns :data:`COLUMNS`).

    ``df.attrs`` carries ``A_corr``, ``eta_corr`` (``{"dpd", "no_dpd"}``)
    and the settings.
    """
    tones = cfg.tones
    if not {1, 2} <= set(tones.n):
        raise InputError("the sweep's fidelity estimate needs gate tones n = 1 and 2")
    grid = check_sweep_size(cfg)
    A = cfg.amplitudes
    res = {d: _spectra(transfer, cfg, grid, A, bool(d)) for d in (0, 1)}
    ar, ab, _ = _spectra(transfer, cfg, grid, [cfg.anchor[0]], bool(cfg.anchor[1]))
    anchor_P1 = {"red": ar[0, 1], "blue": ab[0, 1], "mean": 0.5 * (ar[0, 1] + ab[0, 1])}
    gate_signs = tuple(np.sign([tones.r_blue[tones.n.index(k)] for k in (1, 2)]))

    frames = []
    for d in (0, 1):
        Pr, Pb, eta = res[d]
        P = {"red": Pr, "blue": Pb, "mean": 0.5 * (Pr + Pb)}
        dP = {"red": res[1][0] - res[0][0], "blue": res[1][1] - res[0][1]}
        dP["mean"] = 0.5 * (dP["red"] + dP["blue"])
        F = {sb: estimate(P[sb], SWEEP_HARMONICS, gate_signs=gate_signs, nbar=cfg.nbar,
                          formula=cfg.formula).F_est for sb in ("red", "blue")}
        F["mean"] = 0.5 * (F["red"] + F["blue"])
        for sb in ("red", "blue", "mean"):
            p = P[sb]
            frames.append(pd.DataFrame({
                "A": A, "dpd": d, "sideband": sb,
                "P0_dB": p[:, 0], "P1_dB": p[:, 1], "P2_dB": p[:, 2], "P3_dB": p[:, 3],
                "R10_dB": p[:, 1] - p[:, 0], "R23_dB": p[:, 2] - p[:, 3],
                "dP1_dB": dP[sb][:, 1], "dP2_dB": dP[sb][:, 2], "eta_bar": eta,
                "F_est": F[sb], "eps_est": 1.0 - F[sb],
                "r_rel": 10 ** ((p[:, 1] - anchor_P1[sb]) / 20)}))
    df = pd.concat(frames, ignore_index=True)[COLUMNS]
    df = df.sort_values(["dpd", "A", "sideband"], kind="stable", ignore_index=True)
    df.attrs.update({
        "A_corr": transfer.A_corr, "nu": cfg.nu, "xi0": cfg.xi0, "nbar": cfg.nbar,
        "am_only": cfg.am_only, "formula": cfg.formula, "eta_ref": cfg.eta_ref,
        "anchor_A": cfg.anchor[0], "anchor_dpd": cfg.anchor[1], "tones": tones.name,
        "fs": grid.fs, "n_samples": grid.n_samples})
    df.attrs["eta_corr"] = eta_corr(df)
    return df


def efficiency_spline(df: pd.DataFrame, dpd: int) -> CubicSpline:
    """Cubic spline ``A -> eta_bar`` for one DPD flag (S6.6)."""
    sub = df[(df["dpd"] == dpd) & (df["sideband"] == "mean")].sort_values("A")
    if len(sub) < 4:
        raise InputError(f"sweep table has {len(sub)} amplitudes for dpd={dpd}; need >= 4",
                         file=df.attrs.get("source"))
    return CubicSpline(sub["A"].to_numpy(), sub["eta_bar"].to_numpy())


def eta_corr(df: pd.DataFrame, A_corr: float | None = None) -> dict:
    """``eta_bar`` at ``A_corr`` for both flags (spline-interpolated)."""
    Ac = df.attrs.get("A_corr") if A_corr is None else A_corr
    if Ac is None:
        raise InputError("A_corr unknown: the sweep table carries no A_corr")
    out = {}
    for d, key in ((1, "dpd"), (0, "no_dpd")):
        sp = efficiency_spline(df, d)
        lo, hi = sp.x[0], sp.x[-1]
        out[key] = float(sp(Ac)) if lo <= Ac <= hi else None
    return out


def first_crossing(x, y, level):
    """First x (increasing) where y rises through ``level``; log-log interpolation.

    Only points with ``x, y > 0`` are used; ``None`` when the curve never
    reaches ``level`` or already starts at or above it.
    """
    order = np.argsort(x)
    x, y = np.asarray(x)[order], np.asarray(y)[order]
    ok = (x > 0) & (y > 0)
    x, y = x[ok], y[ok]
    if x.size < 2 or y[0] >= level:
        return None
    above = np.flatnonzero(y >= level)
    if above.size == 0:
        return None
    i = above[0]
    lx0, lx1 = np.log(x[i - 1]), np.log(x[i])
    ly0, ly1 = np.log(y[i - 1]), np.log(y[i])
    return float(np.exp(lx0 + (np.log(level) - ly0) * (lx1 - lx0) / (ly1 - ly0)))


def first_crossing_rows(x, y, level):
    """Row-wise first rise of ``y`` through ``level`` along increasing ``x``, log-log interpolated.

    Vectorised form of :func:`first_crossing` for a batch of curves (rows); NaN
    where the curve never reaches ``level`` or starts above it.
    """
    x = np.asarray(x, dtype=float)
    y = np.asarray(y, dtype=float)
    order = np.argsort(x, axis=1)
    x = np.take_along_axis(x, order, axis=1)
    y = np.take_along_axis(y, order, axis=1)
    above = y >= level
    has = above.any(axis=1) & ~above[:, 0]
    i = np.where(has, np.argmax(above, axis=1), 1)
    r = np.arange(x.shape[0])
    with np.errstate(divide="ignore", invalid="ignore"):
        lx0, lx1 = np.log(x[r, i - 1]), np.log(x[r, i])
        ly0, ly1 = np.log(np.maximum(y[r, i - 1], 1e-300)), np.log(np.maximum(y[r, i], 1e-300))
        out = np.exp(lx0 + (np.log(level) - ly0) * (lx1 - lx0) / (ly1 - ly0))
    return np.where(has, out, np.nan)


def thresholds(df: pd.DataFrame) -> dict:
    """Threshold efficiencies and ``eta_bar_corr`` (main text, Fig. 5).

    ``eta_th(eps)``: the lowest ``eta_bar`` at which ``eps_est`` (mean of the
    sidebands) rises through ``eps``, interpolated linearly in
    ``log(eps_est)`` vs ``log(eta_bar)`` between grid points; ``None`` when the
    curve never reaches ``eps`` or already exceeds it at the smallest
    ``eta_bar`` of the sweep.

    Returns ``{"eta_corr": {"dpd", "no_dpd"}, "eta_th": {"dpd": {"1e-2", ...},
    "no_dpd": {...}}}``.
    """
    out = {"eta_corr": df.attrs.get("eta_corr") or eta_corr(df), "eta_th": {}}
    for d, key in ((1, "dpd"), (0, "no_dpd")):
        sub = df[(df["dpd"] == d) & (df["sideband"] == "mean")]
        out["eta_th"][key] = {name: first_crossing(sub["eta_bar"], sub["eps_est"], lev)
                              for name, lev in THRESHOLD_LEVELS.items()}
    return out


def read_sweep_table(path) -> pd.DataFrame:
    """Read a ``sweep.csv`` written by ``dpdfit sweep``, validated.

    Columns :data:`COLUMNS`, finite numbers, ``A`` in [0, 1], ``dpd`` 0/1,
    ``sideband`` red/blue/mean and no (A, dpd, sideband) twice; an
    :class:`~dpdfit.errors.InputError` names file, column and row.  The
    header's ``A_corr`` (or None) goes into ``df.attrs["A_corr"]``.
    """
    name = str(path)
    df = read_table(path, COLUMNS, numeric=[c for c in COLUMNS if c != "sideband"],
                    ranges={"A": (0.0, 1.0), "dpd": (0, 1)}, unique=["A", "dpd", "sideband"])
    bad = ~df["sideband"].isin(["red", "blue", "mean"])
    if bad.any():
        i = int(np.flatnonzero(bad.to_numpy())[0])
        raise InputError(f"sideband must be red, blue or mean, got '{df['sideband'].iloc[i]}'",
                         file=name, column="sideband", row=i + 1)
    frac = df["dpd"] != np.round(df["dpd"])
    if frac.any():
        i = int(np.flatnonzero(frac.to_numpy())[0])
        raise InputError(f"dpd must be 0 or 1, got {df['dpd'].iloc[i]:g}", file=name,
                         column="dpd", row=i + 1)
    df["dpd"] = df["dpd"].astype(int)
    try:
        a_corr = read_csv_header(path).get("A_corr")
    except UnicodeDecodeError as exc:
        raise InputError(f"not UTF-8 text (byte {exc.start + 1})", file=name) from None
    except RecursionError:
        raise InputError("a '# key: value' header line is nested too deeply to be read as "
                         "JSON", file=name) from None
    df.attrs["A_corr"] = _header_a_corr(a_corr, name)
    return df


def _header_a_corr(value, name: str) -> float | None:
    """The header's ``A_corr``: None, or a finite number in (0, 1] as ``dpdfit sweep``
    writes it; an InputError naming the file for anything else (the header may have been
    edited, or come from elsewhere)."""
    if value is None:
        return None
    number = None
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        try:
            number = float(value)
        except OverflowError:                 # an integer of hundreds of digits
            number = math.inf
    if number is None or not (math.isfinite(number) and 0 < number <= 1):
        what = (f"{number:g}" if number is not None else
                {str: "text", list: "a list", dict: "an object", bool: "true or false"}
                .get(type(value), type(value).__name__))
        raise InputError(f"the header's A_corr must be a number in (0, 1], got {what}",
                         file=name)
    return number
