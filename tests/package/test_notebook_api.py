"""Use from Python and notebooks: the Analysis object, logging and progress,
lmfit views of the fits, the emcee chain, ``python -m dpdfit`` and the commands' help."""

from __future__ import annotations

import contextlib
import importlib.util
import io
import json
import logging
import subprocess
import sys

import numpy as np
import pandas as pd
import pytest

import dpdfit
from dpdfit.cli.main import build_parser, main
from dpdfit.core.progress import progress_bar, progress_enabled, progress_scope
from tests.helpers.paths import ROOT

CAMP = ROOT / "datasets" / "synthetic_campaign"


def _compare_module():
    spec = importlib.util.spec_from_file_location("compare_analyze",
                                                  ROOT / "scripts" / "compare_analyze.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


class _Records(logging.Handler):
    def __init__(self):
        super().__init__(logging.DEBUG)
        self.records = []

    def emit(self, record):
        self.records.append(record)


@pytest.fixture(scope="module")
def api():
    """``analyze`` without an output folder, progress off; what it printed and logged."""
    logger = logging.getLogger("dpdfit")
    rec, old = _Records(), logger.level
    logger.addHandler(rec)
    logger.setLevel(logging.INFO)
    out, err = io.StringIO(), io.StringIO()
    try:
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            res = dpdfit.analyze(CAMP, plots=False, diagnosis=False, progress=False)
    finally:
        logger.removeHandler(rec)
        logger.setLevel(old)
    return res, out.getvalue(), err.getvalue(), rec.records


@pytest.mark.slow
def test_analyze_returns_the_analysis_with_its_tables(api):
    res = api[0]
    assert isinstance(res, dpdfit.Analysis)
    assert {"calibration_runs", "sweep", "gate", "alignment_points",
            "spectra_measured"} <= set(res.tables)
    assert all(isinstance(df, pd.DataFrame) for df in res.tables.values())
    assert res.sweep is res.tables["sweep"] and len(res.gate) == 10
    assert list(res.budget.columns) == ["estimate", "error"] and "delta" in res.budget.index
    assert res.status.loc["gates", "status"] == "ok"
    al = res.alignment
    assert al.alpha_khz == res.summary["gates"]["alignment"]["alpha_khz"]
    assert res.calibration.amplitude.A_corr == res.summary["calibration"]["A_corr"]
    assert res.diagnosis is None and res.results["budget"] is not None


@pytest.mark.slow
def test_the_summary_is_rendered_from_the_typed_results(api):
    """summary.json's sections are made from the steps' results: the alignment is the
    gates step's AlignmentFit, the budget the budget step's result; plain JSON."""
    res = api[0]
    assert res.summary["analyses"]["diagnosis"]["status"] == "skipped"
    assert res.failures == [] and json.loads(json.dumps(res.summary))["campaign"]
    assert res.results["gates"].alignment is res.alignment
    assert res.summary["budget"]["delta"] == res.results["budget"].to_dict()["delta"]
    assert res.summary["budget"]["delta"]["estimate"] == pytest.approx(res.alignment.delta)


@pytest.mark.slow
def test_progress_false_prints_nothing_and_messages_go_through_logging(api):
    res, out, err, records = api
    assert out == "" and err == ""
    msgs = [r.getMessage() for r in records]
    assert "[analyze] calibration ..." in msgs
    assert all(r.name.startswith("dpdfit.") for r in records)
    # the gate step's warning is logged (and kept on the result), not printed
    assert any(r.levelno == logging.WARNING for r in records) and res.messages


@pytest.mark.slow
def test_save_writes_what_the_command_line_writes(api, tmp_path, capsys):
    cli = tmp_path / "cli"
    assert main(["analyze", str(CAMP), "-o", str(cli), "--no-plots", "--no-diagnosis"]) == 0
    err = capsys.readouterr().err
    assert "[analyze] calibration ..." in err and "[analyze]   done in" in err
    saved = api[0].save(tmp_path / "api")
    files = lambda d: sorted(p.relative_to(d) for p in d.rglob("*") if p.is_file())  # noqa: E731
    assert files(saved) == files(cli)
    assert _compare_module().compare(cli, saved) == []


def test_progress_default_follows_the_terminal_and_the_scope(monkeypatch):
    monkeypatch.setattr(sys, "stderr", io.StringIO())
    assert not progress_enabled() and progress_enabled(True)
    with progress_scope(True):
        assert progress_enabled() and not progress_enabled(False)
        with progress_scope(None):
            assert progress_enabled()
    with progress_scope(False):
        with progress_bar(total=3, desc="x", progress=None) as bar:
            bar.update(3)
    assert sys.stderr.getvalue() == ""


def test_python_m_dpdfit_help():
    run = subprocess.run([sys.executable, "-m", "dpdfit", "--help"], capture_output=True,
                         text=True, cwd=ROOT)
    assert run.returncode == 0, run.stderr
    assert "analyze" in run.stdout and "``" not in run.stdout and ":mod:" not in run.stdout


def test_every_command_has_a_description_and_an_example():
    sub = next(a for a in build_parser()._actions if a.dest == "command")
    assert len(sub.choices) >= 17
    for name, parser in sub.choices.items():
        text = parser.format_help()
        assert parser.description and len(parser.description) > 40, name
        assert "example:" in text and f"dpdfit {name}" in text.split("example:")[1], name
        assert "``" not in text, name


def _check_round_trip(params, names, values, cov):
    err = np.sqrt(np.diag(cov))
    for i, n in enumerate(names):
        assert params[n].value == pytest.approx(values[i], rel=0, abs=0)
        assert params[n].stderr == pytest.approx(err[i], rel=1e-12)
        for j, m in enumerate(names):
            if j != i:
                assert params[n].correl[m] == pytest.approx(cov[i, j] / (err[i] * err[j]),
                                                             rel=1e-12)


def _amp_data(seed=1):
    rng = np.random.default_rng(seed)
    A = np.linspace(0, 1, 80)
    y = A + 0.1 * A ** 2 - 0.2 * A ** 3
    return A, 3 * y ** 2 + rng.normal(0, 0.01, A.size), np.full(A.size, 0.01)


def test_amplitude_and_phase_to_lmfit_round_trip():
    A, P, s = _amp_data()
    cal = dpdfit.fit_amplitude(A, P, s, order=4)
    raw = cal.to_lmfit(raw=True)
    _check_round_trip(raw, [f"b_{k}" for k in cal.powers], cal.raw_coefficients,
                      np.asarray(cal.raw_covariance))
    norm = cal.to_lmfit()
    assert not norm["a_1"].vary and norm["a_1"].value == 1.0
    names = [f"a_{k}" for k in cal.powers[1:]]
    _check_round_trip(norm, names, cal.coefficients[1:], np.asarray(cal.covariance)[1:, 1:])
    assert norm["A_corr"].value == pytest.approx(cal.A_corr, rel=1e-12)
    assert norm["A_corr"].stderr == cal.A_corr_stderr
    ph = dpdfit.fit_phase(A, 0.3 * A - 0.1 * A ** 2, np.full(A.size, 1e-3), order=3)
    _check_round_trip(ph.to_lmfit(), ["b_1", "b_2", "b_3"], ph.coefficients,
                      np.asarray(ph.covariance))
    for rep in (cal.fit_report(), ph.fit_report()):
        assert "[[Variables]]" in rep and "[[Fit Statistics]]" in rep
        assert "no scale_covar rescaling" in rep


def test_alignment_to_lmfit_round_trip(api):
    al = api[0].alignment
    p = al.to_lmfit()
    e = np.array([al.alpha_khz_err, al.delta_err])
    cov = np.diag(e ** 2)
    cov[0, 1] = cov[1, 0] = al.correlation * e[0] * e[1]
    _check_round_trip(p, ["alpha_khz", "delta"], [al.alpha_khz, al.delta], cov)
    assert "alpha_khz" in al.fit_report()


def test_posterior_keeps_the_emcee_chain():
    from dpdfit.fits.posterior import sample_amplitude_posterior
    A, P, s = _amp_data(2)
    r = sample_amplitude_posterior(A, P, s, 4, n_walkers=16, n_steps=120, seed=3, force=True,
                                   progress=False)
    assert r.chain.shape == (120, 16, 4) and r.log_prob.shape == (120, 16)
    assert r.acceptance_fraction.shape == (16,)
    assert np.mean(r.acceptance_fraction) == pytest.approx(r.acceptance)
    np.testing.assert_array_equal(r.chain[r.n_discard:].reshape(-1, 4), r.b_draws)
    assert not r.chain.flags.writeable and r.chain.nbytes == 120 * 16 * 4 * 8
