"""Leaving forms out of the catalog: what the harness's leave-one-form-out mode relies on."""

from types import SimpleNamespace

import pytest

from dpdfit.analyses.diagnosis.effects import EFFECTS
from dpdfit.analyses.diagnosis.model.residuals import Problem, check_forms_left_out


def _forms(left_out):
    stub = SimpleNamespace(forms_left_out=check_forms_left_out(left_out))
    return {f.name: f for f in Problem.forms_of(stub, "dephasing")}


def test_nothing_left_out_keeps_the_catalog():
    assert list(_forms({})) == [f.name for f in EFFECTS["dephasing"].forms_for()]


def test_a_left_out_form_is_gone_and_its_chain_restarts_from_its_own_start():
    forms = _forms({"dephasing": ["mixed"]})
    assert "mixed" not in forms
    # stretched started from mixed, which started from independent
    assert forms["stretched"].starts_from == "independent"
    assert forms["coherence_stretched"].starts_from == "coherence_mixed"


def test_a_chain_head_left_out_leaves_its_followers_without_a_start():
    forms = _forms({"dephasing": ["independent", "mixed"]})
    assert forms["stretched"].starts_from is None


def test_unknown_effect_or_form_is_refused_by_name():
    with pytest.raises(KeyError, match="unknown effect 'nope'"):
        check_forms_left_out({"nope": ["x"]})
    with pytest.raises(KeyError, match="dephasing has no form 'x'"):
        check_forms_left_out({"dephasing": "x"})
