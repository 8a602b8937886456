"""Reading a multi-run calibration table and fitting it run by run: :func:`stability`."""

from __future__ import annotations

import numpy as np
import pandas as pd

from dpdfit.core.defaults import AMPLITUDE_ORDER, PHASE_MIN_A, PHASE_ORDER
from dpdfit.errors import DpdfitError, FitError, InputError
from dpdfit.fits.calibration import fit_amplitude, fit_phase
from dpdfit.recordings.calibration_runs import CALIBRATION_COLUMNS, list_runs
from dpdfit.recordings.tables import (check_calibration_phases, check_repeated_rows,
                                      read_calibration_table)

from .result import StabilityResult
from .timeseries import allan_deviation, drift_test

__all__ = ["stability", "missing_stability_columns"]

_DEFAULT_ORDER = {"amplitude": AMPLITUDE_ORDER, "phase": PHASE_ORDER}


def _check_frame(df: pd.DataFrame, kind: str) -> tuple[pd.DataFrame, str]:
    """Validated copy of a calibration DataFrame (numbers finite, timestamps parsed)."""
    value_col, err_col = CALIBRATION_COLUMNS[kind]
    df = df.copy()
    name = str(df.attrs.get("source", "<DataFrame>"))
    for col in ("A", value_col):
        if col not in df.columns:
            raise InputError(f"required column is missing; columns present: "
                             f"{list(df.columns)}", file=name, column=col)
    if len(df) == 0:
        raise InputError("table has no rows", file=name)
    df = df.reset_index(drop=True)
    for col in ("A", value_col) + ((err_col,) if err_col in df.columns else ()):
        vals = pd.to_numeric(df[col], errors="coerce").to_numpy(dtype=float)
        bad = ~np.isfinite(vals)
        if bad.any():
            raise InputError("value is not a finite number", file=name, column=col,
                             row=int(np.flatnonzero(bad)[0]) + 1)
        df[col] = vals
    if "run" in df.columns:
        df["run"] = df["run"].astype(str)
    if "timestamp" in df.columns:
        ts = pd.to_datetime(df["timestamp"], errors="coerce", utc=True, format="mixed")
        bad = ts.isna().to_numpy()
        if bad.any():
            i = int(np.flatnonzero(bad)[0])
            raise InputError(f"'{df['timestamp'].iloc[i]}' is not a date/time (use ISO "
                             "8601, e.g. 2026-03-01T09:30:00)", file=name,
                             column="timestamp", row=i + 1)
        df["timestamp"] = ts
    check_repeated_rows(df, name)
    return df, name


def _load(df_or_path, kind: str) -> tuple[pd.DataFrame, str]:
    """A calibration table validated as the campaign folder validates it: a file by its
    reader (:func:`~dpdfit.recordings.tables.read_calibration_table`), a DataFrame by
    the same rules."""
    if not isinstance(df_or_path, pd.DataFrame):
        return read_calibration_table(df_or_path, kind), str(df_or_path)
    df, name = _check_frame(df_or_path, kind)
    if kind == "phase":                    # phases in degrees: refused as by the readers
        check_calibration_phases(df, name)
    return df, name


def missing_stability_columns(df: pd.DataFrame) -> list[str]:
    """The optional calibration columns the stability needs and ``df`` lacks (``run``
    labels the runs, ``timestamp`` places them in time): an empty list when it can run."""
    return [c for c in ("run", "timestamp") if c not in df.columns]


def _run_labels(df: pd.DataFrame, name: str) -> list[str]:
    if "run" not in df.columns:
        raise InputError("stability needs a 'run' column labelling the calibration runs "
                         f"(columns present: {list(df.columns)})", file=name)
    if "timestamp" not in df.columns:
        raise InputError("stability needs a 'timestamp' column (ISO 8601 date/time of "
                         f"each run; columns present: {list(df.columns)})", file=name)
    labels = list_runs(df)
    if len(labels) < 2:
        raise InputError(f"stability needs >= 2 calibration runs, the file holds "
                         f"{len(labels)} ({', '.join(labels)})", file=name)
    return labels


def _fit_run(sub, kind, K, A_min, grid, name, lab, cal=None):
    """One run: ``(record, curve on grid)``; ``cal``: its precomputed fit, if any."""
    value_col, err_col = CALIBRATION_COLUMNS[kind]
    A = sub["A"].to_numpy(dtype=float)
    v = sub[value_col].to_numpy(dtype=float)
    e = sub[err_col].to_numpy(dtype=float) if err_col in sub.columns else None
    ts = sub["timestamp"].min()
    src = {"file": name, "run": lab, "timestamp": ts.isoformat()}
    try:
        with np.errstate(over="ignore", invalid="ignore"):  # non-finite: refused below
            if kind == "amplitude":
                cal = cal or fit_amplitude(A, v, e, K, source=src)
                val, se, curve = cal.A_corr, cal.A_corr_stderr, cal.y(grid)
            else:
                cal = cal or fit_phase(A, v, e, K, A_min=A_min, A_max=1.0, source=src)
                val, se, curve = cal.phi_at_1, cal.phi_at_1_stderr, cal.phi(grid)
    except DpdfitError as exc:
        raise FitError(f"{name}: run '{lab}' ({len(A)} points): {exc}") from None
    except (ValueError, ArithmeticError, np.linalg.LinAlgError) as exc:  # e.g. 1e300 values
        raise FitError(f"{name}: run '{lab}' ({len(A)} points): the fit failed "
                       f"({type(exc).__name__}: {str(exc).splitlines()[0] if str(exc) else ''})"
                       ) from None
    if not (np.isfinite(val) and np.isfinite(se)):
        raise FitError(f"{name}: run '{lab}' ({len(A)} points): fitted value {val:g} +/- "
                       f"{se:g} is not finite")
    rec = {"run": lab, "timestamp": ts, "value": float(val), "stderr": float(se),
           "n_points": int(cal.n_points), "reduced_chi2": float(cal.reduced_chi2)}
    return rec, curve


def _in_time_order(recs, curves):
    """Sort the runs by timestamp; adds ``day`` (since the first run), ISO timestamps."""
    order_t = sorted(range(len(recs)), key=lambda i: recs[i]["timestamp"])
    recs = [recs[i] for i in order_t]
    curves = np.array([curves[i] for i in order_t])
    t0 = recs[0]["timestamp"]
    for r in recs:
        r["day"] = (r["timestamp"] - t0).total_seconds() / 86400.0
        r["timestamp"] = r["timestamp"].isoformat()
    return recs, curves


def _notes(n_runs, allan, std, ses) -> list[str]:
    notes = []
    if n_runs < 3:
        notes.append("only 2 runs: no error on the trend")
    if not allan:
        notes.append("Allan deviation not meaningful: no averaging time has two adjacent "
                     "non-empty windows")
    elif max(n for _, _, n in allan) < 5:
        notes.append("Allan deviation rests on fewer than 5 window pairs at every tau: "
                     "indicative only")
    fit_ratio = std / float(np.sqrt(np.mean(ses ** 2))) if np.all(ses > 0) else float("inf")
    if fit_ratio > 2:
        notes.append(f"run-to-run scatter is {fit_ratio:.1f}x the mean fit error: the "
                     "calibration varies between runs beyond its statistical error")
    return notes


def stability(df_or_path, kind: str = "amplitude", order: int | None = None,
              A_min: float = PHASE_MIN_A, *, grid_points: int = 201,
              fits: dict | None = None) -> StabilityResult:
    """Per-run calibration fits of a multi-run file and their stability over time.

    Parameters
    ----------
    df_or_path : path-like or pandas.DataFrame
        Multi-run calibration table with columns ``run``, ``timestamp``,
        ``A`` and ``power`` [``power_err``] (amplitude) or ``phase_rad``
        [``phase_err``] (phase).
    kind : {"amplitude", "phase"}
    order : int, optional
        Polynomial order K (default 8 for the amplitude, 5 for the phase).
    A_min : float
        Lower end of the phase fit window (phase only).
    fits : dict, optional
        Precomputed fits of (some of) the runs, ``{run label: calibration}``
        (e.g. :func:`dpdfit.fits.drift.fit_runs`), made with the same order
        (and window); these runs are not refitted.

    Raises
    ------
    InputError
        Missing ``run``/``timestamp`` column, unparsable timestamps, fewer
        than 2 runs.
    FitError
        A run that cannot be fitted (e.g. too few points for the order),
        naming the run and the file.
    """
    if kind not in CALIBRATION_COLUMNS:
        raise InputError(f"kind must be 'amplitude' or 'phase', got '{kind}'")
    K = _DEFAULT_ORDER[kind] if order is None else int(order)
    if K < 1 or (kind == "amplitude" and K < 2):
        raise InputError(f"order must be >= {2 if kind == 'amplitude' else 1}, got {K}"
                         + (" (K = 1 fixes y = A: nothing to track)" if K == 1 else ""))
    if kind == "phase" and not 0 <= A_min < 1:
        raise InputError(f"phase fit window needs 0 <= A_min < 1, got A_min = {A_min}")
    df, name = _load(df_or_path, kind)
    labels = _run_labels(df, name)
    grid = np.linspace(0.0 if kind == "amplitude" else A_min, 1.0, grid_points)
    fits = fits or {}
    rows = df.groupby("run", sort=False).indices        # one pass, not one per run
    fitted = [_fit_run(df.iloc[rows[lab]], kind, K, A_min, grid, name, lab, fits.get(lab))
              for lab in labels]
    recs, curves = _in_time_order([r for r, _ in fitted], [c for _, c in fitted])
    days = np.array([r["day"] for r in recs])
    vals = np.array([r["value"] for r in recs])
    ses = np.array([r["stderr"] for r in recs])
    mean = float(vals.mean())
    std = float(vals.std(ddof=1))
    allan = allan_deviation(days, vals)
    try:
        with np.errstate(over="raise", invalid="raise", divide="raise", under="ignore"):
            drift = drift_test(days, vals, ses)
    except (ValueError, ArithmeticError, np.linalg.LinAlgError) as exc:   # e.g. 1e22 values
        raise FitError(f"{name}: the drift test across runs failed ({type(exc).__name__}); "
                       f"fitted values {', '.join(f'{v:.6g}' for v in vals[:6])}: a run far "
                       "off the others?") from None
    return StabilityResult(
        kind=kind, quantity="y(1) = A_corr" if kind == "amplitude" else "phi(1) [rad]",
        runs=recs, mean=mean, std=std,
        relative_std=float(std / abs(mean)) if mean != 0 else float("inf"),
        n_runs=len(recs), span_days=float(days[-1] - days[0]),
        drift=drift, allan=allan,
        grid=grid, curves=curves, mean_curve=curves.mean(axis=0),
        std_curve=curves.std(axis=0, ddof=1), order=K, A_min=float(A_min),
        source=name, notes=_notes(len(recs), allan, std, ses))
