"""Implausible recorded values refused at the campaign boundary, with their likely cause.

A value in the wrong unit passes every check of its own file (a finite,
positive number) and then either reaches an analysis that reports a
confident wrong answer or a model whose arrays grow without bound (a gate
rate stored in Hz under the kHz label made the gate engine ask for a 38 GiB
array).  The readers therefore also refuse, each with one
:class:`~dpdfit.errors.InputError` line naming the value, the file, the column
and row, and the likely slip (an :class:`~dpdfit.errors.ImplausibleValueError`,
which ``dpdfit analyze`` and ``dpdfit diagnose`` turn into a refusal of the whole
campaign: :meth:`~dpdfit.recordings.campaign_folder.CampaignFolder.check_plausible`):

* a gate rate (``gate_rates.csv`` ``xi0_khz``) above the mode frequency
  (``campaign.json`` ``nu_hz``: a gate detuned beyond the mode is no gate), or
  more than :data:`RATE_SPECTRA_FACTOR` away, either way, from the gate
  detuning of the spectra (``xi0_spectra_hz``): :func:`check_gate_rates`,
  called by :class:`~dpdfit.recordings.campaign_folder.CampaignFolder`;
* phases (parity ``phase_rad`` per scan, ``calibration_phase.csv``
  ``phase_rad`` per run) spanning more than :data:`DEGREES_SPAN_RAD`: degrees
  stored as radians (:func:`check_phase_span`);
* a phase calibration run whose phases are :data:`DEGREES_RUN_RATIO` times the other
  runs' (a run added in degrees to a campaign in radians, its AM-to-PM too small for its
  span to show it): :func:`check_phase_run_scale`;
* shots below 1 and amplitudes ``A`` outside [0, 1] are refused by the
  readers' own checks (:func:`dpdfit.recordings.counts.check_counts`,
  :func:`dpdfit.recordings.tables.read_table`), whose messages name the slip too.
"""

from __future__ import annotations

import math

import numpy as np
import pandas as pd

from dpdfit.errors import ImplausibleValueError, InputError

__all__ = ["DEGREES_SPAN_RAD", "DEGREES_RUN_RATIO", "RATE_SPECTRA_FACTOR", "check_gate_rates",
           "check_phase_span", "check_phase_run_scale"]

#: Phases spanning more than this (rad) within one parity scan or one calibration run
#: look like degrees.  A parity fringe (period pi in phi) is fully sampled by a span
#: of pi, a scan over one 2*pi turn of the analysis pulse's phase is the usual design,
#: and twice that (four fringe periods) leaves room for over-scanned radian scans; an
#: AOM's amplitude-to-phase conversion over the whole amplitude range is a fraction of
#: a turn (0.6 to 3.1 rad in the bundled and validation campaigns).  A degree scan of
#: even a quarter fringe (45 deg), or an AM-to-PM of 0.22 rad (12.6 deg) written in
#: degrees, already spans more than 4*pi = 12.6.
DEGREES_SPAN_RAD = 4 * math.pi

#: A phase calibration run whose typical phase (the median ``|phase_rad|`` at ``A >=
#: 0.5``, where the beat is strong and the AM-to-PM largest) is more than this factor above
#: the median of the other runs' looks like degrees (a factor 180/pi = 57.3).  The runs of
#: one AOM drift by a percent from run to run (the paper's phi(1): 0.0009 rad of 0.28); an
#: AOM with no AM-to-PM to speak of reads its noise in every run, a few mrad, and an
#: AM-to-PM of 0.02 rad appearing in one run is still below 20 times that.
DEGREES_RUN_RATIO = 20.0

#: A gate rate more than this factor above or below the spectra's gate detuning
#: ``xi0_spectra_hz`` is refused: the spectra are recorded with the gate's own drive
#: at a detuning of the same order (20 kHz against 3 to 7.3 kHz gate rates in the
#: bundled and validation campaigns, factors 2.7 to 6.3), while a unit slip
#: (Hz or MHz labelled kHz) moves the rate by 1000.
RATE_SPECTRA_FACTOR = 10.0


def _source(key: str, defaults) -> str:
    return (f"campaign.json's default {key}, absent from the file" if key in defaults
            else f"campaign.json {key}")


def check_gate_rates(rates: pd.DataFrame, nu_hz: float, xi0_spectra_hz: float, file: str,
                     defaults=(), campaign_file: str | None = None) -> None:
    """Refuse a gate rate above the mode frequency or more than :data:`RATE_SPECTRA_FACTOR`
    away from the spectra's gate detuning (module doc).

    ``rates``: a validated ``gate_rates.csv`` (``xi0_khz``; the index is each row's
    0-based data row, as :func:`~dpdfit.recordings.gate_rates.read_gate_rates` gives it:
    a pooled setting is named by its first row);
    ``defaults``: the ``campaign.json`` keys that took their defaults (named as such);
    ``campaign_file``: the ``campaign.json`` named when ``nu_hz`` or
    ``xi0_spectra_hz`` is not positive.
    """
    for key, v in (("nu_hz", nu_hz), ("xi0_spectra_hz", xi0_spectra_hz)):
        if not v > 0:
            raise InputError(f"key '{key}' must be > 0 (Hz), got {v:g}", file=campaign_file)
    xi = rates["xi0_khz"].to_numpy(dtype=float) * 1e3
    rows = np.asarray(rates.index, dtype=int) + 1
    near = ((xi <= RATE_SPECTRA_FACTOR * xi0_spectra_hz)
            & (xi >= xi0_spectra_hz / RATE_SPECTRA_FACTOR))
    above = xi > nu_hz
    if above.any():
        i = int(np.flatnonzero(above)[0])
        cause = ("nu_hz written in kHz, not Hz?" if near[i] else "stored in Hz with unit kHz?")
        raise ImplausibleValueError(f"gate rate {xi[i] / 1e3:.4g} kHz exceeds the mode frequency "
                                    f"{nu_hz / 1e3:.4g} kHz ({_source('nu_hz', defaults)}): "
                                    f"{cause}", file=file, column="xi0_khz", row=int(rows[i]))
    if not near.all():
        i = int(np.flatnonzero(~near)[0])
        high = xi[i] > xi0_spectra_hz
        ratio = xi[i] / xi0_spectra_hz if high else xi0_spectra_hz / xi[i]
        raise ImplausibleValueError(
            f"gate rate {xi[i] / 1e3:.4g} kHz is {ratio:.3g}x {'above' if high else 'below'} "
            f"the spectra's gate detuning {xi0_spectra_hz / 1e3:.4g} kHz "
            f"({_source('xi0_spectra_hz', defaults)}), more than {RATE_SPECTRA_FACTOR:g}x "
            f"away: stored in {'Hz' if high else 'MHz'} with unit kHz, or a wrong "
            "xi0_spectra_hz?", file=file, column="xi0_khz", row=int(rows[i]))


def check_phase_span(df: pd.DataFrame, column: str, keys, file: str, label) -> None:
    """Refuse phases spanning more than :data:`DEGREES_SPAN_RAD` within a group.

    ``keys``: the columns whose values make a group (a parity scan, a calibration run;
    empty: the whole file); ``label(key)`` names a group's key tuple in the message.
    The row named is the group's largest phase.
    """
    if df.empty:
        return
    vals = df[column].to_numpy(dtype=float)
    keys = list(keys)
    group = (df.groupby(keys, sort=False).ngroup().to_numpy() if keys
             else np.zeros(len(df), dtype=int))
    hi = pd.Series(vals).groupby(group).transform("max").to_numpy()
    lo = pd.Series(vals).groupby(group).transform("min").to_numpy()
    wide = hi - lo > DEGREES_SPAN_RAD
    if not wide.any():
        return
    g = group[int(np.flatnonzero(wide)[0])]
    rows = np.flatnonzero(group == g)
    i = int(rows[np.argmax(vals[rows])])
    key = tuple(df[k].iloc[i] for k in keys)
    raise ImplausibleValueError(
        f"the phases of {label(key)} span {lo[i]:.4g} to {hi[i]:.4g} ({hi[i] - lo[i]:.4g}), "
        f"more than 4*pi = {DEGREES_SPAN_RAD:.4g} rad: in degrees? (radians expected; "
        "phase_rad = phase_deg * pi / 180)", file=file, column=column, row=i + 1)


def check_phase_run_scale(df: pd.DataFrame, column: str, file: str) -> None:
    """Refuse a phase calibration run whose phases are more than :data:`DEGREES_RUN_RATIO`
    times the other runs' (module doc): degrees among runs in radians, which no span
    check sees when the AM-to-PM is small (0.1 rad is 5.7 degrees).  ``df``: a validated
    ``calibration_phase.csv`` with a ``run`` column; the row named is the run's largest
    ``|phase|``."""
    if "run" not in df.columns or df.empty:
        return
    A = df["A"].to_numpy(dtype=float)
    vals = np.abs(df[column].to_numpy(dtype=float))
    runs = df["run"].to_numpy()
    strong = A >= 0.5
    level = {}
    for r in dict.fromkeys(runs.tolist()):
        sel = strong & (runs == r)
        if sel.sum() >= 3:
            level[r] = float(np.median(vals[sel]))
    if len(level) < 2:
        return
    for r, v in level.items():
        others = float(np.median([x for k, x in level.items() if k != r]))
        if others > 0 and v > DEGREES_RUN_RATIO * others:
            rows = np.flatnonzero(runs == r)
            i = int(rows[np.argmax(vals[rows])])
            raise ImplausibleValueError(
                f"the phases of run {r} are {v / others:.3g}x those of the other runs "
                f"(median |phase| at A >= 0.5: {v:.4g} against {others:.4g} rad), more than "
                f"{DEGREES_RUN_RATIO:g}x: in degrees? (radians expected; phase_rad = "
                "phase_deg * pi / 180)", file=file, column=column, row=i + 1)
