"""Which effects the forward selection tries as an addition to the named ones."""

from dpdfit.analyses.diagnosis.decisions.additions import _candidates

RANKING = [{"effect": "am_pm_omitted", "delta_bic": -7000.0},
           {"effect": "stale_calibration", "delta_bic": -120.0},
           {"effect": "higher_order_im", "delta_bic": -30.0},
           {"effect": "motional_heating", "delta_bic": 6.7},
           {"effect": "spam_offset", "delta_bic": 6.7},
           {"effect": "dephasing", "delta_bic": 6.6},
           {"effect": "am_pm_omitted+dephasing", "delta_bic": -7010.0}]
NAMED = {"am_pm_omitted"}


def test_decisive_alone_first_then_masked_on_a_side_with_a_located_mismatch():
    got = _candidates(RANKING, NAMED, left={"tones", "gates"}, located={"gates"}, pairs=6)
    assert got == ["stale_calibration", "higher_order_im", "motional_heating", "spam_offset",
                   "dephasing"]


def test_masked_effects_only_in_the_room_pairs_leaves():
    assert _candidates(RANKING, NAMED, {"tones", "gates"}, {"gates"}, pairs=3) == [
        "stale_calibration", "higher_order_im", "motional_heating"]


def test_no_masked_effect_where_the_named_model_leaves_no_located_mismatch():
    # the gates are searched (the campaign's gates showed a mismatch), but the named model
    # describes them: only effects decisive alone are tried there, as before
    assert _candidates(RANKING, NAMED, {"tones", "gates"}, located={"tones"}, pairs=6) == [
        "stale_calibration", "higher_order_im"]
    assert _candidates(RANKING, NAMED, {"gates"}, located=set(), pairs=6) == []
