"""Generalisation of the discrepancy diagnosis: forms the catalog does not have.

Recordings whose effect comes from an independent implementation with a
different functional form than the catalog's (see ``tests/helpers/independent_effects.py``)
must still be named correctly: a two-pole (not single-pole) modulator memory as
``aom_memory``, a linearly ramped drift of compression, efficiency and amplifier
shape (not an amplitude-axis scaling) as ``stale_calibration``.

Each test simulates one null harness campaign, rewrites its ``spectra.csv`` from
the independent generator and diagnoses the folder.
"""

import time

import numpy as np
import pandas as pd
import pytest

from dpdfit.analyses.diagnosis.diagnose import diagnose
from tests.helpers import independent_effects as ie

TAU = 40e-9          # two-pole kernel t/tau^2 exp(-t/tau): mean delay 2 tau = 80 ns
F_OFF = 2.5e6        # response centre offset from the carrier, Hz
DRIFT = 0.02         # table's calibration: A_corr 2 % above the day's (linear ramp since)


def _summary(d) -> str:
    top = [(r["effect"], round(r["delta_bic"], 1),
            {k: round(v, 4) for k, v in r["params"].items()}) for r in d.ranking[:3]]
    tot = {k: round(v, 2) for k, v in d.redchi_before.items()}
    aft = {k: round(v, 2) for k, v in d.redchi_after.items()}
    return (f"verdict={d.verdict}; top3={top}; redchi_before={tot}; redchi_after={aft}; "
            f"diagnosis {d.seconds:.0f} s")


def _entry(d, effect):
    return next(r for r in d.ranking if r["effect"] == effect)


@pytest.mark.slow
def test_two_pole_memory_named_aom_memory(tmp_path):
    t0 = time.perf_counter()
    folder = tmp_path / "campaign"
    cfg, truth = ie.null_campaign(folder, seed=4242)
    # the recoded tone generator reproduces the simulator's null spectra
    orig = pd.read_csv(folder / "spectra.csv")
    aom = ie.day_aom(truth)
    lut, _ = ie.day_lut(folder, cfg)
    null = ie.write_spectra(folder, cfg, lambda i, A, d: aom.field(
        ie.drive_envelope(cfg, A, lut, d).astype(complex)), seed_key=90)
    hi = (orig.snr_db > 60).to_numpy()
    dev = (null.P_dB - orig.P_dB)[hi]
    dev = dev - dev.groupby([null.A[hi], null.dpd[hi]]).transform("median")
    assert np.max(np.abs(dev)) < 0.1
    ie.memory_kernel_spectra(folder, cfg, truth, tau=TAU, f_off=F_OFF)
    d = diagnose(folder)
    print(f"\n[two-pole memory, tau={TAU * 1e9:.0f} ns (mean delay {2 * TAU * 1e9:.0f} ns), "
          f"f_off={F_OFF / 1e6:.1f} MHz] {_summary(d)}; total {time.perf_counter() - t0:.0f} s")
    assert d.verdict == "aom_memory", _summary(d)
    entry = _entry(d, "aom_memory")
    # a linear memory of the drive: the fast (acoustic) form, its response time near the
    # kernel's mean delay
    assert entry["variant"] == "fast", _summary(d)
    tau_fit = entry["params"]["tau"]                               # ns
    mean_delay = 2 * TAU * 1e9
    assert mean_delay / 3 < tau_fit < 3 * mean_delay, _summary(d)


@pytest.mark.slow
def test_linear_drift_named_stale_calibration(tmp_path):
    t0 = time.perf_counter()
    folder = tmp_path / "campaign"
    cfg, truth = ie.null_campaign(folder, seed=4343)
    _, table_fit = ie.drift_profile_spectra(folder, cfg, truth, drift_rel=DRIFT)
    amp = pd.read_csv(folder / "calibration_amplitude.csv")
    _, day_fit = ie.lut_from_run(amp[amp.run == amp.run.iloc[-1]], cfg.order, cfg.lut_points)
    rel = table_fit.A_corr / day_fit.A_corr - 1                  # what the table assumes
    d = diagnose(folder)
    print(f"\n[linear drift, A_corr +{DRIFT:.0%} at table time (fitted {rel:+.4f}), "
          f"eta_ref and amplifier shape ramped] {_summary(d)}; "
          f"total {time.perf_counter() - t0:.0f} s")
    assert rel > 0
    assert d.verdict == "stale_calibration", _summary(d)
    # the AOM's y(1) today is below the table calibration's
    assert _entry(d, "stale_calibration")["sizes"]["y1_drift"]["value"] < 0, _summary(d)
