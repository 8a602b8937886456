"""The diagnosis figures' baseline is the baseline behind ``redchi_before``.

An effect's fit may re-choose the phase-sign convention (a memory effect:
``phase_sign.refit_other_sign``, ``repredict_gates``) and leave the problem with the
other sign's models.  The baseline series (grey points of the diagnosis figures) and
the null model's ``phase_sign`` must be those of the baseline fit, captured when it is
computed, not re-evaluated afterwards under the effect's convention.
"""

import numpy as np

import dpdfit.analyses.diagnosis.diagnose as diagnose_module
from dpdfit.analyses.diagnosis.diagnose import diagnose
from dpdfit.report.diagnosis_plots import DIAGNOSIS_GROUPS, diagnosis_figure
from tests.helpers.paths import ROOT

CAMPAIGN = ROOT / "datasets" / "synthetic_campaign"


def _flip_after_baseline(monkeypatch, seen: dict):
    """Make the effect stage leave the problem with the other phase-sign convention (as a
    memory fit that prefers it does), recording the baseline's series before the flip."""
    original = diagnose_module._fit_singles

    def fit_singles(prob, base, effects):
        seen["sign"] = prob.tone.phase_sign
        seen["series"] = prob.series(dict(base.nuisances))
        seen["redchi"] = base.redchi()
        out = original(prob, base, effects)
        other = prob.tone.with_phase_sign(-prob.tone.phase_sign)
        prob.gate = prob.gate.rebased(other, {})
        prob.use_tone(other)
        seen["series_flipped"] = prob.series(dict(base.nuisances))
        return out

    monkeypatch.setattr(diagnose_module, "_fit_singles", fit_singles)


def _same_series(a: list, b: list) -> bool:
    return len(a) == len(b) and all(
        s[:4] == t[:4] and np.array_equal(s[4], t[4]) and np.array_equal(s[5], t[5])
        for s, t in zip(a, b))


def test_figure_baseline_is_the_one_behind_redchi_before_after_a_sign_flip(monkeypatch):
    seen: dict = {}
    _flip_after_baseline(monkeypatch, seen)
    d = diagnose(CAMPAIGN, effects=(), pairs=0, progress=False)
    # the flip does change the gate series: the test can tell the two baselines apart
    assert not _same_series(seen["series"], seen["series_flipped"])
    assert d.redchi_before == seen["redchi"]
    assert _same_series(d.series_before, seen["series"])
    assert d.extra["null_model"]["phase_sign"] == seen["sign"]
    # the grey points of the gates figure are those series
    fig = diagnosis_figure(d, "gates")
    grey = [line for ax in fig.axes for line in ax.get_lines() if line.get_label() == "baseline"]
    gates = [s for s in d.series_before if DIAGNOSIS_GROUPS["gates"](s[0])]
    assert grey and len(grey) == len(gates)
    for line, s in zip(grey, gates):
        assert np.array_equal(line.get_ydata(), s[5])
