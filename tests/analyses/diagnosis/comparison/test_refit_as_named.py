"""The refit of a named hypothesis (the separation a recording achieved is measured with
it) fits it as the diagnosis does: a tone-side effect's field carried to the gates under
the better phase-sign convention, gate-side additions fitted on that field.

The campaign: a harness campaign with a missing AM-to-PM phase and extra dephasing, a
SPAM recording and a long parity scan added (the closed loop's second step on it).  Fitted
with the sign kept, the named AM-to-PM alone was refitted 640 above the diagnosis's own
fit of it, so every separation measured against it was an artefact of the refit.
"""

from __future__ import annotations

import pytest

from dpdfit.analyses.diagnosis.comparison.refits import refit_label
from dpdfit.analyses.diagnosis.diagnose import diagnose
from dpdfit.simulation.campaign import simulate_campaign
from dpdfit.simulation.further_recordings import extend_config
from dpdfit.simulation.harness_campaign import harness_config

SEED = 1564548152
EFFECTS = {"am_pm_omitted": {"dphi": -0.135},
           "dephasing": {"f_cm": 0.92, "rate": 52.0}}
FURTHER = ({"what": "spam", "settings": {"scans": 2, "shots": 1000, "states": ["00", "11"]}},
           {"what": "parity", "settings": {"A": 0.4, "dpd": 0, "scans": 87, "shots": 10000}})


@pytest.fixture(scope="module")
def diagnosed(tmp_path_factory):
    cfg = harness_config(SEED).inject(EFFECTS)
    for m in FURTHER:
        cfg = extend_config(cfg, m)
    folder = tmp_path_factory.mktemp("refit") / "campaign"
    simulate_campaign(folder, seed=SEED, config=cfg, progress=False)
    return diagnose(folder, progress=False)


def test_the_named_hypothesis_refitted_has_the_diagnosis_chi2(diagnosed):
    d = diagnosed
    assert d.chosen is not None and d.chosen.effects[0] == "am_pm_omitted"
    label = {"effects": list(d.chosen.effects), "forms": list(d.chosen.forms)}
    assert refit_label(d.context, d.baseline, label) == pytest.approx(d.chosen.chi2,
                                                                      rel=2e-3)


def test_a_gate_side_addition_is_refitted_on_the_named_field(diagnosed):
    # nested hypotheses: the addition can only lower the chi2 (to the fit's tolerance),
    # and here it does, by the contrast the carried field leaves to dephasing
    d = diagnosed
    alone = refit_label(d.context, d.baseline,
                        {"effects": ["am_pm_omitted"], "forms": ["post"]})
    both = refit_label(d.context, d.baseline, {"effects": ["am_pm_omitted", "dephasing"],
                                               "forms": ["post", "coherence_mixed"]})
    assert both <= alone * (1 + 1e-4)
    assert alone - both > 10.0


def test_the_masked_dephasing_is_tried_as_an_addition(diagnosed):
    # dephasing alone does not beat the baseline (the baseline's field fits the contrast);
    # under the named AM-to-PM's field the contrast is misfitted and dephasing is tried
    tried = [e["effect"] for step in diagnosed.steps for e in step]
    assert "am_pm_omitted+dephasing" in tried
