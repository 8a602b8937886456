"""An addition whose fitted size is consistent with zero is an upper limit on that effect,
not an open alternative; the proposal is aimed at the strongest open alternative."""

from __future__ import annotations

import json

import pytest

from dpdfit.analyses.diagnosis.decisions.alternatives import (Alternative,
                                                              strongest_alternative)
from dpdfit.analyses.diagnosis.decisions.upper_limits import (LIMIT_LEVEL, ZERO_Z,
                                                              UpperLimit,
                                                              split_upper_limits)
from dpdfit.analyses.diagnosis.effects.base import Size
from dpdfit.analyses.diagnosis.fitting.fit_result import FitResult
from dpdfit.analyses.diagnosis.fitting.likelihood_intervals import profile_errors
from dpdfit.analyses.diagnosis.proposal import propose as propose_module
from dpdfit.analyses.diagnosis.proposal.next_measurement import NextMeasurement
from dpdfit.analyses.diagnosis.rendering import report_text
from dpdfit.analyses.diagnosis.result import Diagnosis

NAMED = ("aom_memory",)


def _fit(added: str | None = "stale_calibration", value: float = 1e-4,
         error: float = 1e-4, named=NAMED) -> FitResult:
    """A joint fit of the named effects plus ``added`` whose main size is ``value`` with
    the 1-sigma ``error``.  Its parameters have curvature errors (none is profiled), so
    no problem is needed to read its sizes."""
    effects = tuple(named) + (() if added is None else (added,))
    forms = tuple("two_scales" if e == "aom_memory" else "table" for e in effects)
    sizes = {"aom_memory": {"tau_ns": Size("tau_ns", 120.0, 5.0, "ns", "memory time")}}
    if added == "stale_calibration":
        sizes[added] = {"y1_drift": Size("y1_drift", value, error, "1",
                                         "fractional change of y(1) since the table's run")}
    elif added is not None:
        from dpdfit.analyses.diagnosis.effects import EFFECTS
        main = EFFECTS[added].main
        sizes[added] = {main: Size(main, value, error, "1", "")}
    return FitResult(effect="+".join(effects), params={}, params_err={}, nuisances={},
                     chi2=100.0, n_obs=120, n_par=10, chi2_by_observable={},
                     n_by_observable={}, forms=forms, sizes=sizes)


def _addition(effect="stale_calibration", gap_t=-4.0, tau=1.0, room=None) -> Alternative:
    return Alternative(effect, gap_t * tau - 20.0, gap_t, tau, None, NAMED + (effect,),
                       room=room)


def _swap(effect="detector_nonlinearity", gap_t=3.0) -> Alternative:
    return Alternative(effect, gap_t + 1.0, gap_t, 1.5, "aom_memory", (effect,),
                       separation_sigma=1.0)


def test_an_addition_whose_size_is_consistent_with_zero_is_an_upper_limit():
    alts = [(_addition(), _fit(value=1e-4, error=1e-4))]
    still, limits = split_upper_limits(None, alts)
    assert still == []
    (u,) = limits
    assert isinstance(u, UpperLimit)
    assert (u.effect, u.form, u.quantity, u.unit) == ("stale_calibration", "table",
                                                     "y1_drift", "1")
    assert u.value == pytest.approx(1e-4) and u.sigma == pytest.approx(1e-4)
    # |value| + 1.96 sigma at 95 %
    assert ZERO_Z == 1.96 and LIMIT_LEVEL == 0.95
    assert u.limit == pytest.approx(1e-4 + 1.96e-4) and u.level == 0.95
    assert u.named == ("aom_memory", "stale_calibration")
    assert u.text() == "stale_calibration [table] |y1 drift| < 0.0003 (95 %)"


def test_a_negative_size_is_bounded_by_its_magnitude():
    (u,) = split_upper_limits(None, [(_addition(), _fit(value=-1.5e-4, error=1e-4))])[1]
    assert u.value == pytest.approx(-1.5e-4)
    assert u.limit == pytest.approx(1.5e-4 + 1.96e-4)


def test_the_sigma_carries_the_dispersion_of_the_additions_evidence():
    # 3 sigma statistically, but the evidence scatters 4 times as much as an exact model's
    fit = _fit(value=3e-4, error=1e-4)
    still, limits = split_upper_limits(None, [(_addition(tau=1.0), fit)])
    assert len(still) == 1 and limits == ()
    still, (u,) = split_upper_limits(None, [(_addition(tau=4.0), fit)])
    assert still == []
    assert u.sigma == pytest.approx(2e-4) and u.tempering == 4.0
    assert u.limit == pytest.approx(3e-4 + 1.96 * 2e-4)


def test_an_addition_whose_fit_does_not_describe_the_recordings_is_not_bounded():
    # a size fitted through a misfit (tempering 14, beyond what any observable of a null
    # campaign shows) can sit far from the truth with a small error: no bound from it
    from dpdfit.analyses.diagnosis.evidence.thresholds import NULL_REDCHI_MAX
    fit = _fit(value=1e-4, error=1e-4)
    alt = (_addition(tau=14.0), fit)
    assert 14.0 > NULL_REDCHI_MAX
    still, limits = split_upper_limits(None, [alt])
    assert still == [alt] and limits == ()
    (u,) = split_upper_limits(None, [(_addition(tau=NULL_REDCHI_MAX), fit)])[1]
    assert u.tempering == NULL_REDCHI_MAX


def test_an_addition_whose_size_is_clearly_not_zero_stays_an_alternative():
    alt = (_addition(), _fit(value=1e-3, error=1e-4))
    still, limits = split_upper_limits(None, [alt])
    assert still == [alt] and limits == ()


def test_a_swap_or_an_addition_without_room_is_never_converted():
    swap = (_swap("stale_calibration"), _fit(value=0.0, error=1e-3, named=()))
    room = (_addition(room={"family": "aom_memory", "form": "one_scale",
                            "delta_bic_tempered": 2.0}), _fit(value=0.0, error=1e-3))
    still, limits = split_upper_limits(None, [swap, room])
    assert still == [swap, room] and limits == ()


def test_order_of_the_open_alternatives_is_kept():
    a = (_swap("detector_nonlinearity"), _fit(None))
    b = (_addition(), _fit(value=0.0, error=1e-4))
    c = (_addition("spam_offset", gap_t=-6.0), _fit("spam_offset", value=0.05, error=1e-3))
    still, limits = split_upper_limits(None, [a, b, c])
    assert still == [a, c]
    assert [u.effect for u in limits] == ["stale_calibration"]


def test_an_addition_without_a_finite_error_stays_open():
    alt = (_addition(), _fit(value=1e-4, error=float("nan")))
    assert split_upper_limits(None, [alt]) == ([alt], ())


def test_profile_errors_reads_nothing_when_every_error_has_its_curvature():
    # no parameter at a bound or without an error: the sizes as fitted, the problem
    # (here absent) not consulted
    fit = _fit(value=2e-4, error=1e-4)
    sizes = profile_errors(None, fit, "stale_calibration")
    assert sizes == fit.sizes["stale_calibration"]


def test_the_proposal_is_aimed_at_the_strongest_open_alternative(monkeypatch):
    seen = {}

    def fake(prob, hyps, tempering=1.0, profile=True):
        seen.update(hyps=hyps, tempering=tempering)
        return NextMeasurement("spectra")

    monkeypatch.setattr(propose_module, "propose_next_measurement", fake)
    chosen = _fit(None)
    weak_swap = (_swap("detector_nonlinearity", gap_t=6.0), _fit("detector_nonlinearity"))
    close_swap = (_swap("stale_calibration", gap_t=1.0), _fit("stale_calibration"))
    favoured = (Alternative("spam_offset", -30.0, -7.0, 2.5, None,
                            NAMED + ("spam_offset",)), _fit("spam_offset", value=0.05))
    alts = [weak_swap, close_swap, favoured]
    assert strongest_alternative(alts) is favoured
    assert strongest_alternative([]) is None
    propose_module.propose(None, chosen, alts, [], {})
    # the named fit against the strongest rival alone, at its dispersion of the evidence
    assert [[f.effect for f in g] for g in seen["hyps"]] == [
        ["aom_memory"], ["aom_memory+spam_offset"]]
    assert seen["tempering"] == 2.5
    propose_module.propose(None, chosen, [weak_swap, close_swap], [], {})
    assert [[f.effect for f in g] for g in seen["hyps"]] == [
        ["aom_memory"], ["aom_memory+stale_calibration"]]


def _diagnosis(limits=()) -> Diagnosis:
    base = FitResult(effect="baseline", params={}, params_err={}, nuisances={"g": 1.0},
                     chi2=300.0, n_obs=120, n_par=8, chi2_by_observable={"tones:R": 300.0},
                     n_by_observable={"tones:R": 120})
    return Diagnosis(campaign="camp", mismatches=[], ranking=[], verdict="aom_memory",
                     redchi_before={"tones:R": 2.5}, redchi_after={"tones:R": 1.0},
                     baseline=base, chosen=None, baseline_p_value=1e-9, seconds=1.0,
                     alternatives=(_swap(),), upper_limits=tuple(limits))


def test_json_has_the_upper_limits_and_keeps_every_other_key():
    (u,) = split_upper_limits(None, [(_addition(), _fit(value=1e-4, error=1e-4))])[1]
    empty = json.loads(json.dumps(_diagnosis().to_dict(), default=float))
    assert empty["upper_limits"] == []
    d = json.loads(json.dumps(_diagnosis([u]).to_dict(), default=float))
    assert set(d) == set(empty)
    assert [a["effect"] for a in d["alternatives"]] == ["detector_nonlinearity"]
    (entry,) = d["upper_limits"]
    assert entry["effect"] == "stale_calibration" and entry["quantity"] == "y1_drift"
    assert entry["limit"] == pytest.approx(2.96e-4) and entry["level"] == 0.95
    assert UpperLimit.from_dict(entry) == u
    # the keys before it are where they were: alternatives, then upper_limits
    keys = list(d)
    assert keys.index("upper_limits") == keys.index("alternatives") + 1
    assert "upper_limits" in d["conventions"]


def test_report_has_the_bounded_line_only_with_upper_limits():
    (u,) = split_upper_limits(None, [(_addition(), _fit(value=1e-4, error=1e-4))])[1]
    text = report_text(_diagnosis([u]))
    assert ("  not seen, bounded: stale_calibration [table] |y1 drift| < 0.0003 (95 %)"
            in text.splitlines())
    assert "not seen, bounded" not in report_text(_diagnosis())
