"""Pooling of real parity scans (Supplement S7.4).

Repeated scans carry each scan's own small analysis-phase offset, recorded as
is: the fit uses the exact binomial likelihood of every recorded phase (the
merged 0.01-rad grid is only for tables and plots), and a set of scans that do
not share one fringe is reported by a likelihood-ratio test with a warning,
never refused.
"""

import json
import logging

import numpy as np
import pandas as pd
import pytest
from scipy.optimize import minimize

from dpdfit.cli.main import main
from dpdfit.fits.counts import gate_fidelities
from tests.helpers.paths import ROOT, TEST_DATA

PHI16 = np.arange(16) * 2 * np.pi / 16
SHOTS = (400, 625, 900)
VALIDATION = ROOT.parent / "shared" / "validation_campaigns"


def _scans(rng, A, phi0, offsets, shift_phi0=(0.0, 0.0, 0.0)):
    """Three scans with unequal shots, per-scan phase offsets, different numbers of
    phases, phases partly outside [0, 2 pi) and rows shuffled."""
    rows = []
    for s, (n, off, dphi) in enumerate(zip(SHOTS, offsets, shift_phi0), start=1):
        ph = PHI16 + off
        if s == 2:
            ph = ph[::2]                                       # 8 phases only
        if s == 3:
            ph = ph - 2 * np.pi                                # all negative
        p = (1 + A * np.cos(2 * ph + phi0 + dphi)) / 2
        k = rng.binomial(n, p)
        rows += [{"A": 0.5, "dpd": 0, "scan": s, "phase_rad": f, "n_even": kk, "shots": n}
                 for f, kk in zip(ph, k)]
    par = pd.DataFrame(rows).sample(frac=1.0, random_state=int(rng.integers(1 << 31)))
    par = par.reset_index(drop=True)
    pop = pd.DataFrame({"A": [0.5], "dpd": [0], "scan": [1], "n_even": [1900], "shots": [2000]})
    return pop, par


def _independent_mle(par):
    """Binomial MLE of p = (1 + A cos(2 phi + phi0)) / 2 on every row, with the
    analytic Hessian of -lnL (written here, sharing no code with dpdfit)."""
    ph, k, n = (par[c].to_numpy(float) for c in ("phase_rad", "n_even", "shots"))

    def nll(x):
        p = np.clip((1 + x[0] * np.cos(2 * ph + x[1])) / 2, 1e-300, 1 - 1e-16)
        return -np.sum(k * np.log(p) + (n - k) * np.log1p(-p))

    best = min((minimize(nll, [0.9, a], method="Nelder-Mead",
                         options={"xatol": 1e-12, "fatol": 1e-12, "maxiter": 20000})
                for a in np.linspace(-3, 3, 7)), key=lambda r: r.fun)
    A, phi0 = best.x
    if A < 0:
        A, phi0 = -A, phi0 + np.pi
    c, s = np.cos(2 * ph + phi0), np.sin(2 * ph + phi0)
    p = (1 + A * c) / 2
    g = -(k / p - (n - k) / (1 - p))
    h = k / p ** 2 + (n - k) / (1 - p) ** 2
    pa, pf = c / 2, -A * s / 2
    H = np.array([[np.sum(h * pa * pa), np.sum(h * pa * pf + g * (-s / 2))],
                  [np.sum(h * pa * pf + g * (-s / 2)), np.sum(h * pf * pf + g * (-A * c / 2))]])
    return A, float(np.sqrt(np.linalg.inv(H)[0, 0]))


def test_pooled_jittered_unequal_scans_match_an_independent_binomial_mle():
    rng = np.random.default_rng(14)
    for _ in range(5):
        pop, par = _scans(rng, 0.95, 0.3, rng.uniform(-0.006, 0.006, 3))
        row = gate_fidelities(pop, par).iloc[0]
        A, err = _independent_mle(par)
        assert abs(row["contrast"] - A) < 2e-5
        assert abs(row["F_par_err"] / err - 1) < 2e-3
        assert row["parity_method"] == "hessian"


@pytest.mark.slow
def test_pooled_contrast_error_covers():
    """1-sigma coverage 68 +/- 5 % and no bias over 400 seeded replicates."""
    rng = np.random.default_rng(2026)
    pulls = []
    for _ in range(400):
        pop, par = _scans(rng, 0.95, rng.uniform(-np.pi, np.pi), rng.uniform(-0.006, 0.006, 3))
        row = gate_fidelities(pop, par).iloc[0]
        pulls.append((row["contrast"] - 0.95) / row["F_par_err"])
    pulls = np.array(pulls)
    assert 0.63 <= np.mean(np.abs(pulls) <= 1) <= 0.73
    assert abs(pulls.mean()) < 0.15


@pytest.mark.slow
def test_consistent_scans_pass_the_per_scan_test_at_its_nominal_rate():
    rng = np.random.default_rng(7)
    p = []
    for _ in range(300):
        pop, par = _scans(rng, 0.9, 0.1, rng.uniform(-0.006, 0.006, 3))
        row = gate_fidelities(pop, par).iloc[0]
        assert row["parity_scan_lr_dof"] == 4
        p.append(row["parity_scan_lr_p"])
    # under the null the LR test's p-value is uniform: 5 % below 0.05 (300 draws)
    assert 0.02 <= np.mean(np.array(p) < 0.05) <= 0.09


def test_a_shifted_scan_is_reported_with_a_warning_not_refused(caplog):
    rng = np.random.default_rng(3)
    pop, par = _scans(rng, 0.95, 0.3, (0.0, 0.002, -0.003), shift_phi0=(0.0, 0.0, 0.4))
    par.attrs["source"] = "parity.csv"
    with caplog.at_level(logging.WARNING, logger="dpdfit.fits.counts"):
        tab = gate_fidelities(pop, par)
    assert len(tab) == 1 and np.isfinite(tab["contrast"].iloc[0])
    assert tab["parity_scan_lr_p"].iloc[0] < 1e-6
    msgs = [r.getMessage() for r in caplog.records]
    assert len(msgs) == 1 and "A=0.5, dpd=0" in msgs[0] and "parity.csv" in msgs[0]


@pytest.mark.parametrize("camp", ["v01", "v02"])
def test_validation_campaign_scans_are_accepted_by_the_cli(camp, capsys):
    d = TEST_DATA / "validation" / camp
    code = main(["fidelity", "--populations", str(d / "populations.csv"),
                 "--parity", str(d / "parity.csv"), "--json"])
    assert code == 0
    rec = json.loads(capsys.readouterr().out)
    assert len(rec) == 10 and all(0.5 < r["F"] < 1 and r["F_err"] > 0 for r in rec)


@pytest.mark.skipif(not VALIDATION.exists(), reason="validation campaigns not on this machine")
def test_all_validation_campaigns_are_accepted(capsys):
    n = 0
    for d in sorted(p for p in VALIDATION.iterdir() if (p / "parity.csv").exists()):
        assert main(["fidelity", "--populations", str(d / "populations.csv"),
                     "--parity", str(d / "parity.csv"), "--json"]) == 0, d.name
        capsys.readouterr()
        n += 1
    assert n == 20
