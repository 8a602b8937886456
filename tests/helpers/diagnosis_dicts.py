"""Diagnosis JSON dicts (``dpdfit diagnose --json``) for the comparison's tests: an
earlier diagnosis that proposes a recording to separate its binding pair
(:func:`before`), and a later one that refitted that pair (:func:`after`)."""

from __future__ import annotations

TRUTH = {"effects": ["stale_calibration"], "forms": ["aom"], "chi2": 100.0,
         "expected_delta_bic": 27.0}
RIVAL = {"effects": ["detector_nonlinearity"], "forms": ["linear"], "chi2": 110.0,
         "expected_delta_bic": 45.0}
PROPOSAL = {"what": "spectra", "settings": {"amplitudes": [0.85, 0.95], "dpd": [0, 1]},
            "expected_delta_bic": 27.0, "decisive": True,
            "separates": ["stale_calibration", "detector_nonlinearity"],
            "binding": {"truth": TRUTH, "rival": RIVAL}}


def alternative(effect, named, replaces, gap=4.0):
    """An entry of ``alternatives``."""
    return {"effect": effect, "named": named, "replaces": replaces, "delta_bic": gap + 1,
            "delta_bic_tempered": gap, "tempering": 1.5}


def ranked(effect, dbic, tempered=None):
    """An entry of ``ranking``."""
    return {"effect": effect, "delta_bic": dbic, "p_value": 1e-9, "params": {},
            "params_err": {}, **({} if tempered is None else {"delta_bic_tempered": tempered})}


def diagnosis(verdict, named, alternatives=(), ranking=(), nxt=None, refits=None,
              campaign="camp"):
    """A diagnosis's JSON dict with the keys a comparison reads."""
    d = {"campaign": campaign, "verdict": verdict,
         "effects": [{"effect": e, "form": "catalog", "fidelity_cost": 1e-3,
                      "fidelity_cost_err": 1e-4, "sizes": {}} for e in named],
         "ranking": list(ranking), "alternatives": list(alternatives), "next_measurement": nxt}
    if refits is not None:
        d["refits"] = refits
    return d


def before():
    """The earlier diagnosis: stale_calibration named, three alternatives, a proposal."""
    return diagnosis("stale_calibration", ["stale_calibration"],
                     [alternative("detector_nonlinearity", ["detector_nonlinearity"],
                                  "stale_calibration"),
                      alternative("dephasing", ["stale_calibration", "dephasing"], None),
                      alternative("spam_offset", ["spam_offset"], "stale_calibration")],
                     [ranked("stale_calibration", -80.0, -40.0),
                      ranked("detector_nonlinearity", -75.0, -37.0),
                      ranked("spam_offset", -60.0, -33.0), ranked("dephasing", -20.0)],
                     nxt=PROPOSAL, campaign="before")


def refit_entries(truth_chi2, rival_chi2):
    """The later diagnosis's refits of the binding pair (rival first)."""
    return [{"effects": RIVAL["effects"], "forms": RIVAL["forms"], "chi2": rival_chi2},
            {"effects": TRUTH["effects"], "forms": TRUTH["forms"], "chi2": truth_chi2}]


def after(nxt=None, refits=None):
    """The later diagnosis: stale_calibration + dephasing named, the pair refitted."""
    return diagnosis("stale_calibration", ["stale_calibration", "dephasing"],
                     [alternative("spam_offset", ["spam_offset", "dephasing"],
                                  "stale_calibration", 6.0),
                      alternative("motional_heating", ["stale_calibration", "dephasing",
                                                       "motional_heating"], None)],
                     [ranked("stale_calibration", -150.0, -90.0),
                      ranked("spam_offset", -120.0, -80.0),
                      ranked("detector_nonlinearity", -60.0, -30.0),
                      ranked("dephasing", -25.0, -12.0), ranked("motional_heating", -15.0)],
                     nxt=nxt, refits=refit_entries(200.0, 240.0) if refits is None else refits,
                     campaign="after")
