"""``stale_calibration``: the predistortion table belongs to another calibration.

Catalog form ("table"): the table belongs to an earlier calibration whose
order-8 polynomial is free (``a_k + dc_k``, unit slope kept: a drifted AOM
*and* that run's own fit errors), parametrised by the calibration's 7 error
modes.  The forward model (today's AOM) is unchanged, so only the DPD flag is
affected.

Variant "aom": the AOM drifted since the named run, which made the table and
describes the model's forward transfer; today's transfer is free along the
run-to-run drift modes of the amplitude runs (``sa_i``, in units of their sd;
as many as the campaign has, :meth:`StaleAom.for_campaign`).

Both are reported as ``drift``: the table calibration's fractional difference
of y(A) at ``A = DRIFT_AT_A`` (mid gate range, where the spectra constrain it;
y(1) is an extrapolation for DPD'd waveforms), with its delta-method error.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from .base import Effect, Param

__all__ = ["StaleTable", "StaleAom", "STALE_CALIBRATION", "STALE_AOM", "DRIFT_AT_A"]

#: stale_calibration's "drift" is the table calibration's fractional y(A) difference at this A
DRIFT_AT_A = 0.5


class StaleTable(Effect):
    """The catalog form: the table's calibration is free along its error modes."""

    def derived(self, tone, p, cov, names):
        # the fractional difference of the table's y(A) at A = 0.5 by the delta method
        # (dc = st @ modes is linear)
        idx = [names.index(f"st{i}") for i in range(len(tone.stale_modes))]
        a = DRIFT_AT_A
        y_a = tone.y_calibrated(a)
        g = tone.stale_modes @ (a ** np.arange(2, 2 + tone.stale_modes.shape[1])) / y_a
        return ({"drift": float(g @ np.array([p[names[i]] for i in idx]))},
                {"drift": float(np.sqrt(max(g @ cov[np.ix_(idx, idx)] @ g, 0.0)))})


class StaleAom(Effect):
    """The variant: today's AOM drifted along the run-to-run drift modes."""

    def for_campaign(self, tone):
        return dataclasses.replace(self, params=self.params[:len(tone.drift_modes)])

    def derived(self, tone, p, cov, names):
        # the AOM drifted since the table's run: drift = y_table(0.5)/y_today(0.5) - 1
        # (the table's calibration relative to today's AOM, as for the table variant)
        if not self.params:
            return {}, {}
        idx = [names.index(f"sa{i}") for i in range(len(tone.drift_modes))]
        a = DRIFT_AT_A
        powers = a ** np.arange(2, 2 + tone.drift_modes.shape[1])
        y_a = tone.y_calibrated(a)
        dy = tone.drift_modes @ powers
        y_t = y_a + float(dy @ np.array([p[names[i]] for i in idx]))
        g = -y_a / y_t ** 2 * dy
        return ({"drift": y_a / y_t - 1},
                {"drift": float(np.sqrt(max(g @ cov[np.ix_(idx, idx)] @ g, 0.0)))})


STALE_CALIBRATION = StaleTable(
    "stale_calibration", "tones",
    tuple(Param(f"st{i}", "sigma", -60.0, 60.0, 0.0, 1.0) for i in range(7)),
    "predistortion table from an earlier calibration: its amplitude polynomial "
    "a_k + dc_k (k = 2..8, a_1 = 1) is free, parametrised by the calibration's 7 "
    "error modes (st_i, in units of their sigma); reported as drift = the table "
    "calibration's fractional difference of y(0.5)",
    form="table")

STALE_AOM = StaleAom(
    "stale_calibration", "tones",
    tuple(Param(f"sa{i}", "sd", -20.0, 20.0, 0.0, 1.0) for i in range(3)),
    "the AOM drifted since the calibration run that made the table: today's transfer is "
    "the run's plus its run-to-run drift modes",
    form="aom", variant=True)
